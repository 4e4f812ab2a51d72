"""The tile engine's last visits' write-backs, patched into window rows read before them (prefetch)."""

from amaranth.hdl import Array, Cat, Const, Module, Mux, Signal
from amaranth.lib import data, wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .tile_layouts import BFS_FIELDS, EDT_FIELDS, pixel_layout

__all__ = ["WritePatch"]


class WritePatch(wiring.Component):
    """The tile rows the last ``visits`` tile visits wrote, laid over a window row as it loads.

    With the prefetch (:class:`~hdl.edt_bfs.tile_engine.TileEngine`,
    ``prefetch`` = d), a visit's window rows are read while up to d earlier
    visits still iterate and write: such a read may reach the store before
    those visits' writes and return the words as they were.  Every visit
    before them wrote before the read was given (the store keeps reads
    behind earlier writes, StateSignature's contract), so the row the store
    returns plus the writes of the last d visits, oldest first, is the row
    as it is now.  This block keeps those writes (a bank per visit, d banks
    in a ring, a visit's bank being the oldest one's; the rows in a small
    memory with a read port per age, which synthesis maps to distributed
    RAM, not to flip-flops behind wide multiplexers) and patches them in:
    a pixel of a loaded row takes a bank's value where the bank's visit
    wrote it (its tile's own rows: the word of the same word column, or
    the edge pixel of the word left or right of it) and wrote it in the
    same phase (the EDT writes di, dx, dy; the BFS hop and parent: only
    those fields are patched, so a write of another phase, before the
    goals, never is).  A row read after all those writes is patched with
    what it already holds: the patch is right whatever the store's timing.
    A bank remembers which of its tile's rows its visit wrote (a visit may
    leave rows out: the engine's ``skip_clean``), and forgets them when the
    visit that writes it next has loaded its window (``start``): until
    then its rows are the oldest writes a load may still need.

    Parameters
    ----------
    w : dict
        :func:`~hdl.edt_bfs.tile_layouts.tile_widths`.
    t_r, t_c : int
        The array (a tile's rows; pixels per word).
    visits : int
        Banks: the visits read ahead (1..4).

    Ports
    -----
    init : In(1)
        Forget every bank (a job's start: nothing written yet).
    wr : In(1), wr_row : In(range(t_r)), wr_word : In(t_c pixels)
        This visit writes tile row ``wr_row`` (the word it gives the store).
    r0 : In, own : In, c : In, bfs : In(1)
        This visit's tile: its first map row, its rows inside the map, its
        word column; the phase.  Taken with each ``wr``.
    start : In(1)
        This visit has loaded its window and will write: its bank forgets
        the rows of the visit before (not in the cycle of a ``wr``).
    done : In(1)
        This visit ended: the next one writes the next bank.
    ld_row : In, ld_c : In
        The map row being loaded and the loading visit's word column
        (``bfs`` is its phase).
    raw : In(T_c + 2 pixels), loaded : Out(T_c + 2 pixels)
        The row as the store answered (the word column's left neighbour's
        last pixel, the word, the right neighbour's first) and as it is
        now.  Combinational.
    """

    def __init__(self, w, t_r, t_c, visits):
        if not 1 <= visits <= 4:
            raise ValueError(f"visits {visits!r}: must be 1..4")
        self.w, self.t_r, self.t_c, self.visits = w, t_r, t_c, visits
        px = pixel_layout(w)
        super().__init__({
            "init": In(1),
            "wr": In(1), "wr_row": In(range(t_r)), "wr_word": In(data.ArrayLayout(px, t_c)),
            "r0": In(w["row"] + 1), "own": In(range(t_r + 1)), "c": In(range(w["words"])), "bfs": In(1),
            "start": In(1), "done": In(1),
            "ld_row": In(w["row"]), "ld_c": In(range(w["words"])),
            "raw": In(data.ArrayLayout(px, t_c + 2)), "loaded": Out(data.ArrayLayout(px, t_c + 2)),
        })

    def elaborate(self, platform):
        m = Module()
        w, t_r, t_c, n = self.w, self.t_r, self.t_c, self.visits
        wsize = data.ArrayLayout(pixel_layout(w), t_c).size
        cur = Signal(range(max(n, 2)))        # the bank this visit writes: the oldest visit's
        with m.If(self.init):
            m.d.sync += cur.eq(0)
        with m.Elif(self.done):
            m.d.sync += cur.eq(Mux(cur == n - 1, 0, cur + 1))
        wrote = [Signal(t_r, name=f"b{b}_rows") for b in range(n)]     # the tile rows the bank's visit wrote
        r0 = [Signal(self.r0.shape(), name=f"b{b}_r0") for b in range(n)]
        own = [Signal(self.own.shape(), name=f"b{b}_own") for b in range(n)]
        col = [Signal(self.c.shape(), name=f"b{b}_c") for b in range(n)]
        bfs = [Signal(name=f"b{b}_bfs") for b in range(n)]
        rbits = max(1, (t_r - 1).bit_length())         # a tile row's index; bank b's row i at b 2^rbits + i
        m.submodules.rows = rows = Memory(shape=wsize, depth=n << rbits, init=[])
        wp = rows.write_port()
        m.d.comb += [wp.addr.eq(Cat(self.wr_row[:rbits], cur)), wp.data.eq(self.wr_word.as_value()),
                     wp.en.eq(self.wr)]
        for b in range(n):
            with m.If(self.init):
                m.d.sync += wrote[b].eq(0)
            with m.Elif(self.wr & (cur == b)):
                m.d.sync += [wrote[b].eq(wrote[b] | (Const(1, t_r) << self.wr_row)), r0[b].eq(self.r0),
                             own[b].eq(self.own), col[b].eq(self.c), bfs[b].eq(self.bfs)]
            with m.Elif(self.start & (cur == b)):
                m.d.sync += wrote[b].eq(0)
        # Oldest first: bank (cur + age) mod n is the age-th oldest; a newer visit's write wins.
        row = self.raw
        for age in range(n):
            sel = Signal(range(max(n, 2)), name=f"age{age}")
            m.d.comb += sel.eq(Mux(cur + age >= n, cur + age - n, cur + age))
            pick = {k: Array(v)[sel] for k, v in (("wrote", wrote), ("r0", r0), ("own", own), ("c", col),
                                                   ("bfs", bfs))}
            off = Signal(w["row"] + 1, name=f"age{age}_off")     # the loaded row in the bank's tile
            m.d.comb += off.eq(self.ld_row - pick["r0"])
            hit = Signal(name=f"age{age}_hit")
            m.d.comb += hit.eq(pick["wrote"].bit_select(off[:rbits], 1) & (pick["bfs"] == self.bfs)
                               & (self.ld_row >= pick["r0"]) & (off < pick["own"]))
            rp = rows.read_port(domain="comb")
            m.d.comb += rp.addr.eq(Cat(off[:rbits], sel[:max(1, (n - 1).bit_length())]))
            src = data.ArrayLayout(pixel_layout(w), t_c)(rp.data)
            same = Signal(name=f"age{age}_same")     # the bank's tile in the loading visit's word column
            m.d.comb += same.eq(pick["c"] == self.ld_c)
            where = {0: pick["c"] + 1 == self.ld_c, t_c + 1: pick["c"] == self.ld_c + 1}
            out = Signal(data.ArrayLayout(pixel_layout(w), t_c + 2), name=f"age{age}_row")
            m.d.comb += out.eq(row)
            for x in range(t_c + 2):
                spx = src[t_c - 1] if x == 0 else src[0] if x == t_c + 1 else src[x - 1]
                there = where.get(x, same)
                for group, use in ((EDT_FIELDS, ~self.bfs), (BFS_FIELDS, self.bfs)):
                    for f in group:
                        m.d.comb += getattr(out[x], f).eq(Mux(hit & there & use, getattr(spx, f), getattr(row[x], f)))
            row = out
        m.d.comb += self.loaded.eq(row)
        return m
