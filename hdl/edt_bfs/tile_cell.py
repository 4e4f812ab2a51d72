"""One cell of the tile engine's array: Fig. 2's EDT cell in the squared-distance form and the BFS relaxation."""

from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from navcores.models.edt_bfs import OFFSETS

from .select import candidate, inc, min_select_halves, pick, winner_offset
from .tile_layouts import cell_layout, flat, nb_layout

__all__ = ["TileCell"]


class TileCell(wiring.Component):
    """A pixel of the tile: paper 004's cell (Fig. 2) for the EDT, a hop relaxation for the BFS.

    Neighbour i = 1..8 as in Fig. 1 (``6 2 5 / 3 0 1 / 7 4 8``); at the
    tile's edge the neighbours are the halo's registers.  Both phases share
    one MIN selection in two levels
    (:func:`~hdl.edt_bfs.select.min_select_halves`: neighbours 1-4 and 5-8
    each flat, 6 pairwise comparisons at once and a one-hot winner, then
    the halves' smallest keys compared: 13 comparators where the untiled
    :class:`~hdl.edt_bfs.cell.EdtCell`'s flat MIN has 28, the same winner,
    the smallest index among the smallest key; AND-OR multiplexers).

    *EDT* (one iteration k per visit, :func:`models.edt_bfs.edt_step`, computed
    here as :func:`models.edt_bfs.edt_step_d2`): a neighbour shows ``d2`` =
    dx^2 + dy^2 where the paper's cell shows delta.  ADD-SUB gives each
    neighbour's candidate (eq. 2, :func:`~hdl.edt_bfs.select.candidate`:
    ``d2_i = d2(p_i) + DX_i + DY_i``, ``DX_i = 2 sr dx(p_i) + 1``), the MIN
    over the done neighbours picks the winner m, INC gives its vector only
    (eq. 1, ``dx_m = dx(p_m) + sr_m``: the winner's vector and offset
    multiplexed, then one pair of adders instead of eight; the BFS's
    winning hop is the winning key itself, the ADD-SUB gated off: 11 %
    fewer LUT4 than a multiplexer of eight INC results and one of the
    hops), and a present cell not done with a done neighbour becomes done
    with ``di = k`` and the winner's vector when ``d2_m <= kk``, one
    comparator on the winner's d2 (the untiled cell tests every candidate
    beside the selection instead: here eight comparators cost 10 % of the
    cell for 5 % of its clock).  ``kk`` = K(k) = k^2 + k comes from the
    engine.

    This is the paper's cell, bit for bit.  The loader gives a done
    neighbour ``delta_{k-1}(p_i) = K(k-1) - d2(p_i)`` (the invariant of
    :mod:`models.edt_bfs`, with K(k-1) = k(k-1)), so eq. 3 gives
    ``delta_i = K(k-1) - DX_i - DY_i - d2(p_i) = K(k-1) - d2_i``: delta_i is
    a strictly decreasing function of d2_i, so the MAX tree's winner (the
    largest delta_i, ties to the smallest index) is the MIN's (the smallest
    d2_i, ties to the smallest index), and the third enable, the +2k
    adder's sign ``delta_m + 2k >= 0`` (eq. 4's growth, applied to the
    winner), is ``K(k-1) + 2k - d2_m = k^2 + k - d2_m >= 0``, i.e.
    ``d2_m <= kk``.  The engine keeps kk as it kept k(k-1), by increments
    (``kk += 2k + 2`` as k becomes k + 1).  d2 is not kept: the visit runs
    one iteration, and the loader computes each level's d2 from the vector.

    *BFS* (relaxation, one iteration per clock): the same MIN on the
    neighbours' ``hop`` (smallest hop, ties to the smallest index) gives
    ``m`` and its index; a cfr cell with a visited neighbour takes
    ``hop = m + 1`` when that is below its hop (or it is not visited); the
    parent register takes that index when ``hop = m + 1`` (else 0) in every
    iteration, so the last one, which changes nothing, leaves the parent of
    the final values (:meth:`models.edt_bfs_tiled.TileEngine.bfs_visit`).

    *Select register* (``select_reg``): the MIN's one-hot winner, its key
    (d2_m or the hop) and "a neighbour is done / visited" are registered
    every cycle, and the iteration uses them: the clock's path from a
    neighbour's register through the ADD-SUB, the comparators and the
    winner logic ends in those registers, and the
    step's starts there, through the AND-OR multiplexers and the
    threshold's comparator (EDT; the BFS: the multiplexed hop + 1 against
    the cell's) into the cell's register.  They hold what the step would
    compute from registers that do not change in between, so the
    iteration is the same bit for bit; the engine gives every ``step`` a
    select cycle before it (no ``load``, ``clear`` or ``step`` of the array
    in the cycle before a step: :class:`~models.edt_bfs_tiled.Timing`'s
    ``iteration`` 2).

    Ports
    -----
    phase : In(1)
        0: EDT, 1: BFS.
    step : In(1)
        Run one iteration (with ``select_reg``: only in a cycle after one
        without ``load``, ``clear`` or ``step`` anywhere in the array).
    k : In(k bits)
        The EDT's level (the paper's iteration number k: di of a new cell).
    kk : In(kk bits)
        K(k) = k^2 + k (:func:`models.edt_bfs.k_square`), the EDT's threshold.
    clear : In(1)
        Clear ``present``, ``flag``, ``fresh``, ``cfr``, ``chg`` (a visit's schedule).
    load : In(1), ld : In(cell_layout's width)
        Load the register from the loader's lane (``clear`` and ``load`` win over ``step``).
    n1 .. n8 : In(nb_layout's width)
        The neighbours' ``nb`` (``val``: d2 in the EDT, hop in the BFS;
        ``edt``: 1 in an EDT step and 0 in a BFS step wherever ``flag`` is
        1, the ADD-SUB's gate; elsewhere any value).
    nb : Out(nb_layout's width)
        What the neighbours read.
    state : Out(cell_layout's width)
        The register (write-back, marks).
    upd : Out(1)
        This iteration changes the cell (combinational).
    smark : Out(1)
        EDT self mark: present, not done, and a neighbour done in RAM
        (combinational from the registers; read after the iteration).
    dirty : Out(1), with ``dirty`` only
        The write-back's fields (EDT: di, dx, dy; BFS: hop, parent) may
        differ from the loaded ones: set by an iteration that writes one of
        them with a new value (EDT: the cell becomes done; BFS: its hop
        falls or its parent changes), cleared by ``clear`` and ``load``.  A
        flip-flop: the engine's skip_clean writes back only the pixels it
        marks, instead of comparing each row with a copy of it as loaded.
        Never clear where a field differs (an EDT cell made done again with
        the same vector is marked: one pixel written for nothing).
    """

    def __init__(self, w, dirty=False, select_reg=False):
        self.w, self.with_dirty, self.select_reg = w, bool(dirty), bool(select_reg)
        # Plain vectors (the layouts are views inside): see tile_layouts.flat.
        cl, nl = cell_layout(w).size, nb_layout(w).size
        ports = {"phase": In(1), "step": In(1), "k": In(w["k"]), "kk": In(w["kk"]), "clear": In(1), "load": In(1),
                 "ld": In(cl)}
        ports.update({f"n{i}": In(nl) for i in OFFSETS})
        ports.update({"nb": Out(nl), "state": Out(cl), "upd": Out(1), "smark": Out(1)})
        if self.with_dirty:
            ports["dirty"] = Out(1)
        super().__init__(ports)

    def elaborate(self, platform):
        m = Module()
        w = self.w
        hb = w["hop"]
        # One register for the whole state (Icarus wakes one process per register per edge).
        r_bits, r = flat(cell_layout(w), "r")
        nb_out = nb_layout(w)(self.nb)
        m.d.comb += [self.state.eq(r_bits), nb_out.flag.eq(r.flag), nb_out.ram.eq(r.flag | r.fresh),
                     nb_out.val.eq(r.val), nb_out.dx.eq(r.dx), nb_out.dy.eq(r.dy), nb_out.edt.eq(r.edt)]
        n = {i: nb_layout(w)(getattr(self, f"n{i}")) for i in OFFSETS}

        # ADD-SUB and INC (eq. 1-3 in the d2 form): one candidate per neighbour.
        # The key is d2_i (EDT) or the hop (BFS: DX_i, DY_i gated to 0, so the
        # comparators take val as it is, a hop below 2^hop with the upper bits 0;
        # one adder instead of an adder and a multiplexer in front of them).  The
        # gate is the neighbour's own ``edt`` flip-flop, not ``phase``: the same
        # value wherever the key counts (a done / visited neighbour, loaded in
        # this visit), from a register beside the adders.
        # d2_i cannot wrap where it counts (tile_layouts.tile_widths).
        cands = []
        for i in OFFSETS:
            nb = n[i]
            key = candidate(m, i, nb.val, nb.dx, nb.dy, w["val"], gate=nb.edt)
            cands.append((nb.flag, key, nb.dx, nb.dy))

        # MIN: two halves, ties to the smallest index; the winner's d2 (EDT), vector, hop (BFS), index.
        win, km = min_select_halves(m, [c[0] for c in cands], [c[1] for c in cands], w["val"])
        if self.select_reg:
            # Written every cycle, read only in a step after a select cycle: no reset needed.
            win_q = Signal(len(win), name="win_q", reset_less=True)
            km_q = Signal(len(km), name="key_m", reset_less=True)
            m.d.sync += [win_q.eq(Cat(*win)), km_q.eq(km)]
            win, km = list(win_q), km_q
        # INC after the MIN (eq. 1 on the winner only): the winner's vector plus
        # its offset p - p_m, one pair of adders instead of one per neighbour.
        xn = pick(m, win, [c[2] for c in cands], signed(w["dx"]), "x_n")
        yn = pick(m, win, [c[3] for c in cands], signed(w["dy"]), "y_n")
        xm, ym = inc(m, "m", xn, yn, winner_offset(m, win, 0), winner_offset(m, win, 1), w["dx"], w["dy"])
        # The BFS's key is the neighbour's hop itself (the ADD-SUB gated off),
        # so the winner's key is its hop: no multiplexer of its own.
        hm = km[:hb]
        im = pick(m, win, list(OFFSETS), 4, "i_m")
        vm = Signal(name="v_m", reset_less=self.select_reg)
        some = vm.eq(Cat(*[c[0] for c in cands]).any())       # a neighbour done (EDT) / visited (BFS)
        if self.select_reg:
            m.d.sync += some
        else:
            m.d.comb += some

        # EDT: the third enable, d2_m <= kk (delta_m + 2k >= 0), on the winner's d2.
        en_edt = Signal(name="en_edt")
        m.d.comb += en_edt.eq(self.step & ~self.phase & r.present & ~r.flag & vm & (km <= self.kk))

        # BFS: m = the smallest visited neighbour hop.
        m1 = Signal(hb + 1, name="m1")
        m.d.comb += m1.eq(hm + 1)
        hop = r.val[:hb]
        en_bfs = Signal(name="en_bfs")
        m.d.comb += en_bfs.eq(self.step & self.phase & r.cfr & vm & (~r.flag | (m1 < hop)))
        parent = Mux(r.flag & vm & (hop == m1), im, 0)

        with m.If(self.clear):
            m.d.sync += [r.present.eq(0), r.flag.eq(0), r.fresh.eq(0), r.cfr.eq(0), r.chg.eq(0)]
        with m.Elif(self.load):
            m.d.sync += r_bits.eq(self.ld)
        with m.Elif(en_edt):
            m.d.sync += [r.flag.eq(1), r.chg.eq(1), r.aux.eq(self.k), r.dx.eq(xm), r.dy.eq(ym)]
        with m.Elif(self.step & self.phase):
            m.d.sync += r.aux.eq(parent)
            with m.If(en_bfs):
                m.d.sync += [r.flag.eq(1), r.chg.eq(1), r.val.eq(m1)]

        if self.with_dirty:
            with m.If(self.clear | self.load):
                m.d.sync += self.dirty.eq(0)
            with m.Elif(en_edt | (self.step & self.phase & (en_bfs | (parent != r.aux)))):
                m.d.sync += self.dirty.eq(1)

        near = Cat(*[n[i].ram for i in OFFSETS]).any()
        m.d.comb += [self.upd.eq(en_edt | en_bfs), self.smark.eq(r.present & ~r.flag & near)]
        return m
