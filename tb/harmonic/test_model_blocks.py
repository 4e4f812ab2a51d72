"""The block-synchronous planner model (models.harmonic.plan) and the
Decision model, against the landed single-block relaxation and against
properties the section 4 pseudo-code fixes.

* One block covering the map, I at least the iterations relax needs: the same
  values and the same iteration count as :func:`relax` (the paper's schedule:
  plus the second sweep's one stable iteration), level by level, and the
  cycle count of each schedule's formula.
* Several blocks: every run ends; a converged run is a fixed point of eq. (2)
  on the whole map with no local maximum; block_iterations is bounded by
  I * B * sweeps and at least B per sweep (the paper's schedule); the cycle
  count is the timing table's sum.
* The default schedule (still blocks) against the paper's: the same field at
  the end of every level, bit for bit, hence the same precisions and result;
  the dirty bits' invariant (a clean block is a fixed point of its own
  update) after every visit; the folded check (each block's Maximum flags of
  its last stable visit) equals the Maximum of the final field at every
  level; every visit's cycles follow StillTiming.
* Stop criterion: a corridor too long for p1 needs a higher precision;
  p_max too low: converged false with the maxima counted.
* Events: an obstacle / goal during a run, and one before a run (after
  convergence), each ending in a fixed point.
"""

import numpy as np
import pytest

from navcores.models.harmonic import (
    VISIT_OVERHEAD, decision, iteration_cycles, local_max, neighbours, one, pad_to_blocks, plan, reachable, relax,
    step,
)
from navcores.models.harmonic.grid import BlockGrid
from navcores.models.harmonic.schedule import EveryBlock, StillBlocks, StillTiming, Timing, run


def _random_map(rows, cols, seed, density=0.25):
    rng = np.random.default_rng(seed)
    ob = rng.random((rows, cols)) < density
    free = np.argwhere(~ob)
    goal = tuple(free[rng.integers(len(free))])
    return ob, [goal]


def _corridor(length):
    ob = np.ones((3, length + 2), dtype=bool)
    ob[1, 1:length + 1] = False
    return ob, [(1, length)]


def _is_fixed_point(res):
    h, const = res.padded_h, res.padded_const
    hn, _, stable, _ = step(h, const, res.p, neighbours(h))
    return stable.all()


@pytest.mark.parametrize("paper", [False, True])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_one_block_equals_relax(seed, paper):
    ob, goals = _random_map(7, 9, seed)
    sched = (10, 20)
    res = plan(ob, goals, block=ob.shape, iters=10**6, schedule=sched, paper_schedule=paper)
    reach = reachable(ob, goals)
    const = ob | ~reach
    h = np.zeros(ob.shape, dtype=object)
    h[goals[0]] = one(sched[0])
    const[goals[0]] = True
    h, it = relax(h, const, sched[0])
    # The paper's: sweep 1 relaxes (it iterations, the last stable); sweep 2
    # finds the block stable in its first iteration: a whole sweep without
    # change.  Still blocks: sweep 1 only (the block ends clean).
    assert res.levels[0]["block_iterations"] == it + paper and res.levels[0]["sweeps"] == 1 + paper
    mx = int(local_max(h, const, neighbours(h)).sum())
    assert res.levels[0]["maxima"] == mx
    if mx:
        h, it2 = relax(h * (1 << (sched[1] - sched[0])), const, sched[1])
        assert res.levels[1]["block_iterations"] == it2 + paper
    assert (res.h == h).all() and (res.const == const).all()
    if paper:   # each sweep's visit, its confirmation iteration, the check pass's visit
        assert res.cycles == sum(lv["sweeps"] + 1 for lv in res.levels) * VISIT_OVERHEAD + sum(
            (lv["block_iterations"] + 3) * (lv["p"] + 2) for lv in res.levels)
    else:       # one visit per level, no confirmation, no check pass
        assert res.cycles == len(res.levels) * VISIT_OVERHEAD + sum(
            lv["block_iterations"] * (lv["p"] + 2) for lv in res.levels)
        assert res.check_iterations == 0 and res.skipped == 0


@pytest.mark.parametrize("paper", [False, True])
@pytest.mark.parametrize("seed", [4, 5, 6, 7])
@pytest.mark.parametrize("block,iters", [((3, 6), 2), ((6, 12), 5), ((4, 5), 1)])
def test_blocks_terminate_in_a_fixed_point(seed, block, iters, paper):
    ob, goals = _random_map(12, 24, seed)
    res = plan(ob, goals, block=block, iters=iters, schedule=(8, 16, 32, 48), paper_schedule=paper)
    B = res.blocks[0] * res.blocks[1]
    assert _is_fixed_point(res)
    assert res.visits + res.skipped == B * res.sweeps
    assert res.visits <= res.block_iterations <= iters * res.visits
    if paper:
        assert res.visits == B * res.sweeps and res.skipped == 0
    assert res.node_updates == res.block_iterations * block[0] * block[1]
    assert res.check_iterations == (0 if not paper else B * sum(lv["maxima"] is not None for lv in res.levels))
    h, const = res.padded_h, res.padded_const
    mx = int(local_max(h, const, neighbours(h)).sum())
    assert res.converged == (mx == 0) and res.maxima == mx
    assert [lv["p"] for lv in res.levels] == [8, 16, 32, 48][:len(res.levels)]
    assert res.potential().max() <= 1.0 and res.potential()[goals[0]] == 1.0
    # unreachable free cells are walled off (constant 0) and reported
    assert (res.unreachable == (~ob & ~reachable(ob, goals))).all()
    assert (res.h[res.unreachable] == 0).all() and res.const[res.unreachable].all()


class _Watched(StillBlocks):
    """StillBlocks that checks the dirty bits' invariant after every visit
    and records each block's Maximum flags at its stable visits (what the
    Control module keeps for the folded check)."""

    def __init__(self, grid):
        super().__init__(grid)
        self.flags, self.checked = {}, 0

    def after(self, b, stable, changed):
        super().after(b, stable, changed)
        g = self.grid
        pad = g.pad
        nb = (pad[:-2, 1:-1], pad[1:-1, 2:], pad[1:-1, :-2], pad[2:, 1:-1])
        new = np.where(g.const, g.hv, sum(nb) >> 2)
        mx = local_max(g.hv, g.const, nb)
        if stable:
            self.flags[b] = _block(mx, g, b).any()
        for c in g.blocks:      # a clean block is a fixed point of its own update
            if not self.dirty[c]:
                assert (_block(new, g, c) == _block(g.hv, g, c)).all(), (b, c)
                self.checked += 1


def _block(a, g, b):
    return a[b[0] * g.n:(b[0] + 1) * g.n, b[1] * g.m:(b[1] + 1) * g.m]


@pytest.mark.parametrize("seed,block,iters", [(4, (3, 6), 2), (5, (6, 12), 3), (6, (4, 5), 1), (7, (3, 6), 6)])
def test_still_blocks_same_field_and_folded_check(seed, block, iters):
    """Still blocks and the paper's schedule end every level in the same
    field; the clean blocks' invariant holds after every visit; the OR of
    each block's flags of its last stable visit is the level's check; every
    visit's cycles follow StillTiming (K = i if stable, else I)."""
    ob, goals = _random_map(12, 24, seed)
    sched = (6, 12, 24, 36)
    paper_trace, still_trace = [], []
    paper = run(BlockGrid(ob, goals, block, iters, sched), visits=EveryBlock(), timing=Timing(),
                trace=paper_trace)
    grid = BlockGrid(ob, goals, block, iters, sched)
    watch = _Watched(grid)
    levels = []
    orig_check = grid.check

    def check(level):
        maxima, extra = orig_check(level)
        levels.append((grid.p, np.array(grid.hv, dtype=object), maxima, any(watch.flags.values())))
        return maxima, extra
    grid.check = check
    still = run(grid, visits=watch, timing=StillTiming(), trace=still_trace)
    assert watch.checked > 0
    paper_ends = {p: h for ev, p, _, h, _ in paper_trace if ev == "check"}
    for p, h, maxima, flagged in levels:
        assert (h == paper_ends[p]).all(), f"level p={p}: the fields differ"
        assert flagged == (maxima > 0), f"level p={p}: folded check {flagged}, maxima {maxima}"
    assert (still.padded_h == paper.padded_h).all() and still.p == paper.p
    assert still.converged == paper.converged
    assert still.cycles < paper.cycles and still.check_iterations == 0
    # every visit's cycles: K*L + VISIT_OVERHEAD with 1 <= K <= I (L = iteration_cycles(p))
    for (_, _, _, _, c0), (ev, p, _, _, c1) in zip(still_trace, still_trace[1:]):
        if ev == "visit":
            k, rem = divmod(c1 - c0 - VISIT_OVERHEAD, iteration_cycles(p))
            assert rem == 0 and 1 <= k <= iters, (c0, c1)
        elif ev in ("check", "raise"):
            assert c1 == c0
    levels_skipped = [lv["skipped"] for lv in still.levels]
    assert sum(levels_skipped) == still.skipped and still.skipped > 0


def test_stop_criterion_corridor_needs_precision():
    ob, goals = _corridor(20)
    res = plan(ob, goals, block=(3, 6), iters=4, schedule=(8, 16, 24, 48))
    assert res.converged and res.p == 48
    assert [lv["maxima"] > 0 for lv in res.levels[:-1]] == [True] * (len(res.levels) - 1)
    assert res.levels[-1]["maxima"] == 0
    short = plan(ob, goals, block=(3, 6), iters=4, schedule=(8, 12))
    assert not short.converged and short.p == 12 and short.maxima > 0


def test_pad_and_reachable():
    ob = np.zeros((4, 7), dtype=bool)
    ob[:, 3] = True
    pad = pad_to_blocks(ob, (3, 6))
    assert pad.shape == (6, 12) and pad[4:, :].all() and pad[:, 7:].all() and not pad[0, 0]
    reach = reachable(ob, [(0, 0)])
    assert reach[:, :3].all() and not reach[:, 4:].any()
    with pytest.raises(ValueError, match="no goal"):
        plan(ob, [], block=(3, 6))
    with pytest.raises(ValueError, match="increasing"):
        plan(ob, [(0, 0)], block=(3, 6), schedule=(16, 8))


@pytest.mark.parametrize("paper", [False, True])
@pytest.mark.parametrize("kind", ["obstacle", "goal"])
@pytest.mark.parametrize("at", [1, 3, 9])
def test_event_during_run_terminates(kind, at, paper):
    ob, goals = _random_map(12, 24, 11, density=0.15)
    base = plan(ob, goals, block=(6, 12), iters=3, schedule=(12, 24), paper_schedule=paper)
    free = np.argwhere(~ob & reachable(ob, goals))
    cell = tuple(free[len(free) // 2])
    res = plan(ob, goals, block=(6, 12), iters=3, schedule=(12, 24), events=[(at, cell, kind)],
               paper_schedule=paper)
    assert res.events_applied == 1 and res.clear_passes == 1
    assert res.padded_const[cell] and res.padded_h[cell] == (one(res.p) if kind == "goal" else 0)
    assert _is_fixed_point(res)
    assert (res.padded_h != base.padded_h).any()


def test_event_before_run_equals_fresh_plan():
    """An order sent while idle (after convergence) restarts every free node
    from 0: the next run is the fresh run on the changed map, cycle for cycle."""
    ob, goals = _random_map(12, 24, 12, density=0.1)
    free = np.argwhere(~ob & reachable(ob, goals))
    for cell in map(tuple, free[3:]):       # the first free cell that cuts nothing off
        ob2 = ob.copy()
        ob2[cell] = True
        if (reachable(ob2, goals) == (reachable(ob, goals) & ~ob2)).all():
            break
    else:
        raise AssertionError("every free cell disconnects the test map")
    for paper in (False, True):
        a = plan(ob, goals, block=(6, 12), iters=4, schedule=(12, 24), events=[(0, cell, "obstacle")],
                 paper_schedule=paper)
        b = plan(ob2, goals, block=(6, 12), iters=4, schedule=(12, 24), paper_schedule=paper)
        assert (a.h == b.h).all() and a.cycles == b.cycles and a.sweeps == b.sweeps


def test_clear_avoids_oscillation():
    """Without the restart, the state after a new obstacle can oscillate
    (README "Found on the way"); the planner's restart from 0 cannot."""
    ob, goals = _random_map(6, 12, 5, density=0.1)
    for paper in (False, True):
        res = plan(ob, goals, block=(3, 6), iters=2, schedule=(4, 6),
                   events=[(2, (2, 5), "obstacle"), (4, (4, 2), "obstacle")], paper_schedule=paper)
        assert res.events_applied == 2 and _is_fixed_point(res)


def test_decision():
    h = np.array([[0, 10, 0], [3, 5, 9], [0, 1, 0]], dtype=object)
    # centre 5: N 10, E 9, S 1, W 3: NE (25+16=41), ES (16+16=32), SW (16+4=20), WN (4+25=29)
    t, (gr, gc) = decision(h, 1, 1)
    assert t == 0 and (gr, gc) == (5 - 10, 9 - 5)
    # a flat node: every triangle ties, the first (NE) wins with a null vector
    assert decision(np.ones((3, 3), dtype=object), 1, 1) == (0, (0, 0))
    # outside the map reads 0: corner (0, 0) of an all-4 grid: N and W are 0
    t, (gr, gc) = decision(np.full((2, 2), 4, dtype=object), 0, 0)
    assert t == 3 and (gr, gc) == (4 - 0, 4 - 0)
    with pytest.raises(ValueError, match="outside"):
        decision(h, 3, 0)
