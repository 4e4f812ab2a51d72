"""The section 4 schedule: the one block-synchronous loop with increasing
precision, its cycle accounting and its result (paper 000, section 4
pseudo-code, 3.3, 4.5; the Control module, 5.1 and 5.3).

Number format and rounding: the loop moves no values; every value, update
and rounding belongs to the field it drives (fixed point:
:class:`~models.harmonic.grid.BlockGrid`; block exponents:
:class:`~models.harmonic.exponents.ExponentGrid`).  Here are only exact
integer counts: passes, iterations and clock cycles.

The loop (:func:`run`) is the pseudo-code of section 4 as the Control module
(hdl/harmonic/controller.py) runs it::

    p = schedule[0]
    loop
      sweep: every block b, in the visit order, runs up to I iterations,
             stopping after the first one in which it is stable (it counts)
      after every pass: apply the dynamic orders due (a clear pass each),
             then sweep again
      another sweep while the last one changed a block
      check pass: one check iteration per block, the Maximum flags
      no local maximum: converged, stop
      the field may rescale at the same p (block exponents' re-pick): a new
             level, sweep again
      else the next precision of the schedule (a new level); after the last:
             not converged, stop

Its variations are a *grid* (the field it runs on, a strategy object whose
methods the loop calls) and four optional hooks, so :func:`~models.harmonic.plan`,
:func:`~models.harmonic.plan_explore` and
:func:`~models.harmonic.plan_exponents` share this one loop:

=====================  =========================================================
hook                   what it does (fixed point / block exponents / explore)
=====================  =========================================================
grid.visit             one block visit, returns (counted i, stable): the
                       Jacobi iterations on the field's storage
                       (BlockGrid.visit / ExponentGrid.visit, the ring
                       converted to the block's exponent)
grid.scan_cycles       cycles before an update or check visit (0 / the RTL
                       variant's clamp scan)
grid.after_visit       work after a visit, in cycles, 0 for none (0 / the
                       exponent re-pick's shift visit); non-zero counts as a
                       change of the block
grid.check             the check pass: (local maxima, extra cycles)
grid.rescale           at a check pass with maxima, before raising p: the
                       cycles of a rescale at the same p, 0 for none (0 /
                       the re-pick of every block)
grid.raise_precision   the next p and its data moves in cycles; None after
                       the last (0: free / coarsening saturated blocks)
grid.apply_due         the dynamic orders due after a pass (a clear pass each)
order(sweep)           the blocks of a sweep in visit order (raster, the
                       RTL's; plan_explore: serpentine, alternate, goal)
visits                 which visits a sweep skips and whether another sweep
                       is needed (None: every block, another sweep while one
                       changed a block; plan_explore: still-block skipping)
timing                 the Control module's cycle accounting
                       (:class:`Timing`, the tables below)
trace                  None or a list that gets (event, p, exponents,
                       values, cycles) after every visit, re-pick, check,
                       clear pass and precision rise
progress               None or ``progress(result, p, cycles)`` after every
                       pass (update or check): the commands' progress line
=====================  =========================================================

Where later work goes: skipping still blocks in plan() and the RTL (issue 19)
is a ``visits`` policy (:class:`EveryBlock` is the protocol) with its own
skip cost, plus a :class:`Timing` whose ``update_visit`` drops the
confirmation iteration and whose ``check_pass`` folds the check into a sweep;
an exponent width chosen from the map (issue 22) is ExponentGrid's ``e_max``;
a vectorized fast path replaces ``grid.visit`` (a grid class whose visit
runs on precomputed views, or batches independent blocks) without touching
the loop.

Timing of the Control module (hdl/harmonic/controller.py), in clock cycles,
measured on the RTL and asserted by tb/harmonic/test_planner.py.  An
iteration takes L = :func:`~models.harmonic.ram.iteration_cycles` (p) = p+2
cycles (p >= 4; 6 below, and a shift iteration of block exponents one
more); a block visit running K iterations takes K*L + VISIT_OVERHEAD:

==================  ======================================================
cycle of a visit    what happens
==================  ======================================================
t                   VSTART: the clusters get ``run`` (start request)
t+1, t+2            the clusters' lead-in (first addresses presented; the
                    RAM answers two cycles later: its output register)
t+3 .. t+2+K*L      K iterations (update, check or clear)
+1 .. +3            cycles 0 .. 2 of the stop iteration: the last
                    iteration's top two bits are computed and written (the
                    write runs two bit positions behind the read, eq. 2's
                    /4, and one cycle behind its computation)
t+5+K*L             (cycle 2) the last iteration's Stable / Maximum flags
t+6+K*L             VEND: next block, pass, precision or end decided
==================  ======================================================

==================  ======================================================
phase               cycles
==================  ======================================================
update visit        K = min(i + 1, I) if iteration i (1-based) was the
                    first stable one, else K = I.  The flags of an
                    iteration come at cycle 2 of the next one, after that
                    one's command was taken at its cycle 1, so an early
                    stop costs one confirmation iteration; it reads the
                    same words and borders, so it changes nothing, and it
                    is not counted in ``block_iterations``
check visit         K = 1 (one check iteration: the Maximum flags)
clear visit         K = 1 (free nodes write 0, Sel/Sat of the order)
pass / level        0: decided in the last visit's VEND cycle; a precision
                    change moves no data (MSB-first words, LSB addresses
                    zeroed at load)
run                 RUN_OVERHEAD: START's own cycle is not counted, the
                    last VEND is
dynamic order       SET_OVERHEAD + one clear pass (B clear visits); an
                    order sent while idle runs outside any run
==================  ======================================================
"""

from dataclasses import dataclass, field

import numpy as np

from .node import one
from .ram import iteration_cycles

__all__ = ["VISIT_OVERHEAD", "RUN_OVERHEAD", "SET_OVERHEAD", "visit_cycles", "Timing", "PlanResult",
           "EveryBlock", "run"]

VISIT_OVERHEAD = 7
RUN_OVERHEAD = 0
SET_OVERHEAD = 0


def visit_cycles(k, p, shift=False):
    """Cycles of one block visit running ``k`` iterations at precision ``p``
    (``shift``: a shift visit of block exponents, padded iterations)."""
    return k * iteration_cycles(p, shift) + VISIT_OVERHEAD


class Timing:
    """The Control module's cycle accounting (the tables above): what
    :func:`run` adds for the run, each update visit, check pass and clear
    pass.  A schedule with other costs (issue 19: no confirmation iteration,
    the check pass folded into a sweep) is a subclass."""

    run = RUN_OVERHEAD

    def update_visit(self, i, stable, iters, p):
        """An update visit that counted ``i`` iterations (``stable``: its
        i-th was stable; the confirmation iteration is paid, not counted)."""
        return visit_cycles(min(i + 1, iters) if stable else iters, p)

    def check_pass(self, blocks, p):
        return blocks * visit_cycles(1, p)

    def clear_pass(self, blocks, p):
        return SET_OVERHEAD + blocks * visit_cycles(1, p)


TIMING = Timing()


def check_schedule(schedule):
    """The precisions as a list: increasing, the first >= 2."""
    sched = [int(p) for p in schedule]
    if not sched or sched[0] < 2 or any(b <= a for a, b in zip(sched, sched[1:])):
        raise ValueError(f"schedule {tuple(schedule)}: needs increasing precisions, the first >= 2")
    return sched


@dataclass
class PlanResult:
    """Outcome of :func:`~models.harmonic.plan` on an H x W map (values
    cropped to H x W).

    ``h``: values at precision ``p`` (object ints, goal = 2**p); ``const``:
    goals, obstacles and walled-off cells.  ``maxima``: local maxima among
    the free (non-constant) nodes at the last check pass (0 when converged).
    ``unreachable``: free cells of the input map no goal reaches; they were
    loaded as constant-0 obstacles.  ``sweeps``: update passes over all
    blocks; ``block_iterations``: update iterations counted as the pseudo-code
    counts them (i, the stable one included), summed over block visits;
    ``check_iterations``: check iterations (one per block per check pass);
    ``node_updates``: block_iterations * n*m (every node of a block is
    updated in an iteration, obstacles and padding included);
    ``clear_passes``: passes that restarted the free nodes from 0 after a
    dynamic order; ``cycles``: the clock cycles the RTL spends from its START
    command to idle (see the timing table of :mod:`models.harmonic.schedule`);
    ``levels``: per precision level, dicts with p, sweeps, block_iterations,
    maxima (None if the level ended without a check); ``events_applied``:
    events that were due.
    """
    h: np.ndarray
    const: np.ndarray
    p: int
    converged: bool
    maxima: int
    unreachable: np.ndarray
    sweeps: int = 0
    block_iterations: int = 0
    check_iterations: int = 0
    node_updates: int = 0
    clear_passes: int = 0
    cycles: int = 0
    levels: list = field(default_factory=list)
    events_applied: int = 0
    block: tuple = (1, 1)
    blocks: tuple = (1, 1)
    padded_h: np.ndarray = None
    padded_const: np.ndarray = None
    # block exponents only (plan(..., block_exponents=True)); None otherwise
    exponents: np.ndarray = None
    frac_bits: int = None
    mantissa: np.ndarray = None
    repicks: int = 0
    saturated: int = 0

    def potential(self):
        """Values as floats in [0, 1]."""
        unit = one(self.p if self.frac_bits is None else self.frac_bits)
        return np.array([[int(v) / unit for v in row] for row in self.h], dtype=float)


class EveryBlock:
    """The ``visits`` protocol of :func:`run`, as the paper and the RTL
    schedule it: every block is visited in every sweep, and another sweep
    follows while the last one changed a block.  A policy that skips blocks
    overrides these; ``run`` counts its skipped visits in each level's
    ``skipped`` and charges ``skip_cycles`` for each."""

    skip_cycles = 0

    def reset(self):
        """A new level or a clear pass: every block may change again."""

    def skip(self, b):
        """True: the sweep passes block ``b`` by."""
        return False

    def before(self, b):
        """Just before block ``b``'s visit."""

    def after(self, b, stable, changed):
        """After block ``b``'s visit (``changed``: it changed the block)."""

    def again(self, changed):
        """Another sweep after this one (``changed``: it changed a block)?"""
        return changed


def run(grid, events=(), order=None, visits=None, timing=TIMING, trace=None, progress=None):
    """Run the schedule on ``grid`` (see the hook table above) and
    return its :class:`PlanResult`.

    ``events``: dynamic orders ``(s, (r, c), kind)``: passes are numbered
    0, 1, ... from the start of the run (update and check passes alike); an
    order with s >= 1 is applied at the end of pass s-1 (the Control module
    takes a host order at the next pass boundary), s = 0 before the run (a
    SET command sent while idle: its cycles are not part of the run).
    ``order``: ``order(sweep)`` -> the blocks of the level's sweep number
    ``sweep`` in visit order; default ``grid.blocks`` (raster, the RTL's).
    ``visits``: None (every block) or an :class:`EveryBlock` policy; it sees
    the visits, not what ``grid.after_visit`` does (plan_explore uses one on
    the fixed-point grid, where that is nothing).
    """
    res, B, iters = grid.res, grid.B, grid.iters
    if order is None:
        order = lambda sweep: grid.blocks      # noqa: E731 - the RTL's raster order
    due = grid.orders(events)
    grid.apply_due(due, 0)                     # pass 0: sent while idle, before START
    cycles = timing.run
    passes = 0

    def note(event):
        if trace is not None:
            trace.append((event, grid.p, *grid.snapshot(), cycles))

    def new_level():
        level = grid.new_level()
        if visits is not None:
            level["skipped"] = 0
            visits.reset()
        return level

    def cleared():
        """After a pass: the orders due now, a clear pass each; True if any."""
        nonlocal cycles
        k = grid.apply_due(due, passes)
        if k:
            cycles += k * timing.clear_pass(B, grid.p)
            if visits is not None:
                visits.reset()
            note("clear")
        return k > 0

    level = new_level()
    maxima = 0
    note("start")
    while True:
        changed = False                        # an update pass (a sweep)
        for b in order(level["sweeps"]):
            if visits is not None:
                if visits.skip(b):
                    cycles += visits.skip_cycles
                    level["skipped"] += 1
                    continue
                visits.before(b)
            cycles += grid.scan_cycles(b)
            i, stable = grid.visit(b)
            res.block_iterations += i
            level["block_iterations"] += i
            cycles += timing.update_visit(i, stable, iters, grid.p)
            moved = i > 1 or not stable        # the block changed
            changed |= moved
            if visits is not None:
                visits.after(b, stable, moved)
            note("visit")
            extra = grid.after_visit(b, i, stable, level)
            if extra:
                cycles += extra
                changed = True
                note("repick")
        res.sweeps += 1
        level["sweeps"] += 1
        passes += 1
        if progress is not None:
            progress(res, grid.p, cycles)
        if cleared() or (changed if visits is None else visits.again(changed)):
            continue
        maxima, extra = grid.check(level)      # a check pass: nothing written
        cycles += timing.check_pass(B, grid.p) + extra
        res.check_iterations += B
        level["maxima"] = maxima
        note("check")
        passes += 1
        if cleared():
            continue
        if maxima == 0:
            res.converged = True
            break
        extra = grid.rescale(level)
        if extra:                              # a new level at the same p
            cycles += extra
            res.levels.append(level)
            level = new_level()
            note("repick")
            continue
        extra = grid.raise_precision()
        if extra is None:                      # the schedule's last precision
            break
        cycles += extra
        res.levels.append(level)
        level = new_level()
        note("raise")
    res.levels.append(level)
    return grid.result(cycles, maxima)
