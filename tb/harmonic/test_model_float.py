"""Block exponents where floating point fails (issue 22), in the model.

* The fast visit (plan_exponents(..., fast=True)) is the reference visit
  bit for bit: mantissas, exponents, p, converged, sweeps, visits, block
  iterations, re-picks, saturated blocks and cycles, on random maps, a
  corridor and a spiral, both schedules, the RTL variant and the model's
  rule, a small e_max, dynamic orders, across the int64 / Python-int switch.
* exponent_bound and precision_estimate on maps whose distances are known.
* The 64x64 crop of maze512-1-0 (goal (1, 1), longest distance 236: a
  fixed point needs about 450 bits): with exponents from the map it
  converges at p = 192, every exponent within e_max, and both the exact
  ascent and the Decision module's paths reach the goal from every
  reachable cell; at p = 128 it does not converge (the test can fail).
* The log-space solver (tb/harmonic/logspace.py) against scipy's float64
  solve where float64 holds the field (the 64x64 crop), and on the
  128x128 crop, where float64 holds 0 in most cells, its ascent still
  reaches the goal from every reachable cell.
"""

from pathlib import Path

import numpy as np
import pytest

from dirichlet import dirichlet
from logspace import log_harmonic, order_field
from planner_maps import corridor, random_map, spiral, straight
from navcores.models.harmonic import (ascent_reaches, decision_paths, distances, exponent_bound, plan,
                                      precision_estimate, reachable)
from navcores.models.maps import load_map

ROOT = Path(__file__).resolve().parents[2]
FIELDS = ("p", "converged", "maxima", "sweeps", "visits", "skipped", "block_iterations", "check_iterations",
          "clear_passes", "cycles", "repicks", "saturated", "frac_bits", "at_e_max")


def _maze(n):
    return load_map(ROOT / "maps" / "maze512-1-0.map")[:n, :n], [(1, 1)]


CASES = [
    ("random", random_map(18, 36, 1, density=0.25), dict(block=(3, 6), iters=3, schedule=(6, 10, 14))),
    ("random paper", random_map(18, 36, 2, density=0.25),
     dict(block=(6, 12), iters=2, schedule=(4, 8, 12), paper_schedule=True)),
    ("random rule", random_map(18, 36, 3, density=0.25), dict(block=(3, 6), iters=2, schedule=(4, 8, 12), rtl=False)),
    ("corridor", corridor(15, 24), dict(block=(3, 6), iters=4, schedule=(8, 16, 24, 32))),
    ("spiral e_max 5", spiral(18, 18), dict(block=(3, 6), iters=2, schedule=(8, 16, 24), e_max=5)),
    ("orders, int64 to ints", random_map(9, 18, 3, density=0.25),
     dict(block=(3, 6), iters=3, schedule=(6, 10, 60, 62), events=((10, (4, 14), "obstacle"), (20, (7, 3), "goal")))),
]


@pytest.mark.parametrize("name,case,opts", CASES, ids=[c[0] for c in CASES])
def test_fast_visit_is_the_reference(name, case, opts):
    ob, goals = case
    opts = {"rtl": True, **opts}
    ref = plan(ob, goals, block_exponents=True, **opts)
    fast = plan(ob, goals, block_exponents=True, fast=True, **opts)
    assert ref.visits > 0 and ref.exponents.max() > 0, "the run re-picked nothing"
    assert (fast.mantissa == ref.mantissa).all() and (fast.exponents == ref.exponents).all(), name
    assert {k: getattr(fast, k) for k in FIELDS} == {k: getattr(ref, k) for k in FIELDS}, name
    assert fast.levels == ref.levels


def test_exponent_bound_and_precision_estimate():
    ob, goals = straight(3, 48)
    assert exponent_bound(ob, goals) == 2 * 47
    # a 3x6 block of the corridor holds 6 cells and sees the one before them: spread 6
    assert precision_estimate(ob, goals, (3, 6), headroom=1) == (2 * 6 + 1 + 2, 6)
    ob, goals = corridor(9, 12)
    d = distances(ob, goals)
    assert d[goals[0]] == 0 and d.max() == exponent_bound(ob, goals) // 2
    assert (d >= 0).sum() == reachable(ob, goals).sum() == (~ob).sum()


def test_maze64_converges_and_every_cell_reaches_the_goal():
    ob, goals = _maze(64)
    reach = reachable(ob, goals)
    e_max = exponent_bound(ob, goals)
    assert e_max == 2 * 236
    res = plan(ob, goals, block=(6, 12), iters=6, schedule=(192,), block_exponents=True, rtl=True, fast=True,
               e_max="map")
    print(f"64x64 crop: p {res.p}, e_b {res.exponents.min()}..{res.exponents.max()} of {res.e_max}, "
          f"{res.cycles} cycles, {res.block_iterations} block iterations")
    assert res.converged and res.maxima == 0 and res.p == 192
    assert res.e_max == e_max and 0 <= res.exponents.min() and res.exponents.max() <= e_max
    assert res.exponents.max() > 255, "the run needs more than an 8-bit exponent"
    assert ascent_reaches(res.h, goals, reach).sum() == reach.sum() == 743
    goal = np.zeros(res.mantissa.shape, dtype=bool)
    goal[goals[0]] = True
    paths = decision_paths(res.mantissa, res.exponents, res.block, res.p, goal, np.argwhere(reach))
    assert all(ok for _, ok in paths)
    for path, _ in paths[:50]:              # 4-connected, free cells only
        assert all(abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1 and not ob[b] for a, b in zip(path, path[1:]))
    low = plan(ob, goals, block=(6, 12), iters=6, schedule=(128,), block_exponents=True, rtl=True, fast=True,
               e_max="map")
    assert not low.converged and ascent_reaches(low.h, goals, reach).sum() < reach.sum()


def _float64(ob, goals):
    reach = reachable(ob, goals)
    goal = np.zeros(ob.shape, dtype=bool)
    goal[goals[0]] = True
    free, _, x, _ = dirichlet(goal.astype(float), ob | ~reach | goal)
    return free, x, reach


def test_log_space_against_float64():
    ob, goals = _maze(64)
    free, x, reach = _float64(ob, goals)
    assert (x > 0).all()
    u, sweeps, converged = log_harmonic(ob, goals)
    assert converged and sweeps > 118         # the front moves 2 cells a sweep: 236 cells away
    assert np.abs(u[tuple(free.T)] - np.log(x)).max() < 1e-6
    assert ascent_reaches(order_field(u), goals, reach).sum() == reach.sum()


def test_log_space_where_float64_underflows():
    ob, goals = _maze(128)
    free, x, reach = _float64(ob, goals)
    zero = int((x == 0).sum())
    assert zero > 3000, zero                  # the 3,527 cells at exactly 0
    u, _, converged = log_harmonic(ob, goals)
    assert converged and np.isfinite(u[reach]).all()
    assert ascent_reaches(order_field(u), goals, reach).sum() == reach.sum() == 4927
