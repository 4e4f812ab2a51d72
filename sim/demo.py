"""Demo: harmonic planning on a bundled benchmark map, model and RTL.

1. Load a Moving AI map and one of its scenarios (start, goal).
2. Golden model (models.harmonic.plan, the map as one block): relax the
   potential from zero until every node is stable, and raise the precision
   while local maxima remain (the paper's increasing-precision loop, section
   3.3.2 and the section 4 pseudo-code).  Free cells the goal cannot reach are walled off first: they
   would stay a zero plateau for ever.
3. Follow the gradient from the start (models.harmonic.trajectory) and
   compare the path with a plain BFS shortest path.
4. RTL: run the 3x6 Cluster (emitted Verilog, Icarus or Verilator through
   cocotb) on a window of the map on that path, from zero with the model's
   converged field as its fixed boundary, until the cluster itself reports
   stability; compare every iteration, the flags and the RAM read back with
   the model, bit for bit.
5. Write potential.png (field, path, window) and summary.txt / summary.json.

    python -m sim.demo [--map maps/room-32-32-4.map] [--out results/demo]
"""

import argparse
import json
import os
import sys
import tempfile
import time
from collections import deque
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from hdl.harmonic.cluster import COLS, ROWS  # noqa: E402
from models.harmonic import neighbours, one, plan, ram_image, step, trajectory  # noqa: E402
from sim.mapfile import load_map, load_scenarios  # noqa: E402

MOVES = ((-1, 0), (0, 1), (0, -1), (1, 0))


def bfs(free, source):
    """4-connected BFS distances from ``source`` (-1 where unreachable)."""
    dist = -np.ones(free.shape, dtype=int)
    dist[source] = 0
    queue = deque([source])
    while queue:
        r, c = queue.popleft()
        for dr, dc in MOVES:
            rr, cc = r + dr, c + dc
            if 0 <= rr < free.shape[0] and 0 <= cc < free.shape[1] and free[rr, cc] and dist[rr, cc] < 0:
                dist[rr, cc] = dist[r, c] + 1
                queue.append((rr, cc))
    return dist


def pick_window(free, path):
    """Top-left corner of the 3x6 window with the most free cells on the path."""
    on_path = np.zeros(free.shape, dtype=bool)
    on_path[tuple(np.array(path).T)] = True
    best, corner = -1, (0, 0)
    for r in range(free.shape[0] - ROWS + 1):
        for c in range(free.shape[1] - COLS + 1):
            score = 4 * on_path[r:r + ROWS, c:c + COLS].sum() + free[r:r + ROWS, c:c + COLS].sum()
            if score > best:
                best, corner = score, (r, c)
    return corner


def window_job(h, const, p, corner):
    """Initial words (free cells from 0) and boundary ring of one window."""
    r, c = corner
    padded = np.zeros((h.shape[0] + 2, h.shape[1] + 2), dtype=object)
    padded[1:-1, 1:-1] = h
    ring = padded[r:r + ROWS + 2, c:c + COLS + 2].copy()
    wc = const[r:r + ROWS, c:c + COLS].copy()
    wh = np.where(wc, h[r:r + ROWS, c:c + COLS], 0).astype(object)
    return wh, wc, ring


def run_rtl(wh, wc, ring, p, sim, max_iterations, work):
    """Run sim/cluster_window.py on the emitted Cluster; returns its result."""
    from tb.runner import run
    job, result = work / "job.json", work / "result.json"
    job.write_text(json.dumps({
        "p": p, "max_iterations": max_iterations,
        "h": [[int(v) for v in row] for row in wh],
        "const": wc.tolist(), "ring": [[int(v) for v in row] for row in ring],
    }))
    run("harmonic_cluster", {"depth": 1024}, sim, "sim.cluster_window",
        env={"HARMONIC_JOB": job, "HARMONIC_RESULT": result}, log_file=work / "sim.log")
    return json.loads(result.read_text())


def compare_rtl(result, wh, wc, ring, p):
    """Replay the RTL's commands on the model; returns (mismatches, iterations, final h)."""
    h, const = wh, wc
    mismatches = []
    n_update = sum(not c for c in result["checked"])
    for k, words in enumerate(result["words"]):
        if not ((np.array(words["h"], dtype=object) == h).all() and (np.array(words["const"]) == const).all()):
            mismatches.append(f"words read by iteration {k}")
        enable = not result["checked"][k]
        h_next, c_next, stable, maximum = step(h, const, p, neighbours(h, ring), enable=enable)
        if np.array(result["stable"][k]).tolist() != stable.tolist():
            mismatches.append(f"stable flags of iteration {k}")
        if not enable and np.array(result["local_max"][k]).tolist() != maximum.tolist():
            mismatches.append(f"local-max flags of iteration {k}")
        if result["done_cycles"][k] != (k + 1) * (p + 2) + 4:
            mismatches.append(f"iteration {k} timing: {result['done_cycles'][k]} cycles")
        h, const = h_next, c_next
    if result["readback"] != ram_image(h, const, p):
        mismatches.append("RAM read back after the run")
    return mismatches, n_update, h


def plot(path_png, obstacle, h, p, path, goal, corner, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    values = np.array([[float(v) / one(p) for v in row] for row in h])
    field = np.where(obstacle, np.nan, np.log10(np.maximum(values, 2.0 ** -p)))
    fig, ax = plt.subplots(figsize=(7, 6.8))
    ax.set_facecolor("black")
    im = ax.imshow(field, cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=ax, label="log10 potential (goal = 1)")
    pr, pc = np.array(path).T
    ax.plot(pc, pr, color="white", lw=1.5, label="gradient ascent")
    ax.plot(pc[0], pr[0], "o", color="tab:orange", label="start")
    ax.plot(goal[1], goal[0], "*", color="red", ms=14, label="goal")
    ax.add_patch(Rectangle((corner[1] - 0.5, corner[0] - 0.5), COLS, ROWS, fill=False,
                           ec="tab:red", lw=2, label="3x6 cluster window (RTL)"))
    ax.set_title(title, fontsize=9)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=4, fontsize=7, frameon=False)
    fig.tight_layout()
    fig.savefig(path_png, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--map", default=str(ROOT / "maps" / "room-32-32-4.map"))
    ap.add_argument("--scen", help="scenario file (default: the map's *-even-10.scen)")
    ap.add_argument("--index", type=int, default=-1, help="scenario line (default: the longest)")
    ap.add_argument("--p0", type=int, default=16, help="initial precision")
    ap.add_argument("--p-step", type=int, default=16, help="precision increase per level")
    ap.add_argument("--p-max", type=int, default=256, help="largest precision tried")
    ap.add_argument("--sim", default="icarus", choices=("icarus", "verilator"))
    ap.add_argument("--no-rtl", action="store_true", help="skip the cluster RTL run")
    ap.add_argument("--out", default=str(ROOT / "results" / "demo"))
    args = ap.parse_args(argv)

    t_start = time.time()
    obstacle = load_map(args.map)
    scen_path = Path(args.scen) if args.scen else Path(args.map).with_name(Path(args.map).stem + "-even-10.scen")
    scenarios = load_scenarios(scen_path, obstacle)
    if not scenarios:
        raise SystemExit(f"{scen_path}: no scenario")
    scen = max(scenarios, key=lambda s: s.optimal_length) if args.index < 0 else scenarios[args.index]
    start, goal = scen.start, scen.goal

    free = ~obstacle
    dist = bfs(free, goal)
    walled = int((free & (dist < 0)).sum())
    if dist[start] < 0:
        raise SystemExit(f"start {start} cannot reach goal {goal}")
    obstacle = obstacle | (dist < 0)             # unreachable pockets become walls

    # The model's planner with the whole map as one block (so every level is
    # one Jacobi relaxation, counted until the sweep that finds it stable).
    res = plan(obstacle, [goal], block=obstacle.shape, iters=10**9,
               schedule=range(args.p0, args.p_max + 1, args.p_step))
    h, const, p = res.h, res.const, res.p
    levels = [{"p": lv["p"], "iterations": lv["block_iterations"], "local_maxima": lv["maxima"]}
              for lv in res.levels]
    t_model = time.time() - t_start
    path = trajectory(h, [goal], start).path
    reached = path[-1] == goal

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {
        "map": Path(args.map).name, "start": start, "goal": goal,
        "walled_unreachable_cells": walled, "levels": levels, "final_p": p,
        "model_seconds": round(t_model, 2),
        "path_reaches_goal": reached, "path_steps": len(path) - 1, "bfs_steps": int(dist[start]),
    }

    corner = pick_window(~obstacle, path)
    if not args.no_rtl:
        wh, wc, ring = window_job(h, const, p, corner)
        t0 = time.time()
        with tempfile.TemporaryDirectory() as work:
            result = run_rtl(wh, wc, ring, p, args.sim, 40 * (p + 8), Path(work))
        mismatches, n_update, h_win = compare_rtl(result, wh, wc, ring, p)
        global_win = h[corner[0]:corner[0] + ROWS, corner[1]:corner[1] + COLS]
        summary["rtl"] = {
            "simulator": args.sim, "window_top_left": corner, "p": p,
            "iterations": len(result["words"]), "update_iterations": n_update,
            "cycles_per_iteration": p + 2, "mismatches_vs_model": mismatches,
            "max_ulps_from_global_field": int(max(abs(int(a) - int(b)) for a, b in
                                                  zip(h_win.ravel(), global_win.ravel()))),
            "seconds": round(time.time() - t0, 1),
        }

    title = (f"{summary['map']}: harmonic potential at p={p}, "
             f"{'path reaches goal' if reached else 'path stuck'} in {len(path) - 1} steps "
             f"(BFS {dist[start]})")
    plot(out / "potential.png", obstacle, h, p, path, goal, corner, title)
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=str))
    lines = [
        f"map {summary['map']}  start {start}  goal {goal}  ({walled} unreachable free cells walled off)",
        "increasing precision (model):",
        *[f"  p={lv['p']:4d}: stable after {lv['iterations']:6d} iterations, "
          f"{lv['local_maxima']} local maxima" for lv in levels],
        f"gradient ascent: {'reaches the goal' if reached else 'STUCK'} in {len(path) - 1} steps; "
        f"BFS shortest path {dist[start]} steps",
    ]
    if "rtl" in summary:
        r = summary["rtl"]
        lines += [
            f"cluster RTL ({r['simulator']}) on the 3x6 window at {corner}, p={p}: "
            f"{r['iterations']} iterations ({r['update_iterations']} updates, {p + 2} cycles each)",
            f"  bit-exact against the model: {'yes' if not r['mismatches_vs_model'] else 'NO: ' + '; '.join(r['mismatches_vs_model'])}",
            f"  window fixed point vs the global field: at most {r['max_ulps_from_global_field']} ulp apart",
        ]
    lines.append(f"wrote {out / 'potential.png'}, {out / 'summary.txt'}, {out / 'summary.json'}")
    text = "\n".join(lines)
    (out / "summary.txt").write_text(text + "\n")
    print(text)
    ok = reached and ("rtl" not in summary or not summary["rtl"]["mismatches_vs_model"])
    return 0 if ok else 1


if __name__ == "__main__":
    os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")
    sys.exit(main())
