"""The block schedule's result against scipy's sparse Dirichlet solve.

Bound (stated and proved here; README "Planner command line and benches").
Write F for the floored Jacobi map of the planner at precision p, on the whole
padded map, constants (obstacles, goals, walled-off cells, padding) fixed:
F(x)_i = floor((x_N + x_E + x_W + x_S) / 4) in units of 2**-p.

1. Every fixed point of F is within the single-block bound.  If x = F(x)
   then, in values, x = Hx + C - e with e_i = the dropped fraction of node i,
   0 <= e_i <= (3/4) 2**-p (a sum of integers over 4 drops 0, 1/4, 2/4 or 3/4
   of an ulp).  The exact solution satisfies x* = Hx* + C, so
   (I - H)(x* - x) = e and, (I - H)^-1 = sum_k H^k being non-negative (H is
   substochastic and every walk leaves the free nodes),
       0 <= x* - x = (I - H)^-1 e <= (3/4) 2**-p (I - H)^-1 1.
   plan() stops a level only after a sweep in which no block changes, i.e.
   every block is stable in its first iteration against its neighbours'
   stored values: the state is a fixed point of F on the whole map, whatever
   the block size, I, block order or precision schedule.  So the block
   schedule gives the same bound as the single block.

2. Stronger, from below the block schedule gives the SAME fixed point, bit
   for bit.  F is monotone.  The start x0 (goals 1, free 0) has x0 <= F(x0).
   Updating any subset of nodes to F(x) keeps x <= F(x) and keeps x below
   every fixed point m >= x0; the values rise in integers, so any schedule
   that ends in a fixed point ends in the least fixed point above x0, the
   one Jacobi from x0 (relax) reaches.  Raising p by s multiplies the field
   by 2**s: floor(2**s a) >= 2**s floor(a) keeps it below F, and by induction
   along the Jacobi run it stays below the least fixed point at p + s, so
   every level ends in relax's fixed point at that level's p.

Tested on random maps, the paper's corridor and a spiral, room and random
bundled maps, with several blocks (padding included), I and schedules:
fixed point (exact, integers), bit-identity with relax from zero at the final
p, and the bound against scipy (float64: at p <= 32, where the bound is far
above float round-off) plus e recomputed and x* - x = (I-H)^-1 e checked.  A
negative control: a coarser fixed point (p = 8 scaled up) violates the bound
at the finer p, so the check can fail.
"""

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from dirichlet import dirichlet
from harmonic_small_maps import corridor, spiral
from navcores.models.harmonic import neighbours, one, plan, relax, step
from navcores.models.maps import load_map

ROOT = Path(__file__).resolve().parents[2]


def _random(rows, cols, seed, density=0.25):
    rng = np.random.default_rng(seed)
    ob = rng.random((rows, cols)) < density
    free = np.argwhere(~ob)
    return ob, [tuple(int(x) for x in free[rng.integers(len(free))])]


def _bundled(name, goal):
    return load_map(ROOT / "maps" / name), [goal]


MAPS = {
    "random-13x17-a": lambda: _random(13, 17, 21),
    "random-13x17-b": lambda: _random(13, 17, 22, 0.15),
    "two-goals-10x20": lambda: (_random(10, 20, 23)[0], [(0, 0), (9, 19)]),
    "corridor-12": lambda: corridor(12),
    "spiral-9": lambda: spiral(9),
    "room-32-32-4": lambda: _bundled("room-32-32-4.map", (30, 31)),
    "random-32-32-10": lambda: _bundled("random-32-32-10.map", (31, 31)),
    "maze-32-32-2": lambda: _bundled("maze-32-32-2.map", (1, 31)),
}

SCHEDULES = [((3, 6), 1, (8, 16, 24, 32)), ((4, 4), 3, (16, 32)), ((5, 7), 6, (12, 20, 32))]


def _check_bound(h, const, goal, p, slack=1e-12):
    """Returns (max gap / bound, count); raises AssertionError with details."""
    free, a, exact, resolvent = dirichlet(goal, const)
    x = np.array([int(h[r, c]) / one(p) for r, c in free])
    gap = exact - x
    bound = 0.75 * 2.0 ** -p * resolvent
    assert (gap >= -slack).all(), f"field above x* by {-gap.min():.3g}"
    assert (gap <= bound + slack).all(), f"gap {gap.max():.3g} over the bound {bound[gap.argmax()]:.3g}"
    # x* - x = (I - H)^-1 e with e the dropped fractions, recomputed exactly.
    hn = neighbours(h)
    total = hn[0] + hn[1] + hn[2] + hn[3]
    e = np.array([(int(total[r, c]) - 4 * int(h[r, c])) / 4 / one(p) for r, c in free])
    assert (e >= 0).all() and (e <= 0.75 * 2.0 ** -p).all()
    assert np.allclose(spla.spsolve(a, e), gap, rtol=0, atol=1e-12)
    return float((gap / np.maximum(bound, 1e-300)).max()), len(free)


@pytest.mark.parametrize("block,iters,schedule", SCHEDULES, ids=lambda v: str(v).replace(" ", ""))
@pytest.mark.parametrize("name", list(MAPS))
def test_block_schedule_within_single_block_bound(name, block, iters, schedule):
    ob, goals = MAPS[name]()
    res = plan(ob, goals, block=block, iters=iters, schedule=schedule)
    # plan stops where local maxima vanish: the bound is tested at res.p.
    h, const, p = res.padded_h, res.padded_const, res.p
    goal = np.zeros(const.shape, dtype=bool)
    goal[tuple(np.array(goals).T)] = True
    # 1. a fixed point of F on the whole padded map (exact, integers)
    _, _, stable, _ = step(h, const, p, neighbours(h))
    assert stable.all(), "plan ended off a fixed point of the floored map"
    # 2. the same field as single-block Jacobi from zero at p
    h0 = np.where(goal, one(p), 0).astype(object)
    ref, _ = relax(h0, const, p)
    assert (ref == h).all(), "block schedule and single block differ"
    # 3. within the bound of the exact solution
    ratio, n = _check_bound(h, const, goal, p)
    assert n > 0 and 0 <= ratio <= 1
    if p <= 24:
        assert ratio > 1e-3, "the bound should not be vacuous"


def test_bound_can_fail():
    """A fixed point at a coarser precision (p = 8) written at p = 24 is a
    valid-looking field that is NOT within the p = 24 bound."""
    ob, goals = _random(13, 17, 21)
    coarse = plan(ob, goals, block=(4, 4), iters=3, schedule=(8,))
    h = coarse.padded_h * (1 << 16)
    goal = np.zeros(h.shape, dtype=bool)
    goal[goals[0]] = True
    with pytest.raises(AssertionError, match="over the bound"):
        _check_bound(h, coarse.padded_const, goal, 24)


def test_padding_changes_nothing():
    """A map that is not a multiple of the block, padded with obstacles: the
    field on the original cells is the unpadded one (outside reads 0 anyway)."""
    ob, goals = _random(13, 17, 22, 0.15)
    a = plan(ob, goals, block=(13, 17), iters=10**6, schedule=(16, 32))
    b = plan(ob, goals, block=(5, 7), iters=2, schedule=(16, 32))
    assert b.padded_h.shape == (15, 21) and (a.h == b.h).all() and a.p == b.p


@pytest.mark.parametrize("block,iters", [((3, 6), 2), ((4, 4), 1), ((5, 7), 4)])
def test_plan_explore_defaults_are_plan(block, iters):
    """plan_explore (the benchmarks' schedule variants) with its defaults is
    plan() counter for counter; every order, with and without skipping still
    blocks, ends in the same fixed point (part 2 above)."""
    from navcores.models.harmonic import plan_explore
    ob, goals = _random(13, 17, 22, 0.15)
    sched = (8, 16, 24)
    a = plan(ob, goals, block=block, iters=iters, schedule=sched)
    b = plan_explore(ob, goals, block=block, iters=iters, schedule=sched)
    for k in ("p", "converged", "maxima", "sweeps", "block_iterations", "check_iterations",
              "node_updates", "cycles"):
        assert getattr(a, k) == getattr(b, k), k
    assert (a.padded_h == b.padded_h).all()
    cycles = set()
    for order in ("raster", "serpentine", "alternate", "goal"):
        for skip in (False, True):
            c = plan_explore(ob, goals, block=block, iters=iters, schedule=sched, order=order, skip=skip)
            assert (c.padded_h == a.padded_h).all() and c.p == a.p, (order, skip)
            _, _, stable, _ = step(c.padded_h, c.padded_const, c.p, neighbours(c.padded_h))
            assert stable.all()
            cycles.add(c.cycles)
    assert len(cycles) > 2, "the variants must differ in cost"
