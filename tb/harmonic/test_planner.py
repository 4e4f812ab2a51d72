"""The whole harmonic Planner RTL against models.harmonic.plan, bit-exact.

One build per parameter set (B = BR x BC blocks of n x m nodes), each on
Icarus and Verilator: ``b3x6`` (3x3 blocks of one cluster: every border
kind), ``b6x12`` (2x2 blocks of 6x12 nodes, four clusters each: the seams
between clusters inside a block; planner_maps only, Verilator at -O0) and
``b3x6_paper`` (the paper's schedule, ``Planner(paper_schedule=True)``
against ``plan(..., paper_schedule=True)``; planner_maps only).  The cocotb
tests drive only the host streams (sim/rtl/planner_driver.py):

* planner_maps: a corridor, a spiral and a random map: LOAD, START, poll
  STATUS to the end, READ every node: every stored value and constant flag
  equals the model's, and so do the final precision, converged, sweeps,
  block iterations, check iterations and the cycle count.  Then DIRECTION
  at every node of the map's edges, at the nodes next to block seams, at
  up to 24 nodes with ties among the Decision's terms and at random cells
  equals models.harmonic.decision (outside the map reads 0: the border
  nodes at the map's edge), and its response latency equals
  hdl.harmonic.planner.direction_latency(p, neighbours in the map).
* planner_dynamic: an obstacle added during a run (taken at the end of the
  pass the model's event names; the SET response's counters prove which),
  then an obstacle added after convergence (SET while idle, START): values,
  counters and cycles equal the model's.
* planner_bad_commands: a node outside the map (LOAD, SET, READ, DIRECTION),
  START with no goal, bad precisions, zero iterations, unknown ops, LOAD /
  READ / DIRECTION / START during a run: each gets its error code, and the
  run that follows still equals the model bit for bit (nothing corrupted).

Every test drives the host streams with random idle cycles before each
command and random back-pressure on the responses (seeded: SEED= replays),
and asserts that both happened.  The run's cycles are the planner's own
(the STATUS cycles field), so the stalls must not change them: they still
equal the model's.
"""

import json
import os
import random

import cocotb
import numpy as np
import pytest

from navcores.hdl.harmonic.planner import direction_latency
from navcores.hdl.params import unelaborated
from navcores.models.harmonic import decision, plan
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.planner_driver import Code, Op, PlannerDriver, arithmetic
from navcores.sim.rtl.planner_job import run_map
from navcores.sim.rtl.runner import SIMULATORS, run
from tb.harmonic.harmonic_fields import tie_kinds
from tb.harmonic.planner_maps import MAPS, random_map

SETS = {
    # 3x3 blocks of one cluster: every border kind (B+-1, B+-k, the map edge)
    "b3x6": dict(n=3, m=6, br=3, bc=3, p_max=16, depth=256),
    # 2x2 blocks of 6x12 nodes (4 clusters each: the seams between clusters
    # inside a block, and B+-1, B+-k, the map edge between blocks)
    "b6x12": dict(n=6, m=12, br=2, bc=2, p_max=12, depth=64),
    # the paper's schedule (Planner(paper_schedule=True)) on the b3x6 blocks
    "b3x6_paper": dict(n=3, m=6, br=3, bc=3, p_max=16, depth=256, paper_schedule=1),
}
# (map, schedule, I) per parameter set; schedules arithmetic, p <= p_max
RUNS = {
    "b3x6": [("corridor", (6, 12), 4), ("spiral", (6, 12), 2), ("random", (8, 16), 3)],
    "b6x12": [("corridor", (6, 12), 3), ("spiral", (6, 12), 4), ("random", (4, 8, 12), 2)],
    "b3x6_paper": [("spiral", (6, 12), 2), ("random", (8, 16), 3)],
}
# Icarus runs these runs of a set (indices into RUNS), Verilator all of them:
# Icarus simulates the 6x12 planner at a few hundred cycles a second, and
# these two maps still reach every DIRECTION kind planner_maps asserts (edge,
# seam, the three ties, the four triangles), which the test checks.
ICARUS_RUNS = {"b6x12": (0, 2)}
# Sets that run planner_maps only (the Control logic the other tests
# exercise is the same as b3x6's; these add the cluster seams inside a block
# and the paper's schedule).
MAPS_ONLY = ("b6x12", "b3x6_paper")
# Verilator builds the 6x12 planner's C++ at -O0: g++ -Os took 10+ minutes
# on the four clusters; the runs are short (12x24 map, p <= 12).
VERILATOR_ARGS = {"b6x12": ("-CFLAGS", "-O0")}
PARAMS = json.loads(os.environ.get("PLANNER_PARAMS", json.dumps(SETS["b3x6"])))
SET_NAME = os.environ.get("PLANNER_SET", "b3x6")
SET_RUNS = [RUNS[SET_NAME][int(i)] for i in os.environ["PLANNER_RUNS"].split(",")] \
    if os.environ.get("PLANNER_RUNS") else RUNS[SET_NAME]
PAPER = bool(PARAMS.get("paper_schedule", 0))


# stalls on the host streams: idle cycles before a command, ready low on the responses
IDLE, BACK_PRESSURE = 0.3, 0.5


def _driver(dut):
    P = PARAMS
    return PlannerDriver(dut, P["n"], P["m"], (P["br"], P["bc"]), P["p_max"],
                         rng=random.Random(cocotb.RANDOM_SEED), idle=IDLE, back_pressure=BACK_PRESSURE)


def _stalled(drv):
    """The commands waited idle cycles and the responses met back-pressure."""
    assert drv.cmd.idle > 0 and drv.resp.stalls > 0, (drv.cmd.idle, drv.resp.stalls)
    return f"{drv.commands} commands, {drv.cmd.idle} idle cycles, {drv.resp.stalls} response stalls"


def _shape():
    return PARAMS["br"] * PARAMS["n"], PARAMS["bc"] * PARAMS["m"]


def _padded(ob, goals):
    goal = np.zeros(ob.shape, dtype=bool)
    for r, c in goals:
        goal[r, c] = True
    return goal


async def _run(drv, ob, goals, sched, iters, events=()):
    """Model and RTL on one map; compare everything; return the model result."""
    P = PARAMS
    res = plan(ob, goals, block=(P["n"], P["m"]), iters=iters, schedule=sched, events=events,
               paper_schedule=PAPER)
    st, h, const = await run_map(drv, ob | res.unreachable, _padded(ob, goals), arithmetic(sched),
                                 iters, events)
    bad = np.argwhere((h != res.padded_h) | (const != res.padded_const))
    assert not len(bad), (f"{len(bad)} nodes differ, first {tuple(bad[0])}: RTL {h[tuple(bad[0])]} "
                          f"model {res.padded_h[tuple(bad[0])]}\nRTL\n{h}\nmodel\n{res.padded_h}")
    got = {k: int(st[k]) for k in ("p", "converged", "sweeps", "block_iterations",
                                   "check_iterations", "clear_passes", "cycles")}
    want = {"p": res.p, "converged": int(res.converged), "sweeps": res.sweeps,
            "block_iterations": res.block_iterations, "check_iterations": res.check_iterations,
            "clear_passes": res.clear_passes, "cycles": res.cycles}
    assert got == want, f"status {got}\nmodel  {want}"
    return res, h


@cocotb.test()
async def planner_maps(dut):
    await start(dut)
    drv = _driver(dut)
    rng = random.Random(cocotb.RANDOM_SEED)
    rows, cols = _shape()
    compared = 0
    seen = dict.fromkeys(("edge", "seam", "row_tie", "col_tie", "both_ties", "triangle_0", "triangle_1",
                          "triangle_2", "triangle_3"), 0)
    for name, sched, iters in SET_RUNS:
        ob, goals = MAPS[name](rows, cols, cocotb.RANDOM_SEED % 1000)
        res, h = await _run(drv, ob, goals, sched, iters)
        compared += h.size
        dut._log.info(f"{name} {rows}x{cols}, {sched}, I={iters}: p={res.p} converged={res.converged} "
                      f"sweeps={res.sweeps} block_iterations={res.block_iterations} "
                      f"cycles={res.cycles}: all {h.size} nodes equal")
        compared += await _directions(drv, res, name, rng, seen)
    dut._log.info(f"DIRECTION: {seen}")
    assert all(seen.values()), f"not exercised: {[k for k, v in seen.items() if not v]}"
    assert compared > len(SET_RUNS) * rows * cols
    dut._log.info(_stalled(drv))


async def _directions(drv, res, name, rng, seen):
    """DIRECTION at the map's edges (the border reads 0 there), next to the
    block seams (neighbours in other blocks), at up to 24 nodes with a tie
    among the Decision's terms and at random cells, against
    models.harmonic.decision, each with its response latency."""
    h, p = res.padded_h, res.p
    rows, cols = h.shape
    n, m = PARAMS["n"], PARAMS["m"]
    cells = {(r, c) for r, c in np.ndindex(rows, cols) if r in (0, rows - 1) or c in (0, cols - 1)}
    cells |= {(r, c) for r, c in np.ndindex(rows, cols) if r % n in (0, n - 1) and c % m in (0, m - 1)}
    ties = [(r, c) for r, c in np.ndindex(rows, cols) if any(tie_kinds(_around(h, r, c)).values())]
    cells |= set(rng.sample(ties, min(len(ties), 24)))
    cells |= {(rng.randrange(rows), rng.randrange(cols)) for _ in range(6)}
    for r, c in sorted(cells):
        b, x, y = drv.locate(r, c)
        resp = await drv.command(Op.DIRECTION, block=b, row=x, col=y)
        t, (gr, gc) = decision(h, r, c)
        assert resp["code"] == Code.OK
        got = (resp["triangle"], resp["g_row"], resp["g_col"], resp["value"])
        assert got == (t, gr, gc, h[r, c]), f"{name} ({r}, {c}): RTL {got} model {(t, gr, gc)}"
        inside = (r > 0) + (r < rows - 1) + (c > 0) + (c < cols - 1)
        assert drv.latency == direction_latency(p, inside), (
            f"{name} ({r}, {c}): DIRECTION took {drv.latency} cycles, expected {direction_latency(p, inside)}")
        seen["edge"] += inside < 4
        seen["seam"] += r % n in (0, n - 1) and c % m in (0, m - 1) and inside == 4
        for k, hit in tie_kinds(_around(h, r, c)).items():
            if k in seen:
                seen[k] += hit
        seen[f"triangle_{t}"] += 1
    return len(cells)


def _around(h, r, c):
    """{"c", "N", "E", "S", "W": value} at (r, c), 0 outside the map."""
    rows, cols = h.shape
    v = {"c": int(h[r, c])}
    for d, (dr, dc) in (("N", (-1, 0)), ("E", (0, 1)), ("S", (1, 0)), ("W", (0, -1))):
        rr, cc = r + dr, c + dc
        v[d] = int(h[rr, cc]) if 0 <= rr < rows and 0 <= cc < cols else 0
    return v


@cocotb.test(skip=SET_NAME in MAPS_ONLY)
async def planner_dynamic(dut):
    await start(dut)
    drv = _driver(dut)
    rows, cols = _shape()
    P = PARAMS
    # a map whose runs converge at p = 16 on the b3x6 set (~20K cycles each)
    sched, iters = ((8, 16) if P["p_max"] >= 16 else (6, 12)), 3
    ob, goals = random_map(rows, cols, 3, density=0.1)
    base = plan(ob, goals, block=(P["n"], P["m"]), iters=iters, schedule=sched, paper_schedule=PAPER)
    free = np.argwhere(~ob & ~base.unreachable & ~_padded(ob, goals))
    passes = base.sweeps + base.check_iterations // (P["br"] * P["bc"])
    s = min(3, passes - 1)
    cell = tuple(int(x) for x in free[len(free) // 3])
    goal2 = tuple(int(x) for x in free[-1])
    res, _ = await _run(drv, ob, goals, sched, iters,
                        events=[(s, cell, "obstacle"), (s + 2, goal2, "goal")])
    assert res.events_applied == 2 and res.clear_passes == 2
    if SET_NAME == "b3x6":
        assert res.converged, "the dynamic map is meant to converge (a converged run on the RTL)"
    dut._log.info(f"obstacle at {cell} taken at the end of pass {s - 1}, goal at {goal2} at the end "
                  f"of pass {s + 1}: equal, converged={res.converged}, {res.cycles} cycles")
    # After the run: an obstacle while idle, then a new run.
    ob2 = ob.copy()
    ob2[cell] = True
    goals = goals + [goal2]
    cell2 = tuple(int(x) for x in free[2 * len(free) // 3])
    # The idle SET clears at the last run's p = 16; the new run starts lower
    # (every word above the clear's bits is 0, so any schedule is valid).
    res2, _ = await _run(drv, ob2, goals, (4, 8), iters, events=[(0, cell2, "obstacle")])
    assert res2.events_applied == 1
    dut._log.info(f"obstacle at {cell2} after the run: equal, {res2.cycles} cycles")
    dut._log.info(_stalled(drv))


@cocotb.test(skip=SET_NAME in MAPS_ONLY)
async def planner_bad_commands(dut):
    await start(dut)
    drv = _driver(dut)
    P = PARAMS
    B, n, m, p_max = P["br"] * P["bc"], P["n"], P["m"], P["p_max"]
    checked = 0

    async def expect(code, op, **f):
        nonlocal checked
        resp = await drv.command(op, **f)
        assert resp["code"] == code, f"{op} {f}: {resp['code']}, expected {code}"
        checked += 1
        return resp

    await expect(Code.NO_GOAL, Op.START, p1=4, step=4, p_last=8, iters=2)
    for op in (Op.LOAD, Op.SET, Op.READ, Op.DIRECTION):
        for where in ({"block": B}, {"row": n}, {"col": m}):
            await expect(Code.BAD_NODE, op, **{"block": 0, "row": 0, "col": 0, **where})
    for raw in (6, 7):      # ops the layout can carry but the planner does not know
        await expect(Code.BAD_OP, raw, block=0)
    rows, cols = _shape()
    ob, goals = random_map(rows, cols, 3)
    sched, iters = (4, 8), 2
    res = plan(ob, goals, block=(n, m), iters=iters, schedule=sched, paper_schedule=PAPER)
    await drv.load_map(ob | res.unreachable, _padded(ob, goals))
    for f in ({"p1": 1, "step": 1, "p_last": 8}, {"p1": 4, "step": 4, "p_last": p_max + 1},
              {"p1": 8, "step": 4, "p_last": 4}, {"p1": 4, "step": 0, "p_last": 8}):
        await expect(Code.BAD_PRECISION, Op.START, iters=2, **f)
    await expect(Code.BAD_ITERS, Op.START, p1=4, step=4, p_last=8, iters=0)
    await expect(Code.OK, Op.START, p1=4, step=4, p_last=8, iters=iters)
    await expect(Code.BUSY, Op.LOAD, block=0, row=0, col=0, flags=(1 << 18) - 1)
    await expect(Code.BUSY, Op.READ, block=0, row=0, col=0)
    await expect(Code.BUSY, Op.DIRECTION, block=0, row=0, col=0)
    await expect(Code.BUSY, Op.START, p1=4, step=4, p_last=8, iters=2)
    await expect(Code.BAD_NODE, Op.SET, block=B, row=0, col=0)
    st = await drv.wait_idle()
    h, const = await drv.read_all(ob.shape)
    assert (h == res.padded_h).all() and (const == res.padded_const).all(), "a refused command changed the map"
    assert (st["cycles"], st["sweeps"], st["p"]) == (res.cycles, res.sweeps, res.p)
    dut._log.info(f"{checked} refused commands, each with its code; the run after them is exact")
    dut._log.info(_stalled(drv))


@pytest.mark.parametrize("sim", SIMULATORS)
@pytest.mark.parametrize("name", SETS)
def test_planner(sim, name):
    run("harmonic_planner", SETS[name], sim, "test_planner",
        env={"PLANNER_PARAMS": json.dumps(SETS[name]), "PLANNER_SET": name,
             "PLANNER_RUNS": ",".join(map(str, ICARUS_RUNS.get(name, ()))) if sim == "icarus" else ""},
        build_args=VERILATOR_ARGS.get(name, ()))


# --- elaboration (no simulation) ---

def test_block_elaborates_paper_sizes():
    """36x66 (paper 5.4: the XC2V6000 grid, 4 blocks at p = 254) and 48x96
    (Table 3) blocks elaborate: the block level (all clusters instantiated and
    wired, border and Early/Cvg trees) and one of its clusters.  A full
    recursive elaboration of 4608 nodes takes minutes: `make verilog` /
    scripts/synth.py cover emission at the tested sizes."""
    from amaranth.hdl import Fragment
    from navcores.hdl.harmonic.block import Block
    for n, m, blocks in ((36, 66, (2, 2)), (48, 96, (1, 1))):
        blk = Block(n, m, blocks, p_max=254, depth=1024)
        mod = blk.elaborate(None)
        assert (blk.CR, blk.CC) == (n // 3, m // 6)
        names = list(mod._named_submodules)
        assert sum(str(k).startswith("cluster_") for k in names) == (n // 3) * (m // 6)
        Fragment.get(mod._named_submodules["cluster_0_0"][0], None)
        unelaborated([blk, mod])    # elaborated by hand, at the block level only (and one cluster)


@pytest.mark.parametrize("kwargs,message", [
    (dict(n=6, m=12, blocks=(5, 4), p_max=62, depth=1024),
     "20 blocks at p_max=62 needs 20 \\* \\(p_max\\+2\\) = 1280 words per cluster RAM, but the RAM depth is 1024"),
    (dict(n=4, m=12), "block rows n=4: must be a positive multiple of 3"),
    (dict(n=6, m=10), "block columns m=10: must be a positive multiple of 6"),
    (dict(n=6, m=12, p_max=1), "p_max=1 is not supported"),
])
def test_block_refuses(kwargs, message):
    from navcores.hdl.harmonic.block import Block
    with pytest.raises(ValueError, match=message):
        Block(**kwargs)


def test_block_fits_exactly():
    from navcores.hdl.harmonic.block import Block
    assert unelaborated(Block(6, 12, (4, 4), p_max=62, depth=1024)).stride == 64      # 16 * 64 = 1024
