"""The EDT/BFS tile engine (hdl/edt_bfs/tile_engine.py) against the tiled model, bit for bit and cycle for cycle.

Every job's distances, vectors (NNT), nearest obstacles, cfr, visited
flags, hop counts, parents, path, EDT levels, tile visits, the visit trace
(phase, level, tile, iterations, tiles enqueued: visit by visit) and cycle
count (source always valid, sink always ready) equal
models.edt_bfs_tiled.plan_path_tiled's.  Cases: the bundled 64x64 maps
and random maps of every family (full maps and maps whose last row and
column of tiles are partial, 1 x n and n x 1 maps) with one to three goals;
no obstacles, only obstacles, several goals, an unreachable goal, a goal on
an obstacle, start = goal, the start outside the cfr, no start, no
read-out, a d_far beyond every distance; a changed environment (a second
and third map into the same engine, no reset); random idle cycles on the
map and goal streams and back-pressure on the results (same results and
trace, more cycles); a reset in the EDT, the BFS and the read-out, after
which the engine is idle and the next job exact; refusals (a map larger
than the RAM, an empty one: cmd_err; a start outside the map: start_err; a
goal outside the map: goal_err, dropped); with TILE_STORE=external the
engine with its state outside on sim/rtl/state_store.py's store, at
StateRam's timing (cycle-exact) and with random latency and stalls (the
same results in more cycles); with TILE_PREFETCH=d (the engine reads the
next d visits' windows during this one: hdl/edt_bfs/tile_engine.py) the
same results and trace, in fewer cycles than the model's at StateRam's
timing; with TILE_SKIP_CLEAN=1 the visits write fewer words than the
model's words written (without: as many), and with TILE_BFS_SLOTS=1 as
well (the DRAM stores' bfs_slots) a BFS read needs no edge word; with TILE_ITER=2 (the cells'
registered MIN winner: two cycles an array iteration) the cycles of
the model's Timing(iteration=2).  On Icarus (which sees the engine's
internals) the engine's cycles in its FSM states equal the model's cycle
terms (sim/rtl/engine_states.py) in a job at StateRam's timing, and through
the DRAM sum to the job's cycles with the scan, levels and iterations
unchanged.  Environment: TILE_PARAMS
(t_r,t_c,max_h,max_w), TILE_JOBS (random jobs), TILE_MID (HxW of the maps
of the edge cases, stalls, resets and changed environments), TILE_MAPS
(the bundled maps to run, comma-separated), TILE_LARGE (1: random maps
at the RAM's full size too).
"""

import os
from pathlib import Path

import cocotb
import numpy as np
import pytest
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge

from images import FAMILIES, free_cells
from navcores.hdl.edt_bfs.tile_engine import model_timing
from navcores.models.edt_bfs_tiled import Timing, plan_path_tiled
from navcores.models.maps import load_grid
from navcores.sim.rtl.edt_tile_driver import TileEngineDriver, compare
from navcores.sim.rtl.engine_states import EngineStates
from navcores.sim.rtl.litedram import NativeCount
from navcores.sim.rtl.runner import run, seed_from_env

T_R, T_C, MAX_H, MAX_W = (int(v) for v in os.environ.get("TILE_PARAMS", "8,8,64,64").split(","))
JOBS = int(os.environ.get("TILE_JOBS", "6"))
MID = tuple(int(v) for v in os.environ.get("TILE_MID", f"{MAX_H}x{MAX_W}").split("x"))
BUNDLED = [n for n in os.environ.get("TILE_MAPS", "").split(",") if n]
LARGE = os.environ.get("TILE_LARGE") == "1"
EXTERNAL = os.environ.get("TILE_STORE") == "external"
DRAM = os.environ.get("TILE_STORE") == "dram"
PREFETCH = int(os.environ.get("TILE_PREFETCH", "0"))     # visits read ahead
SKIP_CLEAN = os.environ.get("TILE_SKIP_CLEAN") == "1"    # rows the visit did not change not written
BFS_SLOTS = os.environ.get("TILE_BFS_SLOTS") == "1"      # the edge pixels' BFS groups in the B words
ITER = int(os.environ.get("TILE_ITER", "1"))              # cycles an array iteration takes (iter_cycles)
# the DRAM test's native ports (rows of a window on different ports: BANK_AT); one in the 1port case
DRAM_PORTS = int(os.environ.get("TILE_DRAM_PORTS", 4))
MAPS = Path(__file__).resolve().parents[2] / "maps"


async def _setup(dut):
    seed = seed_from_env()
    drv = TileEngineDriver(dut, T_R, T_C, MAX_H, MAX_W, seed=seed, bfs_slots=BFS_SLOTS)
    await drv.start()
    dut._log.info(f"seed {seed} (replay with SEED={seed})")
    return drv, np.random.default_rng(seed)


def _model(img, goals, start, dfar, readout=True):
    return plan_path_tiled(img, goals, start, dfar, array=(T_R, T_C), readout=readout, timing=model_timing(ITER))


async def _check(drv, img, goals, start, dfar, readout=True, cycles=True, **kw):
    """One job on the engine and the model; everything compared, with
    ``cycles`` the cycles too (the model's plus what the stalls set by the
    caller cost)."""
    model = _model(img, goals, start, dfar, readout)
    raw = await drv.job(img, goals, start, dfar, readout=readout, **kw)
    got = drv.decode(raw, img.shape, readout)
    n = compare(got, model, cycles=cycles, readout=readout)
    assert raw["cmd_err"] == raw["start_err"] == raw["goal_err"] == 0
    return n, model, raw


def _states(dut):
    """The engine's cycles by state (sim/rtl/engine_states.py, what bench_dram --states prints), started;
    None on Verilator, whose builds here keep the engine's internals hidden (sim/rtl/runner.py)."""
    if "icarus" not in cocotb.SIM_NAME.lower():
        return None
    states = EngineStates(dut)
    states.start()
    return states


def _case(rng, shape, family=None):
    family = family or list(FAMILIES)[int(rng.integers(len(FAMILIES)))]
    img = FAMILIES[family](rng, *shape)
    cells = free_cells(img, rng, 4)
    if len(cells) < 2:
        img[0, 0] = img[-1, -1] = False
        cells = [(0, 0), (shape[0] - 1, shape[1] - 1)]
    return img, cells[0], cells[1:1 + int(rng.integers(1, 4))]


def _partial(lo, hi, t):
    """A size in lo..hi that is not a multiple of t (when t > 1)."""
    n = hi
    while t > 1 and n % t == 0:
        n -= 1
    return max(lo, n)


@cocotb.test()
async def bundled_and_random(dut):
    """The bundled 64x64 maps (when they fit), then random maps: full, partial last tiles, thin."""
    drv, rng = await _setup(dut)
    compared = visits = paths = partial = 0
    for name in BUNDLED:
        img = load_grid(MAPS / f"{name}.map")
        cells = free_cells(img, rng, 4)
        c, model, _ = await _check(drv, img, cells[1:], cells[0], 0)
        compared, visits, paths = compared + c, visits + model.tile_visits, paths + model.path_found
        dut._log.info(f"{name}: {model.tile_visits} visits, {model.cycles} cycles, path {len(model.path)}")
    # the largest map and partial last tiles (TILE_LARGE: at the RAM's size, else at the mid size),
    # thin maps along the RAM's full width and height, then random sizes up to the mid size
    big = (MAX_H, MAX_W) if LARGE else MID
    shapes = [(_partial(2, big[0], T_R), _partial(2, big[1] * 3 // 4, T_C)), (1, MAX_W), (MAX_H, 1)]
    stalled = 0
    for n in range(JOBS):
        shape = shapes[n] if n < len(shapes) else tuple(int(v) for v in rng.integers(1, [MID[0] + 1, MID[1] + 1]))
        img, start, goals = _case(rng, shape)
        drv.set_stalls(rng, 0.3, 0.3) if n % 2 else drv.set_stalls()    # every other job stalled
        states = _states(dut) if n == 0 else None
        c, model, raw = await _check(drv, img, goals, start, int(rng.integers(0, 2)))
        if states is not None:      # at StateRam's timing each of the model's cycle terms is its states' cycles
            states.stop()
            assert states.terms() == model.stats["cycle_terms"], (states.terms(), model.stats["cycle_terms"])
        compared, visits, paths = compared + c, visits + model.tile_visits, paths + model.path_found
        partial += shape[0] % T_R != 0 and shape[1] % T_C != 0
        stalled += raw["starved"] > 0 and raw["stalls"] > 0
    drv.set_stalls()
    dut._log.info(f"{compared} values compared, {visits} tile visits, {paths} paths, {partial} partial maps, "
                  f"{stalled} jobs stalled")
    assert visits > 5 * JOBS and paths >= 2 and partial >= 1 and stalled >= JOBS // 2 - 1


@cocotb.test()
async def edge_cases(dut):
    drv, rng = await _setup(dut)
    h, w = MID
    img = np.zeros((h, w), dtype=bool)
    # no obstacles: nothing done, everything in the cfr, no EDT visit; two goals at once
    _, m, _ = await _check(drv, img, [(0, 0), (h - 1, w - 1)], (h // 2, w // 2), 2)
    assert m.stats["visits_edt"] == 0 and m.path_found and (m.distance == -1).all()
    # only obstacles: no free pixel, the goal dropped
    _, m, _ = await _check(drv, ~img, [(0, 0)], (0, 0), 0)
    assert not m.path_found and m.iterations_edt == 1
    # a wall: an unreachable goal alone, then with a reachable one (several goals)
    wall = img.copy()
    wall[:, w // 2] = True
    _, m, _ = await _check(drv, wall, [(h - 1, w - 1)], (0, 0), 0)
    assert not m.path_found and m.visited[h - 1, w - 1]
    _, m, _ = await _check(drv, wall, [(h - 1, w - 1), (h - 1, 0), (0, 1)], (0, 0), 0)
    assert m.path_found
    # a goal on an obstacle (dropped) beside a good one; start = goal; start outside the cfr
    _, m, _ = await _check(drv, wall, [(0, w // 2), (1, 1)], (h - 1, 0), 0)
    assert m.path[-1] == (1, 1)
    _, m, _ = await _check(drv, wall, [(1, 1)], (1, 1), 0)
    assert m.path == [(1, 1)]
    _, m, _ = await _check(drv, wall, [(1, 1)], (0, w // 2 - 1), 1)
    assert not m.cfr[0, w // 2 - 1] and not m.path_found
    # no start; no read-out (the path only); no goal at all; a d_far beyond every distance
    await _check(drv, wall, [(1, 1)], None, 0)
    _, m, raw = await _check(drv, wall, [(1, 1)], (h - 1, 1), 0, readout=False)
    assert m.path_found and len(raw["beats"]) == len(m.path)
    _, m, _ = await _check(drv, wall, [], (0, 0), 0)
    assert not m.visited.any()
    _, m, _ = await _check(drv, wall, [(0, 0)], (0, 1), 10_000)
    assert not m.cfr.any()
    dut._log.info("11 edge-case jobs compared")


@cocotb.test()
async def changed_environment(dut):
    """New maps into the same engine without a reset: nothing of the previous job survives."""
    drv, rng = await _setup(dut)
    h, w = MID
    img = np.zeros((h, w), dtype=bool)
    img[2:4, 2:w - 2] = True
    goals, start = [(h - 1, w - 1)], (0, 0)
    _, m1, _ = await _check(drv, img, goals, start, 1)
    moved = np.zeros_like(img)
    moved[h - 4:h - 2, 2:w - 2] = True
    _, m2, _ = await _check(drv, moved, goals, start, 1)
    assert not np.array_equal(m1.distance, m2.distance)
    small = img[: h // 2, : w // 2]              # a smaller map: stale words around it
    _, m3, _ = await _check(drv, small, [(h // 2 - 1, 0)], (0, w // 2 - 1), 0)


@cocotb.test()
async def back_pressure(dut):
    """Random idle cycles on the map and goal streams, back-pressure on the results."""
    drv, rng = await _setup(dut)
    for n, (idle, bp) in enumerate(((0.4, 0.6), (0.0, 0.7), (0.7, 0.0))):
        shape = (MID[0], MAX_W) if n == 1 else (MID[0] // 2 + 1, MID[1])
        img, start, goals = _case(rng, shape, "random")
        drv.set_stalls(rng, idle, bp)
        _, model, raw = await _check(drv, img, goals, start, 0)
        assert (raw["starved"] > 0) == (idle > 0) and (raw["stalls"] > 0) == (bp > 0)
        assert raw["cycles"] == model.cycles + raw["starved"] + raw["stalls"] > model.cycles
    drv.set_stalls()


async def _idle_after_reset(drv):
    d = drv.dut
    await drv.reset()
    await ReadOnly()
    assert int(d.busy.value) == 0 and int(d.c_stream__ready.value) == 1
    assert int(d.o_stream__valid.value) == 0 and int(d.m_stream__ready.value) == 0
    assert int(d.g_stream__ready.value) == 0
    await RisingEdge(d.clk)


@cocotb.test()
async def reset_mid_job(dut):
    """A reset in the EDT, in the BFS and in the read-out; then the same job is exact."""
    drv, rng = await _setup(dut)
    img = FAMILIES["rooms"](rng, *MID)
    img[0, 0] = img[-1, -1] = False
    goals, start = [(MID[0] - 1, MID[1] - 1)], (0, 0)
    m = _model(img, goals, start, 0)
    c = m.stats["cycles"]
    marks = {"EDT": c["load"] + c["scan"] + c["edt"] // 2,
             "BFS": c["load"] + c["scan"] + c["edt"] + c["goals"] + c["bfs"] // 2,
             "read-out": m.cycles - c["readout"] // 2}
    for phase, at in marks.items():
        assert await drv.job(img, goals, start, 0, abort_after=at) is None
        await _idle_after_reset(drv)
        await _check(drv, img, goals, start, 0)
    dut._log.info(f"reset in {', '.join(marks)}: the next job exact")


@cocotb.test()
async def refusals(dut):
    """Bad commands and points: the defined error responses."""
    drv, rng = await _setup(dut)
    img = FAMILIES["random"](rng, 4, 4, 0.2)
    for h, w in ((MAX_H + 1, 4), (4, MAX_W + 1), (0, 4), (4, 0)):
        if h >= 1 << drv.widths["height"] or w >= 1 << drv.widths["width"]:
            continue                            # not expressible in the command's fields
        raw = await drv.job(img, [], None, 0, height=h, width=w)
        assert raw["cmd_err"] == 1 and raw["cycles"] == 0 and raw["words_sent"] == 0 and not raw["beats"]
    img, start, goals = _case(rng, MID)
    h, w = img.shape
    # a start outside the map: no path, the rest as without a start
    model = _model(img, goals, None, 0)
    raw = await drv.job(img, goals, (h, 0), 0)
    assert raw["start_err"] == 1
    compare(drv.decode(raw, img.shape), model)
    # a goal outside the map: dropped (goal_err), its read's cycles (Timing.goal), the rest as without it
    model = _model(img, goals, start, 0)
    raw = await drv.job(img, goals + [(0, w)], start, 0)
    assert raw["goal_err"] == 1 and raw["start_err"] == 0
    got = drv.decode(raw, img.shape)
    got["cycles"] -= Timing().goal
    compare(got, model)
    # and a good job clears the flags
    _, _, raw = await _check(drv, img, goals, start, 0)


def _check_full_reads(st, before, img, model, start):
    """The store's reads of every field since ``before``: the read-out's words and one a path pixel
    (the start's alone without a path), but with the prefetch none for a step to a pixel of the word
    read (left or right inside it).  Returns those steps."""
    path = model.path or [start]
    inside = sum(r == r1 and c // T_C == c1 // T_C for (r, c), (r1, c1) in zip(path, path[1:]))
    full = st.full_reads - before - img.shape[0] * -(-img.shape[1] // T_C)
    assert full == len(path) - (inside if PREFETCH else 0), (full, len(path), inside)
    return inside


@cocotb.test(skip=not EXTERNAL)
async def external_store(dut):
    """The engine with its state outside (store="external") on the test's store
    (sim/rtl/state_store.py): with StateRam's timing the same results and
    cycles; with random latency and stalls on the store, idle cycles on the
    map and goals and back-pressure on the results the same results and
    trace in more cycles; a reset in mid-job with the slow store (what it
    still holds dropped), then an exact job."""
    drv, rng = await _setup(dut)
    st = drv.store
    assert st is not None, "the top has no state port"
    jobs = 0
    for shape in (MID, (_partial(2, MAX_H, T_R), _partial(2, MAX_W, T_C))):
        img, start, goals = _case(rng, shape)
        # StateRam's timing: cycle-exact; with the prefetch faster (the latency it hides)
        writes, full_reads = st.writes, st.full_reads
        _, model, raw = await _check(drv, img, goals, start, 0, cycles=not PREFETCH)
        if PREFETCH:
            assert raw["cycles"] < model.cycles, (raw["cycles"], model.cycles)
        _check_full_reads(st, full_reads, img, model, start)
        # the visits' writes: the model's words written, or fewer skipping the rows left clean
        h, w = img.shape
        visits = st.writes - writes - h * -(-w // T_C) - sum(
            1 for r, c in goals if 0 <= r < h and 0 <= c < w and model.cfr[r, c])     # load, roots
        full = model.stats["words_written"]
        assert visits < full if SKIP_CLEAN else visits == full, (visits, full)
        jobs += 1
    # a path along row 0 inside one word (the parent east before south-east): 5 steps inside
    img, start, goals = np.zeros(MID, dtype=bool), (0, 0), [(0, 5)]
    full_reads = st.full_reads
    _, model, _ = await _check(drv, img, goals, start, 0, cycles=not PREFETCH)
    assert _check_full_reads(st, full_reads, img, model, start) == 5
    jobs += 1
    st.set_timing(latency=2, extra=0.5, stall=0.3)
    drv.set_stalls(rng, 0.2, 0.3)
    for n in range(3):
        img, start, goals = _case(rng, MID if n else (MAX_H, MAX_W), "rooms" if n else "random")
        late, paused = st.late, st.rd.paused + st.wr.paused
        _, model, raw = await _check(drv, img, goals, start, n % 2, cycles=False)
        if not PREFETCH:            # (read ahead, the store's latency partly hides)
            assert raw["cycles"] > model.cycles + raw["starved"] + raw["stalls"], (raw["cycles"], model.cycles)
        assert st.late > late and st.rd.paused + st.wr.paused > paused     # the store's delays happened
        jobs += 1
    img, start, goals = _case(rng, MID, "rooms")
    m = _model(img, goals, start, 0)
    assert await drv.job(img, goals, start, 0, abort_after=m.cycles // 2) is None
    await _idle_after_reset(drv)
    st.set_timing()
    drv.set_stalls()
    await _check(drv, img, goals, start, 0, cycles=not PREFETCH)
    dut._log.info(f"{jobs + 1} jobs compared, {st.reads} reads, {st.writes} writes, {st.late} late answers")


@cocotb.test(skip=not DRAM)
async def dram_store(dut):
    """The engine with its state in a DRAM (store="dram": hdl/edt_bfs/dram_store.py
    on the controller's clock, hdl/edt_bfs/state_cdc.py crossing to it) on
    sim/rtl/native_dram.py clocked by dram_clk (DRAM_PERIOD_NS against the
    engine's 10 ns): the same results and visit trace as the model in more
    cycles, at a fast DRAM and at a slow one (random latency, stalls) with
    idle input and back-pressure; resets of the engine alone in mid-job while
    the DRAM still owes answers (which the crossing must drop), each
    followed by an exact job; no answer ever held back at the DRAM."""
    drv, rng = await _setup(dut)
    st = drv.store
    assert st is not None and hasattr(st, "ports"), "the top has no dram port"
    count = NativeCount(dut)        # the bench's count of native commands (scripts/bench_dram.py), checked here
    count.on = True
    count.start()

    jobs = 0
    for shape in (MID, (_partial(2, MAX_H, T_R), _partial(2, MAX_W, T_C))):
        img, start, goals = _case(rng, shape)
        states = _states(dut) if not jobs else None
        _, model, raw = await _check(drv, img, goals, start, 0, cycles=False)
        if not PREFETCH:            # (read ahead, the fast DRAM's latency may hide: fewer cycles)
            assert raw["cycles"] > model.cycles, (raw["cycles"], model.cycles)
        if states is not None:      # the DRAM costs in the load (its writes) and the reads, not in the iterations
            states.stop()
            got, ref = states.terms(), model.stats["cycle_terms"]
            assert sum(got.values()) == raw["cycles"] and got["load"] >= ref["load"], (got, ref, raw["cycles"])
            assert all(got[k] == ref[k] for k in ("scan", "level", "iterate")), (got, ref)
            assert PREFETCH or got["read"] > ref["read"], (got, ref)
        jobs += 1
    # A job without obstacles writes no EDT state: with skip_clean no A word at all (the store keeps the
    # load's obstacle bits on chip and answers the words no write changed from them, over the words the
    # jobs before wrote), without it the load writes every word's.
    lay = drv.dram_layout

    def a_writes():
        return sum(n for addr, n in st.write_at.items() if addr & ((1 << lay["kb"]) - 1) < lay["a"])

    def e_reads():
        return sum(n for addr, n in st.read_at.items() if addr & ((1 << lay["kb"]) - 1) >= lay["a"] + lay["b"])

    before, e_before = a_writes(), e_reads()
    await _check(drv, np.zeros(MID, dtype=bool), [(0, 5)], (MID[0] - 1, MID[1] - 1), 0, cycles=False)
    loaded = MID[0] * -(-MID[1] // T_C) * lay["a"]
    assert a_writes() - before == 0 if SKIP_CLEAN else a_writes() - before >= loaded, (a_writes() - before, loaded)
    # and its BFS reads its neighbours' edge pixels: from the E words the BFS writes wrote, or with
    # bfs_slots from the B words (the E words never written since the load: no E word read at all)
    assert e_reads() - e_before == 0 if BFS_SLOTS else e_reads() - e_before > 0, e_reads() - e_before
    jobs += 1
    st.set_timing(latency=6, extra=0.5, stall=0.3)
    drv.set_stalls(rng, 0.2, 0.3)
    for n in range(2):
        img, start, goals = _case(rng, MID, "rooms" if n else "random")
        late, paused = st.late, st.paused
        await _check(drv, img, goals, start, n % 2, cycles=False)
        assert st.late > late and st.paused > paused        # the DRAM's delays happened
        jobs += 1
    drv.set_stalls()
    img, start, goals = _case(rng, MID, "rooms")
    _, _, raw = await _check(drv, img, goals, start, 0, cycles=False)      # the job's length at this DRAM
    owed_reads = resets = 0
    while resets < 3 or (resets < 16 and owed_reads < 2):           # resets at random points, two with answers owed
        resets += 1
        assert await drv.job(img, goals, start, 0, abort_after=int(rng.integers(raw["cycles"] // 8,
                                                                                 raw["cycles"]))) is None
        owed_reads += st.reads > st.answered
        await _idle_after_reset(drv)
        await _check(drv, img, goals, start, 0, cycles=False)
        jobs += 1
    dut._log.info(f"{jobs} jobs compared, {st.reads} reads, {st.writes} writes, {st.late} late answers; "
                  f"{resets} resets, {owed_reads} with answers owed")
    assert owed_reads >= 2 and st.reads > 1000 and st.writes > 100
    await ClockCycles(dut.dram_clk, 100)            # the last writes reach the DRAM
    assert (count.reads, count.writes) == (st.reads, st.writes), (count.reads, count.writes, st.reads, st.writes)
    assert count.cycles * len(count.ports) > st.reads + st.writes
    # each read reads its edge word; with skip_clean the BFS visits' and the goals' skip the A words
    first, edge = (sum(n for addr, n in st.read_at.items() if addr & ((1 << lay["kb"]) - 1) == k)
                   for k in (0, lay["a"] + lay["b"]))
    if not BFS_SLOTS:       # (with bfs_slots they skip the edge word: the job without obstacles above)
        assert first < edge if SKIP_CLEAN else first == edge, (first, edge)
    used = [len(p.cmd.beats) for p in st.ports]
    assert len(used) == DRAM_PORTS and min(used) > 100, f"commands per native port: {used}"
    # LiteDRAM's native port does not wait for rdata.ready: an answer held back would be lost
    assert st.held_back == 0, f"{st.held_back} cycles an answer was held back"


def _params(p):
    return dict(zip(("t_r", "t_c", "max_h", "max_w", "store", "dram_ports", "prefetch", "skip_clean", "iter_cycles",
                     "bfs_slots"), p))


# One build per simulator and parameter set.  An 8x8 array on a 64x64 RAM on
# both simulators; on Verilator the bundled room-64-64-8 (64x64) and a 63x47
# map (the last row and column of tiles partial), on both thin maps along the
# RAM's full width and height and the other cases on 13x21 maps (2 x 3
# tiles, partial both ways).  Icarus simulates the 8x8 array slowly (every
# loaded window row wakes the cells around it: about 5 ms a cycle on the
# shared machine, against about 2 ms for Verilator's -O0 build, mostly
# cocotb), so there it runs the sized cases on small maps; the controller
# and stream cases run on Verilator at 8x8 and on Icarus with a non-square,
# non-power-of-two 3x5 array on a 23x67 RAM (constant divisions by reciprocal, partial
# tiles everywhere) whose cells register their MIN's winner (iter_cycles 2: two cycles an iteration).
# (sim, (t_r, t_c, max_h, max_w), random jobs, mid size, bundled maps, large, cocotb test filter or None)
SIZED = "bundled_and_random|edge_cases"
CASES = [
    ("verilator", (8, 8, 64, 64), 4, "13x21", "room-64-64-8", 1, None),
    ("icarus", (8, 8, 64, 64), 4, "13x21", "", 0, SIZED),
    ("icarus", (3, 5, 23, 67, "bram", 1, 0, 0, 2), 4, "11x17", "", 1, None),
]


@pytest.mark.parametrize("sim, params, jobs, mid, maps, large, only", CASES,
                         ids=[f"{s}-{p[0]}x{p[1]}-map{p[2]}x{p[3]}{'-sized' if o else ''}{'-iter2' if p[8:] else ''}"
                              for s, p, _, _, _, _, o in CASES])
def test_edt_tile_engine(sim, params, jobs, mid, maps, large, only):
    env = {"TILE_PARAMS": ",".join(map(str, params[:4])), "TILE_JOBS": jobs, "TILE_MID": mid, "TILE_MAPS": maps,
           "TILE_LARGE": large, "TILE_ITER": _params(params).get("iter_cycles", 1)}
    if only:
        env["COCOTB_TEST_FILTER"] = only
    ran = run("edt_tile_engine", _params(params), sim, "test_edt_tile_engine", env=env)
    # without a filter: the six, external_store and dram_store (skipped: a block-RAM top has neither port)
    assert ran == (len(only.split("|")) if only else 8), f"{ran} cocotb tests ran"


# The stores outside the engine: a 4x8 array (a power-of-two word) over maps up to 21x35 (partial
# tiles), its state on the state port (external: sim/rtl/state_store.py), without and with the
# prefetch and skip_clean, or in a DRAM behind DRAM_PORTS native ports on a clock of their own
# (dram: sim/rtl/native_dram.py), with both, on a 4x8 and a 2x8 array, and both with the cells' MIN
# winner registered (iter_cycles 2); the 4x8's DRAM with the edge pixels' BFS groups in the B words
# (bfs_slots), the 2x8's without.
STORE_CASES = {"external": (4, "external", 0, 0, 1), "external-prefetch1": (4, "external", 1, 0, 1),
               "external-prefetch2-skip": (4, "external", 2, 1, 1),
               "dram-prefetch2-skip-slots": (4, "dram", 2, 1, 1, 4, 1),
               "2x8-dram-prefetch2-skip": (2, "dram", 2, 1, 1), "external-prefetch2-skip-iter2": (4, "external", 2, 1, 2),
               "2x8-dram-1port": (2, "dram", 0, 0, 1, 1)}


@pytest.mark.parametrize("case", STORE_CASES.values(), ids=STORE_CASES)
@pytest.mark.parametrize("sim", ["icarus", "verilator"])
def test_edt_tile_engine_store(sim, case):
    t_r, store, prefetch, skip_clean, iter_cycles, *rest = case      # then the DRAM's ports (default 4), bfs_slots
    ports = rest[0] if rest else 4 if store == "dram" else 1
    bfs_slots = rest[1] if len(rest) > 1 else 0
    params = (t_r, 8, 21, 35, store, ports, prefetch, skip_clean, iter_cycles, bfs_slots)
    env = {"TILE_PARAMS": ",".join(map(str, params[:4])), "TILE_MID": "13x21", "TILE_STORE": store,
           "TILE_PREFETCH": prefetch, "TILE_SKIP_CLEAN": skip_clean, "TILE_ITER": iter_cycles,
           "TILE_DRAM_PORTS": ports, "TILE_BFS_SLOTS": bfs_slots, "COCOTB_TEST_FILTER": f"{store}_store"}
    assert run("edt_tile_engine", _params(params), sim, "test_edt_tile_engine", env=env) == 1
