"""The Planner's block-exponent option (``Planner(..., block_exponents=True)``)
against ``models.harmonic.plan(..., block_exponents=True, rtl=True)``, bit-exact.

Two builds per simulator, 3x3 blocks of 3x6 nodes (B = 9, every border
kind), p_max 14.  ``default`` (e_max 255, headroom 1, the model's
defaults): one cocotb test runs four small runs (two random maps whose
exponents move and saturate, a corridor, the first random map again with
an obstacle and a goal ordered during the run) one after the other through the
host streams: LOAD, START, STATUS to the end, READ every node (the
mantissa, the flag and the block's exponent): every mantissa, flag and e_b,
the final p, converged, sweeps, block iterations, check iterations and the
cycle count equal the model's.  Then DIRECTION at every node whose
neighbours lie in a block with another exponent, and at the map's corners:
triangle, gradient, value and exponent equal
``models.harmonic.decision_exponents``.  It asserts that the runs exercised
what they claim: re-picks (some e_b > 0), a precision rise with a saturated
block (coarsening), both converged and not-converged runs, dynamic orders
(SET during the run, taken in the pass meant: their clear passes restart
the exponents), and DIRECTIONs whose neighbours were shifted left, right
and clamped.  ``bounded`` (the
Planner's e_max = 10 and headroom = 0): one random map on which exponents
stop at e_max, against the model with the same bounds.
``underflow`` (issue 22: 1x8 blocks, p_max 16, e_max from the map,
exponent_bound: 94): a straight corridor of 48 cells whose field a 64-bit
fixed point loses after 33 cells (the fixed-point words at p = 62 are 0
there: test_corridor_underflows_fixed_point) converges at p = 16, bit for
bit with the model.  ``wide`` (PLANNER_EXP_WIDE=1 only: 1x26 blocks, its
Verilator build took 12 minutes on this machine): the same corridor, 156
cells, e_max 310 (9-bit exponent registers), exponents above 255.
PLANNER_EXP_ONLY=0,2 runs only those maps of the default set.  The host
streams run with random idle cycles before each command and random
back-pressure on the responses (seeded: SEED= replays): the counters and
cycles still equal the model's.
"""

import os
import random

import cocotb
import numpy as np
import pytest

from navcores.models.harmonic import convert_mantissa, decision_exponents, exponent_bound, plan
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.planner_driver import Code, Op, PlannerDriver, arithmetic, exponent_params
from navcores.sim.rtl.planner_job import run_map
from navcores.sim.rtl.runner import SIMULATORS, run
from tb.harmonic.planner_maps import MAPS

PARAMS = dict(n=3, m=6, br=3, bc=3, p_max=14, depth=256)
GEOMETRY = ("br", "bc", "p_max", "depth")       # a set's build parameters that are not the model's bounds
STRAIGHT = dict(br=1, bc=8, p_max=16, depth=256)
WIDE = dict(br=1, bc=26, p_max=16, depth=512)


def _straight(geometry):
    """The straight corridor of a 1 x bc build with its e_max from the map."""
    return {**geometry, "e_max": exponent_bound(*MAPS["straight"](3, 6 * geometry["bc"], 0))}


# name: (extra Planner parameters, [(map, seed, schedule, I, orders)], what the runs must exercise)
SETS = {
    "default": ({}, [("random", 1, (6, 10, 14), 3, ()), ("random", 3, (6, 10, 14), 3, ()),
                     ("corridor", 0, (4, 8, 12), 2, ()),
                     ("random", 1, (6, 10, 14), 3, ((19, (4, 14), "obstacle"), (30, (7, 3), "goal")))],
                ("repick", "coarsen", "converged", "not_converged", "left", "right", "clamped", "orders")),
    "bounded": ({"e_max": 10, "headroom": 0}, [("random", 1, (6, 10, 14), 3, ())],
                ("at_e_max", "coarsen", "left", "right")),
    "underflow": (_straight(STRAIGHT), [("straight", 0, (8, 12, 16), 3, ())], ("repick", "converged")),
}
if os.environ.get("PLANNER_EXP_WIDE") == "1":
    SETS["wide"] = (_straight(WIDE), [("straight", 0, (8, 12, 16), 3, ())], ("repick", "converged", "wide"))
ONLY = os.environ.get("PLANNER_EXP_ONLY")
# Icarus runs these runs of a set (indices), Verilator all of them: the
# corridor and the random map with orders still reach every claim of the set
# (asserted below); the other two random runs add values, not kinds.
ICARUS_RUNS = {"default": (2, 3)}


def _model(name, seed, sched, iters, events, bounds, shape=(9, 18)):
    ob, goals = MAPS[name](*shape, seed)
    res = plan(ob, goals, block=(3, 6), iters=iters, schedule=sched, events=events, block_exponents=True,
               rtl=True, **bounds)
    return ob, goals, res


@cocotb.test()
async def planner_exponents_against_model(dut):
    extra, runs, claims = SETS[os.environ["PLANNER_EXP_SET"]]
    P = {**PARAMS, **extra}
    bounds = {k: v for k, v in extra.items() if k not in GEOMETRY}
    await start(dut)
    drv = PlannerDriver(dut, P["n"], P["m"], (P["br"], P["bc"]), P["p_max"], exponents=True,
                        e_max=bounds.get("e_max", 255), rng=random.Random(cocotb.RANDOM_SEED),
                        idle=0.3, back_pressure=0.5)
    seen = dict.fromkeys(("repick", "coarsen", "converged", "not_converged", "at_e_max", "orders", "nodes",
                          "directions", "left", "right", "clamped", "wide"), 0)
    if ONLY and not extra:
        runs = [runs[int(i)] for i in ONLY.split(",")]
    elif os.environ.get("PLANNER_EXP_RUNS"):
        runs = [runs[int(i)] for i in os.environ["PLANNER_EXP_RUNS"].split(",")]
    for name, seed, sched, iters, events in runs:
        ob, goals, res = _model(name, seed, sched, iters, events, bounds, (P["br"] * P["n"], P["bc"] * P["m"]))
        goal = np.zeros(ob.shape, dtype=bool)
        for r, c in goals:
            goal[r, c] = True
        # load, START, each order during its pass (the response proves it), read back
        st, h, const = await run_map(drv, ob | res.unreachable, goal, arithmetic(sched), iters, events)
        tag = f"{name} seed {seed} schedule {sched} I={iters} orders {events}"
        keys = ("p", "converged", "sweeps", "block_iterations", "check_iterations", "clear_passes", "cycles")
        got = {k: int(st[k]) for k in keys}
        want = {k: int(getattr(res, k)) for k in keys}
        dut._log.info(f"{tag}: RTL {got} exponents {drv.block_exponents.tolist()}")
        dut._log.info(f"{tag}: model {want} exponents {res.exponents.tolist()}")
        assert drv.block_exponents.tolist() == res.exponents.tolist(), (
            f"{tag}: exponents RTL {drv.block_exponents.tolist()} model {res.exponents.tolist()}")
        bad = np.argwhere((h != res.mantissa) | (const != res.padded_const))
        assert not len(bad), (f"{tag}: {len(bad)} nodes differ, first {tuple(bad[0])}\nRTL\n{h}\n"
                              f"model\n{res.mantissa}")
        assert got == want, f"{tag}: RTL {got} model {want}"
        seen["nodes"] += h.size
        await _directions(dut, drv, res, tag, seen)
        seen["repick"] += int(res.exponents.max() > 0)
        seen["coarsen"] += int(any(lv["saturated"] for lv in res.levels[:-1]))
        seen["converged" if res.converged else "not_converged"] += 1
        seen["at_e_max"] += int((res.exponents == bounds.get("e_max")).sum())
        seen["orders"] += res.clear_passes
        seen["wide"] += int(res.exponents.max() > 255)       # an exponent an 8-bit register cannot hold
    dut._log.info(f"compared: {seen}; {drv.commands} commands, {drv.cmd.idle} idle cycles, "
                  f"{drv.resp.stalls} response stalls")
    assert drv.cmd.idle > 0 and drv.resp.stalls > 0, "the host streams stalled"
    if not ONLY:
        assert all(seen[k] for k in (*claims, "nodes", "directions")), seen


async def _directions(dut, drv, res, tag, seen):
    """DIRECTION where the exponent conversion matters, against the model."""
    n, m = res.block
    mant, E, p = res.mantissa, res.exponents, res.p
    rows, cols = mant.shape
    cells = {(0, 0), (0, cols - 1), (rows - 1, 0), (rows - 1, cols - 1)}
    for r, c in np.ndindex(rows, cols):
        for rr, cc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
            if 0 <= rr < rows and 0 <= cc < cols and E[rr // n, cc // m] != E[r // n, c // m]:
                cells.add((r, c))
                s = int(E[r // n, c // m] - E[rr // n, cc // m])
                seen["left" if s > 0 else "right"] += 1
                seen["clamped"] += convert_mantissa(int(mant[rr, cc]), s, p)[1]
    for r, c in sorted(cells):
        b, x, y = drv.locate(r, c)
        resp = await drv.command(Op.DIRECTION, block=b, row=x, col=y)
        t, (gr, gc), e = decision_exponents(mant, E, (n, m), p, r, c)
        got = (resp["code"], resp["triangle"], resp["g_row"], resp["g_col"], resp["value"], resp["exponent"])
        want = (Code.OK, t, gr, gc, mant[r, c], e)
        assert got == want, f"{tag}: DIRECTION ({r}, {c}): RTL {got} model {want}"
        seen["directions"] += 1


@pytest.mark.parametrize("sim", SIMULATORS)
@pytest.mark.parametrize("name", SETS)
def test_planner_exponents(sim, name):
    run("harmonic_planner", exponent_params({**PARAMS, **SETS[name][0]}), sim, "test_planner_exponents",
        env={"PLANNER_EXP_SET": name,
             "PLANNER_EXP_RUNS": ",".join(map(str, ICARUS_RUNS.get(name, ()))) if sim == "icarus" else ""})


@pytest.mark.parametrize("geometry,zeros,top", [(STRAIGHT, 10, 64), (WIDE, 100, 256)])
def test_corridor_underflows_fixed_point(geometry, zeros, top):
    """The underflow (and wide) set's map: a 64-bit fixed-point word (p =
    62, the word p+2 bits) holds 0 in the far cells of the straight
    corridor and does not converge; block exponents converge at p = 16 (the
    RTL's p_max), with exponents at least ``top`` (wide: more than an 8-bit
    register holds), within the map's e_max."""
    ob, goals = MAPS["straight"](3, 6 * geometry["bc"], 0)
    fixed = plan(ob, goals, block=(3, 6), iters=3, schedule=(62,))
    assert not fixed.converged and (fixed.h[1] == 0).sum() > zeros, fixed.h[1]
    e_max = _straight(geometry)["e_max"]
    assert e_max == 2 * (6 * geometry["bc"] - 1)
    res = plan(ob, goals, block=(3, 6), iters=3, schedule=(8, 12, 16), block_exponents=True, rtl=True,
               e_max=e_max)
    assert res.converged and res.p <= geometry["p_max"] and top <= res.exponents.max() <= e_max


def test_exponent_option_is_checked_and_default_off():
    from navcores.hdl.harmonic.planner import Planner, response_layout
    from navcores.hdl.params import unelaborated
    with pytest.raises(ValueError, match="block_exponents=2: must be True or False"):
        Planner(3, 6, (3, 3), 14, 256, block_exponents=2)
    with pytest.raises(ValueError, match="headroom=15: leaves no mantissa bit at p_max=14"):
        Planner(3, 6, (3, 3), 14, 256, block_exponents=True, headroom=15)
    unelaborated(Planner(3, 6, (3, 3), 14, 256, block_exponents=True, headroom=14))     # the bound itself
    assert "exponent" not in dict(response_layout(14)) and "exponent" in dict(response_layout(14, exponents=True))
    assert not unelaborated(Planner(3, 6, (3, 3), 14, 256)).exponents
