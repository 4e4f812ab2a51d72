"""Block exponents (issue 10): models.harmonic.plan(..., block_exponents=True).

* e_max = 0 (every exponent pinned at 0) is plan() exactly: values, p,
  sweeps, iterations, check iterations, cycles.
* Termination and the invariant behind it, on random maps with several
  blocks, I, headrooms, re-pick modes and small exponent bounds: every run
  ends; the exact values (mantissa / 2**(p+e_b)) never fall from one event to
  the next; 0 <= e_b <= e_max; goal blocks keep e = 0; within a precision
  level e_b only rises; p + e_b never falls.
* The end of a level is a fixed point of the update with conversions,
  recomputed independently with exact fractions (floor, clamp) node by node.
* Every value stays below scipy's sparse Dirichlet solve (the sub-solution
  claim of the termination argument).
* Cycles: each event's cycle increment follows the timing model (visits,
  check passes, shift visits of re-picks).
* On random-32-32-10, p = 16 (a level at which the fixed-point planner still
  has local maxima) converges with exponents, exact-value local maxima are
  0, and the ascent reaches the goal from every reachable cell.
* The exponent-aware Decision (decision_exponents) on converged fields,
  against exact fractions: each gradient component within one unit of the
  exact plane's (unless a neighbour clamps), a triangle other than the
  exact Decision's only within the score slack that bound allows, and it
  agrees with the exact Decision far more often than the raw mantissas do
  where exponents differ (the negative control: Decision before the option).
* Dynamic orders with exponents: an order's clear pass also restarts every
  e_b, so the run after it equals a fresh run on the changed map from the
  current precision (values, exponents, p, converged), and its cycles are
  those up to the clear pass plus the fresh run's; an order while idle
  (pass 0) is the map with that goal.
* convert_mantissa and the option checks.
"""

from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from dirichlet import dirichlet
from harmonic_small_maps import corridor, spiral
from planner_maps import random_map
from navcores.models.harmonic import (
    RUN_OVERHEAD, TRIANGLES, VISIT_OVERHEAD, ascent_reaches, convert_mantissa, decision, decision_exponents,
    local_max, plan, reachable, visit_cycles,
)

ROOT = Path(__file__).resolve().parents[2]


def _random_map(rows, cols, seed):
    return random_map(rows, cols, seed, density=0.2)


def _exact(mant, E, p, n, m):
    """Exact values (Fractions) of a padded mantissa array."""
    out = np.empty(mant.shape, dtype=object)
    for (r, c), v in np.ndenumerate(mant):
        out[r, c] = Fraction(int(v), 1 << (p + int(E[r // n, c // m])))
    return out


def _scaled(mant, E, p, n, m, F):
    """Exact values times 2**F (F >= every p + e_b): integers, comparable."""
    shift = np.repeat(np.repeat(F - p - np.asarray(E, dtype=object), n, axis=0), m, axis=1)
    return np.array(mant, dtype=object) << shift


def _fixed_point_violations(res, p):
    """Nodes whose mantissa differs from the update of their neighbours, each
    neighbour's exact value floored into the node's units and clamped at the
    word's top: an independent restatement of the conversion rule."""
    n, m = res.block
    mant, E, const = res.mantissa, res.exponents, res.padded_const
    val = _exact(mant, E, p, n, m)
    rows, cols = mant.shape
    cap = (1 << (p + 1)) - 1
    bad = checked = 0
    for r in range(rows):
        for c in range(cols):
            if const[r, c]:
                continue
            unit = 1 << (p + int(E[r // n, c // m]))
            total = 0
            for rr, cc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
                if 0 <= rr < rows and 0 <= cc < cols:
                    q = val[rr, cc] * unit
                    total += min(q.numerator // q.denominator, cap)
            checked += 1
            bad += (total >> 2) != int(mant[r, c])
    return bad, checked


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_pinned_exponents_are_plan(seed):
    ob, goals = _random_map(11, 17, seed)
    for block, iters, sched in (((3, 6), 3, (6, 12, 24, 48)), ((4, 4), 2, (8, 16, 32))):
        ref = plan(ob, goals, block=block, iters=iters, schedule=sched)
        res = plan(ob, goals, block=block, iters=iters, schedule=sched, block_exponents=True, e_max=0)
        assert (res.h == ref.h).all() and (res.padded_h == ref.padded_h).all()
        for k in ("p", "converged", "maxima", "sweeps", "block_iterations", "check_iterations", "cycles",
                  "node_updates"):
            assert getattr(res, k) == getattr(ref, k), k
        assert [lv["block_iterations"] for lv in res.levels] == [lv["block_iterations"] for lv in ref.levels]
        assert res.frac_bits == res.p and not res.exponents.any() and res.repicks == 0


CASES = [
    # (map, block, iters, schedule, options)
    ("random", (3, 6), 3, (6, 10, 14), dict()),
    ("random", (4, 4), 2, (4, 8, 12, 16), dict(headroom=0)),
    ("random", (3, 3), 4, (5, 9), dict(headroom=2, repick="check")),
    ("random", (4, 5), 1, (6, 12), dict(e_max=4)),
    ("corridor", (3, 4), 3, (6, 12, 18), dict()),
    ("spiral", (4, 4), 2, (6, 10, 14, 18), dict(e_max=7)),
    ("random", (3, 6), 2, (6, 10, 14), dict(repick="stable", ceiling=True)),
]


def _case_map(kind, seed):
    if kind == "corridor":
        return corridor(22)
    if kind == "spiral":
        return spiral(11)
    return _random_map(12, 15, seed)


@pytest.mark.parametrize("case", range(len(CASES)))
def test_termination_invariant(case):
    kind, block, iters, sched, opts = CASES[case]
    ob, goals = _case_map(kind, 10 + case)
    trace = []
    res = plan(ob, goals, block=block, iters=iters, schedule=sched, block_exponents=True, trace=trace, **opts)
    n, m = block
    e_max = opts.get("e_max", 255)
    goal_blocks = {(r // n, c // m) for r, c in goals}
    prev = None
    compared = levels_seen = coarsened = 0
    F = max(p + int(E.max()) for _, p, E, _, _ in trace)
    for event, p, E, mant, _ in trace:
        assert E.min() >= 0 and E.max() <= e_max
        for b in goal_blocks:
            assert E[b] == 0
        val = _scaled(mant, E, p, n, m, F)
        if prev is not None:
            _, pp, pE, pval = prev
            if event == "raise":
                coarsened += int((E < pE).sum())
            assert (val >= pval).all(), f"a value fell at {event}"
            assert ((p + E) >= (pp + pE)).all(), "a block lost resolution"
            if event != "raise":
                assert p == pp and (E >= pE).all(), "an exponent fell within a level"
            else:
                levels_seen += 1
            compared += val.size
        prev = (event, p, E, val)
    assert compared > 0 and levels_seen > 0 and trace[-1][0] == "check"     # across a precision rise too
    # the run ended at a fixed point of the update with conversions
    bad, checked = _fixed_point_violations(res, res.p)
    assert bad == 0 and checked > 0
    # the exponents were exercised: re-picks in every case, and a saturated
    # block's exponent lowered at a precision rise in these cases
    assert res.repicks > 0 and res.exponents.max() > 0
    assert (coarsened > 0) == (case in (0, 1, 3, 6)), coarsened
    if "e_max" in opts:
        assert res.exponents.max() <= opts["e_max"]


def test_below_dirichlet_solution():
    """Sub-solution: every exact value is at most the exact harmonic solution."""
    for seed in (4, 5):
        ob, goals = _random_map(12, 18, seed)
        res = plan(ob, goals, block=(3, 6), iters=3, schedule=(8, 16, 24), block_exponents=True)
        goal = np.zeros(ob.shape, dtype=bool)
        goal[tuple(np.array(goals).T)] = True
        free, _, x, _ = dirichlet(goal, res.const)
        unit = 1 << res.frac_bits
        got = np.array([int(res.h[r, c]) / unit for r, c in free])
        assert (got <= x * (1 + 1e-9) + 1e-300).all()
        assert (got > 0).sum() == len(free) - int((~reachable(ob, goals) & ~ob).sum())


def test_cycles_follow_timing_model():
    ob, goals = _random_map(12, 15, 7)
    trace = []
    iters = 3
    res = plan(ob, goals, block=(3, 5), iters=iters, schedule=(6, 10, 14), block_exponents=True,
               trace=trace)
    B = res.blocks[0] * res.blocks[1]
    counted = {"visit": 0, "repick": 0, "check": 0, "raise": 0}
    for (_, _, pE, _, pc), (event, p, E, _, c) in zip(trace, trace[1:]):
        delta = c - pc
        moved = int((E != pE).sum())
        if event == "visit":
            k, rem = divmod(delta - VISIT_OVERHEAD, p + 2)
            assert rem == 0 and 1 <= k <= iters
        elif event in ("repick", "raise"):
            assert delta == moved * visit_cycles(1, p)
            assert event == "raise" or moved > 0
        else:
            assert delta == B * visit_cycles(1, p)
        counted[event] += 1
    assert trace[-1][4] == res.cycles
    assert counted["visit"] > 0 and counted["check"] > 0 and counted["repick"] > 0


def test_exponents_converge_where_fixed_point_cannot():
    from navcores.models.maps import load_map
    ob = load_map(ROOT / "maps" / "random-32-32-10.map")
    goals = [(29, 6)]                                    # the longest scenario's goal
    fixed = plan(ob, goals, schedule=(16,))
    assert not fixed.converged and fixed.maxima > 0
    res = plan(ob, goals, schedule=(16,), block_exponents=True)
    assert res.converged and res.p == 16 and res.exponents.max() > 0
    assert res.exponents[4, 0] == 0                      # the goal's block (6x12 blocks)
    h = np.array(res.padded_h, dtype=object)
    pad = np.zeros((h.shape[0] + 2, h.shape[1] + 2), dtype=object)
    pad[1:-1, 1:-1] = h
    nb = (pad[:-2, 1:-1], pad[1:-1, 2:], pad[1:-1, :-2], pad[2:, 1:-1])
    assert local_max(h, res.padded_const, nb).sum() == 0
    reach = reachable(ob, goals)
    cells = reach & ~ob
    ok = ascent_reaches(res.h, goals, cells)
    assert ok[cells].all() and cells.sum() > 500
    assert res.potential().max() == 1.0


def test_convert_mantissa():
    p = 6                                    # top = 127
    assert convert_mantissa(0b1011011, -3, p) == (0b1011, False)
    assert convert_mantissa(5, 0, p) == (5, False)
    assert convert_mantissa(5, 4, p) == (80, False)
    assert convert_mantissa(5, 5, p) == (127, True)
    assert convert_mantissa(0, 40, p) == (0, False)
    assert convert_mantissa(1, 40, p) == (127, True)
    assert convert_mantissa(127, -9, p) == (0, False)
    arr = np.array([0, 1, 3, 8], dtype=np.int64)
    out, clamped = convert_mantissa(arr, 5, p)
    assert list(out) == [0, 32, 96, 127] and clamped and out.dtype == np.int64


def test_option_errors():
    ob, goals = _random_map(6, 6, 1)
    with pytest.raises(ValueError, match="event kind 'wall'"):
        plan(ob, goals, block_exponents=True, events=[(1, (0, 0), "wall")])
    with pytest.raises(ValueError, match="block_exponents=True only"):
        plan(ob, goals, headroom=1)
    with pytest.raises(ValueError, match="repick"):
        plan(ob, goals, block_exponents=True, repick="never")
    with pytest.raises(ValueError, match="headroom=-1"):
        plan(ob, goals, block_exponents=True, headroom=-1)
    with pytest.raises(ValueError, match="e_max=-2"):
        plan(ob, goals, block_exponents=True, e_max=-2)


def test_rtl_variant_conservative_maxima():
    """rtl=True (the planner RTL's variant): converted-Maximum convergence
    implies no exact local maximum on the common scale; the check pass never
    re-picks (asserted inside); scans cost cycles only where exponents differ."""
    from navcores.models.harmonic import local_max
    from tb.harmonic.planner_maps import random_map
    converged = 0
    for seed in range(6):
        ob, goals = random_map(9, 18, seed)
        res = plan(ob, goals, block=(3, 6), iters=3, schedule=(6, 10, 14), block_exponents=True, rtl=True)
        ref = plan(ob, goals, block=(3, 6), iters=3, schedule=(6, 10, 14), block_exponents=True)
        assert res.cycles >= ref.cycles
        if res.converged:
            converged += 1
            h = res.padded_h
            pad = np.zeros((h.shape[0] + 2, h.shape[1] + 2), dtype=object)
            pad[1:-1, 1:-1] = h
            nb = (pad[:-2, 1:-1], pad[1:-1, 2:], pad[1:-1, :-2], pad[2:, 1:-1])
            assert not local_max(h, res.padded_const, nb).any()
    assert converged >= 2
    with pytest.raises(ValueError, match="rtl=True"):
        plan(ob, goals, block_exponents=True, rtl=True, repick="stable")


def _decision_fields():
    """Converged block-exponent fields (the RTL's variant): small random
    maps with 3x6 blocks and random-32-32-10 at p = 16 with 6x12 blocks."""
    from navcores.models.maps import load_map
    for seed in range(4):
        ob, goals = random_map(9, 18, seed)
        yield plan(ob, goals, block=(3, 6), iters=3, schedule=(6, 10, 14), block_exponents=True, rtl=True)
    ob = load_map(ROOT / "maps" / "random-32-32-10.map")
    yield plan(ob, [(29, 6)], schedule=(16,), block_exponents=True, rtl=True)


def test_decision_exponents_against_exact():
    seen = {"nodes": 0, "mixed": 0, "aware": 0, "raw": 0, "other_triangle": 0, "clamped": 0}
    for res in _decision_fields():
        n, m = res.block
        p, E, mant = res.p, res.exponents, res.mantissa
        F = p + int(E.max())
        X = _scaled(mant, E, p, n, m, F)                 # exact values, times 2**F
        cap = (1 << (p + 1)) - 1
        for r, c in np.argwhere(~res.padded_const):
            t, (g_row, g_col), e = decision_exponents(mant, E, (n, m), p, r, c)
            assert e == E[r // n, c // m]
            k = F - p - e                                # exact, in the centre's units: X / 2**k
            h = Fraction(int(X[r, c]), 1 << k)
            assert h == mant[r, c]
            x = {}
            for d, (dr, dc) in {"N": (-1, 0), "E": (0, 1), "S": (1, 0), "W": (0, -1)}.items():
                rr, cc = r + dr, c + dc
                inside = 0 <= rr < mant.shape[0] and 0 <= cc < mant.shape[1]
                x[d] = Fraction(int(X[rr, cc]), 1 << k) if inside else Fraction(0)
            clamp = any(v > cap for v in x.values())
            te, _ = decision(X, r, c)

            def exact(tri):
                a, b = TRIANGLES[tri]
                return ((x["S"] - h) if "S" in (a, b) else (h - x["N"]),
                        (x["E"] - h) if "E" in (a, b) else (h - x["W"]))

            def score(tri):
                a, b = TRIANGLES[tri]
                return (h - x[a]) ** 2 + (h - x[b]) ** 2

            if not clamp:
                er, ec = exact(t)
                pair = TRIANGLES[t]
                # v' <= x < v' + 1: an "x - h" component is above, an "h - x" one below
                for got, want, up in ((g_row, er, "S" in pair), (g_col, ec, "E" in pair)):
                    assert (0 <= want - got < 1) if up else (-1 < want - got <= 0), (r, c, got, want)
                if te != t:
                    # only as close as the one-unit errors allow: |a^2 - a'^2| < 2|a| + 1
                    slack = sum(2 * abs(v) + 1 for tri in (t, te) for v in exact(tri))
                    assert score(te) - score(t) < slack, (r, c, t, te)
                    seen["other_triangle"] += 1
            seen["nodes"] += 1
            seen["clamped"] += clamp
            nbe = {E[rr // n, cc // m] for rr, cc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1))
                   if 0 <= rr < mant.shape[0] and 0 <= cc < mant.shape[1]}
            if nbe != {e}:
                seen["mixed"] += 1
                seen["aware"] += t == te
                seen["raw"] += decision(mant, r, c)[0] == te
    print(seen)
    assert seen["mixed"] >= 300
    assert seen["aware"] >= 0.9 * seen["mixed"] and seen["raw"] <= 0.8 * seen["mixed"], seen


@pytest.mark.parametrize("rtl", [False, True])
def test_orders_restart_exponents(rtl):
    ob, goals = random_map(9, 18, 1)
    kw = dict(block=(3, 6), iters=3, block_exponents=True, rtl=rtl)
    sched = (6, 10, 14)
    cell = (4, 14)                       # free; as an obstacle it cuts no cell off
    ob2 = ob.copy()
    ob2[cell] = True
    assert not ob[cell] and cell not in goals
    assert (reachable(ob2, goals) | ob2).sum() == (reachable(ob, goals) | ob).sum()
    raised = 0
    for s in (3, 19, 36):
        trace = []
        res = plan(ob, goals, schedule=sched, events=[(s, cell, "obstacle")], trace=trace, **kw)
        i = next(k for k, t in enumerate(trace) if t[0] == "clear")
        p_at = trace[i][1]
        raised += int(trace[i - 1][2].max() > 0)          # exponents had moved before the order
        assert not trace[i][2].any()                      # ... and restart at 0
        fresh = plan(ob2, goals, schedule=[q for q in sched if q >= p_at], **kw)
        assert (res.mantissa == fresh.mantissa).all() and (res.exponents == fresh.exponents).all()
        assert (res.p, res.converged) == (fresh.p, fresh.converged)
        assert res.cycles == trace[i][4] + fresh.cycles - RUN_OVERHEAD
        assert res.clear_passes == res.events_applied == 1
    assert raised >= 2
    # pass 0: a goal ordered while idle is the map with that goal
    g2 = (7, 3)
    assert not ob[g2] and reachable(ob, goals)[g2]
    res = plan(ob, goals, schedule=sched, events=[(0, g2, "goal")], **kw)
    ref = plan(ob, [*goals, g2], schedule=sched, **kw)
    assert (res.mantissa == ref.mantissa).all() and (res.exponents == ref.exponents).all()
    assert (res.p, res.converged, res.cycles, res.sweeps) == (ref.p, ref.converged, ref.cycles, ref.sweeps)
    assert res.clear_passes == 0 and res.events_applied == 1
