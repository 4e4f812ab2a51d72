"""W_1 on the fly: which tiles hold a free pixel 8-adjacent to an obstacle, from the map rows as they load."""

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from navcores.models.edt_bfs import OFFSETS

from .tile_layouts import named

__all__ = ["FrontierFlags"]


class FrontierFlags(wiring.Component):
    """The per-tile frontier flags of W_1 (:meth:`models.edt_bfs_tiled.TileEngine.first_worklist`).

    Each map word (``p`` obstacle bits of row r, word column w) arrives once.
    With the row above it (a line buffer) and the last pixels of the words
    before (registers), every 8-adjacent pair of pixels lies in some beat's
    2 x (p + 1) window (rows r - 1 and r, columns w p - 1 .. w p + p - 1);
    a present free pixel of a pair whose other pixel is an obstacle flags its
    tile.  A beat touches at most tile rows R(r - 1), R(r) and tile columns
    w - 1, w.  Flags accumulate in two registers of a tile row each (tile row
    R(r) and the one above, which row r = R T_r still completes) and go to a
    flag RAM as each tile row is final; the last beat writes the last one or
    two (two banks by tile-row parity, so both in one cycle).  The scan
    reads one flag word (a tile row) per ``scan_en``; a read in the cycle of
    the write sees it (transparent).

    Ports
    -----
    init : In(1)
        A job's start: clear the accumulators.
    beat : In(1), obst : In(p)
        One map word: bit j = column w p + j is an obstacle.
    row, wcol, tile_row : In
        The word's row r, word column w, and tile row R(r) = r // T_r.
    tile_top : In(1)
        r is the first row of its tile row (r mod T_r = 0).
    row_end, last : In(1)
        The word is its row's last / the map's last.
    width : In
        The map's width W (columns from W on are absent).
    scan_en : In(1), scan_row : In
        Read tile row ``scan_row``'s flags; ``flags`` (bit C = tile column C)
        shows them the next cycle, held until the next read.
    """

    def __init__(self, w, p):
        self.w, self.p = w, p
        nc = w["tile_cols"]
        super().__init__({
            "init": In(1), "beat": In(1), "obst": In(p),
            "row": In(w["row"]), "wcol": In(range(w["words"])), "tile_row": In(range(w["tile_rows"])),
            "tile_top": In(1), "row_end": In(1), "last": In(1), "width": In(w["width"]),
            "scan_en": In(1), "scan_row": In(range(w["tile_rows"])), "flags": Out(nc),
        })

    def elaborate(self, platform):
        m = Module()
        w, p = self.w, self.p
        nc = w["tile_cols"]

        # The row above: one word per word column (read before this beat overwrites it).
        m.submodules.line = line = Memory(shape=p, depth=w["words"], init=[])
        lr = line.read_port(domain="comb")
        lw = line.write_port()
        m.d.comb += [lr.addr.eq(self.wcol), lw.addr.eq(self.wcol), lw.data.eq(self.obst), lw.en.eq(self.beat)]
        cur_left = Signal()             # row r, column w p - 1
        prev_left = Signal()            # row r - 1, column w p - 1
        with m.If(self.beat):
            m.d.sync += [cur_left.eq(self.obst[p - 1]), prev_left.eq(lr.data[p - 1])]

        # The 2 x (p + 1) window: present, obstacle.
        above = named(m, "above", self.row != 0)
        base = named(m, "base", self.wcol * p)
        cols = [named(m, "col0", self.wcol != 0)] + [named(m, f"col{j + 1}", base + j < self.width) for j in range(p)]
        pres = {(0, x): named(m, f"pres0_{x}", above & cols[x]) for x in range(p + 1)}
        pres.update({(1, x): cols[x] for x in range(p + 1)})
        bit = {(0, 0): prev_left, (1, 0): cur_left}
        bit.update({(0, x + 1): lr.data[x] for x in range(p)})
        bit.update({(1, x + 1): self.obst[x] for x in range(p)})
        obst = {(y, x): named(m, f"obst{y}_{x}", pres[y, x] & bit[y, x]) for (y, x) in pres}
        hit = {}
        for (y, x) in pres:
            nbs = [obst[y + dy, x + dx] for dy, dx in OFFSETS.values() if (y + dy, x + dx) in pres]
            hit[y, x] = named(m, f"hit{y}_{x}", pres[y, x] & ~bit[y, x] & Cat(*nbs).any())
        f = {(y, side): named(m, f"f{y}{side}", Cat(*[hit[y, x] for x in (range(1) if side == 0 else range(1, p + 1))]).any())
             for y in (0, 1) for side in (0, 1)}

        # Tile-row accumulators.
        fl_cur = Signal(nc)
        fl_prev = Signal(nc)
        to_prev = named(m, "to_prev", self.tile_top & above)    # row r - 1 belongs to tile row R - 1
        start = named(m, "start", to_prev & ~cols[0])           # a new tile row begins (R >= 1)
        at_w = [named(m, f"at_w{c}", self.wcol == c) for c in range(nc)]

        def spread(left, here):
            return Cat(*[(left & at_w[c + 1] if c + 1 < nc else 0) | (here & at_w[c]) for c in range(nc)])

        up = named(m, "up", spread(f[0, 0], f[0, 1]))
        new_prev = Signal(nc)
        new_cur = Signal(nc)
        m.d.comb += [new_prev.eq(Mux(start, fl_cur, fl_prev) | Mux(to_prev, up, 0)),
                     new_cur.eq(Mux(start, 0, fl_cur) | spread(f[1, 0], f[1, 1]) | Mux(to_prev, 0, up))]
        with m.If(self.init):
            m.d.sync += [fl_cur.eq(0), fl_prev.eq(0)]
        with m.Elif(self.beat):
            m.d.sync += [fl_cur.eq(new_cur), fl_prev.eq(new_prev)]

        # The flag RAM: tile row R in bank R mod 2 at R // 2.
        done_prev = named(m, "done_prev", self.beat & to_prev & self.row_end)   # tile row R - 1 is final
        done_cur = named(m, "done_cur", self.beat & self.last)                  # the last tile row is final
        half = max(2, -(-w["tile_rows"] // 2))         # depth 2 at least: no 0-bit address
        rd_odd = Signal()
        with m.If(self.scan_en):
            m.d.sync += rd_odd.eq(self.scan_row[0])
        outs = []
        for k in range(2):
            mem = Memory(shape=nc, depth=half, init=[])
            m.submodules[f"flags{k}"] = mem
            wp = mem.write_port()
            rp = mem.read_port(transparent_for=(wp,))
            prev_row = Signal(range(w["tile_rows"]), name=f"prev_row{k}")
            m.d.comb += prev_row.eq(self.tile_row - 1)
            cur_here = named(m, f"cur_here{k}", done_cur & (self.tile_row[0] == k))
            prev_here = named(m, f"prev_here{k}", done_prev & (prev_row[0] == k))
            m.d.comb += [wp.en.eq(cur_here | prev_here),
                         wp.addr.eq(Mux(cur_here, self.tile_row, prev_row) >> 1),
                         wp.data.eq(Mux(cur_here, new_cur, new_prev)),
                         rp.addr.eq(self.scan_row >> 1), rp.en.eq(self.scan_en)]
            outs.append(rp.data)
        m.d.comb += self.flags.eq(Mux(rd_odd, outs[1], outs[0]))
        return m
