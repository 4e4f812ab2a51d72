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
      sweep: every block b (default: every *dirty* block), in the visit
             order, runs up to I iterations, stopping after the first one
             in which it is stable (it counts)
      after every pass: apply the dynamic orders due (a clear pass each),
             then sweep again
      another sweep while the last one changed a block (default: while a
             block is dirty)
      the check: (paper) a check pass, one check iteration per block, the
             Maximum flags; (default) the flags each block's last visit left
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
                       is needed (:class:`StillBlocks`, the default: dirty
                       bits; :class:`EveryBlock`, the paper's: every block,
                       another sweep while one changed a block)
timing                 the Control module's cycle accounting
                       (:class:`StillTiming` / :class:`Timing`, the tables
                       below)
trace                  None or a list that gets (event, p, exponents,
                       values, cycles) after every visit, re-pick, check,
                       clear pass and precision rise
progress               None or ``progress(result, p, cycles)`` after every
                       pass (update or check): the commands' progress line
=====================  =========================================================

The two schedules the Control module runs are a ``visits`` policy and a
:class:`Timing` (:func:`control`): the paper's (``paper_schedule=True``:
:class:`EveryBlock`, :class:`Timing`) and the default, still blocks
(:class:`StillBlocks`, :class:`StillTiming`).  Where later work goes: an
exponent width chosen from the map (issue 22) is ExponentGrid's ``e_max``;
a vectorized fast path replaces ``grid.visit`` (a grid class whose visit
runs on precomputed views, or batches independent blocks) without touching
the loop.

The default schedule: still blocks cost nothing (issue 19)
-----------------------------------------------------------
Section 4.5.2: "large parts of the environment stay unchanged (still) for
several iterations while distant blocks slowly propagate the changes".  The
paper still visits them (one stable iteration each, and here one more: the
confirmation iteration below) and ends every level with a sweep that
changes nothing and a check pass.  The default schedule drops all three:

1. **Dirty bits.**  One bit per block (:class:`StillBlocks`): all set at a
   level's start and after a clear pass; a visit clears its block's bit,
   sets it again if the visit used up its I iterations without a stable
   one, and sets the bit of every neighbour block whose facing edge the
   visit changed (the RTL: an edge node's Stable flag low in an update
   iteration; the Block ORs them per edge).  A sweep visits the dirty blocks
   only, in raster order; the next dirty block is chosen in the visit's
   last cycle, so a skipped block costs no cycle.  The update phase ends
   when no bit is set: no confirmation sweep.
2. **No confirmation iteration.**  The flags of iteration i come at cycle 2
   of iteration i+1, which the clusters have started; when iteration i was
   stable the Control module stops them right there (the cluster's
   ``abort``), so a visit that is stable at its i-th iteration costs i
   iterations, not i+1.
3. **The check folded in.**  The node compares its word with each
   neighbour's LSB first, from the same port-A streams its adder reads (the
   last differing bit decides, as the first does MSB first), so every
   update iteration brings the Maximum flags of the values it read; the
   Control module keeps, per block, the flag of the block's last stable
   iteration, and a level ends with the OR of those B bits: no check pass.

**Why skipping never changes the result** (the fixed point and the
local-maximum check).  Let F be the floored update on the whole map and
F_b its part for block b: F_b(x) depends only on block b's words and its
ring (the facing edges of its four neighbours; with block exponents, their
exact values, converted: a re-pick keeps the exact values).

* Invariant: between visits, every clean block b is a fixed point of its
  own update, F_b(x) = x_b.  At a level's start and after a clear pass no
  block is clean.  A visit that ends with a stable iteration leaves
  F_b(x) = x_b (that iteration rewrote every word unchanged from the
  current words and ring) and clears the bit; one that does not leaves the
  bit set.  For any other clean block c, F_c can change only if its ring
  changes, i.e. if the visit changed the edge facing c, and then c's bit is
  set.  A re-pick's shift visit changes block b's units (its ring is read
  finer): b's bit is set; its neighbours see the same exact values.
* So when no bit is set, every block is a fixed point against its ring: the
  whole map is a fixed point of F, as at the end of the paper's confirmation
  sweep.  Every visit either raises the field (finitely often: values only
  rise from below and are bounded) or clears a bit and sets none, so every
  level ends.  From below, any schedule of block updates that stops at a
  fixed point stops at the least one (hdl/harmonic/README.md, "The block
  schedule's error bound"), so in fixed point every level ends in the very
  field the paper's schedule ends in, bit for bit: the same precisions, the
  same final field; only the cycles differ.
* The abort (2) is exact: after a stable iteration i, iteration i+1 reads
  the same words and ring (another block's border words are written only
  while that block is visited), so everything it writes before it is
  stopped (its flag bit at cycle 2; iteration i's last two bits were
  written at cycles 0-1, before) is what is already stored.
* The folded check (3) is the check pass's: block b's last visit of the
  level ended with a stable iteration, after which b was not visited again
  and no facing edge changed (else its bit would be set at the end), so the
  words and ring that iteration compared are the final field's, and the
  OR over blocks is the check pass's Cvg.  tb/harmonic/test_model_blocks.py
  checks all of it: equal fields level by level against the paper's
  schedule, and each block's flag of its last stable visit against the
  Maximum of the final field.

Cycles of the default schedule (:class:`StillTiming`): an update visit
stable at its i-th iteration K = i (else K = I) iterations, K*L +
VISIT_OVERHEAD (L = iteration_cycles(p)); a skipped block 0; no check pass; clear visits as in the
paper's (K = 1).  ``check_iterations`` stays 0 and passes (for the dynamic
orders) are the sweeps.

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

__all__ = ["VISIT_OVERHEAD", "RUN_OVERHEAD", "SET_OVERHEAD", "visit_cycles", "Timing", "StillTiming",
           "PlanResult", "EveryBlock", "StillBlocks", "control", "run"]

VISIT_OVERHEAD = 7
RUN_OVERHEAD = 0
SET_OVERHEAD = 0


def visit_cycles(k, p, shift=False):
    """Cycles of one block visit running ``k`` iterations at precision ``p``
    (``shift``: a shift visit of block exponents, padded iterations)."""
    return k * iteration_cycles(p, shift) + VISIT_OVERHEAD


class Timing:
    """The Control module's cycle accounting of the paper's schedule
    (``paper_schedule=True``, the tables above): what :func:`run` adds for
    the run, each update visit, check pass and clear pass.
    ``folded_check``: False, every level ends with a check pass of B check
    visits (counted in ``check_iterations`` and as a pass)."""

    run = RUN_OVERHEAD
    folded_check = False

    def update_visit(self, i, stable, iters, p):
        """An update visit that counted ``i`` iterations (``stable``: its
        i-th was stable; the confirmation iteration is paid, not counted)."""
        return visit_cycles(min(i + 1, iters) if stable else iters, p)

    def check_pass(self, blocks, p):
        return blocks * visit_cycles(1, p)

    def clear_pass(self, blocks, p):
        return SET_OVERHEAD + blocks * visit_cycles(1, p)


class StillTiming(Timing):
    """The default schedule's accounting (still blocks, see "The default
    schedule" above): an update visit whose i-th iteration was stable costs
    i iterations (the iteration after it is stopped when its flags come, at
    its cycle 2: the confirmation iteration is gone), one that used up its I
    iterations I; no check pass (``folded_check``: the Maximum flags come
    with every update iteration and the Control module keeps each block's
    flag from its last stable one); skipped blocks cost nothing (the next
    dirty block is found in the visit's last cycle)."""

    folded_check = True

    def update_visit(self, i, stable, iters, p):
        return visit_cycles(i if stable else iters, p)

    def check_pass(self, blocks, p):
        return 0


TIMING = Timing()
STILL_TIMING = StillTiming()


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
    the free (non-constant) nodes at the last check (0 when converged).
    ``unreachable``: free cells of the input map no goal reaches; they were
    loaded as constant-0 obstacles.  ``sweeps``: update passes over all
    blocks (a block skipped as still is passed by); ``visits``: update
    visits; ``skipped``: visits skipped (still blocks; 0 in the paper's
    schedule); ``block_iterations``: update iterations counted as the
    pseudo-code counts them (i, the stable one included), summed over block
    visits; ``check_iterations``: check iterations (one per block per check
    pass; 0 in the default schedule, whose check is folded into the visits);
    ``node_updates``: block_iterations * n*m (every node of a block is
    updated in an iteration, obstacles and padding included);
    ``clear_passes``: passes that restarted the free nodes from 0 after a
    dynamic order; ``cycles``: the clock cycles the RTL spends from its START
    command to idle (see the timing table of :mod:`models.harmonic.schedule`);
    ``levels``: per precision level, dicts with p, sweeps, block_iterations,
    skipped, maxima (None if the level ended without a check);
    ``events_applied``: events that were due; ``paper_schedule``: the run
    used the paper's schedule (else the default, still blocks).
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
    visits: int = 0
    skipped: int = 0
    paper_schedule: bool = False
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
    e_max: int = None
    at_e_max: int = 0

    def potential(self):
        """Values as floats in [0, 1]."""
        unit = one(self.p if self.frac_bits is None else self.frac_bits)
        return np.array([[int(v) / unit for v in row] for row in self.h], dtype=float)


class EveryBlock:
    """The ``visits`` protocol of :func:`run`, as the paper schedules it
    (``paper_schedule=True``): every block is visited in every sweep, and
    another sweep follows while the last one changed a block.  A policy that
    skips blocks overrides these; ``run`` counts its skipped visits in each
    level's ``skipped`` and charges ``skip_cycles`` for each."""

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

    def touched(self, b):
        """Block ``b``'s words were moved after its visit (block exponents:
        a re-pick's shift visit, which makes its ring finer)."""

    def again(self, changed):
        """Another sweep after this one (``changed``: it changed a block)?"""
        return changed


# A block's edges (N, E, W, S) and the neighbour block each one faces.
_EDGES = ((-1, 0), (0, 1), (0, -1), (1, 0))


class StillBlocks(EveryBlock):
    """The default ``visits`` policy: one dirty bit per block (the Control
    module's ``dirty`` register; see "The default schedule" above).

    Every block is dirty at the start of a level and after a clear pass.  A
    sweep visits the dirty blocks in its order and passes the others by at
    no cost.  A visit clears the block's bit, sets it again if the visit
    used up its I iterations without a stable one, and sets the bit of each
    neighbour block whose facing edge (the block's top row for the block
    above, ...) the visit changed: in the RTL, an edge node's Stable flag
    low in one of the visit's update iterations (values only rise within a
    visit, so that is "the edge changed"); here, the edge before and after.
    A re-pick's shift visit (block exponents) sets the block's own bit: its
    ring is read at a finer scale now, its neighbours' view of it is the
    same exact value.  The update phase of a level ends when no bit is set.
    """

    def __init__(self, grid):
        self.grid = grid
        self.dirty = dict.fromkeys(grid.blocks, True)

    def reset(self):
        for b in self.dirty:
            self.dirty[b] = True

    def skip(self, b):
        return not self.dirty[b]

    def _edges(self, b):
        blk = self.grid.block(b)
        return blk[0], blk[:, -1], blk[:, 0], blk[-1]

    def before(self, b):
        self.dirty[b] = False
        self.was = [e.copy() for e in self._edges(b)]

    def after(self, b, stable, changed):
        if not changed:
            return
        self.dirty[b] = not stable
        for (dr, dc), now, was in zip(_EDGES, self._edges(b), self.was):
            nb = (b[0] + dr, b[1] + dc)
            if nb in self.dirty and not (now == was).all():
                self.dirty[nb] = True

    def touched(self, b):
        self.dirty[b] = True

    def again(self, changed):
        return any(self.dirty.values())


def control(grid, paper_schedule=False):
    """The Control module's schedule for ``grid``: (visits policy, timing);
    the default (still blocks) or the paper's."""
    if paper_schedule:
        return EveryBlock(), TIMING
    return StillBlocks(grid), STILL_TIMING


def run(grid, events=(), order=None, visits=None, timing=TIMING, trace=None, progress=None):
    """Run the schedule on ``grid`` (see the hook table above) and
    return its :class:`PlanResult`.

    ``events``: dynamic orders ``(s, (r, c), kind)``: passes are numbered
    0, 1, ... from the start of the run (update and check passes alike; the
    default schedule has no check pass); an order with s >= 1 is applied at
    the end of pass s-1 (the Control module takes a host order at the next
    pass boundary), s = 0 before the run (a SET command sent while idle: its
    cycles are not part of the run).
    ``order``: ``order(sweep)`` -> the blocks of the level's sweep number
    ``sweep`` in visit order; default ``grid.blocks`` (raster, the RTL's).
    ``visits``: None (every block) or an :class:`EveryBlock` policy; it sees
    the visits, and ``touched`` after a visit that ``grid.after_visit``
    charged cycles for.  ``timing``: :class:`Timing` (the paper's) or
    :class:`StillTiming` (:func:`control` pairs them with the policy).
    """
    res, B, iters = grid.res, grid.B, grid.iters
    if order is None:
        order = lambda sweep: grid.blocks      # noqa: E731 - the RTL's raster order
    if visits is None:
        visits = EveryBlock()
    folded = timing.folded_check
    due = grid.orders(events)
    grid.apply_due(due, 0)                     # pass 0: sent while idle, before START
    cycles = timing.run
    passes = 0

    def note(event):
        if trace is not None:
            trace.append((event, grid.p, *grid.snapshot(), cycles))

    def new_level():
        level = grid.new_level()
        level["skipped"] = 0
        visits.reset()
        return level

    def cleared():
        """After a pass: the orders due now, a clear pass each; True if any."""
        nonlocal cycles
        k = grid.apply_due(due, passes)
        if k:
            cycles += k * timing.clear_pass(B, grid.p)
            visits.reset()
            note("clear")
        return k > 0

    level = new_level()
    maxima = 0
    note("start")
    while True:
        changed = False                        # an update pass (a sweep)
        for b in order(level["sweeps"]):
            if visits.skip(b):
                cycles += visits.skip_cycles
                level["skipped"] += 1
                res.skipped += 1
                continue
            visits.before(b)
            cycles += grid.scan_cycles(b)
            i, stable = grid.visit(b)
            res.block_iterations += i
            res.visits += 1
            level["block_iterations"] += i
            cycles += timing.update_visit(i, stable, iters, grid.p)
            moved = i > 1 or not stable        # the block changed
            changed |= moved
            visits.after(b, stable, moved)
            note("visit")
            extra = grid.after_visit(b, i, stable, level)
            if extra:
                cycles += extra
                changed = True
                visits.touched(b)
                note("repick")
        res.sweeps += 1
        level["sweeps"] += 1
        passes += 1
        if progress is not None:
            progress(res, grid.p, cycles)
        if cleared() or visits.again(changed):
            continue
        # The check: a pass of check visits (the paper's), or the Maximum
        # flags every block's last (stable) visit left (folded: no cycles).
        maxima, extra = grid.check(level)
        level["maxima"] = maxima
        if not folded:
            cycles += timing.check_pass(B, grid.p) + extra
            res.check_iterations += B
            passes += 1
        note("check")
        if not folded and cleared():
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
