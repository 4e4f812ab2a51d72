# amaranth: UnusedElaboratable=no
"""The node-exponent engine (issue 22) against models.harmonic, bit-exact and cycle-exact.

``NodeExponentEngine(max_h=9, max_w=16, p=12, e_max=255)`` on both simulators,
through the command's driver (sim/rtl/node_engine_driver.py):

* a serpentine corridor of 9x16 whose far end is about 2**-150 below the goal
  (a 64-bit fixed point holds 0 there; the node exponents do not);
* random maps (non-square, a width that is not a power of two, two goals,
  walled-off free cells that stay 0, a map with no obstacle);
* a run cut short by max_iter (not a fixed point);
* a bad command (refused: ``error``, the engine stays idle), then a job;
* a reset in the middle of a sweep, then a job.

Every job: the read-out equals plan_node_exponents(..., order="red-black",
until_fixed=True) word for word, ``iterations`` and ``fixed`` equal the
model's, and ``cycles`` equals engine_cycles(H, W, iterations).  The cells
and commands come with random idle cycles, the read-out with random
back-pressure; the seed is printed (replay with SEED=).  The test counts
what it exercised (a fixed point, a cut-short run, zeros left, exponents
beyond 64 bits, a refusal, a reset, back-pressure stalls) and asserts each.
"""

import os
import random

import cocotb
import numpy as np
import pytest
from cocotb.triggers import ClockCycles, RisingEdge

from planner_maps import corridor, random_map
from navcores.models.harmonic.node_exponents import engine_cycles, plan_node_exponents
from navcores.sim.rtl.node_engine_driver import NodeEngineDriver
from navcores.sim.rtl.runner import SIMULATORS, run, seed_from_env

PARAMS = {"max_h": 9, "max_w": 16, "p": 12, "e_max": 255, "headroom": 2}   # as sim harmonic sizes it: one build


def _maps(rng):
    """[(name, obstacle, goals, max_iter)]."""
    ob, goals = corridor(9, 16)
    out = [("corridor", ob, goals, 1000)]
    ob2, g2 = random_map(7, 10, int(rng.integers(1 << 30)), density=0.3)
    free = np.argwhere(~ob2)
    g2.append(tuple(int(x) for x in free[rng.integers(len(free))]))
    out.append(("random 7x10, two goals", ob2, g2, 1000))
    out.append(("5x2, no obstacle", np.zeros((5, 2), dtype=bool), [(4, 1)], 1000))
    out.append(("corridor cut short", ob, goals, 5))
    ob4, g4 = random_map(9, 13, int(rng.integers(1 << 30)), density=0.45)    # pockets no goal reaches
    out.append(("random 9x13, dense", ob4, g4, 1000))
    return out


async def _job(drv, ob, goals, max_iter, seen):
    H, W = ob.shape
    model = plan_node_exponents(ob, goals, p=PARAMS["p"], e_max=PARAMS["e_max"], order="red-black",
                                until_fixed=True, max_iter=max_iter)
    got = await drv.job(ob, goals, max_iter, expect_iterations=model.iterations)
    v, e = np.array(got["mantissa"]), np.array(got["exponents"])
    assert (v == model.mantissa).all() and (e == model.exponents).all(), \
        f"field differs at {np.argwhere((v != model.mantissa) | (e != model.exponents))[:5].tolist()}"
    assert (got["iterations"], got["fixed"]) == (model.iterations, model.fixed_point)
    assert got["cycles"] == engine_cycles(H, W, model.iterations), (got["cycles"], engine_cycles(H, W, model.iterations))
    assert not got["busy"] and not got["error"]
    seen["fixed"] += model.fixed_point
    seen["cut short"] += not model.fixed_point
    seen["zeros"] += int(((~ob) & (model.mantissa == 0)).sum()) > 0
    seen["beyond 64 bits"] += int(model.exponents[model.mantissa > 0].max()) + PARAMS["p"] > 64


@cocotb.test()
async def engine_jobs(dut):
    seed = int(os.environ["ENGINE_SEED"])
    rng = np.random.default_rng(seed)
    drv = NodeEngineDriver(dut, PARAMS)
    drv.set_stalls(random.Random(seed), idle=0.25, back_pressure=0.4)
    await drv.start()
    seen = {"fixed": 0, "cut short": 0, "zeros": 0, "beyond 64 bits": 0, "refused": 0, "reset": 0}
    for name, ob, goals, max_iter in _maps(rng):
        dut._log.info(f"{name}: {ob.shape}, goals {goals}, max_iter {max_iter}")
        await _job(drv, ob, goals, max_iter, seen)

    # A bad command: refused, nothing taken from the cells, the engine idle.
    drv.cmd.put({"height": 0, "width": 4, "max_iter": 3})
    for _ in range(40):
        await RisingEdge(dut.clk)
        if int(dut.error.value):
            break
    assert int(dut.error.value) and not int(dut.busy.value)
    seen["refused"] += 1
    ob, goals = random_map(6, 9, 7, density=0.25)
    await _job(drv, ob, goals, 1000, seen)

    # A reset in the middle of a sweep, then a job from scratch.
    ob, goals = corridor(9, 16)
    drv.submit(ob, goals, 1000)
    await ClockCycles(dut.clk, 9 * 16 * 3 + 2000)
    assert int(dut.busy.value) and int(dut.cycles.value) > 0, "the job should be sweeping"
    await drv.streams.apply_reset()
    assert not int(dut.busy.value) and int(dut.cycles.value) == 0
    seen["reset"] += 1
    await _job(drv, ob, goals, 1000, seen)
    seen["stalls"] = drv.field.stalls
    dut._log.info(f"exercised: {seen}")
    assert all(seen.values()), f"not exercised: {[k for k, v in seen.items() if not v]}"


@pytest.mark.parametrize("sim", SIMULATORS)
def test_node_exponent_engine(sim):
    seed = seed_from_env()
    print(f"SEED={seed} (replay with SEED={seed})")
    run("harmonic_node_exponent_engine", PARAMS, sim, "test_node_exponent_engine", env={"ENGINE_SEED": str(seed)})


@pytest.mark.parametrize("kw,match", [
    (dict(max_h=0, max_w=8, e_max=20), "max_h"), (dict(max_h=4, max_w=1, e_max=20), "max_w"),
    (dict(max_h=4, max_w=2000, e_max=20), "max_w"), (dict(max_h=4, max_w=8, e_max=0), "e_max"),
    (dict(max_h=4, max_w=8, p=8, headroom=7, e_max=20), "headroom"),
])
def test_refusals(kw, match):
    from navcores.hdl.harmonic.node_exponent_engine import NodeExponentEngine
    with pytest.raises(ValueError, match=match):
        NodeExponentEngine(**kw)
