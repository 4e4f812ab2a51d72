"""The tile engine's scheduler state: a FIFO of tiles and a queued bit per tile."""

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import data, wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from navcores.models.edt_bfs import OFFSETS

from ..arith import divmod_const, times
from .tile_layouts import named

__all__ = ["Worklist", "tile_layout"]


def tile_layout(w):
    """A tile's coordinates: tile row ``r`` and tile column ``c``."""
    return data.StructLayout({"r": range(w["tile_rows"]), "c": range(w["tile_cols"])})


class Worklist(wiring.Component):
    """The worklist of :mod:`models.edt_bfs_tiled` (``_Fifo``): a FIFO of tiles, no duplicates.

    The FIFO is a RAM of tiles_max entries (a tile is queued at most once, so
    it never overflows; the EDT's two worklists W_k and W_{k+1} share it, W_k
    at the head and W_{k+1} behind it, since no tile is in both).  The queued
    bits live in nine RAM banks by (tile row mod 3, tile column mod 3), so
    the bits of a tile's 3 x 3 tile neighbourhood are read in one cycle
    (``look``): the engine marks only tiles not queued, and a mark costs a
    beat only when it enqueues.

    Ports
    -----
    init : In(1)
        Empty the FIFO (a job's start; the queued bits are written by the scan).
    pop : In(1)
        Take the head: ``head`` shows it the next cycle (held until the next
        pop), when its queued bit is cleared.  Not in the cycle after a
        ``push`` or ``clear`` of the same tile.
    head : Out(tile_layout)
    count : Out
        Tiles queued.
    peek : Out(tile_layout).array(peek) (``peek`` > 0 only)
        ``peek[d]``: the tile the (d + 1)-th pop from now takes (a read port
        each, always reading d entries behind the head as it is after this
        cycle's pop): valid while ``count`` > d, from the cycle after a pop
        and from the cycle after the push that wrote it (the engine's
        prefetch of the next visits' windows; ``peek[0]`` is the tile the
        next pop takes, so a visit pops and sets up in one cycle).
    look : In(1), look_at : In(tile_layout)
        Read the queued bits around ``look_at``; ``near`` shows them the
        next cycle (held until the next look): bit 0 the tile itself, bit i
        the tile in direction i (Fig. 1; don't-care outside the map).
    near : Out(9)
    push : In(1), push_tile : In(tile_layout)
        Enqueue a tile that is not queued (the caller checked ``near``).
    clear : In(1), clear_tile : In(tile_layout)
        Clear a tile's queued bit (the scan's tiles without a frontier).

    At most one of push, clear and the pop's clear per cycle.  The queued
    bits are written a cycle later, through a register, and read
    transparently: ``near`` behaves as if the write were immediate.
    """

    def __init__(self, w, peek=0):
        self.w, self.peeks = w, peek
        self.depth = w["tile_rows"] * w["tile_cols"]
        tl = tile_layout(w)
        super().__init__({
            "init": In(1), "pop": In(1), "head": Out(tl), "count": Out(range(self.depth + 1)),
            "look": In(1), "look_at": In(tl), "near": Out(9),
            "push": In(1), "push_tile": In(tl), "clear": In(1), "clear_tile": In(tl),
            **({"peek": Out(tl).array(peek)} if peek else {}),
        })

    def elaborate(self, platform):
        m = Module()
        w, depth = self.w, self.depth
        tl = tile_layout(w)

        # FIFO
        m.submodules.fifo = fifo = Memory(shape=tl, depth=depth, init=[])
        rp, wp = fifo.read_port(), fifo.write_port()
        head = Signal(range(depth))
        tail = Signal(range(depth))

        def inc(p):
            return Mux(p == depth - 1, 0, p + 1)

        if self.peeks:
            # the peek ports read behind the head as it is after this cycle's pop, so that they show
            # the tiles after it the next cycle (the engine's visit pops and sets up in one cycle)
            ahead = Signal(range(depth))
            m.d.comb += ahead.eq(Mux(self.pop, inc(head), head))
        for d in range(self.peeks):
            pp = fifo.read_port(transparent_for=(wp,))     # a push there shows the next cycle
            m.d.comb += [pp.addr.eq(ahead if d == 0 else Mux(ahead + d >= depth, ahead + d - depth, ahead + d)),
                         self.peek[d].eq(pp.data)]

        m.d.comb += [rp.addr.eq(head), rp.en.eq(self.pop), self.head.eq(rp.data),
                     wp.addr.eq(tail), wp.data.eq(self.push_tile), wp.en.eq(self.push)]
        with m.If(self.init):
            m.d.sync += [head.eq(0), tail.eq(0), self.count.eq(0)]
        with m.Else():
            with m.If(self.pop):
                m.d.sync += head.eq(inc(head))
            with m.If(self.push):
                m.d.sync += tail.eq(inc(tail))
            m.d.sync += self.count.eq(self.count + self.push - self.pop)

        # Queued bits: bank (r mod 3, c mod 3) holds tile (r, c) at (r // 3) * sc + c // 3,
        # with one spare row and column of addresses for the neighbours past the last tile.
        sr = -(-w["tile_rows"] // 3) + 1
        sc = -(-w["tile_cols"] // 3) + 1
        # With the peek ports the look's tile comes straight from the FIFO RAM's output
        # (peek[0]), so its path to the banks' addresses is kept short: the divisions by 3 are
        # lookup tables and a bank row is a power of two of addresses (the address a
        # concatenation, no multiply-add); without them (a registered tile) as before.
        fast = bool(self.peeks)
        kc = max(1, (sc - 1).bit_length())
        if fast:
            sc = 1 << kc

        def address(q_r, q_c):
            return Cat(q_c[:kc], q_r) if fast else times(q_r, sc) + q_c
        # A queued bit's write goes through a register (the bank and address logic after it, off
        # the engine's mark -> push path); the read ports are transparent to it, so a look in the
        # cycle after a push sees the push as before.
        popped = Signal()
        m.d.sync += popped.eq(self.pop)
        wr_tile = Signal(tl)
        wr_val = Signal()
        wr_en = Signal()
        m.d.sync += wr_en.eq(popped | self.push | self.clear)
        with m.If(popped):
            m.d.sync += [wr_tile.eq(rp.data), wr_val.eq(0)]
        with m.Elif(self.push):
            m.d.sync += [wr_tile.eq(self.push_tile), wr_val.eq(1)]
        with m.Elif(self.clear):
            m.d.sync += [wr_tile.eq(self.clear_tile), wr_val.eq(0)]
        wq = [named(m, n, v, shape) for n, v, shape in (
            ("wq_r", wr_tile.r // 3, range(sr)), ("wm_r", wr_tile.r % 3, 2),
            ("wq_c", wr_tile.c // 3, range(sc)), ("wm_c", wr_tile.c % 3, 2))]
        waddr = named(m, "waddr", address(wq[0], wq[2]), range(sr * sc))

        at = self.look_at
        if fast:
            (qr, mr), (qc, mc) = divmod_const(at.r, 3, table_bits=8), divmod_const(at.c, 3, table_bits=8)
        else:
            qr, mr, qc, mc = at.r // 3, at.r % 3, at.c // 3, at.c % 3
        lr, lm = named(m, "lq_r", qr, range(sr)), named(m, "lm_r", mr, 2)
        cq, cm = named(m, "lq_c", qc, range(sc)), named(m, "lm_c", mc, 2)
        seen = Signal(4)               # (r mod 3, c mod 3) of the last look
        with m.If(self.look):
            m.d.sync += seen.eq(Cat(lm, cm))

        def shifted(q, mod, k, name):
            """(q, valid) of the neighbour coordinate that bank index k holds: (k - mod) mod 3 = 0, +1, -1."""
            rel = named(m, f"rel_{name}", Mux(k >= mod, k - mod, k + 3 - mod), 2)
            up = Mux(mod == 2, q + 1, q)
            down = Mux(mod == 0, q - 1, q)
            ok = named(m, f"ok_{name}", ~((rel == 2) & (mod == 0) & (q == 0)))
            return named(m, f"q_{name}", Mux(rel == 0, q, Mux(rel == 1, up, down)), len(q) + 1), ok

        bits = {}
        rows = [shifted(lr, lm, a, f"r{a}") for a in range(3)]
        cols = [shifted(cq, cm, b, f"c{b}") for b in range(3)]
        for a in range(3):
            qa, oka = rows[a]
            for b in range(3):
                qb, okb = cols[b]
                mem = Memory(shape=1, depth=sr * sc, init=[])
                m.submodules[f"queued{a}{b}"] = mem
                qwp = mem.write_port()
                qrp = mem.read_port(transparent_for=(qwp,))
                m.d.comb += [qrp.addr.eq(Mux(oka & okb, address(qa, qb), 0)), qrp.en.eq(self.look),
                             qwp.addr.eq(waddr), qwp.data.eq(wr_val),
                             qwp.en.eq(wr_en & (wq[1] == a) & (wq[3] == b))]
                bits[a, b] = qrp.data

        # near[i]: the bank of (r + dr, c + dc) mod 3, by the looked-at tile's residues.
        seen_is = {(mr, mc): named(m, f"seen{mr}{mc}", seen == mr | (mc << 2)) for mr in range(3) for mc in range(3)}

        def bank_bit(dr, dc):
            out = 0
            for (mr, mc), hit in seen_is.items():
                out = Mux(hit, bits[(mr + dr) % 3, (mc + dc) % 3], out)
            return out

        m.d.comb += self.near.eq(Cat(bank_bit(0, 0), *[bank_bit(dr, dc) for dr, dc in OFFSETS.values()]))
        return m
