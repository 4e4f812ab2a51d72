"""The golden model itself, against independent references.

Error bound tested: the floored relaxation's fixed point ``x`` (in units of
1.0) satisfies ``x = Hx + C - e`` with ``0 <= e < 3/4 * 2**-p`` per free node
(the floor drops at most 3/4 of an ulp of a sum of integers divided by 4), so
with the exact Dirichlet solution ``x* = Hx* + C``:

    0 <= x* - x <= (3/4) 2**-p (I - H)^-1 1       componentwise,

where ``(I - H)^-1 1`` is itself one sparse solve.  Both sides are checked
against scipy's sparse solve (float64, so a 1e-12 slack), and exactly, with
rational arithmetic, on the paper's corridor at p = 256.
"""

from fractions import Fraction

import numpy as np
import pytest

from dirichlet import dirichlet
from navcores.models.harmonic import (
    from_ram_image, local_max, neighbours, one, ram_image, relax, step, word_bits,
)


def _grid(rows, cols, seed, density=0.2, goals=1):
    """Random obstacles and goals: (goal mask, constant mask)."""
    rng = np.random.default_rng(seed)
    const = rng.random((rows, cols)) < density
    goal = np.zeros((rows, cols), dtype=bool)
    goal.flat[rng.choice(np.flatnonzero(~const), size=goals, replace=False)] = True
    return goal, const | goal


def _initial(goal, p):
    """All-zero free space, goals at 1.0."""
    return np.where(goal, np.full(goal.shape, one(p), dtype=object), np.zeros(goal.shape, dtype=object))


def _corridor(length, p):
    """Paper section 3.2.2: a 1xL corridor, obstacle left, goal right."""
    goal = np.zeros((1, length + 1), dtype=bool)
    goal[0, length] = True
    const = goal.copy()
    const[0, 0] = True
    return _initial(goal, p), const


@pytest.mark.parametrize("p", [12, 20, 32])
@pytest.mark.parametrize("shape,seed,goals", [((6, 9), 1, 1), ((10, 10), 2, 2), ((3, 17), 3, 1)])
def test_fixed_point_within_truncation_bound(shape, seed, goals, p):
    goal, const = _grid(*shape, seed, goals=goals)
    h, iterations = relax(_initial(goal, p), const, p)
    free, _, exact, resolvent = dirichlet(goal, const)
    x = np.array([h[r, c] for r, c in free], dtype=float) / one(p)
    bound = 0.75 * 2.0 ** -p * resolvent
    gap = exact - x
    assert (gap >= -1e-12).all(), f"model above the exact solution by {-gap.min():.3g}"
    assert (gap <= bound + 1e-12).all(), f"gap {gap.max():.3g} > bound {bound[gap.argmax()]:.3g}"
    # The bound is not vacuous: it is far below the values themselves.
    assert bound.max() < 1e-2
    assert iterations > 1


def test_corridor_p256_exact():
    """The corridor's values near the obstacle need O(L) bits (section 3.2.2).
    Exact rationals, no float."""
    length, p = 24, 256
    h, _ = relax(*_corridor(length, p), p)
    assert all(isinstance(v, int) for v in h.ravel())
    # Exact solution of x_i = (x_{i-1} + x_{i+1}) / 4, x_0 = 0, x_L = 1, and
    # y = (I - H)^-1 1, i.e. y_i = 1 + (y_{i-1} + y_{i+1}) / 4, y_0 = y_L = 0:
    # both by the Thomas algorithm in rationals.
    def solve(rhs, right):
        n = length - 1
        cp, dp = [Fraction(0)] * n, [Fraction(0)] * n
        for i in range(n):
            d = rhs + (right if i == n - 1 else 0)
            denom = 1 - (Fraction(-1, 4) * cp[i - 1] if i else 0)
            cp[i] = Fraction(-1, 4) / denom
            dp[i] = (d - (Fraction(-1, 4) * dp[i - 1] if i else 0)) / denom
        x = [Fraction(0)] * n
        for i in reversed(range(n)):
            x[i] = dp[i] - (cp[i] * x[i + 1] if i < n - 1 else 0)
        return x
    exact = solve(Fraction(0), Fraction(1, 4))
    resolvent = solve(Fraction(1), Fraction(0))
    for i in range(1, length):
        gap = exact[i - 1] - Fraction(h[0, i], one(p))
        assert 0 <= gap <= Fraction(3, 4) * resolvent[i - 1] / one(p), i
    assert h[0, 1] > 0, "the node next to the obstacle must be resolved at p=256"


def test_corridor_needs_precision():
    """At p=16 the same corridor has a plateau of zeros: local maxima remain."""
    h0, const = _corridor(24, 16)
    h, _ = relax(h0, const, 16)
    assert h[0, 1] == 0 and local_max(h, const, neighbours(h)).any()
    h0, const = _corridor(24, 96)
    h, _ = relax(h0, const, 96)
    assert not local_max(h, const, neighbours(h)).any()


def test_from_below_stable_from_above_may_oscillate():
    """Section 4.3.1: truncation can make Jacobi cycle; from 0 it cannot."""
    p = 4
    ring = np.array([[0, 16, 0, 16], [16, 0, 0, 16], [0, 0, 6, 11]], dtype=object)
    const = np.zeros((1, 2), dtype=bool)
    h = np.array([[10, 7]], dtype=object)
    h1, _, st1, _ = step(h, const, p, neighbours(h, ring))
    h2, _, st2, _ = step(h1, const, p, neighbours(h1, ring))
    assert h1.tolist() == [[9, 8]] and h2.tolist() == [[10, 7]] and not st1.any() and not st2.any()
    fixed, _ = relax(np.zeros((1, 2), dtype=object), const, p, ring)
    assert fixed.tolist() == [[9, 7]]
    with pytest.raises(RuntimeError, match="not stable"):
        relax(h, const, p, ring, max_iter=50)


def test_update_is_floor_of_quarter_sum():
    p = 4
    nbrs = tuple(np.array([[v]], dtype=object) for v in (16, 16, 16, 15))
    h, c, st, _ = step(np.array([[0]], dtype=object), np.array([[False]]), p, nbrs)
    assert h[0, 0] == 15 and not st[0, 0]          # floor(63 / 4)
    nbrs = tuple(np.array([[16]], dtype=object) for _ in range(4))
    h, *_ = step(np.array([[0]], dtype=object), np.array([[False]]), p, nbrs)
    assert h[0, 0] == 16                            # four goals give exactly 1.0


def test_sel_sat_and_check_iterations():
    p = 8
    h = np.array([[10, 20, 30]], dtype=object)
    const = np.zeros((1, 3), dtype=bool)
    sel = np.array([[False, True, False]])
    h1, c1, st, mx = step(h, const, p, neighbours(h), sel=sel, sat=1)
    assert h1[0, 1] == one(p) and c1[0, 1] and not st[0, 1]
    # Jacobi: the others saw the old value 20, not the new goal.
    assert h1[0, 0] == (20 + 0) >> 2 and h1[0, 2] == (20 + 0) >> 2
    assert not mx[0, 1], "a node saturated in this iteration counts as constant"
    # A check iteration changes nothing and reports every node stable.
    h2, c2, st2, mx2 = step(h1, c1, p, neighbours(h1), enable=False, sel=~sel, sat=0)
    assert (h2 == h1).all() and (c2 == c1).all() and st2.all()
    assert mx2.tolist() == [[False, False, False]]
    # A constant node keeps its value, and an obstacle can be set on a goal.
    h3, c3, st3, _ = step(h1, c1, p, neighbours(h1), sel=sel, sat=0)
    assert h3[0, 1] == 0 and c3[0, 1] and not st3[0, 1]


def test_local_max_plateaus_count():
    h = np.zeros((3, 4), dtype=object)
    const = np.zeros((3, 4), dtype=bool)
    const[0, 0] = True
    mx = local_max(h, const, neighbours(h))
    assert mx.sum() == 11 and not mx[0, 0]
    h[1, 1] = 5
    mx = local_max(h, const, neighbours(h))
    assert mx[1, 1] and not mx[0, 1] and mx[2, 3]


@pytest.mark.parametrize("p", [2, 7, 64, 300])
def test_ram_image_round_trip(p):
    rng = np.random.default_rng(p)
    h = np.array([int(rng.integers(0, 2**min(p, 62))) << max(0, p - 62) for _ in range(18)], dtype=object)
    h[0], h[1] = one(p), 0
    const = rng.random(18) < 0.3
    words = ram_image(h.reshape(3, 6), const.reshape(3, 6), p)
    assert len(words) == p + 2 and all(0 <= w < 1 << 18 for w in words)
    back = from_ram_image(words, p, (3, 6))
    assert (back[0].ravel() == h).all() and (back[1].ravel() == const).all()
    assert word_bits(one(p), True, p)[:3] == [1, 1, 0]
    with pytest.raises(ValueError, match="outside"):
        word_bits(one(p) + 1, False, p)


def test_neighbours_ring_shape_checked():
    with pytest.raises(ValueError, match="ring must be"):
        neighbours(np.zeros((3, 6), dtype=object), ring=np.zeros((3, 6), dtype=object))
