"""The tile engine's per-pixel state store: on-chip block RAM behind a stream interface."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ..ram_init import undefined_memory
from ..arith import times
from .tile_layouts import BFS_FIELDS, EDT_FIELDS, bfs_layout, edt_layout, flat, named, pixel_layout

__all__ = ["StateRam", "StateSignature", "read_layout", "read_data_layout", "write_layout", "BANKS"]

BANKS = 3       # word columns w - 1, w, w + 1 are in three different banks: a window row is one beat


def read_layout(w):
    """A read command: word column ``wcol`` of map row ``row``; ``di``, ``nnt``
    (dx, dy) and ``bfs`` (hop, parent) name the fields the answer must hold
    (models.edt_bfs_tiled.PHASE_READS: an EDT visit asks for di and nnt, a BFS
    visit for di and bfs, the goals for di and bfs, the path and the map
    read-out for all): the others may be anything, so a store that moves
    only these saves bandwidth (an external one); :class:`StateRam` reads all."""
    return data.StructLayout({"row": w["row"], "wcol": range(w["words"]), "di": 1, "nnt": 1, "bfs": 1})


def read_data_layout(w, p):
    """A read's answer: the word's ``p`` pixels, with the last pixel of word ``wcol - 1``
    (``left``) and the first of word ``wcol + 1`` (``right``): one row of a tile's window."""
    px = pixel_layout(w)
    return data.StructLayout({"left": px, "word": data.ArrayLayout(px, p), "right": px})


def write_layout(w, p, changed=False):
    """A write command: word (``row``, ``wcol``); ``edt`` / ``bfs`` select the field groups written;
    with ``changed`` (last, so the other fields keep their places) a bit per pixel, set for the
    pixels whose written fields the write changes: a store may skip what holds none of them (the
    others are written as they are, so writing them too is never wrong); and ``cfr``, a bit per
    pixel: in the collision-free region by the written di (none, or above the job's d_far), for a
    store that answers a BFS read's di from it (:class:`~hdl.edt_bfs.dram_store.DramStore`)."""
    fields = {"row": w["row"], "wcol": range(w["words"]), "edt": 1, "bfs": 1,
              "word": data.ArrayLayout(pixel_layout(w), p)}
    return data.StructLayout({**fields, **({"changed": p, "cfr": p} if changed else {})})


class StateSignature(wiring.Signature):
    """The state store's interface, seen from the store (the engine holds the flipped one).

    * ``rd`` (in): read commands; ``rd_data`` (out): their answers, in
      command order (:func:`read_data_layout`).
    * ``wr`` (in): write commands (:func:`write_layout`; ``changed``: with
      the pixels each write changes).

    Contract, for any implementation (this block RAM, or an SDRAM
    controller with a cache of window rows): a read accepted after a write
    (in a later cycle) returns the written fields; a word never written
    since power-up (outside the map of every job so far) is don't-care and
    may be X in simulation: the engine reads such words only for pixels
    outside the map, whose flags it gates with ``present``
    (:class:`~hdl.edt_bfs.tile_array.TileArray`), so they reach no output and
    no decision; ``rd.ready`` may depend on
    ``rd_data.ready``, valid never on ready.  The engine accepts every
    answer the cycle it is valid while it loads a tile, so a store with a
    variable latency needs no buffer of its own beyond the pipeline; with
    its prefetch (TileEngine's ``prefetch``) it reads ahead and leaves
    answers waiting, so such a store must hold them (``rd.ready`` low when
    it cannot: StateRam's pipeline, StateCdc's read credit).  The
    engine's cycle counts (:mod:`models.edt_bfs_tiled`'s cycle model) assume
    what :class:`StateRam` gives: commands always ready, answers two cycles
    after the command (``Timing.latency``), reads pipelined (a command every
    cycle while the answers are taken), a read and a write in the same cycle.
    """

    def __init__(self, w, p, changed=False):
        super().__init__({
            "rd": In(stream.Signature(read_layout(w))),
            "rd_data": Out(stream.Signature(read_data_layout(w, p))),
            "wr": In(stream.Signature(write_layout(w, p, changed))),
        })


class StateRam(wiring.Component):
    """Every pixel's state (:func:`~hdl.edt_bfs.tile_layouts.pixel_layout`) in on-chip block RAM.

    A word holds ``p`` pixels of a map row (``p = T_c``: word column w is
    tile column w).  Word columns go to three banks by ``wcol mod 3``, so a
    read fetches the words wcol - 1, wcol and wcol + 1 in one cycle (a tile
    window's row: the tile's word and one pixel on either side).  Each bank
    holds two memories, the EDT's field group (di, dx, dy) and the BFS's
    (hop, parent), written separately.  Bank b holds word (row, wcol) at
    address ``row * S + wcol // 3`` with ``S = ceil(words / 3)``.  The words
    left of column 0 and right of the widest map's last column do not exist:
    their reads return the middle word's address (don't-care pixels).
    The memories have no initial value (:func:`~hdl.ram_init.undefined_memory`:
    no per-word init in the Verilog, which stalled yosys): every job's load
    writes each word of its map before any read of it, and a block RAM
    powers up cleared anyway.

    Parameters
    ----------
    w : dict
        :func:`~hdl.edt_bfs.tile_layouts.tile_widths` (``words`` = word
        columns of the widest map, ``row``: row bits).
    p : int
        Pixels per word (T_c).
    max_h : int
        Rows of the largest map.

    Ports: :class:`StateSignature`.  Reads: latency 2 (the memory's read
    register, then an output register: the DP16KD's, scripts/ecp5_pack.py),
    one per cycle, pipelined: two answers in flight; ``rd.ready`` is low only
    while both stages are full and the answer waits for ``rd_data.ready``;
    the answer is held until taken.  Writes: always ready, one per cycle.
    """

    def __init__(self, w, p, max_h):
        self.w, self.p, self.max_h = w, p, max_h
        self.stride = -(-w["words"] // BANKS)
        self.depth = max_h * self.stride
        super().__init__(StateSignature(w, p))

    def blocks(self):
        """The memories: (name, width, depth) of each."""
        e = edt_layout(self.w).size * self.p
        b = bfs_layout(self.w).size * self.p
        return [(f"{g}{k}", width, self.depth) for k in range(BANKS) for g, width in (("edt", e), ("bfs", b))]

    def elaborate(self, platform):
        m = Module()
        w, p = self.w, self.p
        S = self.stride

        # Reads: bank b reads whichever of wcol - 1, wcol, wcol + 1 it holds.  Two stages: the
        # memory's own read register (stage 1), then a data register per memory (stage 2), which
        # the fit flow packs into the DP16KD's output register (scripts/ecp5_pack.py): the
        # answer leaves a register, not the RAM's 5.8 ns data output.  A stage holds while the
        # one after it is full and not taken.
        cmd = self.rd.payload
        q = named(m, "rd_q", cmd.wcol // BANKS, range(max(S, 2)))        # no 0-bit signal
        r = named(m, "rd_r", cmd.wcol % BANKS, range(BANKS))
        base = named(m, "rd_base", times(cmd.row, S), range(self.depth))
        take, s1_valid, adv1, adv2 = Signal(), Signal(), Signal(), Signal()
        m.d.comb += [adv2.eq(~self.rd_data.valid | self.rd_data.ready),     # stage 2 may load
                     adv1.eq(~s1_valid | adv2),                              # stage 1 may load
                     self.rd.ready.eq(adv1), take.eq(self.rd.valid & adv1)]
        with m.If(adv1):
            m.d.sync += s1_valid.eq(take)
        with m.If(adv2):
            m.d.sync += self.rd_data.valid.eq(s1_valid)
        rot1 = Signal(range(BANKS))         # bank of the middle word, in stage 1
        rot = Signal(range(BANKS))          # and as the answer leaves (stage 2)
        with m.If(take):
            m.d.sync += rot1.eq(r)
        with m.If(adv2):
            m.d.sync += rot.eq(rot1)
        words = []
        wcmd = self.wr.payload
        wr_ = named(m, "wr_r", wcmd.wcol % BANKS, range(BANKS))
        waddr = named(m, "wr_addr", times(wcmd.row, S) + wcmd.wcol // BANKS, range(self.depth))
        for k in range(BANKS):
            # (k - r) mod 3: 0 middle, 1 right (k = r + 1), 2 left
            rel = Signal(range(BANKS), name=f"rel{k}")
            m.d.comb += rel.eq(Mux(k >= r, k - r, k + BANKS - r))
            col = Signal(range(max(S, 2)), name=f"col{k}")
            m.d.comb += col.eq(Mux(rel == 0, q, Mux(rel == 1, Mux(q == S - 1, q, q + (r == BANKS - 1)),
                                                    Mux(q == 0, q, q - (r == 0)))))
            addr = named(m, f"rd_addr{k}", base + col, range(self.depth))
            got = []
            for g, lay in (("edt", edt_layout(w)), ("bfs", bfs_layout(w))):
                group = data.ArrayLayout(lay, p)        # plain-width memories: see tile_layouts.flat
                mem = undefined_memory(shape=group.size, depth=self.depth)
                m.submodules[f"{g}{k}"] = mem
                rp = mem.read_port()
                wp = mem.write_port()
                # reset-less, as the DP16KD output register it becomes (no set/reset to pack)
                held = Signal(group.size, name=f"{g}{k}_q", reset_less=True)
                with m.If(adv2):
                    m.d.sync += held.eq(rp.data)
                m.d.comb += [rp.addr.eq(addr), rp.en.eq(take),
                             wp.addr.eq(waddr), wp.en.eq(self.wr.valid & getattr(wcmd, g) & (wr_ == k))]
                fields = EDT_FIELDS if g == "edt" else BFS_FIELDS
                wd = group(wp.data)
                m.d.comb += [getattr(wd[j], f).eq(getattr(wcmd.word[j], f)) for j in range(p) for f in fields]
                got.append((fields, group(held)))
            _, word = flat(data.ArrayLayout(pixel_layout(w), p), f"bank{k}")
            for fields, d in got:
                m.d.comb += [getattr(word[j], f).eq(getattr(d[j], f)) for j in range(p) for f in fields]
            words.append(word)
        m.d.comb += self.wr.ready.eq(1)

        out = self.rd_data.payload
        for k in range(BANKS):
            with m.If(rot == k):
                m.d.comb += [out.word.eq(words[k]),
                             out.right.eq(words[(k + 1) % BANKS][0]),
                             out.left.eq(words[(k + BANKS - 1) % BANKS][p - 1])]
        return m
