"""One cell of the EDT/NNT + BFS array (paper 004, section IV, Fig. 2)."""

from amaranth.hdl import C, Cat, Module, Mux, Signal, signed
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from navcores.models.edt_bfs import OFFSETS, widths

from ..params import Param, check, checked_init
from .select import candidate, inc, min_select, pick

__all__ = ["EdtCell", "cell_widths", "state_layout", "result_layout"]

MAX_SIDE = 256      # elaboration limit: the read-out and the widths are sized for it


def cell_widths(height, width):
    """Register widths of a cell of an ``height`` x ``width`` array (models.edt_bfs.widths), checked."""
    check(EdtCell.PARAMS, height=height, width=width)
    w = widths(height, width)
    # the checks the formulas promise (stated in models.edt_bfs.widths)
    assert w["delta_max"] < 1 << w["delta"], (w["delta_max"], w["delta"])
    assert w["k_max"] < 1 << w["k"] and w["k_di"] < 1 << w["di"]
    assert height - 1 < 1 << (w["dx"] - 1) and width - 1 < 1 << (w["dy"] - 1)
    assert w["delta_max"] + 2 * height + 2 * width < 1 << (w["cand"] - 1)
    return w


def state_layout(w):
    """The registers a cell's neighbours read (port ``state``, inputs ``n1`` .. ``n8``)."""
    return data.StructLayout({"done": 1, "d2": w["delta"], "dx": signed(w["dx"]),
                              "dy": signed(w["dy"]), "visited": 1})


def result_layout(w):
    """The registers only the read-out reads (port ``result``)."""
    return data.StructLayout({"di": w["di"], "cfr": 1, "parent": 4})


class EdtCell(wiring.Component):
    """Processing element of Fig. 2 in the squared-distance form: ADD-SUB, INC, MIN select, registers.

    The cell holds ``d2`` = Δx² + Δy² where the paper holds δ = k² + k - d2
    (:func:`models.edt_bfs.edt_step_d2`, the same map): the MAX tree of
    δ_i is a MIN of d2_i, the third enable condition δ_m + 2k >= 0 is
    ``d2_m <= kk`` with ``kk`` = k² + k broadcast by the controller, and a
    done cell's register never changes (eq. 4 is no operation).  So no adder
    follows the selection.  The selection is flat: the 28 pairwise
    comparisons of the eight candidates at once, a one-hot winner (the
    smallest index among the smallest d2, the tree's tie-break), an AND-OR
    multiplexer; the enable tests every candidate against ``kk`` beside it.
    One iteration is one clock, as in the paper; the logic between the
    neighbours' registers and this cell's is an adder, a comparator and a few
    LUT levels (the tree had seven adders/comparators in series).

    Parameters
    ----------
    height, width : int
        Size of the array the cell belongs to; they fix the widths
        (:func:`models.edt_bfs.widths`): k (iteration) ``ceil log2(k_max+1)``
        bits, δ ``ceil log2(k_max^2+k_max+1)``, d_i ``ceil log2(k_di+1)``,
        Δx / Δy signed with ``ceil log2(H)`` / ``ceil log2(W)`` magnitude bits,
        where ``k_di`` is the smallest k with ``k^2+k >= (H-1)^2+(W-1)^2``
        and ``k_max = k_di + 1``.

    Ports (neighbour i = 1..8 numbered as in Fig. 1: 6 2 5 / 3 0 1 / 7 4 8)
    -----------------------------------------------------------------------
    shift : In(1)
        Load pipeline (section IV): ``done <- n3.done``, ``visited <-
        n3.visited``, the marks of the cell on the left (p_3; the array feeds
        column 0's p_3 input with the incoming column during a shift); d2,
        Δx, Δy, d_i, cfr and parent are cleared, so nothing of a previous
        image survives a load.
    step_edt : In(1)
        EDT iteration ``k`` (mode 1, step 2).  The registers d2, Δx, Δy, d_i,
        done load the winner only under the paper's three conditions: done
        = 0, some neighbour done, ``d2_m <= kk`` (δ_m + 2k >= 0).
    step_cfr : In(1)
        Mode 2 (step 3): ``cfr <- ~done | (d_i > dfar)`` (a never reached
        cell, possible only without obstacles, is infinitely far);
        ``visited <- visited & cfr`` (a goal outside the cfr is dropped).
    step_bfs : In(1)
        Mode 3 (step 4): a cfr cell not yet visited with a visited neighbour
        becomes visited, ``parent`` = the smallest such neighbour index.
    k : In(k bits)
        Iteration number from the controller's counter (d_i of a new cell).
    kk : In(δ bits)
        ``k² + k`` (:func:`models.edt_bfs.k_square`), from the controller.
    dfar : In(d_i bits)
        d_far.
    n1 .. n8 : In(state_layout)
        Neighbour p_i's ``state`` (tie it to 0 outside the array).
    state : Out(state_layout)
        The registers the neighbours read: ``done``, ``d2`` (Δx² + Δy² of
        a done cell; δ = k² + k - d2), ``dx`` (Δx), ``dy`` (Δy), ``visited``.  (Δx, Δy) = p - nearest obstacle
        pixel, signed (the NNT).
    result : Out(result_layout)
        ``di`` (integer distance: the iteration that set done), ``cfr``
        (collision-free flag), ``parent`` (BFS parent, 0 = none / root).
    changed : Out(1)
        This cycle's step sets done (EDT) or visited (BFS): the controller's
        termination test.

    Each port is one signal and ``state`` and ``result`` are one register
    each (struct layouts), for the simulators' sake: Amaranth emits an
    ``always @(posedge clk)`` per register, and Icarus wakes every such
    process on every clock edge whatever its enable, so eight registers per
    cell cost a 32x32 array 8192 process wake-ups per cycle and two cost
    2048; whole-signal ports also keep the emitted cell module's port names
    fixed, which the array's instances rely on.  The flip-flops are the same.

    Timing: every step is one clock; outputs are registers, ``changed`` is
    combinational from the registers and the step inputs.
    """

    PARAMS = tuple(Param(n, int, lo=1, hi=MAX_SIDE, doc=f"array {n} (sets the widths)",
                         message="array {name} {value!r}: must be an integer in {lo}..{hi}")
                   for n in ("height", "width"))

    @checked_init
    def __init__(self, height, width):
        self.height, self.width = height, width
        w = self.w = cell_widths(height, width)
        ports = {
            "shift": In(1),
            "step_edt": In(1), "step_cfr": In(1), "step_bfs": In(1),
            "k": In(w["k"]), "kk": In(w["delta"]), "dfar": In(w["di"]),
        }
        ports.update({f"n{i}": In(state_layout(w)) for i in range(1, 9)})
        ports.update({"state": Out(state_layout(w)), "result": Out(result_layout(w)), "changed": Out(1)})
        super().__init__(ports)

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"step_cycles": 1, "changed": "combinational from the registers and the step inputs"}

    def elaborate(self, platform):
        m = Module()
        st, res = self.state, self.result
        regs = _View(done=st.done, d2=st.d2, dx=st.dx, dy=st.dy, visited=st.visited,
                     di=res.di, cfr=res.cfr, parent=res.parent)
        nbs = {i: getattr(self, f"n{i}") for i in range(1, 9)}
        ctl = {n: getattr(self, n) for n in ("shift", "step_edt", "step_cfr", "step_bfs", "k", "kk", "dfar")}
        m.d.comb += self.changed.eq(cell_logic(m, self.w, ctl, regs, nbs))
        return m


class _View:
    """Named access to a cell's registers (fields of ``state`` and ``result``)."""

    def __init__(self, **fields):
        self.__dict__.update(fields)


def cell_logic(m, w, ctl, regs, nbs):
    """Fig. 2's logic of one cell into module ``m``; returns its ``changed`` value.

    ``regs``: the cell's registers; ``nbs[i]``: neighbour p_i's
    ``state`` (port n{i}); ``ctl``: the broadcast controls.
    """
    cw = w["cand"]

    # ADD-SUB and INC (eq. 1-3 in the d2 form): candidate d2_i = d2(p_i) +
    # ΔX_i + ΔY_i (= Δx_i² + Δy_i²), Δx_i, Δy_i of each neighbour, and the
    # third enable condition of each, d2_i <= k² + k, beside the selection.
    cands = []
    for i in range(1, 9):
        nb = nbs[i]
        d = candidate(m, i, nb.d2, nb.dx, nb.dy, signed(cw))
        x, y = inc(m, str(i), nb.dx, nb.dy, -OFFSETS[i][0], -OFFSETS[i][1], w["dx"], w["dy"])
        near = Signal(name=f"near_{i}")
        m.d.comb += near.eq(nb.done & (d <= ctl["kk"]))
        cands.append((nb.done, d, x, y, near))

    # MIN (flat, ties to the smallest index: the CMP-MUX tree's result).
    win = min_select(m, [c[0] for c in cands], [c[1] for c in cands])
    dm = pick(m, win, [c[1] for c in cands], w["delta"], "d2_m")
    xm = pick(m, win, [c[2] for c in cands], signed(w["dx"]), "x_m")
    ym = pick(m, win, [c[3] for c in cands], signed(w["dy"]), "y_m")
    en_edt = Signal(name="en_edt")
    m.d.comb += en_edt.eq(ctl["step_edt"] & ~regs.done & Cat(*[c[4] for c in cands]).any())

    # BFS: the smallest visited neighbour index (priority encoder).
    vis = [(i, nbs[i].visited) for i in range(1, 9)]
    first = C(0, 4)
    for i, v in reversed(vis):
        first = Mux(v, i, first)
    any_v = Cat(*[v for _, v in vis]).any()
    en_bfs = Signal(name="en_bfs")
    m.d.comb += en_bfs.eq(ctl["step_bfs"] & regs.cfr & ~regs.visited & any_v)

    cfr_new = ~regs.done | (regs.di > ctl["dfar"])

    with m.If(ctl["shift"]):
        m.d.sync += [
            # load pipeline: take the west neighbour's (p_3's) marks
            regs.done.eq(nbs[3].done), regs.visited.eq(nbs[3].visited),
            regs.d2.eq(0), regs.dx.eq(0), regs.dy.eq(0), regs.di.eq(0),
            regs.cfr.eq(0), regs.parent.eq(0),
        ]
    with m.Elif(en_edt):
        m.d.sync += [
            regs.done.eq(1), regs.d2.eq(dm), regs.dx.eq(xm), regs.dy.eq(ym),
            regs.di.eq(ctl["k"]),
        ]
    # a done cell keeps d2 (eq. 4, δ += 2k, is the broadcast kk's growth)
    with m.Elif(ctl["step_cfr"]):
        m.d.sync += [regs.cfr.eq(cfr_new), regs.visited.eq(regs.visited & cfr_new)]
    with m.Elif(en_bfs):
        m.d.sync += [regs.visited.eq(1), regs.parent.eq(first)]
    return en_edt | en_bfs
