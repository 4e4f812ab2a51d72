"""The EDT/BFS core (hdl/edt_bfs/edt_bfs.py: controller, streams, array of cells) against the model.

Every job's distances, vectors (NNT), cfr, visited flags, parents, path,
iteration counts and cycle count (with an always-valid source and an
always-ready sink) equal models.edt_bfs.plan_path bit for bit.  Cases:
random and structured images (rooms, corridors, isolated points) with one to
three goals; no obstacles; a goal on an obstacle; an unreachable goal; the
start equal to the goal; no path requested; a changed environment (a moved
obstacle, loaded into the same array without reset); random stalls on the
image source and back-pressure on the result stream; a reset in the middle
of the EDT and of the read-out, after which the core is idle and the next
job is exact.  Environment: EDT_SIZE (array side), EDT_JOBS (random jobs).
"""

import os

import cocotb
import numpy as np
import pytest
from cocotb.triggers import ReadOnly, RisingEdge

from edt_bench import EdtBfsDriver, compare
from images import FAMILIES, free_cells
from models.edt_bfs import plan_path
from tb.runner import SIMULATORS, run, seed_from_env

SIZE = int(os.environ.get("EDT_SIZE", "8"))
JOBS = int(os.environ.get("EDT_JOBS", "6"))


async def _setup(dut):
    drv = EdtBfsDriver(dut, SIZE, SIZE)
    await drv.start()
    seed = seed_from_env()
    dut._log.info(f"seed {seed} (replay with SEED={seed})")
    return drv, np.random.default_rng(seed)


async def _check(drv, img, goals, start, dfar, **kw):
    model = plan_path(img, goals, start, dfar)
    got = await drv.job(img, goals, start, dfar, **kw)
    return compare(got, model, cycles="rng" not in kw), model


@cocotb.test()
async def random_and_structured(dut):
    drv, rng = await _setup(dut)
    names = list(FAMILIES)
    compared = found = 0
    for n in range(JOBS):
        img = FAMILIES[names[n % len(names)]](rng, SIZE, SIZE)
        cells = free_cells(img, rng, 4)
        if len(cells) < 2:
            img[0, 0] = False
            cells = [(0, 0), (0, 0)]
        start, goals = cells[0], cells[1:1 + int(rng.integers(1, 4))]
        dfar = int(rng.integers(0, 3))
        c, model = await _check(drv, img, goals, start, dfar)
        compared += c
        found += model.path_found
    dut._log.info(f"{JOBS} jobs, {compared} values compared, {found} paths")
    assert compared >= JOBS * 7 * SIZE * SIZE and found >= 1


@cocotb.test()
async def edge_cases(dut):
    drv, rng = await _setup(dut)
    n = SIZE
    jobs = 0
    # no obstacles: nothing reached, all cfr, one EDT iteration
    img = np.zeros((n, n), dtype=bool)
    _, m = await _check(drv, img, [(0, 0)], (n - 1, n - 1), 2)
    assert m.iterations_edt == 1 and m.path_found and (m.distance == -1).all()
    # a goal on an obstacle (dropped) and a second goal
    img[n // 2, n // 2] = True
    _, m = await _check(drv, img, [(n // 2, n // 2), (n - 1, 0)], (0, n - 1), 0)
    assert m.path[-1] == (n - 1, 0)
    # only a goal on an obstacle: nothing visited, no path
    _, m = await _check(drv, img, [(n // 2, n // 2)], (0, 0), 0)
    assert not m.path_found and m.iterations_bfs == 1
    # unreachable goal behind a wall
    wall = np.zeros((n, n), dtype=bool)
    wall[:, n // 2] = True
    _, m = await _check(drv, wall, [(0, 0)], (n - 1, n - 1), 0)
    assert not m.path_found
    # start equal to the goal
    _, m = await _check(drv, wall, [(1, 1)], (1, 1), 0)
    assert m.path == [(1, 1)]
    # start outside the cfr (next to the wall, dfar 1)
    _, m = await _check(drv, wall, [(0, 0)], (3, n // 2 - 1), 1)
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
    n = SIZE
    img = np.zeros((n, n), dtype=bool)
    img[2:4, 2:n - 2] = True
    goals, start = [(n - 1, n - 1)], (0, 0)
    _, m1 = await _check(drv, img, goals, start, 1)
    moved = np.zeros_like(img)
    moved[n - 4:n - 2, 2:n - 2] = True
    _, m2 = await _check(drv, moved, goals, start, 1)
    assert not np.array_equal(m1.distance, m2.distance)
    # and back, plus a different goal set
    _, m3 = await _check(drv, img, [(n - 1, 0)], (0, n - 1), 0)


@cocotb.test()
async def back_pressure(dut):
    """Random image stalls and result back-pressure: same results, more cycles."""
    drv, rng = await _setup(dut)
    for n in range(3):
        img = FAMILIES["random"](rng, SIZE, SIZE, 0.15)
        cells = free_cells(img, rng, 3)
        model = plan_path(img, cells[1:], cells[0], 0)
        got = await drv.job(img, cells[1:], cells[0], 0, rng=rng, p_valid=0.6, p_ready=0.4)
        compare(got, model, cycles=False)
        assert got["cycles"] > model.cycles


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
    n = SIZE
    img = FAMILIES["rooms"](rng, n, n)
    cells = free_cells(img, rng, 2)
    # in the EDT (after the load), then in the middle of the read-out
    for abort in (n + 3, n + 3 * n + n * n // 2):
        assert await drv.job(img, cells[1:], cells[0], 0, abort_after=abort) is None
        await _idle_after_reset(drv)
        await _check(drv, img, cells[1:], cells[0], 0)


def _params(size):
    return {"height": size, "width": size}


# 8x8 on both simulators, 16x16 on Icarus.  A Verilator build grows with the
# cell count (about 100 kB of C++ per cell instance) and Icarus runs a 32x32
# array at tens of ms per cycle, so 32x32 runs only with EDT_BIG=1
# (hdl/edt_bfs/README.md gives the measured times).
CASES = [(sim, 8, 6) for sim in SIMULATORS] + [("icarus", 16, 4)]
BIG = [("icarus", 32, 1), ("verilator", 16, 2)]


@pytest.mark.parametrize("sim, size, jobs", CASES + BIG, ids=[f"{s}-{n}x{n}" for s, n, _ in CASES + BIG])
def test_edt_bfs_core(sim, size, jobs):
    if (sim, size, jobs) in BIG and os.environ.get("EDT_BIG") != "1":
        pytest.skip("large array: set EDT_BIG=1")
    run("edt_bfs", _params(size), sim, "test_edt_bfs_core", env={"EDT_SIZE": size, "EDT_JOBS": jobs})
