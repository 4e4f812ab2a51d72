"""One cell of the tile engine's array: Fig. 2's EDT cell and the BFS relaxation on one MAX tree."""

from amaranth.hdl import C, Cat, Module, Mux, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from navcores.models.edt_bfs import OFFSETS

from .tile_layouts import cell_layout, flat, nb_layout

__all__ = ["TileCell"]


class TileCell(wiring.Component):
    """A pixel of the tile: paper 004's cell (Fig. 2) for the EDT, a hop relaxation for the BFS.

    Neighbour i = 1..8 as in Fig. 1 (``6 2 5 / 3 0 1 / 7 4 8``); at the
    tile's edge the neighbours are the halo's registers.

    *EDT* (one iteration k per visit, :func:`models.edt_bfs.edt_step`):
    ADD-SUB and INC give each neighbour's candidate (eq. 1-3:
    ``delta_i = delta(p_i) - DX_i - DY_i``, ``dx_i = dx(p_i) + sr``), the MAX
    tree of seven CMP-MUX in three levels takes the largest over the done
    neighbours, ties to the smallest index (a CMP-MUX keeps its left input
    unless the right one is valid and strictly greater), and the +2k adder's
    sign is the third enable: a present cell not done with a done neighbour
    and ``delta_m + 2k >= 0`` becomes done with ``di = k`` and the winner's
    vector.  delta is not kept: the loader rebuilds it each level.

    *BFS* (relaxation, one iteration per clock): the same tree on the key
    ``~hop`` (largest key = smallest hop, ties to the smallest index) gives
    ``m`` and its index; a cfr cell with a visited neighbour takes
    ``hop = m + 1`` when that is below its hop (or it is not visited); the
    parent register takes that index when ``hop = m + 1`` (else 0) in every
    iteration, so the last one, which changes nothing, leaves the parent of
    the final values (:meth:`models.edt_bfs_tiled.TileEngine.bfs_visit`).

    Ports
    -----
    phase : In(1)
        0: EDT, 1: BFS.
    step : In(1)
        Run one iteration.
    k : In(k bits)
        The EDT's level (the paper's iteration number).
    clear : In(1)
        Clear ``present``, ``flag``, ``fresh``, ``cfr``, ``chg`` (a visit's schedule).
    load : In(1), ld : In(cell_layout's width)
        Load the register from the loader's lane (``clear`` and ``load`` win over ``step``).
    n1 .. n8 : In(nb_layout's width)
        The neighbours' ``nb``.
    nb : Out(nb_layout's width)
        What the neighbours read.
    reg : Out(cell_layout's width)
        The register (write-back, marks).
    upd : Out(1)
        This iteration changes the cell (combinational).
    smark : Out(1)
        EDT self mark: present, not done, and a neighbour done in RAM
        (combinational from the registers; read after the iteration).
    """

    def __init__(self, w):
        self.w = w
        # Plain vectors (the layouts are views inside): see tile_layouts.flat.
        cl, nl = cell_layout(w).size, nb_layout(w).size
        ports = {"phase": In(1), "step": In(1), "k": In(w["k"]), "clear": In(1), "load": In(1), "ld": In(cl)}
        ports.update({f"n{i}": In(nl) for i in OFFSETS})
        ports.update({"nb": Out(nl), "reg": Out(cl), "upd": Out(1), "smark": Out(1)})
        super().__init__(ports)

    def elaborate(self, platform):
        m = Module()
        w = self.w
        kw, hb = w["key"], w["hop"]
        # One register for the whole state (Icarus wakes one process per register per edge).
        r_bits, r = flat(cell_layout(w), "r")
        nb_out = nb_layout(w)(self.nb)
        m.d.comb += [self.reg.eq(r_bits), nb_out.flag.eq(r.flag), nb_out.ram.eq(r.flag | r.fresh),
                     nb_out.val.eq(r.val), nb_out.dx.eq(r.dx), nb_out.dy.eq(r.dy)]
        n = {i: nb_layout(w)(getattr(self, f"n{i}")) for i in OFFSETS}

        # ADD-SUB and INC (eq. 1-3), or the BFS key: one candidate per neighbour.
        cands = []
        for i, (dr, dc) in OFFSETS.items():
            nb = n[i]
            sr, sc = -dr, -dc                   # p - p_i
            big_x = (Cat(C(1, 1), nb.dx).as_signed() if sr > 0 else 1 - Cat(C(0, 1), nb.dx).as_signed()) if sr else 0
            big_y = (Cat(C(1, 1), nb.dy).as_signed() if sc > 0 else 1 - Cat(C(0, 1), nb.dy).as_signed()) if sc else 0
            key = Signal(signed(kw), name=f"key_{i}")
            m.d.comb += key.eq(Mux(self.phase, ~nb.val[:hb], nb.val - big_x - big_y))
            cands.append((nb.flag, key, (nb.dx + sr) if sr else nb.dx, (nb.dy + sc) if sc else nb.dy, C(i, 4)))

        # MAX: seven CMP-MUX in three levels, ties to the left (smaller index).
        def cmp_mux(a, b, name):
            sel = Signal(name=f"sel_{name}")
            m.d.comb += sel.eq(b[0] & (~a[0] | (b[1] > a[1])))
            out = []
            for j, shape in enumerate((1, signed(kw), signed(w["dx"]), signed(w["dy"]), 4)):
                s = Signal(shape, name=f"{'vkxyi'[j]}_{name}")
                m.d.comb += s.eq(a[0] | b[0] if j == 0 else Mux(sel, b[j], a[j]))
                out.append(s)
            return out

        l1 = [cmp_mux(cands[j], cands[j + 1], f"{j + 1}{j + 2}") for j in (0, 2, 4, 6)]
        l2 = [cmp_mux(l1[0], l1[1], "1234"), cmp_mux(l1[2], l1[3], "5678")]
        vm, km, xm, ym, im = cmp_mux(l2[0], l2[1], "m")

        # EDT: the +2k adder, its sign the third enable.
        dnew = Signal(signed(kw + 1), name="dnew")
        m.d.comb += dnew.eq(km + Cat(C(0, 1), self.k))
        en_edt = Signal(name="en_edt")
        m.d.comb += en_edt.eq(self.step & ~self.phase & r.present & ~r.flag & vm & ~dnew[-1])

        # BFS: m = the smallest visited neighbour hop.
        m1 = Signal(hb + 1, name="m1")
        m.d.comb += m1.eq(~km[:hb] + 1)
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

        near = Cat(*[n[i].ram for i in OFFSETS]).any()
        m.d.comb += [self.upd.eq(en_edt | en_bfs), self.smark.eq(r.present & ~r.flag & near)]
        return m
