"""The tile engine's array: T_r x T_c cells, the halo ring, the loader's lanes, marks and write-back."""

from amaranth.hdl import Array, Cat, Module, Mux, Signal
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from navcores.models.edt_bfs import OFFSETS

from .tile_cell import TileCell
from .tile_layouts import cell_layout, flat, named, nb_layout, pixel_layout

__all__ = ["TileArray", "ring_regions"]


def ring_regions(t_r, t_c):
    """Window positions (a, b) of the halo ring by the direction (Fig. 1) of the tile they belong to.

    The window is (T_r + 2) x (T_c + 2), the tile its inner T_r x T_c
    (rows 1..T_r, columns 1..T_c), as in :func:`models.edt_bfs_tiled._ring_regions`.
    """
    def side(v, n):
        return -1 if v == 0 else (1 if v == n + 1 else 0)
    out = {i: [] for i in OFFSETS}
    index = {off: i for i, off in OFFSETS.items()}
    for a in range(t_r + 2):
        for b in range(t_c + 2):
            d = (side(a, t_r), side(b, t_c))
            if d != (0, 0):
                out[index[d]].append((a, b))
    return out


class TileArray(wiring.Component):
    """One tile of ``t_r`` x ``t_c`` :class:`TileCell` plus its one-pixel halo, with the lanes that load them.

    A visit (:mod:`models.edt_bfs_tiled`): ``clear`` (the schedule), then one
    window row per ``ld_en`` beat (row ``ld_row`` of the (T_r + 2) x (T_c + 2)
    window, only the rows inside the map), the iterations (``step``), then
    the store: ``wb`` shows tile row ``wb_row`` and ``marks`` the tiles to
    mark, from the registers, which the store does not change (the BFS
    marks through a register of their own: valid from the cycle after the
    visit's last iteration).

    The loader's lanes (one per window column) turn a RAM pixel into a cell
    register: EDT level k: ``flag`` = done before the level (``di <= k-1``:
    a halo pixel made done earlier in the level, ``di = k``, is masked and
    ``fresh``), ``val`` = d2 = ``dx^2 + dy^2`` (two squarers per lane; the
    paper's delta entering iteration k is ``k(k-1) - d2``, :class:`TileCell`),
    ``aux`` = di; BFS: ``flag`` = visited (hop != NONE), ``cfr`` = not done or
    ``di > d_far``, ``chg`` = a root (hop 0), ``val`` = hop, ``aux`` =
    parent.  Every flag is gated by ``present`` (``ld_present``, the lane's
    column inside the map), so pixels outside the map are never done,
    visited or in the cfr, like the untiled array's absent neighbours.

    Ports
    -----
    phase : In(1)
        0: EDT, 1: BFS.
    k : In, kk : In
        The level k and K(k) = k^2 + k (EDT: di of a new pixel, the cells' threshold).
    dfar : In
        d_far (the cfr, BFS).
    clear : In(1)
        Clear every window register's flags (a visit's schedule).
    ld_en : In(1), ld_row : In, ld_px : In(T_c + 2 pixels), ld_present : In(T_c + 2)
        Load window row ``ld_row``: window column b takes ``ld_px[b]``
        (map column c0 - 1 + b), present where ``ld_present[b]``.
    step : In(1)
        One iteration (EDT: iteration k; BFS: one relaxation).  With
        ``select_reg`` (the cells' registered MIN winner, :class:`TileCell`)
        only in a cycle after one without ``clear``, ``ld_en`` or ``step``.
    upd : Out(1)
        Some cell changed in the last cycle's iteration (the BFS visit's end
        test): each cell's change is a flip-flop beside its register, and
        ``upd`` is their OR, so no OR tree of the cells' logic ends a path
        (the cell's iteration into a flip-flop, as into its own register).
    marks : Out(9)
        Bit 0: the EDT's self mark (a present pixel not done next to one done
        in RAM); bit i = 1..8: the tile in direction i is marked (EDT: a halo
        pixel not done in RAM next to a pixel this visit made done; BFS: a
        cfr halo pixel x to which a tile pixel that fell, or a root, offers
        ``hop + 1`` below hop(x), or equal from an index below parent(x)).
        Not yet filtered by the worklist's queued bits.
    wb_row : In, wb : Out(T_c pixels)
        Tile row ``wb_row`` for the write-back: di, dx, dy (EDT) and hop,
        parent (BFS) of each pixel.
    dirty : Out(T_c), with ``dirty`` only
        The pixels of tile row ``wb_row`` whose write-back fields may differ
        from the loaded ones (:class:`TileCell`'s ``dirty``).
    dirty_rows : Out(T_r), with ``dirty`` only
        Bit a: tile row a has such a pixel.
    """

    def __init__(self, t_r, t_c, w, dirty=False, select_reg=False):
        self.t_r, self.t_c, self.w, self.with_dirty, self.select_reg = t_r, t_c, w, bool(dirty), bool(select_reg)
        px = pixel_layout(w)
        super().__init__({
            **({"dirty": Out(t_c), "dirty_rows": Out(t_r)} if self.with_dirty else {}),
            "phase": In(1), "k": In(w["k"]), "kk": In(w["kk"]), "dfar": In(w["di"]),
            "clear": In(1),
            "ld_en": In(1), "ld_row": In(range(t_r + 2)), "ld_px": In(data.ArrayLayout(px, t_c + 2)),
            "ld_present": In(t_c + 2),
            "step": In(1), "upd": Out(1), "marks": Out(9),
            "wb_row": In(range(t_r)), "wb": Out(data.ArrayLayout(px, t_c)),
        })

    def _lane(self, m, b):
        """Window column b's lane: RAM pixel -> cell register value."""
        w = self.w
        px, present = self.ld_px[b], self.ld_present[b]
        bits, v = flat(cell_layout(w), f"lane{b}")
        none_di = px.di == (1 << w["di"]) - 1
        none_hop = px.hop == (1 << w["hop"]) - 1
        sq = Signal(2 * max(w["dx"], w["dy"]) + 1, name=f"sq{b}")
        m.d.comb += sq.eq(px.dx * px.dx + px.dy * px.dy)
        m.d.comb += [v.present.eq(present), v.dx.eq(px.dx), v.dy.eq(px.dy)]
        with m.If(self.phase):
            m.d.comb += [v.flag.eq(present & ~none_hop), v.cfr.eq(present & (none_di | (px.di > self.dfar))),
                         v.chg.eq(present & (px.hop == 0)), v.val.eq(px.hop), v.aux.eq(px.parent)]
        with m.Else():
            m.d.comb += [v.flag.eq(present & (px.di < self.k)), v.fresh.eq(present & (px.di == self.k)),
                         v.val.eq(sq), v.aux.eq(px.di), v.edt.eq(present)]
        return bits

    def elaborate(self, platform):
        m = Module()
        t_r, t_c, w = self.t_r, self.t_c, self.w
        hb = w["hop"]
        lanes = [self._lane(m, b) for b in range(t_c + 2)]

        regs, nbs, cells = {}, {}, {}
        for a in range(t_r + 2):
            load = Signal(name=f"load{a}")
            m.d.comb += load.eq(self.ld_en & (self.ld_row == a))
            for b in range(t_c + 2):
                if 1 <= a <= t_r and 1 <= b <= t_c:
                    cell = cells[a, b] = TileCell(w, self.with_dirty, self.select_reg)
                    m.submodules[f"cell_{a - 1}_{b - 1}"] = cell
                    m.d.comb += [cell.phase.eq(self.phase), cell.step.eq(self.step), cell.k.eq(self.k),
                                 cell.kk.eq(self.kk), cell.clear.eq(self.clear), cell.load.eq(load),
                                 cell.ld.eq(lanes[b])]
                    regs[a, b], nbs[a, b] = cell_layout(w)(cell.state), cell.nb
                else:
                    # A halo cell: a register the lanes load, read by its tile neighbours.
                    bits, r = flat(cell_layout(w), f"halo_{a}_{b}")
                    regs[a, b] = r
                    with m.If(self.clear):
                        m.d.sync += [r.present.eq(0), r.flag.eq(0), r.fresh.eq(0), r.cfr.eq(0), r.chg.eq(0)]
                    with m.Elif(load):
                        m.d.sync += bits.eq(lanes[b])
                    nbs[a, b], nb = flat(nb_layout(w), f"halo_nb_{a}_{b}")
                    m.d.comb += [nb.flag.eq(r.flag), nb.ram.eq(r.flag | r.fresh), nb.val.eq(r.val),
                                 nb.dx.eq(r.dx), nb.dy.eq(r.dy), nb.edt.eq(r.edt)]
        for (a, b), cell in cells.items():
            for i, (dr, dc) in OFFSETS.items():
                m.d.comb += getattr(cell, f"n{i}").eq(nbs[a + dr, b + dc])
        # The cells' change bits, registered where they are computed (one
        # vector: one process in the simulators), then OR-ed from flip-flops.
        chg = Signal(len(cells), name="chg_q")
        m.d.sync += chg.eq(Cat(*[c.upd for c in cells.values()]))
        m.d.comb += self.upd.eq(chg.any())

        # Marks (read in the store, from registers that no longer change).
        inside = set(cells)
        dirs = []
        for i, ring in ring_regions(t_r, t_c).items():
            hits = []
            for a, b in ring:
                x = regs[a, b]
                near = [(j, regs[a + dr, b + dc]) for j, (dr, dc) in sorted(OFFSETS.items())
                        if (a + dr, b + dc) in inside]
                edt = x.present & ~x.flag & ~x.fresh & Cat(*[q.chg for _, q in near]).any()
                # BFS: the best offer hop(q) + 1 of the tile neighbours that fell, the
                # smallest index (seen from x) among equals, as x's own MIN selection takes it.
                vb, jb = near[0][1].chg, near[0][0]
                best = named(m, f"offer_{a}_{b}_{jb}", near[0][1].val[:hb] + 1, hb + 1)
                for j, q in near[1:]:
                    off = named(m, f"offer_{a}_{b}_{j}", q.val[:hb] + 1, hb + 1)
                    sel = named(m, f"take_{a}_{b}_{j}", q.chg & (~vb | (off < best)))
                    vb = named(m, f"any_{a}_{b}_{j}", vb | q.chg)
                    best = named(m, f"best_{a}_{b}_{j}", Mux(sel, off, best), hb + 1)
                    jb = named(m, f"from_{a}_{b}_{j}", Mux(sel, j, jb), 4)
                hop_x = x.val[:hb]
                bfs = x.cfr & vb & ((best < hop_x) | ((best == hop_x) & (jb < x.aux[:4])))
                hits.append((named(m, f"mark_edt_{a}_{b}", edt), named(m, f"mark_bfs_{a}_{b}", bfs)))
            dirs.append([Cat(*[h[g] for h in hits]).any() for g in range(2)])
        # The BFS marks' offer chains are registered: in the store they show the registers of the
        # cycle before, which are the final ones, since a BFS visit's last iteration lowers no hop
        # (so sets no chg) and the halo registers change only at the load.
        bfs_dirs = Signal(8)
        m.d.sync += bfs_dirs.eq(Cat(*[d[1] for d in dirs]))
        self_mark = ~self.phase & Cat(*[c.smark for c in cells.values()]).any()
        m.d.comb += self.marks.eq(Cat(self_mark, Mux(self.phase, bfs_dirs, Cat(*[d[0] for d in dirs]))))

        # Write-back: tile row wb_row, each pixel's fields from its register.
        rows = []
        for a in range(1, t_r + 1):
            bits, row = flat(data.ArrayLayout(pixel_layout(w), t_c), f"wb{a - 1}")
            for b in range(1, t_c + 1):
                r = regs[a, b]
                m.d.comb += [row[b - 1].di.eq(r.aux), row[b - 1].dx.eq(r.dx), row[b - 1].dy.eq(r.dy),
                             row[b - 1].hop.eq(r.val), row[b - 1].parent.eq(r.aux)]
            rows.append(bits)
        m.d.comb += self.wb.eq(Array(rows)[self.wb_row])
        if self.with_dirty:
            dirty = [Cat(*[cells[a, b].dirty for b in range(1, t_c + 1)]) for a in range(1, t_r + 1)]
            m.d.comb += [self.dirty.eq(Array(dirty)[self.wb_row]), self.dirty_rows.eq(Cat(*[d.any() for d in dirty]))]
        return m
