"""The harmonic planner's board top (UART, bridge, Planner) in simulation,
driven through the host's protocol module and job (sim/rtl/board_jobs.py).

* ``protocol``: the bridge's checks (tb/board/board_checks.py, without the
  parts test_board_dflc.py already covers on the same bridge) on this top.
* ``plan``: a map loaded, planned and read back through the board, as
  ``--engine serial`` does: every node's value and flag, the counters and
  the cycles equal models.harmonic.plan's bit for bit
  (board_jobs.harmonic_differences, the host's check).
* ``core_error``: a READ of a node outside the block is the planner's
  BAD_NODE (a CoreError for the host), and the next command works.
* ``host_engine``: ``python -m sim harmonic --engine serial:PORT`` with a
  pseudo-terminal as its port, carried to this board top's UART: the model
  engine's JSON and ``rtl_matches_model``; a block size the board's
  planner does not have refused with one line, exit status 2.

A 3x12 map in two 3x6 blocks, p_max 16, at 4 clocks a bit.
"""

import os
from pathlib import Path

import cocotb
import numpy as np
import pytest

from board_checks import host_command, host_matches_model, open_board, protocol_suite, rng_from_env, run_board
from navcores.models.harmonic import plan
from navcores.sim.rtl.board_driver import UartLine, perform, start
from navcores.sim.rtl.board_jobs import CoreError, RemotePlanner, harmonic, harmonic_differences
from navcores.sim.rtl.planner_driver import Code, Op
from navcores.sim.rtl.runner import SIMULATORS
from tb.harmonic.planner_maps import MAPS

PARAMS = {"core": "harmonic", "n": 3, "m": 6, "br": 1, "bc": 2, "p_max": 16, "depth": 64,
          "divisor": 4, "fifo": 64, "gap_bits": 40, "accept_bits": 2000}
SHAPE = (PARAMS["br"] * PARAMS["n"], PARAMS["bc"] * PARAMS["m"])



@cocotb.test()
async def protocol(dut):
    line, link, info = await open_board(dut, PARAMS, timeout_bits=20_000)
    assert {k: info[k] for k in ("n", "m", "br", "bc", "p_max", "depth")} == \
        {k: PARAMS[k] for k in ("n", "m", "br", "bc", "p_max", "depth")}, info
    n = await protocol_suite(line, info, rng_from_env(), full=False)
    dut._log.info(f"{n} frames checked")


@cocotb.test()
async def plan_matches_model(dut):
    line, link, info = await open_board(dut, PARAMS, timeout_bits=20_000)
    rng = rng_from_env()
    for name, sched, iters in (("random", (8, 16), 2),):
        ob, goals = MAPS[name](*SHAPE, rng.randrange(1000))
        model = plan(ob, goals, block=(PARAMS["n"], PARAMS["m"]), iters=iters, schedule=sched)
        goal = np.zeros(SHAPE, dtype=bool)
        for g in goals:
            goal[g] = True
        status, h, const = await perform(harmonic(link, ob | model.unreachable, goal, (sched[0], sched[1] - sched[0],
                                                                                       sched[-1]), iters), line)
        diff = harmonic_differences(status, h, const, model)
        assert not diff, f"{name}: " + "; ".join(diff)
        assert model.cycles > 0 and (h != 0).any()
        dut._log.info(f"{name}: p={model.p} converged={model.converged} sweeps={model.sweeps} "
                      f"cycles={model.cycles}: all {h.size} nodes and the counters equal")
        await perform(link.reset(), line)
    assert link.bad_frames == 0 and line.framing_errors == 0


@cocotb.test()
async def core_error(dut):
    line, link, info = await open_board(dut, PARAMS, timeout_bits=20_000)
    drv = RemotePlanner(link)
    try:
        await perform(drv.command(Op.READ, block=0, row=PARAMS["n"], col=0), line)
    except CoreError as e:
        assert "BAD_NODE" in str(e), e
    else:
        raise AssertionError("a READ outside the block was not refused")
    drv.check = False
    resp = await perform(drv.command(Op.READ, block=2, row=0, col=0), line)
    assert resp["code"] == Code.BAD_NODE, resp
    st = await perform(drv.command(Op.STATUS), line)
    assert st["code"] == Code.OK and not st["busy"], st


@cocotb.test()
async def host_engine(dut):
    """``python -m sim harmonic MAP --engine serial:PORT`` on this board top
    (its port a pseudo-terminal): the model engine's JSON, trajectories
    included; a block size the board's planner does not have: refused."""
    await start(dut)
    line = UartLine(dut, PARAMS["divisor"], timeout_bits=20_000)
    work = Path(os.environ["HOST_WORK"])
    # p_max 16 converges when no cell is far from the goal: the goal in the middle
    (work / "map.txt").write_text(".....#......\n..#..#..#...\n........#...\n")
    args = ["harmonic", str(work / "map.txt"), "--goal", "1,6", "--start", "0,0", "--block", "3x6",
            "--schedule", "8:8:16", "--iters", "2"]
    data = await host_matches_model(dut, line, args, work, unrecorded=("levels",))  # no per-level record
    assert data["converged"] and data["trajectories"][0]["reached_goal"]
    rc, out, err = await host_command(dut, line, [*args[:-6], "--block", "6x12"])
    assert rc == 2 and err.count("\n") == 1 and "the board's planner has 3x6 blocks" in err, (rc, err)


@pytest.mark.parametrize("sim", SIMULATORS)
def test_board_harmonic(sim, tmp_path):
    run_board("harmonic", PARAMS, sim, tmp_path, ('protocol', 'plan_matches_model', 'core_error', 'host_engine'))
