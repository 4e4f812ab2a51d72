"""The EDT/BFS core (hdl/edt_bfs/edt_bfs.py: controller, streams, array of cells) against the model.

Every job's distances, vectors (NNT), cfr, visited flags, parents, path,
iteration counts and cycle count equal models.edt_bfs.plan_path bit for
bit.  The cycle count is the model's (models.edt_bfs.job_cycles) when the
sources are always valid and the result sink always ready; with random
idle cycles on the command and image sources and random back-pressure on
the results (sim/rtl/stream.py, seeded: SEED= replays) it is the model's
plus exactly the cycles the core lost to them (load cycles with no column,
result beats held back), and the stalled jobs must have had both.  Cases:
random and structured images (rooms, corridors, isolated points) with one to
three goals, every other job stalled; no obstacles; a goal on an obstacle;
an unreachable goal; the start equal to the goal; no path requested; a
changed environment (a moved obstacle, loaded into the same array without
reset, stalled); heavy stalls; a reset in the middle of a stalled load (the
column being presented is dropped), of the EDT and of a stalled read-out,
after which the core is idle and the next job is exact; a start outside a
7x9 array (start_err).  Environment: EDT_SIZE (HxW), EDT_JOBS (random jobs).
"""

import os

import cocotb
import numpy as np
import pytest
from cocotb.triggers import ReadOnly, RisingEdge

from images import FAMILIES, free_cells
from navcores.models.edt_bfs import plan_path
from navcores.sim.rtl.edt_bfs_driver import EdtBfsDriver, compare
from navcores.sim.rtl.runner import SIMULATORS, run, seed_from_env

H, W = (int(v) for v in os.environ.get("EDT_SIZE", "8x8").split("x"))
JOBS = int(os.environ.get("EDT_JOBS", "6"))


async def _setup(dut):
    drv = EdtBfsDriver(dut, H, W)
    await drv.start()
    seed = seed_from_env()
    dut._log.info(f"seed {seed} (replay with SEED={seed})")
    return drv, np.random.default_rng(seed)


# stalls: probability of an idle cycle before a command or column, of ready low on the results
IDLE, BACK_PRESSURE = 0.3, 0.5


async def _check(drv, img, goals, start, dfar, stalled=None):
    """One job against the model (values, path, iterations, cycles); with
    ``stalled`` (a list) the job's lost cycles are appended to it."""
    model = plan_path(img, goals, start, dfar)
    got = await drv.job(img, goals, start, dfar)
    if stalled is not None:
        stalled.append((got["starved"], got["stalls"]))
    else:
        assert got["starved"] == got["stalls"] == 0 and got["cycles"] == model.cycles
    return compare(got, model), model


def _stalled(stalled):
    """The stalled jobs lost cycles both to the image source and to the result sink."""
    starved, stalls = (sum(s[i] for s in stalled) for i in (0, 1))
    assert starved > 0 and stalls > 0, stalled
    return f"{len(stalled)} stalled jobs: {starved} load cycles without a column, {stalls} result stalls"


@cocotb.test()
async def random_and_structured(dut):
    drv, rng = await _setup(dut)
    names = list(FAMILIES)
    compared = found = 0
    stalled = []
    for n in range(JOBS):
        img = FAMILIES[names[n % len(names)]](rng, H, W)
        cells = free_cells(img, rng, 4)
        if len(cells) < 2:
            img[0, 0] = False
            cells = [(0, 0), (0, 0)]
        start, goals = cells[0], cells[1:1 + int(rng.integers(1, 4))]
        dfar = int(rng.integers(0, 3))
        if n % 2:                                   # every other job stalled
            drv.set_stalls(rng, IDLE, BACK_PRESSURE)
        c, model = await _check(drv, img, goals, start, dfar, stalled if n % 2 else None)
        drv.set_stalls()
        compared += c
        found += model.path_found
    dut._log.info(f"{JOBS} jobs, {compared} values compared, {found} paths")
    assert compared >= JOBS * 7 * H * W and (found >= 1 or JOBS < 4)
    if JOBS >= 2:
        dut._log.info(_stalled(stalled))


@cocotb.test()
async def edge_cases(dut):
    drv, rng = await _setup(dut)
    h, w = H, W
    jobs = 0
    # no obstacles: nothing reached, all cfr, one EDT iteration
    img = np.zeros((h, w), dtype=bool)
    _, m = await _check(drv, img, [(0, 0)], (h - 1, w - 1), 2)
    assert m.iterations_edt == 1 and m.path_found and (m.distance == -1).all()
    # a goal on an obstacle (dropped) and a second goal
    img[h // 2, w // 2] = True
    _, m = await _check(drv, img, [(h // 2, w // 2), (h - 1, 0)], (0, w - 1), 0)
    assert m.path[-1] == (h - 1, 0)
    # only a goal on an obstacle: nothing visited, no path
    _, m = await _check(drv, img, [(h // 2, w // 2)], (0, 0), 0)
    assert not m.path_found and m.iterations_bfs == 1
    # unreachable goal behind a wall
    wall = np.zeros((h, w), dtype=bool)
    wall[:, w // 2] = True
    _, m = await _check(drv, wall, [(0, 0)], (h - 1, w - 1), 0)
    assert not m.path_found
    # start equal to the goal
    _, m = await _check(drv, wall, [(1, 1)], (1, 1), 0)
    assert m.path == [(1, 1)]
    # start outside the cfr (next to the wall, dfar 1)
    _, m = await _check(drv, wall, [(0, 0)], (3, w // 2 - 1), 1)
    assert not m.path_found
    # no path requested
    _, m = await _check(drv, wall, [(0, 0)], None, 0)
    # a large dfar: no cfr pixel (clamped to the d_i width, exact)
    _, m = await _check(drv, wall, [(0, 0)], (0, 1), 10_000)
    assert not m.cfr.any()
    jobs = 8
    dut._log.info(f"{jobs} edge-case jobs compared")


@cocotb.test()
async def changed_environment(dut):
    """A moved obstacle loaded into the same array: nothing left over from the old image."""
    drv, rng = await _setup(dut)
    drv.set_stalls(rng, IDLE, BACK_PRESSURE)
    stalled = []
    h, w = H, W
    img = np.zeros((h, w), dtype=bool)
    img[2:4, 2:w - 2] = True
    goals, start = [(h - 1, w - 1)], (0, 0)
    _, m1 = await _check(drv, img, goals, start, 1, stalled)
    moved = np.zeros_like(img)
    moved[h - 3:h - 1, 2:w - 2] = True
    _, m2 = await _check(drv, moved, goals, start, 1, stalled)
    assert not np.array_equal(m1.distance, m2.distance)
    # and back, plus a different goal set
    _, m3 = await _check(drv, img, [(h - 1, 0)], (0, w - 1), 0, stalled)
    dut._log.info(_stalled(stalled))


@cocotb.test()
async def back_pressure(dut):
    """Heavy random stalls (idle 0.4, ready 0.4): same results, the model's
    cycles plus exactly the lost ones."""
    drv, rng = await _setup(dut)
    drv.set_stalls(rng, 0.4, 0.6)
    stalled = []
    for n in range(3):
        img = FAMILIES["random"](rng, H, W, 0.15)
        cells = free_cells(img, rng, 3)
        model = plan_path(img, cells[1:], cells[0], 0)
        got = await drv.job(img, cells[1:], cells[0], 0)
        compare(got, model)                 # cycles: model + starved + stalls
        assert got["cycles"] > model.cycles and got["stalls"] > 0
        stalled.append((got["starved"], got["stalls"]))
    dut._log.info(_stalled(stalled))


async def _idle_after_reset(drv):
    d = drv.dut
    await drv.reset()
    await ReadOnly()
    assert int(d.busy.value) == 0 and int(d.c_stream__ready.value) == 1
    assert int(d.o_stream__valid.value) == 0 and int(d.i_stream__ready.value) == 0
    await RisingEdge(d.clk)


@cocotb.test()
async def reset_mid_job(dut):
    drv, rng = await _setup(dut)
    img = FAMILIES["rooms"](rng, H, W)
    img[0, 0] = img[H - 1, W - 1] = False
    cells = [(0, 0), (H - 1, W - 1)]
    # in the middle of a stalled load (a column is being presented or about
    # to be: the reset drops it), in the EDT (after the load), then in the
    # middle of a read-out with back-pressure
    for abort, idle, back_pressure in ((W // 2, 0.5, 0), (W + 3, 0, 0), (W + 3 * W + H * W // 2, 0, 0.5)):
        drv.set_stalls(rng, idle, back_pressure)
        assert await drv.job(img, cells[1:], cells[0], 0, abort_after=abort) is None
        presented = drv.img.busy
        await _idle_after_reset(drv)
        assert not drv.img.busy and drv.img.valid.value == 0, "the reset dropped what the source held"
        if idle:
            assert presented, "the load was still on at the reset"
        drv.set_stalls()
        await _check(drv, img, cells[1:], cells[0], 0)


@cocotb.test()
async def start_out_of_range(dut):
    """A start outside the array (possible when a side is no power of two): start_err, no path."""
    drv, rng = await _setup(dut)
    rows, cols = 1 << drv.widths["row"], 1 << drv.widths["col"]
    starts = [(r, 0) for r in range(H, rows)] + [(0, c) for c in range(W, cols)]
    img = FAMILIES["random"](rng, H, W, 0.1)
    goals = free_cells(img, rng, 2)
    for start in starts:
        got = await drv.job(img, goals, start, 0)
        compare(got, plan_path(img, goals, None, 0))   # as without a start: no path beats
        assert got["start_err"] == 1 and not got["path"]
    # a valid start clears the flag
    got = await drv.job(img, goals, goals[0], 0)
    assert got["start_err"] == 0
    dut._log.info(f"{len(starts)} out-of-range starts")
    assert len(starts) > 0 or (H & (H - 1) == 0 and W & (W - 1) == 0)


def _params(size):
    h, w = size
    return {"height": h, "width": w}


# Every test at 8x8 on both simulators and at 7x9 (non-square, start_err) on
# Icarus; at 32x32 on Icarus the case list (random and structured
# images with 1-3 goals, and the edge cases: no obstacles, a goal on an
# obstacle, an unreachable goal, start = goal, start outside the cfr, no
# path, a d_far beyond every distance), in one build and one simulator run.
# The changed environment, back-pressure and reset exercise the load
# pipeline, the controller and the streams, which do not depend on the size;
# at 32x32 they are opt-in.  Verilator emits per-instance C++ for the array (about 60-110 kB
# per cell), so its 32x32 build is opt-in too (EDT_BIG=1; the measured costs
# are in hdl/edt_bfs/README.md).
# (sim, size, random jobs, cocotb test filter (a regex) or None for all tests)
SIZED = "random_and_structured|edge_cases"
CASES = [(sim, (8, 8), 6, None) for sim in SIMULATORS] + [
    ("icarus", (7, 9), 3, None), ("icarus", (32, 32), 2, SIZED)]
BIG = [("icarus", (16, 16), 3, None), ("icarus", (32, 32), 3, "changed_environment|back_pressure|reset_mid_job"),
       ("verilator", (16, 16), 2, None), ("verilator", (32, 32), 3, None)]


@pytest.mark.parametrize("sim, size, jobs, only", CASES + BIG,
                         ids=[f"{s}-{n[0]}x{n[1]}{'-' + ('sized' if o == SIZED else o.split('|')[0]) if o else ''}{'-big' if c in BIG else ''}"
                              for c in CASES + BIG for s, n, _, o in [c]])
def test_edt_bfs_core(sim, size, jobs, only):
    if (sim, size, jobs, only) in BIG and os.environ.get("EDT_BIG") != "1":
        pytest.skip("large array: set EDT_BIG=1")
    env = {"EDT_SIZE": f"{size[0]}x{size[1]}", "EDT_JOBS": jobs}
    if only:
        env["COCOTB_TEST_FILTER"] = only
    ran = run("edt_bfs", _params(size), sim, "test_edt_bfs_core", env=env)
    assert not only or ran == len(only.split("|")), f"{ran} cocotb tests ran, filter {only!r}"
