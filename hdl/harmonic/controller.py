"""Control module of the harmonic planner (paper 000, sections 4, 5.1, 5.3)."""

import enum

from amaranth.hdl import Array, C, Cat, Module, Mux, Signal, signed
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ..arith import lowest_one, prefix_or
from ...models.harmonic.ram import SHIFT_STEP
from .block import BlockControlSignature

__all__ = ["Controller", "Mode", "order_layout"]


class Mode(enum.IntEnum):
    UPDATE = 0      # sweep: up to I update iterations per block
    CHECK = 1       # check pass: one check iteration per block (Maximum)
    CLEAR = 2       # clear pass: one clear iteration per block, Sel/Sat of an order


def order_layout(blocks, n, m):
    """A dynamic order (5.1, Sel/Sat): node (row, col) of block (br, bc)
    becomes constant ``sat`` (0 obstacle, 1 goal)."""
    BR, BC = blocks
    return data.StructLayout({"br": range(max(BR, 2)), "bc": range(max(BC, 2)),
                              "row": range(n), "col": range(m), "sat": 1})


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
    * a dynamic order (an ``order`` stream beat: node (br, bc, row, col)
      becomes constant ``sat``) is taken by a *clear pass*: every block runs
      one clear iteration (free nodes write 0) and the ordered node gets
      Sel/Sat in its block's.  While idle it is run at once (its cycles are
      not counted); during a run it waits in a one-deep register for the end
      of the current pass (``order.ready`` low while one waits), then the
      run continues with a sweep at the same precision.

    Timing (cycles, see the table in :mod:`models.harmonic.schedule`): a visit of K
    iterations of L = iteration_cycles(p) cycles (p+2 from p = 4 on) takes
    K*L + 7 cycles:

    =========  ============================================================
    cycle      state
    =========  ============================================================
    t          VSTART: ``run`` requested, the clusters start
    t+1, t+2   lead-in (the clusters present the first addresses; the RAM
               answers two cycles later)
    t+3 ...    K iterations of L cycles; at the take of iteration k
               (its cycle 0) the command is: run while k < I and no
               earlier iteration was stable (flags of k-2 are known)
    +3         cycles 0 .. 2 of the stop iteration: last writes (top bits)
    t+K*L+5    the last iteration's flags; the clusters are idle
    t+K*L+6    VEND: next block / pass / level decided
    =========  ============================================================

    Parameters
    ----------
    blocks : (BR, BC); n, m : block size; p_max : largest precision.
    exponents, e_max, headroom : block exponents (issue 10; default off):
        the exponent members of ``block`` (shift, border conversion, leads),
        e_b registers (0..e_max), the re-pick with headroom h, shift visits
        and the coarsening at a precision rise; an order's clear pass sets
        every e_b back to 0; ``e_rd`` = e of block
        ``e_rd_block``; ``repicks`` counts re-picks
        (:func:`models.harmonic.plan_exponents`, ``rtl=True``).

    Ports
    -----
    start : In(1); p1, step, p_last : In(range(p_max+1)); iters : In(8)
        Start a run (while idle; the planner checks the parameters).
    order : In(stream.Signature(:func:`order_layout`))
        A dynamic obstacle (sat 0) or goal (sat 1) at (B, X, Y); ``ready``
        is low while an order waits (it does not depend on ``valid``).
    busy : Out(1)
        A run or a clear pass in progress (the block's RAMs are in use).
    running, converged : Out(1); p : Out(range(p_max+1))
        Run in progress; outcome of the last run; current precision.
    sweeps, block_iterations, check_iterations, clear_passes : Out(32)
    cycles : Out(48)
        Counters of the last / current run (reset by ``start``).
    block : Out(:class:`~hdl.harmonic.block.BlockControlSignature`)
        The link to the :class:`~hdl.harmonic.block.Block` (its ``control``).
    """

    def __init__(self, blocks, n, m, p_max, exponents=False, e_max=255, headroom=1, paper_schedule=False):
        BR, BC = blocks
        self.BR, self.BC, self.n, self.m, self.p_max = BR, BC, n, m, p_max
        self.stride = p_max + 2           # words per block in the cluster RAMs (b at b*(p_max+2))
        self.exponents, self.e_max, self.headroom = bool(exponents), e_max, headroom
        self.paper = bool(paper_schedule)
        P = range(p_max + 1)
        extra = {}
        if self.exponents:
            extra = {
                "e_rd_block": In(range(max(BR * BC, 2))), "e_rd": Out(range(e_max + 1)),
                "repicks": Out(32),
            }
        super().__init__({
            **extra,
            "start": In(1), "p1": In(P), "step": In(P), "p_last": In(P), "iters": In(8),
            "order": In(stream.Signature(order_layout(blocks, n, m))),
            "busy": Out(1), "running": Out(1), "converged": Out(1), "p": Out(P, init=2),
            "sweeps": Out(32), "block_iterations": Out(32), "check_iterations": Out(32),
            "clear_passes": Out(32), "cycles": Out(48),
            "block": Out(BlockControlSignature(n, m, blocks, p_max, self.exponents, e_max)),
        })

    def elaborate(self, platform):
        m = Module()
        BR, BC = self.BR, self.BC
        br, bc = Signal(range(max(BR, 2))), Signal(range(max(BC, 2)))
        base = Signal.like(self.block.base)     # (br*BC + bc)*(p_max+2), set with br, bc
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

        # p + step and the level's range check, registered (issue 17: the
        # adder's and the comparison's carry chains sat between p and the
        # FSM's next state).  p, step and p_last change only at a start or a
        # rise, each followed by VSTART and a visit of at least 7 cycles
        # before the next VEND reads these.
        p_up, rise_ok = Signal.like(self.p, name="p_up"), Signal(name="rise_ok")
        m.d.sync += [p_up.eq(self.p + step), rise_ok.eq((step != 0) & (self.p + step <= p_last))]

        blk = self.block
        m.d.comb += [
            blk.p.eq(self.p), blk.br.eq(br), blk.bc.eq(bc), blk.base.eq(base),
            blk.enable.eq(mode != Mode.CHECK), blk.clear.eq(mode == Mode.CLEAR),
            blk.Sat.eq(act_sat), blk.sel_row.eq(act_row), blk.sel_col.eq(act_col),
            blk.sel.eq((mode == Mode.CLEAR) & (k == 0) & (br == act_br) & (bc == act_bc)),
            self.order.ready.eq(~pend),
        ]
        with m.If(self.running):
            m.d.sync += self.cycles.eq(self.cycles + 1)
        X = self.exponents
        if X:
            self._exp_signals(m, locals())
            rep, crs, scanned, scan_j, need_scan = (self._x[k] for k in ("rep", "crs", "scanned", "scan_j",
                                                                          "need_scan"))
        upd_visit = Signal()            # this visit is an update visit (not a shift visit)
        m.d.comb += upd_visit.eq(((mode == Mode.UPDATE) & ~rep) if X else (mode == Mode.UPDATE))
        still = None if self.paper else self._still_signals(m)
        if not self.paper:
            self._still_prep(m, locals())

        def latch_order():
            m.d.sync += [act_br.eq(pend_br), act_bc.eq(pend_bc), act_row.eq(pend_row),
                         act_col.eq(pend_col), act_sat.eq(pend_sat), pend.eq(0)]
            if X:
                # With block exponents the clear pass restarts the exponents
                # too (every free node is 0 again; plan_exponents' orders).
                m.d.sync += [*(e.eq(0) for e in self._x["E"]), self._x["sat"].eq(0)]

        take_order = Signal()
        order = self.order.payload
        m.d.comb += take_order.eq(self.order.valid & self.order.ready)
        with m.If(take_order):
            m.d.sync += [pend.eq(1), pend_br.eq(order.br), pend_bc.eq(order.bc),
                         pend_row.eq(order.row), pend_col.eq(order.col), pend_sat.eq(order.sat)]

        with m.FSM() as fsm:
            with m.State("IDLE"):
                with m.If(self.start):
                    if X:
                        m.d.sync += [rep.eq(0), crs.eq(0), scanned.eq(0), self._x["sat"].eq(0),
                                     self.repicks.eq(0)]
                        m.d.sync += [e.eq(0) for e in self._x["E"]]
                    if not self.paper:
                        m.d.sync += [still["dirty"].eq(still["all"]), still["cur"].eq(1)]
                    m.d.sync += [
                        self.p.eq(self.p1), step.eq(self.step), p_last.eq(self.p_last),
                        iters.eq(self.iters), self.running.eq(1), self.busy.eq(1),
                        self.converged.eq(0), mode.eq(Mode.UPDATE), changed.eq(0),
                        br.eq(0), bc.eq(0), base.eq(0),
                        self.sweeps.eq(0), self.block_iterations.eq(0),
                        self.check_iterations.eq(0), self.clear_passes.eq(0), self.cycles.eq(0),
                    ]
                    m.next = "VSTART"
                with m.Elif(pend):          # an order while idle: a clear pass now
                    latch_order()
                    m.d.sync += [mode.eq(Mode.CLEAR), idle_clear.eq(1), self.busy.eq(1),
                                 br.eq(0), bc.eq(0), base.eq(0)]
                    if not self.paper:
                        m.d.sync += still["cur"].eq(1)
                    m.next = "VSTART"
            with m.State("VSTART"):
                if not self.paper:
                    m.d.sync += still["acc"].eq(0)
                if X:
                    with m.If(need_scan):
                        m.d.sync += scan_j.eq(1)
                        m.next = "SCANW"
                    with m.Else():
                        m.d.sync += [k.eq(0), seen.eq(0), first.eq(1), first_ok.eq(0)]
                        m.next = "VRUN"
                else:
                    m.d.sync += [k.eq(0), seen.eq(0), first.eq(1), first_ok.eq(0)]
                    m.next = "VRUN"
            if X:
                with m.State("SCANW"):          # the clamp scan: L more cycles
                    m.d.sync += scan_j.eq(scan_j + 1)
                    with m.If(scan_j == blk.border.scan_len):
                        m.d.sync += scanned.eq(1)
                        m.next = "VSTART"
            with m.State("VRUN"):
                with m.If(blk.take):
                    m.d.sync += k.eq(k + 1)
                with m.If(blk.done):
                    m.d.sync += first.eq(0)
                    with m.If(first):
                        m.d.sync += first_ok.eq(blk.all_stable)
                    with m.If(upd_visit):
                        with m.If(~seen):
                            m.d.sync += self.block_iterations.eq(self.block_iterations + 1)
                        with m.If(blk.all_stable):
                            m.d.sync += seen.eq(1)
                        if not self.paper:
                            # Still blocks: the edges this visit changed, and
                            # the Maximum flags of its stable iteration; the
                            # clusters stop at once (no confirmation iteration).
                            m.d.sync += still["acc"].eq(still["acc"] | blk.edge_changed.as_value())
                            with m.If(blk.all_stable):
                                m.d.sync += still["mx_cur"].eq(blk.any_max)
                                m.next = "VEND"
                    with m.If(mode == Mode.CHECK):
                        m.d.sync += self.check_iterations.eq(self.check_iterations + 1)
                        with m.If(blk.any_max):
                            m.d.sync += anymax.eq(1)
                    with m.If(~blk.busy):
                        m.next = "VEND"
            with m.State("VEND"):
                m.next = "VSTART"
                vend = self._vend if self.paper else self._vend_still
                if X:
                    m.d.sync += scanned.eq(0)
                    with self._vend_exponents(m, locals()):
                        vend(m, locals())
                else:
                    vend(m, locals())
        self._tail(m, locals())
        return m

    def _count_pass(self, m, mode):
        """The counters at the end of a pass: a sweep, or a clear pass of a run."""
        with m.If(mode == Mode.UPDATE):
            m.d.sync += self.sweeps.eq(self.sweeps + 1)
        with m.If((mode == Mode.CLEAR) & self.running):
            m.d.sync += self.clear_passes.eq(self.clear_passes + 1)

    def _vend(self, m, v):
        """The end of a visit: next block, pass, level (fixed point, and the
        exponent option's update/check visits)."""
        mode, first_ok, changed, br, bc, base, anymax, pend = (v[x] for x in (
            "mode", "first_ok", "changed", "br", "bc", "base", "anymax", "pend"))
        idle_clear, p_up, rise_ok, latch_order = v["idle_clear"], v["p_up"], v["rise_ok"], v["latch_order"]
        BR, BC, X = self.BR, self.BC, self.exponents
        with m.If((mode == Mode.UPDATE) & ~first_ok):
            m.d.sync += changed.eq(1)
        with m.If(bc != BC - 1):                    # row-major: the next block's words follow
            m.d.sync += [bc.eq(bc + 1), base.eq(base + self.stride)]
        with m.Elif(br != BR - 1):
            m.d.sync += [br.eq(br + 1), bc.eq(0), base.eq(base + self.stride)]
        with m.Else():                              # the end of a pass
            m.d.sync += [br.eq(0), bc.eq(0), base.eq(0), changed.eq(0), anymax.eq(0)]
            self._count_pass(m, mode)
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
                with m.Elif(rise_ok):
                    m.d.sync += self.p.eq(p_up)
                    if X:
                        self._rise(m, v)
                with m.Else():
                    m.d.sync += [self.running.eq(0), self.busy.eq(0)]
                    m.next = "IDLE"

    # The default schedule: still blocks (models.harmonic.schedule, StillBlocks
    # and StillTiming).  Not elaborated with paper_schedule.

    def _still_signals(self, m):
        """The dirty bits, the per-block Maximum flags, the current block as
        one-hot ``cur`` (beside br, bc) and the visit's edge changes."""
        B = self.BR * self.BC
        x = {
            "all": (1 << B) - 1,
            "dirty": Signal(B, name="dirty"),     # blocks to visit in this level
            "mx": Signal(B, name="mx"),           # Maximum flags of each block's last stable visit
            "cur": Signal(B, name="cur", init=1),  # the current block, one-hot
            "acc": Signal(4, name="edges"),       # N, S, W, E edges changed in this visit
            "mx_cur": Signal(name="mx_cur"),      # the Maximum flags of this visit's stable iteration
        }
        return x

    def _still_next(self, m, v, own):
        """(dirty, mx) after the visit that ends now: the block's bit set
        again if ``own`` (not stable, or its words moved), else cleared;
        its flag from its stable iteration; the bits of the neighbours whose
        facing edge changed (one-hot shifts of ``cur``)."""
        x = v["still"]
        BC, B = self.BC, self.BR * self.BC
        cur, acc, seen = x["cur"], x["acc"], v["seen"]
        all_ = x["all"]
        not_first_col = sum(1 << i for i in range(B) if i % BC != 0)
        not_last_col = sum(1 << i for i in range(B) if i % BC != BC - 1)
        nbr = ((Mux(acc[0], cur >> BC, 0))                                   # N edge: block b-BC
               | (Mux(acc[1], cur << BC, 0) & all_)                          # S edge: block b+BC
               | (Mux(acc[2], cur >> 1, 0) & not_last_col)                   # W edge: block b-1
               | (Mux(acc[3], cur << 1, 0) & all_ & not_first_col))          # E edge: block b+1
        dirty_n, mx_n = Signal(B, name="dirty_n"), Signal(B, name="mx_n")
        m.d.comb += [
            dirty_n.eq((x["dirty"] & ~cur) | Mux(own, cur, 0) | nbr),
            mx_n.eq(Mux(seen, (x["mx"] & ~cur) | Mux(x["mx_cur"], cur, 0), x["mx"])),
        ]
        return dirty_n, mx_n

    def _goto(self, m, v, target):
        """Visit block ``target`` next: a one-hot int, or a (one-hot, br,
        bc, base) tuple of signals (:meth:`_still_prep`'s targets)."""
        BC = self.BC
        if isinstance(target, int):
            i = target.bit_length() - 1
            target = (target, i // BC, i % BC, i * self.stride)
        for reg, val in zip((v["still"]["cur"], v["br"], v["bc"], v["base"]), target):
            m.d.sync += reg.eq(val)

    def _still_prep(self, m, v):
        """The next-block choice of :meth:`_vend_still`, prepared during the
        visit (issue 17: the choice over every block's dirty bit was the path
        of every large planner, through VEND's one cycle into the pass
        counters).  dirty, mx, cur, br, bc and base change only in VEND (and
        at a start or an order in IDLE), and a visit lasts at least 7 cycles
        (VSTART, the clusters' lead-in, ...), so these three register
        stages, recomputed every cycle, hold the current visit's values at
        its VEND;
        what the visit itself decides (its edge changes ``acc``, ``seen``,
        ``mx_cur``) enters VEND as a few gates on them.  Cycle-neutral.

        Stage 0: the blocks from the current one on (a prefix OR of the
        one-hot ``cur``; each mask below is a shift of it).
        Stage 1: D = dirty without the current block; c0 / f0, the first
        block of D after / before the current one; whether c0 comes before
        the S neighbour, f0 before the N / W neighbour; whether another
        block has a Maximum flag; the neighbours' (one-hot, br, bc, base).
        Stage 2: c0 and f0 as (one-hot, br, bc, base)."""
        x = v["still"]
        BR, BC, B, S = self.BR, self.BC, self.BR * self.BC, self.stride
        br, bc, base, cur = v["br"], v["bc"], v["base"], x["cur"]
        all_ = x["all"]

        def reg(name, value, width):
            r = Signal(width, name=name)
            m.d.sync += r.eq(value)
            return r

        def target(name, onehot, br_t, bc_t, base_t):
            return (reg(f"{name}_oh", onehot, B), reg(f"{name}_br", br_t, len(br)),
                    reg(f"{name}_bc", bc_t, len(bc)), reg(f"{name}_base", base_t, len(base)))

        def encode(name, onehot):
            """Stage 2: a one-hot block as (one-hot, br, bc, base)."""
            br_t = bc_t = base_t = 0
            for i in range(B):
                br_t = br_t | Mux(onehot[i], i // BC, 0)
                bc_t = bc_t | Mux(onehot[i], i % BC, 0)
                base_t = base_t | Mux(onehot[i], i * S, 0)
            return target(name, onehot, br_t, bc_t, base_t), reg(f"{name}_any", onehot != 0, 1)

        # stage 0: the blocks from b on (every mask below is a shift of it)
        ge = reg("ge_pre", prefix_or(cur), B)

        def from_(shift):       # the blocks from b + shift on (shift may be negative)
            if shift >= 0:
                return (ge << shift)[:B]
            if -shift >= B:
                return C((1 << B) - 1, B)
            return Cat(ge[-shift:], C((1 << -shift) - 1, -shift))    # ones shifted in at the top

        above, below = from_(1), ~ge & all_
        d = x["dirty"] & ~cur
        c0 = reg("c0_pre", lowest_one(d & above), B)
        f0 = reg("f0_pre", lowest_one(d & below), B)
        p = x["prep"] = {
            "c0_lt_s": reg("c0_lt_s", (d & above & ~from_(BC)) != 0, 1),
            # read only at the end of a sweep, when D holds no block after b: a
            # block of D below b-BC (b-1) is f0, and f0 comes before N (W); without
            # that neighbour (b < BC, b = 0) the mask is empty
            "f0_lt_n": reg("f0_lt_n", (d & ~from_(-BC)) != 0, 1),
            "f0_lt_w": reg("f0_lt_w", (d & ~from_(-1)) != 0, 1),
            "mx_rest0": reg("mx_rest0", (x["mx"] & ~cur) == 0, 1),
            "nx_ok": reg("nx_ok", ~cur[B - 1], 1),
            "e_ok": reg("e_ok", bc != BC - 1, 1), "w_ok": reg("w_ok", bc != 0, 1),
            "s_ok": reg("s_ok", br != BR - 1, 1), "n_ok": reg("n_ok", br != 0, 1),
            # b+1 in row-major order (the E neighbour when bc < BC-1), b+BC, b-BC, b-1
            "NX": target("nx", (cur << 1)[:B], Mux(bc == BC - 1, br + 1, br), Mux(bc == BC - 1, 0, bc + 1),
                         base + S),
            "S": target("s", (cur << BC)[:B], br + 1, bc, base + BC * S),
            "N": target("n", cur >> BC, br - 1, bc, base - BC * S),
            "W": target("w", cur >> 1, br, bc - 1, base - S),
        }
        (p["C0"], p["c0_any"]), (p["F0"], p["f0_any"]) = encode("c0", c0), encode("f0", f0)

    @staticmethod
    def _pick(*choices):
        """Priority choice of targets: (condition, target) pairs, then the
        default target."""
        *pairs, out = choices
        for cond, t in reversed(pairs):
            out = tuple(Mux(cond, a, b) for a, b in zip(t, out))
        return out

    def _vend_still(self, m, v):
        """The end of a visit with still blocks: the dirty bits, the next
        dirty block after this one (the lowest set bit), the end of a sweep
        (an order waits: a clear pass; a block dirty: the next sweep from
        the first one), the end of a level (the folded check: the OR of the
        blocks' Maximum flags).  The choices come from :meth:`_still_prep`:
        in a sweep the next block is the E neighbour (b+1) if its edge
        changed, else c0 or the S neighbour (b+BC), whichever comes first;
        the next sweep starts at f0, the N neighbour, the W neighbour or
        the block itself (not stable), whichever comes first."""
        x = v["still"]
        mode, seen, pend, idle_clear = v["mode"], v["seen"], v["pend"], v["idle_clear"]
        p_up, rise_ok, latch_order = v["p_up"], v["rise_ok"], v["latch_order"]
        p, acc, own = x["prep"], x["acc"], ~seen
        dirty_n, mx_n = self._still_next(m, v, own)
        upd = mode == Mode.UPDATE
        take_e, take_s = acc[3] & p["e_ok"], acc[1] & p["s_ok"]
        take_n, take_w = acc[0] & p["n_ok"], acc[2] & p["w_ok"]
        cand_any = Mux(upd, take_e | p["c0_any"] | take_s, p["nx_ok"])
        cand = self._pick((~upd | take_e, p["NX"]), (p["c0_any"] & (p["c0_lt_s"] | ~take_s), p["C0"]), p["S"])
        here = (x["cur"], v["br"], v["bc"], v["base"])
        first = self._pick((p["f0_lt_n"], p["F0"]), (take_n, p["N"]), (p["f0_lt_w"], p["F0"]),
                           (take_w, p["W"]), (p["f0_any"], p["F0"]), here)
        dirty_left = p["f0_any"] | take_n | take_w | own       # dirty_n != 0 at the end of a sweep
        # mx_n == 0, read only when no block is dirty: then this visit was stable (seen)
        mx_none = p["mx_rest0"] & ~x["mx_cur"]
        with m.If(upd):
            m.d.sync += [x["dirty"].eq(dirty_n), x["mx"].eq(mx_n)]
        with m.If(cand_any):
            self._goto(m, v, cand)
        with m.Else():                                  # the end of a pass
            self._count_pass(m, mode)
            with m.If(pend):
                latch_order()
                m.d.sync += mode.eq(Mode.CLEAR)
                self._goto(m, v, 1)
            with m.Elif(idle_clear):
                m.d.sync += [idle_clear.eq(0), self.busy.eq(0)]
                m.next = "IDLE"
            with m.Elif(mode == Mode.CLEAR):            # every free node is 0 again
                m.d.sync += [mode.eq(Mode.UPDATE), x["dirty"].eq(x["all"])]
                self._goto(m, v, 1)
            with m.Elif(dirty_left):                    # the next sweep
                self._goto(m, v, first)
            with m.Elif(mx_none):                       # no local maximum: converged
                m.d.sync += [self.converged.eq(1), self.running.eq(0), self.busy.eq(0)]
                m.next = "IDLE"
            with m.Elif(rise_ok):
                m.d.sync += [self.p.eq(p_up), x["dirty"].eq(x["all"])]
                self._goto(m, v, 1)
                if self.exponents:
                    self._rise(m, v)
            with m.Else():
                m.d.sync += [self.running.eq(0), self.busy.eq(0)]
                m.next = "IDLE"

    def _tail(self, m, v):
        # The clusters' run: start request in VSTART, then the command at each
        # take.  Plain expressions (continuous assignments in the Verilog), so
        # they are defined from time 0 on every simulator.
        mode, iters, fsm, k, seen = (v[x] for x in ("mode", "iters", "fsm", "k", "seen"))
        limit = Signal(9)
        # Whether a take in VRUN starts another iteration, a register (issue
        # 17: k's comparison with the mode's limit, a carry chain, sat between
        # the mode register and every cluster's take logic).  Its inputs k,
        # seen, mode, iters (and rep, rem) change only in VSTART/VEND, at a
        # take (k, rem) or at a cluster's done (seen: cycle 2 of an
        # iteration).  A visit's first take comes 3 cycles after VSTART (the
        # clusters' two-cycle lead-in) and takes are L >= 6 cycles apart
        # (iteration_cycles pads short words), so the value sampled in the
        # cycle before a take is the value at the take: no cycle changes.
        more = Signal(name="more")
        blk = self.block
        if not self.paper:
            m.d.comb += blk.abort.eq(fsm.ongoing("VRUN") & blk.done & blk.all_stable & v["upd_visit"])
        if self.exponents:
            rep = v["rep"]
            x = self._x
            m.d.comb += [
                blk.border.scan.eq(fsm.ongoing("VSTART") & ~x["scanned"] & ~rep
                                   & ((mode == Mode.UPDATE) | (mode == Mode.CHECK))),
                x["need_scan"].eq(blk.border.scan & (blk.border.scan_len != 0)),
            ]
            m.d.comb += limit.eq(Mux((mode == Mode.UPDATE) & ~rep, iters, 1))
            m.d.sync += more.eq(Mux(rep, x["rem"] != 0, (k < limit) & ~((mode == Mode.UPDATE) & seen)))
            m.d.comb += [
                blk.run.eq((fsm.ongoing("VSTART") & ~v["need_scan"])
                           | (fsm.ongoing("VRUN") & blk.take & more)),
                x["rep_take"].eq(fsm.ongoing("VRUN") & blk.take & rep & (x["rem"] != 0)),
            ]
        else:
            m.d.comb += limit.eq(Mux(mode == Mode.UPDATE, iters, 1))
            m.d.sync += more.eq((k < limit) & ~((mode == Mode.UPDATE) & seen))
            m.d.comb += blk.run.eq(fsm.ongoing("VSTART") | (fsm.ongoing("VRUN") & blk.take & more))

    # Block exponents (issue 10; models.harmonic.plan_exponents(..., rtl=True)).
    # Not elaborated by default.

    def _exp_signals(self, m, v):
        BR, BC, B, p_max, e_max, h = self.BR, self.BC, self.BR * self.BC, self.p_max, self.e_max, self.headroom
        br, bc, mode = v["br"], v["bc"], v["mode"]
        x = self._x = {}
        x["E"] = E = [Signal(range(e_max + 1), name=f"E_{i}") for i in range(B)]
        Ea = Array(E)
        x["sat"] = Signal(B, name="sat")            # clamped in this level
        x["crs_pend"] = Signal(B, name="crs_pend")  # blocks still to coarsen at this rise
        x["rep"] = Signal(name="rep")               # this visit is a shift visit
        x["crs"] = Signal(name="crs")               # ... of the coarsening at a rise
        x["scanned"] = Signal(name="scanned")
        x["scan_j"] = Signal(range(p_max + 4), name="scan_j")
        x["shd"] = shd = Signal.like(self.block.shift_d, name="shd")   # this iteration's rotation
        x["rem"] = rem = Signal(range(p_max + 2), name="rem")         # rotation still to do
        # A shift visit rotates by at most SHIFT_STEP (4) per iteration (the
        # cluster's padded shift iteration never overwrites a bit before it
        # is read and leaves the next iteration's first reads written:
        # models.harmonic.ram.pads), the rest in the last iteration: set at
        # each take.
        with m.If(fsm_take := Signal(name="rep_take")):
            m.d.sync += [shd.eq(Mux(rem > SHIFT_STEP, SHIFT_STEP, rem)),
                         rem.eq(rem - Mux(rem > SHIFT_STEP, SHIFT_STEP, rem))]
        x["rep_take"] = fsm_take
        x["need_scan"] = Signal(name="need_scan")
        b = x["b"] = Signal(range(max(B, 2)), name="b_cur")
        m.d.comb += b.eq(br * BC + bc)
        e = x["e"] = Signal(range(e_max + 1), name="e_cur")
        m.d.comb += e.eq(Ea[b])
        sides = {"N": (br != 0, -BC), "S": (br != BR - 1, BC), "W": (bc != 0, -1), "E": (bc != BC - 1, 1)}
        x["nb"] = {}
        for side, (valid, off) in sides.items():
            en = Signal(range(e_max + 1), name=f"e_{side}")
            m.d.comb += [en.eq(Mux(valid, Ea[(b + off)[:len(b)]], 0)),
                         self.block.border.s[side].eq(Mux(valid, e - en, 0))]
            x["nb"][side] = (valid, en)
        rep = x["rep"]
        m.d.comb += [
            self.block.enable.eq((mode != Mode.CHECK) & ~rep),
            self.block.shift.eq(rep), self.block.shift_d.eq(shd),
            self.block.border.raw.eq((mode == Mode.UPDATE) & ~rep),
            self.e_rd.eq(Ea[self.e_rd_block]),
        ]
        # The re-pick amount d after an update visit (REPICK rule of
        # plan_exponents): with leads as offsets (bit length p+2-lead),
        # top - bit length = lead - 1 - h for the block's own values and
        # lead - 1 - h - e + e' for a neighbour edge in its units.
        W = signed(max(2 * e_max + p_max + 8, 64).bit_length() + 2)
        NONE = p_max + 2
        BIG = (1 << (W.width - 2)) - 1
        terms = [(self.block.lead_own != NONE, self.block.lead_own - 1 - h)]
        for side, (valid, en) in x["nb"].items():
            lead = self.block.border.lead[side]
            terms.append((valid & (lead != NONE), lead - 1 - h - e + en))
        acc = Signal(W, name="d_min")
        cur = BIG
        for i, (ok, t) in enumerate(terms):
            ti = Signal(W, name=f"d_term{i}")
            m.d.comb += ti.eq(Mux(ok, t, BIG))
            cur = Mux(ti < cur, ti, cur)
        m.d.comb += acc.eq(cur)
        d = x["d"] = Signal(W, name="d_repick")
        room = e_max - e
        m.d.comb += d.eq(Mux((acc == BIG) | self.block.all_const | (acc <= 0), 0, Mux(acc > room, room, acc)))

    def _vend_exponents(self, m, v):
        """VEND of the exponent option: the re-pick after an update visit,
        the end of a shift visit, the coarsening sequence; returns the
        context of the ordinary VEND (update/check/clear visits without a
        re-pick, and a re-pick's shift visit, which then moves on)."""
        x = self._x
        mode, rep, crs, d, b = v["mode"], x["rep"], x["crs"], x["d"], x["b"]
        E, sat = x["E"], x["sat"]
        Ea = Array(E)
        with m.If(crs):                               # a coarsening visit ended
            self._next_coarsen(m, v, x["crs_pend"], self.p)
        with m.Elif((mode == Mode.UPDATE) & ~rep):    # an update visit ended
            m.d.sync += sat.eq(sat | (self.block.border.clamped << b))
            with m.If(~v["first_ok"]):
                m.d.sync += v["changed"].eq(1)
            with m.If(d != 0):                        # re-pick: shift visit of this block
                m.d.sync += [Ea[b].eq(Ea[b] + d), rep.eq(1), v["changed"].eq(1),
                             x["rem"].eq(Mux(d > self.p, self.p, d)), self.repicks.eq(self.repicks + 1)]
                if not self.paper:
                    # Still blocks: the visit's dirty bits, the block's own
                    # set (its ring is read finer after the shift).
                    dirty_n, mx_n = self._still_next(m, v, 1)
                    m.d.sync += [v["still"]["dirty"].eq(dirty_n), v["still"]["mx"].eq(mx_n)]
        with m.If(rep & ~crs):
            m.d.sync += rep.eq(0)
        return m.If(~crs & ~((mode == Mode.UPDATE) & ~rep & (d != 0)))

    def _next_coarsen(self, m, v, mask, p_new):
        """Start the shift visit of the first block of ``mask`` (right by
        δ = min(e_b, step), e_b lowered: a left rotation by p+1-δ of the word
        at the new precision ``p_new``, whose low step bits are 0), or end
        the coarsening: sweep from b = 0."""
        x = self._x
        BC, B = self.BC, self.BR * self.BC
        E, step = x["E"], v["step"]
        for i in range(B):
            dl = Mux(E[i] < step, E[i], step)
            with (m.If if i == 0 else m.Elif)(mask[i]):
                m.d.sync += [v["br"].eq(i // BC), v["bc"].eq(i % BC), v["base"].eq(i * self.stride),
                             x["rem"].eq(p_new + 1 - dl),
                             E[i].eq(E[i] - dl),
                             x["crs_pend"].eq(mask & ~(1 << i)), x["rep"].eq(1), x["crs"].eq(1)]
                if not self.paper:
                    m.d.sync += v["still"]["cur"].eq(1 << i)
        with m.Else():
            m.d.sync += [x["rep"].eq(0), x["crs"].eq(0), v["br"].eq(0), v["bc"].eq(0), v["base"].eq(0)]
            if not self.paper:
                m.d.sync += v["still"]["cur"].eq(1)

    def _rise(self, m, v):
        """A precision rise: blocks saturated in the ending level with e_b > 0
        coarsen (ExponentGrid.raise_precision in models/harmonic/exponents.py); clamps restart."""
        x = self._x
        E, sat = x["E"], x["sat"]
        mask = Signal(len(sat), name="crs_mask")
        m.d.comb += mask.eq(sat & Cat(*[e != 0 for e in E]))
        m.d.sync += sat.eq(0)
        self._next_coarsen(m, v, mask, v["p_up"])
