# amaranth: UnusedElaboratable=no
"""The Planner's block-exponent option (``Planner(..., block_exponents=True)``)
against ``models.harmonic.plan(..., block_exponents=True, rtl=True)``, bit-exact.

One build per simulator: 3x3 blocks of 3x6 nodes (B = 9, every border
kind), p_max 14.  One cocotb test runs three small maps (two random maps
whose exponents move and saturate, a corridor) one after the other through
the host streams: LOAD, START, STATUS to the end, READ every node (the
mantissa, the flag and the block's exponent): every mantissa, flag and e_b,
the final p, converged, sweeps, block iterations, check iterations and the
cycle count equal the model's.  It asserts that the runs exercised what
they claim: re-picks (some e_b > 0), a precision rise with a saturated
block (coarsening), and both converged and not-converged runs.
"""

import json
import os

import cocotb
import numpy as np
import pytest

from models.harmonic import plan
from tb.harmonic.planner_bench import Code, Op, PlannerBench, arithmetic, exponent_params
from tb.harmonic.planner_maps import MAPS
from tb.harmonic.serial import start
from tb.runner import SIMULATORS, run

PARAMS = dict(n=3, m=6, br=3, bc=3, p_max=14, depth=256)
# (map, seed, schedule, I)
RUNS = [("random", 1, (6, 10, 14), 3), ("random", 3, (6, 10, 14), 3),
        ("corridor", 0, (4, 8, 12), 2)]
ONLY = os.environ.get("PLANNER_EXP_ONLY")


def _model(name, seed, sched, iters):
    ob, goals = MAPS[name](9, 18, seed)
    res = plan(ob, goals, block=(3, 6), iters=iters, schedule=sched, block_exponents=True, rtl=True)
    return ob, goals, res


@cocotb.test()
async def planner_exponents_against_model(dut):
    P = PARAMS
    await start(dut)
    bench = PlannerBench(dut, P["n"], P["m"], (P["br"], P["bc"]), P["p_max"], exponents=True)
    seen = {"repick": 0, "coarsen": 0, "converged": 0, "not_converged": 0, "nodes": 0}
    runs = [RUNS[int(i)] for i in ONLY.split(",")] if ONLY else RUNS
    for name, seed, sched, iters in runs:
        ob, goals, res = _model(name, seed, sched, iters)
        goal = np.zeros(ob.shape, dtype=bool)
        for r, c in goals:
            goal[r, c] = True
        await bench.load_map(ob | res.unreachable, goal)
        p1, step, p_last = arithmetic(sched)
        resp = await bench.command(Op.START, p1=p1, step=step, p_last=p_last, iters=iters)
        assert resp["code"] == Code.OK, resp["code"]
        st = await bench.wait_idle()
        h, const = await bench.read_all(ob.shape)
        tag = f"{name} seed {seed} schedule {sched} I={iters}"
        got = {k: int(st[k]) for k in ("p", "converged", "sweeps", "block_iterations", "check_iterations",
                                       "cycles")}
        want = {"p": res.p, "converged": int(res.converged), "sweeps": res.sweeps,
                "block_iterations": res.block_iterations, "check_iterations": res.check_iterations,
                "cycles": res.cycles}
        dut._log.info(f"{tag}: RTL {got} exponents {bench.block_exponents.tolist()}")
        dut._log.info(f"{tag}: model {want} exponents {res.exponents.tolist()}")
        assert bench.block_exponents.tolist() == res.exponents.tolist(), (
            f"{tag}: exponents RTL {bench.block_exponents.tolist()} model {res.exponents.tolist()}")
        bad = np.argwhere((h != res.mantissa) | (const != res.padded_const))
        assert not len(bad), (f"{tag}: {len(bad)} nodes differ, first {tuple(bad[0])}\nRTL\n{h}\n"
                              f"model\n{res.mantissa}")
        assert got == want, f"{tag}: RTL {got} model {want}"
        seen["nodes"] += h.size
        seen["repick"] += int(res.exponents.max() > 0)
        seen["coarsen"] += int(any(lv["saturated"] for lv in res.levels[:-1]))
        seen["converged" if res.converged else "not_converged"] += 1
    dut._log.info(f"compared: {seen}")
    if not ONLY:
        assert all(seen[k] for k in seen), seen


@pytest.mark.parametrize("sim", SIMULATORS)
def test_planner_exponents(sim):
    run("harmonic_planner", exponent_params(PARAMS), sim, "test_planner_exponents")


def test_exponent_option_is_checked_and_default_off():
    from hdl.harmonic.planner import Planner, response_layout
    with pytest.raises(ValueError, match="block_exponents=2: must be True or False"):
        Planner(3, 6, (3, 3), 14, 256, block_exponents=2)
    assert "exponent" not in dict(response_layout(14)) and "exponent" in dict(response_layout(14, exponents=True))
    assert not Planner(3, 6, (3, 3), 14, 256).exponents
