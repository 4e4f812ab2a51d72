"""Benchmark: what the harmonic planner's schedule costs, and how many bits it needs.

All numbers come from the golden model (models.harmonic: plan, plan_explore),
whose cycle counts follow the planner RTL's timing table (a block visit of K
iterations at precision p costs K*(p+2) + VISIT_OVERHEAD cycles, a check pass
one iteration per block).

1. Paper 4.5.2 (Fig. 5-6): block-synchronous + increasing precision against
   one block at fixed p_max, on the labyrinth maze-32-32-2 and on
   random-32-32-10 (goal of the longest scenario).  p_max is the precision the
   increasing schedule ends at (the least of 16, 32, ... without local
   maxima), so both runs compute the same field (bit for bit: from below every
   schedule ends in the same fixed point).  The one block needs an array of
   the whole map's size, a block schedule an n x m array, so runs are compared
   by work = cycles x nodes of the array (node-cycles): the time ratio on
   equal hardware.  Then the schedule choices the paper leaves open: I, block
   size, precision step, block order, skipping still blocks.
2. Paper 3.2.2 (Fig. 3): bits of precision needed (least p whose fixed point
   has no local maximum, p scanned one by one) against the longest distance L
   to the goal, on the bundled maps, corridors and spirals.
3. The model's cycle count confirmed on the planner RTL for one small map
   (sim/rtl/planner_driver.py; --rtl none skips it).

    python scripts/bench_harmonic.py [--out build/bench/harmonic.md] [--rtl icarus|verilator|none]

make bench (scripts/bench.py) puts sections 1 and 2 into BENCHMARKS.md.
"""

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))       # tb/ (not installed): the test maps

from tb.harmonic.harmonic_small_maps import corridor, spiral  # noqa: E402
from navcores.models.harmonic import plan, plan_explore, reachable  # noqa: E402
from navcores.models.maps import load_map, longest_scenario  # noqa: E402

CLOCK_HZ = 150e6
RTL_BLOCK, RTL_ITERS = (6, 12), 6          # plan()'s defaults: a 2x2-cluster block


def bundled(name):
    """(obstacle, [goal]) with the goal of the map's job (models.maps.longest_scenario)."""
    path = ROOT / "maps" / name
    obstacle = load_map(path)
    return obstacle, [tuple(longest_scenario(path, obstacle).goal)]


def work(res, block):
    return res.cycles * block[0] * block[1]


def ideal(res, block):
    """Work without the RTL's per-visit costs (confirmation iteration, visit
    overhead, check passes): counted iterations x (p+2) x block nodes, the
    paper's own measure of Fig. 5."""
    return sum(lv["block_iterations"] * (lv["p"] + 2) for lv in res.levels) * block[0] * block[1]


def longest_distance(obstacle, goals):
    """Largest 4-connected BFS distance from a goal to a reachable free cell."""
    from collections import deque
    dist = -np.ones(obstacle.shape, dtype=int)
    queue = deque()
    for g in goals:
        dist[g] = 0
        queue.append(tuple(g))
    while queue:
        r, c = queue.popleft()
        for rr, cc in ((r - 1, c), (r, c + 1), (r, c - 1), (r + 1, c)):
            if 0 <= rr < obstacle.shape[0] and 0 <= cc < obstacle.shape[1] \
                    and not obstacle[rr, cc] and dist[rr, cc] < 0:
                dist[rr, cc] = dist[r, c] + 1
                queue.append((rr, cc))
    return int(dist.max())


# --- 1. cycles ---------------------------------------------------------------

def cycles_section(name):
    obstacle, goals = bundled(name)
    whole = obstacle.shape
    t0 = time.time()
    sched16 = tuple(range(16, 513, 16))
    ref = plan(obstacle, goals, block=RTL_BLOCK, iters=RTL_ITERS, schedule=sched16)
    p_max = ref.p
    base = plan(obstacle, goals, block=whole, iters=10**9, schedule=(p_max,))
    assert (base.h == ref.h).all(), "schedules must reach the same field"
    base_work = work(base, whole)
    rows = []

    def row(label, res, block, extra=""):
        if extra == "same_p=False":
            extra = "a finer field than the others"
        else:
            assert (res.h == ref.h).all() and res.p == p_max, label
        w = work(res, block)
        rows.append(f"| {label} | {block[0]}x{block[1]} | {res.p} | {res.sweeps} | {res.block_iterations} | "
                    f"{res.cycles} | {w / 1e6:.2f} | **{base_wk / w:.2f}** | "
                    f"{ideal(base, whole) / ideal(res, block):.2f} | {extra} |")
        return base_wk / w

    base_wk = base_work
    row("one block, fixed p_max (baseline)", base, whole)
    inc = list(range(16, p_max + 1, 16))
    # Without the increasing schedule the planner cannot know p_max in advance:
    # it would run at the schedule's top, 256, for example.
    row("one block, fixed p = 256 (p_max not known in advance)",
        plan(obstacle, goals, block=whole, iters=10**9, schedule=(256,)), whole, "same_p=False")
    row("one block, increasing 16:16", plan(obstacle, goals, block=whole, iters=10**9, schedule=inc), whole)
    row("RTL blocks, fixed p_max", plan(obstacle, goals, block=RTL_BLOCK, iters=RTL_ITERS,
                                        schedule=(p_max,)), RTL_BLOCK)
    paper = row("RTL blocks, increasing 16:16 (the paper's algorithm)", ref, RTL_BLOCK,
                f"I = {RTL_ITERS}")

    var = []

    def vrow(what, res, block, note=""):
        if res.p == p_max:
            assert (res.h == ref.h).all(), what
        else:       # a finer precision step may stop at a lower p
            note = (note + "; " if note else "") + f"ends at p = {res.p}"
        w = work(res, block)
        visits = res.sweeps * res.blocks[0] * res.blocks[1] - sum(lv.get("skipped", 0) for lv in res.levels)
        var.append((base_wk / w, f"| {what} | {res.cycles} | {w / 1e6:.2f} | {base_wk / w:.2f} | "
                                 f"{res.block_iterations / visits:.2f} | {note} |"))
        return base_wk / w

    # I, on the RTL block
    for it in (1, 2, 3, 4, 8, 16):
        vrow(f"6x12, I = {it}", plan(obstacle, goals, block=RTL_BLOCK, iters=it, schedule=inc), RTL_BLOCK)
    # block size (I = 2: the best I of the 6x12 rows on both maps, see the table)
    for blk in ((3, 6), (4, 4), (8, 8), (16, 16)):
        vrow(f"{blk[0]}x{blk[1]}, I = 2", plan(obstacle, goals, block=blk, iters=2, schedule=inc), blk)
    # precision step
    for step in (8, 32, 64):
        sched = list(range(step, p_max + 1, step))
        if not sched or sched[-1] != p_max:
            sched.append(p_max)
        vrow(f"6x12, I = 6, step {step}", plan(obstacle, goals, block=RTL_BLOCK, iters=RTL_ITERS,
                                               schedule=sched), RTL_BLOCK)
    # block order and skipping still blocks
    for blk, it in ((RTL_BLOCK, RTL_ITERS), ((3, 6), 2), ((4, 4), 2)):
        for order in ("raster", "serpentine", "alternate", "goal"):
            for skip in (False, True):
                if order == "raster" and not skip and blk == RTL_BLOCK:
                    continue                           # = the paper's row
                res = plan_explore(obstacle, goals, block=blk, iters=it, schedule=inc, order=order, skip=skip)
                skipped = sum(lv.get("skipped", 0) for lv in res.levels)
                vrow(f"{blk[0]}x{blk[1]}, I = {it}, order {order}{', skip still blocks' if skip else ''}",
                     res, blk, f"{skipped} visits skipped" if skip else "")
    best = plan_explore(obstacle, goals, block=(4, 4), iters=2, schedule=inc, order="goal", skip=True)
    for step in (8, 32):
        sched = list(range(step, p_max + 1, step))
        if not sched or sched[-1] != p_max:
            sched.append(p_max)
        vrow(f"4x4, I = 2, order goal, skip, step {step}",
             plan_explore(obstacle, goals, block=(4, 4), iters=2, schedule=sched, order="goal", skip=True), (4, 4))
    for it in (1, 3, 4):
        vrow(f"4x4, I = {it}, order goal, skip",
             plan_explore(obstacle, goals, block=(4, 4), iters=it, schedule=inc, order="goal", skip=True), (4, 4))
    vrow("8x8, I = 2, order goal, skip",
         plan_explore(obstacle, goals, block=(8, 8), iters=2, schedule=inc, order="goal", skip=True), (8, 8))

    seconds = time.time() - t0
    L = longest_distance(obstacle, goals)
    lines = [
        f"### {name} (goal {goals[0]}, longest distance L = {L}, p_max = {p_max})",
        "",
        "| run | block | final p | sweeps | block iterations | cycles | work (M node-cycles) | "
        "speed-up vs baseline (equal hardware) | speed-up without the per-visit costs | note |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        f"At {CLOCK_HZ / 1e6:.0f} MHz the paper's algorithm on the 6x12 array takes "
        f"{ref.cycles / CLOCK_HZ * 1e3:.2f} ms; the baseline on a {whole[0]}x{whole[1]} array "
        f"{base.cycles / CLOCK_HZ * 1e3:.3f} ms.",
        "",
        "Schedule variations (increasing 16:16 unless said; speed-up against the same baseline):",
        "",
        "| variation | cycles | work (M node-cycles) | speed-up | Î (iterations per block visit, Fig. 6) | note |",
        "|---|---|---|---|---|---|",
        *[text for _, text in var],
        "",
        f"Best variation: {max(var)[1].split('|')[1].strip()} ({max(var)[0]:.2f}x; "
        f"the paper's algorithm as the RTL runs it: {paper:.2f}x).  Model time {seconds:.0f} s.",
        "",
    ]
    return lines, {"map": name, "paper": paper, "best": max(var)[0], "best_what": max(var)[1].split('|')[1].strip(),
                   "skip_4x4": base_wk / work(best, (4, 4))}


# --- 2. bits needed ------------------------------------------------------------

def bits_needed(obstacle, goals, p_limit=1022):
    """Least p (scanned 2, 3, ...) whose fixed point has no local maximum.
    One block, the precision raised by one bit per level: every level ends in
    relax's fixed point at that p (the least fixed point), so this is the
    least p of the single-block planner."""
    res = plan(obstacle, goals, block=obstacle.shape, iters=10**9, schedule=range(2, p_limit + 1))
    return res.p if res.converged else None


def magnify(obstacle, goals, k):
    big = np.kron(obstacle, np.ones((k, k), dtype=bool)).astype(bool)
    return big, [(r * k, c * k) for r, c in goals]


def bits_section():
    cases = []
    for name in ("empty-16-16.map", "room-32-32-4.map", "random-32-32-10.map", "maze-32-32-2.map", "den312d.map"):
        cases.append((name, *bundled(name)))
    for name in ("room-32-32-4.map", "random-32-32-10.map"):
        ob, goals = bundled(name)
        cases.append((name + " x2", *magnify(ob, goals, 2)))
    for length in (8, 16, 32, 64):
        cases.append((f"corridor {length}", *corridor(length)))
    for size in (7, 11, 15, 19):
        cases.append((f"spiral {size}x{size}", *spiral(size)))
    rows = []
    for label, ob, goals in cases:
        t0 = time.time()
        p = bits_needed(ob, goals)
        L = longest_distance(ob, goals)
        n = int(reachable(ob, goals).sum())
        rows.append((label, ob.size, n, L, p, time.time() - t0))
    lines = [
        "| map | nodes | reachable free | longest distance L | bits needed p | log2(reachable) (Connolly) | "
        "p / log2(L) | p / L | model s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for label, size, n, L, p, s in rows:
        lines.append(f"| {label} | {size} | {n} | {L} | {p} | {math.log2(n):.1f} | "
                     f"{p / math.log2(L):.1f} | {p / L:.2f} | {s:.1f} |")
    return lines, rows


# --- 3. RTL confirmation -------------------------------------------------------

def rtl_section(sim):
    """The model's counters and cycles against the planner RTL on one small map
    (the planner regression's parameter sets, so the build is shared)."""
    from navcores.sim.rtl.planner_driver import run_planner_rtl
    rng = np.random.default_rng(5)
    shape, block, sched, iters = (8, 17), (3, 6), (8, 16), 3
    ob = rng.random(shape) < 0.2
    ob[0, :] = ob[:, 0] = False
    goals = [(0, 0)]
    t0 = time.time()
    model = plan(ob, goals, block=block, iters=iters, schedule=sched)
    out = run_planner_rtl(ob, goals, block, iters, sched, sim)
    keys = ("p", "converged", "sweeps", "block_iterations", "check_iterations", "cycles")
    same = all(int(out[k]) == int(getattr(model, k)) for k in keys) and (out["h"] == model.h).all()
    return [
        "| map | block | I | schedule | simulator | model cycles | RTL cycles | sweeps | block iterations | "
        "field and counters |",
        "|---|---|---|---|---|---|---|---|---|---|",
        f"| random {shape[0]}x{shape[1]} (padded) | {block[0]}x{block[1]} | {iters} | {sched} | {sim} | "
        f"{model.cycles} | {int(out['cycles'])} | {int(out['sweeps'])} | {int(out['block_iterations'])} | "
        f"{'identical' if same else 'DIFFERENT'} |",
        "",
        f"({time.time() - t0:.0f} s)",
        "",
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="build/bench/harmonic.md")
    ap.add_argument("--rtl", choices=("none", "icarus", "verilator"), default="icarus",
                    help="confirm the cycle count on the planner RTL for one small map (default icarus)")
    args = ap.parse_args()
    t0 = time.time()
    lines = [
        "# Harmonic planner benchmarks (model; cycles per the planner RTL's timing table)",
        "",
        "## 1. Block-synchronous + increasing precision against one block at fixed p_max (paper 4.5.2)",
        "",
        "Work = cycles x nodes of the array that runs the schedule (the one block needs the whole map as "
        "an array, the block schedule a 6x12 one; padding to whole blocks counted): the speed-up on equal "
        "hardware.  Every run below ends in the same field, bit for bit.  The paper claims 2 to 4.",
        "",
    ]
    summaries = []
    for name in ("maze-32-32-2.map", "random-32-32-10.map"):
        part, summary = cycles_section(name)
        lines += part
        summaries.append(summary)
        print("\n".join(part), flush=True)
    lines += ["Summary: " + "; ".join(
        f"{s['map']}: the paper's algorithm {s['paper']:.2f}x, best variation {s['best']:.2f}x ({s['best_what']})"
        for s in summaries), ""]
    lines += ["## 2. Bits of precision needed against the longest distance to the goal (paper 3.2.2, Fig. 3)", ""]
    part, _ = bits_section()
    lines += part + [""]
    print("\n".join(part), flush=True)
    if args.rtl != "none":
        try:
            part = rtl_section(args.rtl)
        except Exception as e:  # noqa: BLE001 - the report says what happened
            part = [f"The RTL run failed: {type(e).__name__}: {e}", ""]
        lines += ["## 3. The cycle count on the planner RTL", ""] + part
        print("\n".join(part), flush=True)
    lines.append(f"Bench time {time.time() - t0:.0f} s.")
    text = "\n".join(lines) + "\n"
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
