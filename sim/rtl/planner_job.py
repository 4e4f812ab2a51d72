"""cocotb job: run the harmonic Planner RTL on one whole map.

Reads the job (parameters, padded map, schedule, I, events) from the JSON
file named by $PLANNER_JOB, loads the map through the command stream, sends
the idle events, STARTs, sends each run event while the planner is in the
pass before it, polls STATUS until idle, reads every node back and writes the
status and the values to $PLANNER_RESULT.  It checks nothing itself:
navcores.sim.rtl.planner_driver.run_planner_rtl returns the result for comparison.
"""

import json
import os
from pathlib import Path

import cocotb
import numpy as np

from navcores.models.harmonic import E_MAX

from .clock import start
from .planner_driver import Code, Op, PlannerDriver


async def run_job(dut, job):
    prm = job["params"]
    driver = PlannerDriver(dut, prm["n"], prm["m"], (prm["br"], prm["bc"]), prm["p_max"],
                         exponents=bool(job.get("exponents")), e_max=job.get("e_max", E_MAX))
    obstacle = np.array(job["obstacle"], dtype=bool)
    goal = np.array(job["goal"], dtype=bool)
    out = await run_map(driver, obstacle, goal, job["schedule"], job["iters"], job.get("events", []))
    run_job.exponents = driver.block_exponents.tolist() if driver.exponents else None
    return out


async def run_map(driver, obstacle, goal, schedule, iters, events=()):
    """Load the map, send the idle orders (pass 0), START with ``schedule``
    = (p1, step, p_last), send each order during its pass, wait for the end;
    returns (status, h, const) read back from the planner."""
    await driver.load_map(obstacle, goal)
    events = sorted(events, key=lambda e: e[0])
    for s, (r, c), kind in [e for e in events if e[0] == 0]:
        await set_order(driver, r, c, kind)
    await driver.wait_idle(poll=16)
    p1, step, p_last = schedule
    resp = await driver.command(Op.START, p1=p1, step=step, p_last=p_last, iters=iters)
    assert resp["code"] == Code.OK, resp["code"]
    for s, (r, c), kind in [e for e in events if e[0] > 0]:
        await wait_pass(driver, s - 1)
        await set_order(driver, r, c, kind, during=s - 1)
    status = await driver.wait_idle()
    h, const = await driver.read_all(obstacle.shape)
    return status, h, const


async def set_order(driver, r, c, kind, during=None):
    """SET (r, c); ``during``: the pass the order must be taken in (the
    response's counters, registered after the order, prove it was)."""
    b, x, y = driver.locate(r, c)
    resp = await driver.command(Op.SET, block=b, row=x, col=y, flag=int(kind == "goal"))
    assert resp["code"] == Code.OK, resp["code"]
    if during is not None:
        done = resp["sweeps"] + resp["check_iterations"] // (driver.BR * driver.BC)
        assert done == during and resp["busy"], f"order meant for the end of pass {during} came at {done}"


async def wait_pass(driver, s):
    """Return while pass s is on (passes = sweeps + check passes so far)."""
    from cocotb.triggers import ClockCycles, FallingEdge
    while True:
        st = await driver.command(Op.STATUS)
        done = st["sweeps"] + st["check_iterations"] // (driver.BR * driver.BC)
        assert done <= s and st["busy"], f"pass {s} went by unseen (status {done} passes)"
        if done == s:
            return
        await ClockCycles(driver.dut.clk, 8)
        await FallingEdge(driver.dut.clk)


@cocotb.test()
async def planner_job(dut):
    job = json.loads(Path(os.environ["PLANNER_JOB"]).read_text())
    await start(dut)
    status, h, const = await run_job(dut, job)
    keep = ("busy", "converged", "p", "sweeps", "block_iterations", "check_iterations",
            "clear_passes", "cycles")
    Path(os.environ["PLANNER_RESULT"]).write_text(json.dumps({
        "status": {k: int(status[k]) for k in keep},
        "h": [[int(v) for v in row] for row in h],
        "const": const.tolist(),
        "exponents": run_job.exponents,
    }))
