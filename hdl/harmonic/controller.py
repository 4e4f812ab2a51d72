"""Control module of the harmonic planner (paper 000, sections 4, 5.1, 5.3)."""

import enum

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

__all__ = ["Controller", "Mode"]


class Mode(enum.IntEnum):
    UPDATE = 0      # sweep: up to I update iterations per block
    CHECK = 1       # check pass: one check iteration per block (Maximum)
    CLEAR = 2       # clear pass: one clear iteration per block, Sel/Sat of an order


class Controller(wiring.Component):
    """Scheduling of the section 4 pseudo-code on one :class:`Block`.

    The algorithm is :func:`models.harmonic.plan`; this module runs it over
    the B = BR x BC blocks in row-major order b = br*BC + bc:

    * a *sweep* visits every block with up to ``iters`` (I) update
      iterations; a block stops early after its first stable iteration (the
      Early module: AND of every node's Stable); the sweep *changed* the map
      unless every block was stable in its first iteration;
    * after a sweep without change, a *check pass*: one check iteration per
      block, the Cvg module ORs the Maximum flags; none: converged;
      otherwise p += step while p <= p_last (the new LSB addresses are 0),
      else the run ends not converged;
    * a dynamic order (``order``: node (br, bc, row, col) becomes constant
      ``sat``) is taken by a *clear pass*: every block runs one clear
      iteration (free nodes write 0) and the ordered node gets Sel/Sat in
      its block's.  While idle it is run at once (its cycles are not
      counted); during a run it waits in a one-deep register for the end of
      the current pass (``order_ready`` low while one waits), then the run
      continues with a sweep at the same precision.

    Timing (cycles, see the table in :mod:`models.harmonic`): a visit of K
    iterations takes K*(p+2) + 6 cycles:

    =========  ============================================================
    cycle      state
    =========  ============================================================
    t          VSTART: ``run`` requested, the clusters start
    t+1        lead-in (the clusters present the first addresses)
    t+2 ...    K iterations of p+2 cycles; at the take of iteration k
               (its cycle 1) the command is: run while k < I and no
               earlier iteration was stable (flags of k-2 are known)
    +2         cycles 0, 1 of the stop iteration: last writes (top bits)
    t+K(p+2)+4 the last iteration's flags; the clusters are idle
    t+K(p+2)+5 VEND: next block / pass / level decided
    =========  ============================================================

    Parameters
    ----------
    blocks : (BR, BC); n, m : block size; p_max : largest precision.

    Ports
    -----
    start : In(1); p1, step, p_last : In(range(p_max+1)); iters : In(8)
        Start a run (while idle; the planner checks the parameters).
    order : In(1); order_ready : Out(1); o_br, o_bc, o_row, o_col : In; o_sat : In(1)
        A dynamic obstacle (sat 0) or goal (sat 1) at (B, X, Y).
    busy : Out(1)
        A run or a clear pass in progress (the block's RAMs are in use).
    running, converged : Out(1); p : Out(range(p_max+1))
        Run in progress; outcome of the last run; current precision.
    sweeps, block_iterations, check_iterations, clear_passes : Out(32)
    cycles : Out(48)
        Counters of the last / current run (reset by ``start``).
    blk_* : the :class:`~hdl.harmonic.block.Block` command and flag ports.
    """

    def __init__(self, blocks, n, m, p_max):
        BR, BC = blocks
        self.BR, self.BC, self.n, self.m, self.p_max = BR, BC, n, m, p_max
        P = range(p_max + 1)
        super().__init__({
            "start": In(1), "p1": In(P), "step": In(P), "p_last": In(P), "iters": In(8),
            "order": In(1), "order_ready": Out(1),
            "o_br": In(range(max(BR, 2))), "o_bc": In(range(max(BC, 2))), "o_row": In(range(n)),
            "o_col": In(range(m)), "o_sat": In(1),
            "busy": Out(1), "running": Out(1), "converged": Out(1), "p": Out(P, init=2),
            "sweeps": Out(32), "block_iterations": Out(32), "check_iterations": Out(32),
            "clear_passes": Out(32), "cycles": Out(48),
            "blk_run": Out(1), "blk_p": Out(P), "blk_enable": Out(1), "blk_clear": Out(1),
            "blk_sat": Out(1), "blk_sel": Out(1), "blk_sel_row": Out(range(n)),
            "blk_sel_col": Out(range(m)), "blk_br": Out(range(max(BR, 2))), "blk_bc": Out(range(max(BC, 2))),
            "blk_take": In(1), "blk_done": In(1), "blk_busy": In(1),
            "blk_all_stable": In(1), "blk_any_max": In(1),
        })

    def elaborate(self, platform):
        m = Module()
        BR, BC = self.BR, self.BC
        br, bc = Signal(range(max(BR, 2))), Signal(range(max(BC, 2)))
        mode = Signal(2)
        step, p_last, iters = Signal.like(self.step), Signal.like(self.p_last), Signal(8)
        changed, anymax = Signal(), Signal()
        k = Signal(9)                   # takes (iteration commands) in this visit
        seen = Signal()                 # an update iteration of this visit was stable
        first = Signal()                # the next flags are the visit's first iteration's
        first_ok = Signal()             # ... and that iteration was stable
        idle_clear = Signal()           # the clear pass was ordered while idle
        pend = Signal()
        pend_br, pend_bc = Signal(range(max(BR, 2))), Signal(range(max(BC, 2)))
        pend_row, pend_col, pend_sat = Signal(range(self.n)), Signal(range(self.m)), Signal()
        act_br, act_bc = Signal(range(max(BR, 2))), Signal(range(max(BC, 2)))
        act_row, act_col, act_sat = Signal(range(self.n)), Signal(range(self.m)), Signal()

        m.d.comb += [
            self.blk_p.eq(self.p), self.blk_br.eq(br), self.blk_bc.eq(bc),
            self.blk_enable.eq(mode != Mode.CHECK), self.blk_clear.eq(mode == Mode.CLEAR),
            self.blk_sat.eq(act_sat), self.blk_sel_row.eq(act_row), self.blk_sel_col.eq(act_col),
            self.blk_sel.eq((mode == Mode.CLEAR) & (k == 0) & (br == act_br) & (bc == act_bc)),
            self.order_ready.eq(~pend),
        ]
        with m.If(self.running):
            m.d.sync += self.cycles.eq(self.cycles + 1)

        def latch_order():
            m.d.sync += [act_br.eq(pend_br), act_bc.eq(pend_bc), act_row.eq(pend_row),
                         act_col.eq(pend_col), act_sat.eq(pend_sat), pend.eq(0)]

        take_order = Signal()
        m.d.comb += take_order.eq(self.order & ~pend)
        with m.If(take_order):
            m.d.sync += [pend.eq(1), pend_br.eq(self.o_br), pend_bc.eq(self.o_bc),
                         pend_row.eq(self.o_row), pend_col.eq(self.o_col), pend_sat.eq(self.o_sat)]

        with m.FSM() as fsm:
            with m.State("IDLE"):
                with m.If(self.start):
                    m.d.sync += [
                        self.p.eq(self.p1), step.eq(self.step), p_last.eq(self.p_last),
                        iters.eq(self.iters), self.running.eq(1), self.busy.eq(1),
                        self.converged.eq(0), mode.eq(Mode.UPDATE), changed.eq(0),
                        br.eq(0), bc.eq(0),
                        self.sweeps.eq(0), self.block_iterations.eq(0),
                        self.check_iterations.eq(0), self.clear_passes.eq(0), self.cycles.eq(0),
                    ]
                    m.next = "VSTART"
                with m.Elif(pend):          # an order while idle: a clear pass now
                    latch_order()
                    m.d.sync += [mode.eq(Mode.CLEAR), idle_clear.eq(1), self.busy.eq(1),
                                 br.eq(0), bc.eq(0)]
                    m.next = "VSTART"
            with m.State("VSTART"):
                m.d.sync += [k.eq(0), seen.eq(0), first.eq(1), first_ok.eq(0)]
                m.next = "VRUN"
            with m.State("VRUN"):
                with m.If(self.blk_take):
                    m.d.sync += k.eq(k + 1)
                with m.If(self.blk_done):
                    m.d.sync += first.eq(0)
                    with m.If(first):
                        m.d.sync += first_ok.eq(self.blk_all_stable)
                    with m.If(mode == Mode.UPDATE):
                        with m.If(~seen):
                            m.d.sync += self.block_iterations.eq(self.block_iterations + 1)
                        with m.If(self.blk_all_stable):
                            m.d.sync += seen.eq(1)
                    with m.If(mode == Mode.CHECK):
                        m.d.sync += self.check_iterations.eq(self.check_iterations + 1)
                        with m.If(self.blk_any_max):
                            m.d.sync += anymax.eq(1)
                    with m.If(~self.blk_busy):
                        m.next = "VEND"
            with m.State("VEND"):
                m.next = "VSTART"
                with m.If((mode == Mode.UPDATE) & ~first_ok):
                    m.d.sync += changed.eq(1)
                with m.If(bc != BC - 1):
                    m.d.sync += bc.eq(bc + 1)
                with m.Elif(br != BR - 1):
                    m.d.sync += [br.eq(br + 1), bc.eq(0)]
                with m.Else():                              # the end of a pass
                    m.d.sync += [br.eq(0), bc.eq(0), changed.eq(0), anymax.eq(0)]
                    with m.If(mode == Mode.UPDATE):
                        m.d.sync += self.sweeps.eq(self.sweeps + 1)
                    with m.If((mode == Mode.CLEAR) & self.running):
                        m.d.sync += self.clear_passes.eq(self.clear_passes + 1)
                    with m.If(pend):
                        latch_order()
                        m.d.sync += mode.eq(Mode.CLEAR)
                    with m.Elif(idle_clear):
                        m.d.sync += [idle_clear.eq(0), self.busy.eq(0)]
                        m.next = "IDLE"
                    with m.Elif(mode == Mode.UPDATE):
                        with m.If(~changed & first_ok):
                            m.d.sync += mode.eq(Mode.CHECK)
                    with m.Elif(mode == Mode.CLEAR):
                        m.d.sync += mode.eq(Mode.UPDATE)
                    with m.Else():                          # the end of a check pass
                        m.d.sync += mode.eq(Mode.UPDATE)
                        with m.If(~anymax):
                            m.d.sync += [self.converged.eq(1), self.running.eq(0), self.busy.eq(0)]
                            m.next = "IDLE"
                        with m.Elif((step != 0) & (self.p + step <= p_last)):
                            m.d.sync += self.p.eq(self.p + step)
                        with m.Else():
                            m.d.sync += [self.running.eq(0), self.busy.eq(0)]
                            m.next = "IDLE"
        # The clusters' run: start request in VSTART, then the command at each
        # take.  Plain expressions (continuous assignments in the Verilog), so
        # they are defined from time 0 on every simulator.
        limit = Signal(9)
        m.d.comb += limit.eq(Mux(mode == Mode.UPDATE, iters, 1))
        m.d.comb += self.blk_run.eq(
            fsm.ongoing("VSTART")
            | (fsm.ongoing("VRUN") & self.blk_take & (k < limit) & ~((mode == Mode.UPDATE) & seen)))
        return m
