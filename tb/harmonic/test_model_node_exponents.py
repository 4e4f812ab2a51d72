"""Node exponents (issue 22): block exponents with one node a block, in the model.

* The update against exact fractions on random neighbours, including
  exponent gaps far beyond the word and denormals at e_max: never above the
  exact mean, less than 2 ulp below it (the module's stated bound).
* The order key against exact fractions.
* The fixed point against scipy's float64 solve on the 64x64 crop of
  maze512-1-0 (float64 holds that field: smallest 6.7e-135) at p = 8, 16,
  24: never above the exact field (it starts below and every update floors),
  and the relative error below eps * d (eps = 2**(2 - L), L = p + 1 - h the
  significant bits, d the cell's BFS distance: each step of the walk to the
  goal loses at most eps).
* Where float64 and the block exponents of 6x12 blocks fail: the 128x128
  crop (float64: 3,527 cells at exactly 0; one exponent a block needs p of
  about 2,400 bits): converged with p = 16, the exact ascent and the
  Decision module's paths (block (1, 1)) reach the goal from every
  reachable cell.  A straight corridor that a 64-bit fixed point loses.
* Refusals of bad parameters.
"""

import random
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from dirichlet import dirichlet
from node_words import format_word
from planner_maps import straight
from navcores.models.harmonic import ascent_reaches, decision_paths, distances, reachable
from navcores.models.harmonic.node_exponents import (GUARD, node_update, order_key, plan_node_exponents)
from navcores.models.maps import load_map
from navcores.sim.rtl.runner import seed_from_env

ROOT = Path(__file__).resolve().parents[2]


def _maze(n):
    return load_map(ROOT / "maps" / "maze512-1-0.map")[:n, :n], [(1, 1)]


@pytest.fixture
def rng():
    seed = int(seed_from_env())
    print(f"SEED={seed} (replay with SEED={seed})")
    return random.Random(seed)


def _exact(v, e, p):
    return Fraction(int(v), 1 << (p + int(e)))


@pytest.mark.parametrize("p,h", [(8, 2), (16, 2), (16, 0), (40, 3)])
def test_update_against_exact_fractions(p, h, rng):
    e_max = 300
    vn, en = [], []
    for _ in range(4000):
        words = [format_word(rng, p, h, e_max) for _ in range(4)]
        if rng.random() < 0.3:                          # close exponents: the guard bits matter
            base = rng.randrange(0, e_max - 4)
            words = [(rng.randrange(1 << (p - h), 1 << (p + 1 - h)), base + rng.randrange(1, 5)) for _ in range(4)]
        vn.append([w[0] for w in words])
        en.append([w[1] for w in words])
    v, e = node_update(np.array(vn), np.array(en), p, e_max, h)
    kinds = set()
    for k in range(len(vn)):
        mean = sum(_exact(a, b, p) for a, b in zip(vn[k], en[k])) / 4
        y = _exact(v[k], e[k], p)
        assert 0 <= e[k] <= e_max
        assert y <= mean, (vn[k], en[k])
        if mean == 0:
            assert v[k] == 0 and e[k] == e_max
            kinds.add("zero")
        elif e[k] == e_max and v[k] < (1 << (p - h)):
            assert mean - y < Fraction(2, 1 << (p + e_max))    # denormal: within the last unit (and the alignment's)
            kinds.add("denormal")
        else:
            assert (1 << (p - h)) <= v[k] and (v[k] < (1 << (p + 1 - h)) or e[k] == 0 and v[k] <= (1 << p))
            assert mean - y < Fraction(2, 1 << (p + int(e[k]))), (vn[k], en[k], v[k], e[k])
            kinds.add("normal")
            if max(en[k]) - min(en[k]) > p + GUARD + 2:
                kinds.add("wide gap")
    assert kinds == {"zero", "denormal", "normal", "wide gap"}, kinds


def test_order_key_is_the_value_order(rng):
    p, h, e_max = 12, 2, 50
    words = [format_word(rng, p, h, e_max) for _ in range(400)]
    v, e = np.array(words).T
    key = order_key(v, e, p, e_max)
    exact = [_exact(a, b, p) for a, b in words]
    for i in range(len(words)):
        for j in range(i):
            assert (key[i] < key[j]) == (exact[i] < exact[j]) and (key[i] == key[j]) == (exact[i] == exact[j])


@pytest.mark.parametrize("p", [8, 16, 24])
def test_fixed_point_against_float64(p):
    ob, goals = _maze(64)
    reach = reachable(ob, goals)
    goal = np.zeros(ob.shape, dtype=bool)
    goal[goals[0]] = True
    free, _, x, _ = dirichlet(goal.astype(float), ob | ~reach | goal)
    res = plan_node_exponents(ob, goals, p=p, until_fixed=True)
    assert res.fixed_point and res.converged
    y = np.array([float(_exact(res.mantissa[r, c], res.exponents[r, c], p)) for r, c in free])
    d = distances(ob, goals)[tuple(free.T)]
    rel = (x - y) / x
    eps = 2.0 ** (2 - (p + 1 - res.headroom))
    assert rel.min() >= -1e-12                   # float64's own rounding of x
    assert (rel <= eps * d).all(), (rel / d).max() / eps
    assert rel.max() > eps                       # the error is there: the bound is not vacuous


def test_where_float64_and_block_exponents_fail():
    ob, goals = _maze(128)
    reach = reachable(ob, goals)
    res = plan_node_exponents(ob, goals)
    # The wave needs one iteration a step, and the exponents span the field: e_hi near 2 x 1,920.
    assert res.converged and res.iterations >= 1920 and res.e_hi > 3000
    assert res.e_hi <= res.e_max == 2 * 1920 and res.exponent_bits == 12
    assert ascent_reaches(res.key, goals, reach).sum() == reach.sum() == 4927
    goal = np.zeros(ob.shape, dtype=bool)
    goal[goals[0]] = True
    starts = [tuple(c) for c in np.argwhere(reach)]
    paths = decision_paths(res.mantissa, res.exponents, (1, 1), res.p, goal, starts)
    assert sum(ok for _, ok in paths) == len(starts)


def test_a_corridor_a_fixed_point_loses():
    ob, goals = straight(3, 80)            # 79 cells of corridor: 4**-79 is below a 64-bit fixed point's LSB
    res = plan_node_exponents(ob, goals, p=10)
    reach = reachable(ob, goals)
    assert res.converged and res.zeros == 0 and res.e_hi > 64
    assert ascent_reaches(res.key, goals, reach).sum() == reach.sum()


def test_unconverged_when_stopped_early():
    ob, goals = _maze(64)
    res = plan_node_exponents(ob, goals, max_iter=100)       # the wave is 236 steps long
    assert not res.converged and res.zeros > 0 and res.iterations == 100


@pytest.mark.parametrize("kw,match", [(dict(p=2), "p = 2"), (dict(p=60), "p = 60"), (dict(headroom=20), "headroom"),
                                      (dict(e_max=0), "e_max = 0"), (dict(p=40, e_max=1 << 30), "e_max")])
def test_refusals(kw, match):
    ob, goals = straight(3, 8)
    with pytest.raises(ValueError, match=match):
        plan_node_exponents(ob, goals, **kw)


def test_red_black_reaches_the_same_fixed_point_in_half_the_iterations():
    """The in-place order (even cells, then odd ones from their new values):
    a front moves two steps an iteration in reading order, so the 64x64 crop
    converges in about half of Jacobi's 236 iterations, and both end on the
    same fixed point of the rounded update (the one reached from below)."""
    ob, goals = _maze(64)
    jac = plan_node_exponents(ob, goals, until_fixed=True)
    rb = plan_node_exponents(ob, goals, until_fixed=True, order="red-black")
    assert jac.fixed_point and rb.fixed_point and rb.converged
    assert (rb.mantissa == jac.mantissa).all() and (rb.exponents == jac.exponents).all()
    conv = plan_node_exponents(ob, goals, order="red-black")
    assert conv.converged and 118 <= conv.iterations <= 130 and rb.iterations < jac.iterations
    with pytest.raises(ValueError, match="order"):
        plan_node_exponents(ob, goals, order="gauss")
