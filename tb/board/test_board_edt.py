"""The EDT/BFS board top (UART, bridge, EdtBfs) in simulation, driven
through the host's protocol module and job (sim/rtl/board_jobs.py).

* ``protocol``: the bridge's checks (tb/board/board_checks.py, without the
  parts test_board_dflc.py already covers on the same bridge) on this top.
* ``jobs``: random and structured images through the board, as ``--engine
  serial`` sends them: distances, vectors, cfr, visited flags, parents,
  path, iteration counts equal models.edt_bfs.plan_path bit for bit
  (edt_bfs_driver.compare), and so does the job's cycle count the board
  top measures for the status word, although the UART starves the image
  input and stalls the result stream most of the time.
* ``core_errors``: an image column with no command before it is never
  taken: NAK CORE_TIMEOUT after the accept timeout; a start outside the
  5x5 array (its row field holds 0..7) is the core's start_err, a
  CoreError for the host; the next job is exact.
* ``host_engine``: ``python -m sim edt --engine serial:PORT`` with a
  pseudo-terminal as its port, carried to this board top's UART: the
  model engine's JSON (the cycle count too) and ``rtl_matches_model``; a
  map of another size refused with one line, exit status 2.

A 5x5 array at 4 clocks a bit.
"""

import os
from pathlib import Path

import cocotb
import numpy as np
import pytest

from board_checks import host_command, host_matches_model, open_board, protocol_suite, rng_from_env, run_board
from images import FAMILIES, free_cells
from navcores.hdl.board import protocol as P
from navcores.models.edt_bfs import plan_path
from navcores.sim.rtl.board_driver import UartLine, perform, start
from navcores.sim.rtl.board_jobs import CoreError, edt
from navcores.sim.rtl.edt_bfs_driver import compare
from navcores.sim.rtl.runner import SIMULATORS

PARAMS = {"core": "edt_bfs", "height": 5, "width": 5, "divisor": 4, "fifo": 32, "gap_bits": 40,
          "accept_bits": 300}
H, W = PARAMS["height"], PARAMS["width"]



async def _job(line, link, img, goals, start_, dfar):
    model = plan_path(img, goals, start_, dfar)
    got = await perform(edt(link, img, goals, start_, dfar), line)
    return compare(got, model), model


@cocotb.test()
async def protocol(dut):
    line, link, info = await open_board(dut, PARAMS, timeout_bits=20_000)
    assert (info["height"], info["width"], info["sinks"], len(info["sources"])) == (H, W, info["sinks"], 1)
    assert len(info["sinks"]) == 2 and info["status"] > 32, info
    n = await protocol_suite(line, info, rng_from_env(), full=False)
    dut._log.info(f"{n} frames checked")


@cocotb.test()
async def jobs(dut):
    line, link, info = await open_board(dut, PARAMS, timeout_bits=20_000)
    rng = np.random.default_rng(rng_from_env().randrange(1 << 30))
    compared = found = 0
    for name in ("random", "rooms", "sparse"):
        img = FAMILIES[name](rng, H, W)
        cells = free_cells(img, rng, 3)
        if len(cells) < 2:
            img[0, 0] = img[H - 1, W - 1] = False
            cells = [(0, 0), (H - 1, W - 1)]
        c, model = await _job(line, link, img, cells[1:], cells[0], int(rng.integers(0, 2)))
        compared += c
        found += model.path_found
    assert compared >= 3 * 7 * H * W and link.bad_frames == 0 and line.framing_errors == 0
    dut._log.info(f"3 jobs, {compared} values and the cycle counts equal, {found} paths")


@cocotb.test()
async def core_errors(dut):
    line, link, info = await open_board(dut, PARAMS, timeout_bits=20_000)
    img = np.zeros((H, W), dtype=bool)
    img[2, 1:4] = True
    # an image column before any command: the core never takes it
    try:
        await perform(link.write(1, 0), line)
    except P.BridgeError as e:
        assert e.code == P.Error.CORE_TIMEOUT and e.cmd == P.WRITE + 1, e
    else:
        raise AssertionError("a beat the core cannot take was acknowledged")
    # a start outside the array: the core's start_err, no path read out
    try:
        await perform(edt(link, img, [(4, 4)], (6, 0), 0), line)
    except CoreError as e:
        assert "outside" in str(e), e
    else:
        raise AssertionError("a start outside the array was not refused")
    _, model = await _job(line, link, img, [(0, 4)], (4, 0), 0)
    assert model.path_found


@cocotb.test()
async def host_engine(dut):
    """``python -m sim edt MAP --engine serial:PORT`` on this board top (its
    port a pseudo-terminal): the model engine's JSON, the cycles included."""
    await start(dut)
    line = UartLine(dut, PARAMS["divisor"], timeout_bits=20_000)
    work = Path(os.environ["HOST_WORK"])
    (work / "map.txt").write_text("..#..\n..#..\n.....\n.#...\n.....\n")
    data = await host_matches_model(dut, line, ["edt", str(work / "map.txt"), "--dfar", "0", "--goal", "0,4",
                                                "--start", "0,0"], work)
    assert data["path_found"] and data["cycles"] > H * W
    rc, out, err = await host_command(dut, line, ["edt", "maps/room-32-32-4.map", "--goal", "3,3", "--dfar", "1"])
    assert rc == 2 and err.count("\n") == 1 and "array is 5x5; the map is 32x32" in err, (rc, err)


@pytest.mark.parametrize("sim", SIMULATORS)
def test_board_edt(sim, tmp_path):
    run_board("edt", PARAMS, sim, tmp_path, ('protocol', 'jobs', 'core_errors', 'host_engine'))
