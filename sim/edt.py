"""EDT/NNT + BFS path planning on a map (paper 004): distance map, cfr, path.

Runs Parallel_Path_Plan on MAP (.map, .txt, .pgm/.png as for `sim harmonic`):
the Euclidean distance transform with nearest obstacles, the collision-free
region (integer distance d_i > --dfar), a BFS from the goal(s) and the path
from --start to the nearest goal.  --engine model uses models/edt_bfs.py;
icarus / verilator run the RTL core (an array as large as the map, built on
demand; at most 32x32 = 1024 cells on Icarus and 16x16 = 256 on Verilator,
whose build grows with the cell count) and check it against the model.

JSON (--json): height, width, engine, iterations_edt, iterations_bfs, cycles,
distance (d_i; 0 on obstacles, -1 where never reached, i.e. a map without
obstacles), nearest ([r, c] of the nearest obstacle, null where none), cfr
(0/1), path ([r, c] from start to goal), path_found, rtl_matches_model (RTL
engines).
"""

import json
import tempfile
from pathlib import Path

import numpy as np

from navcores.models.edt_bfs import plan_path

from .cli import CliError, check_cell, parse_cell
from navcores.models.maps import load_grid

ENGINES = ("model", "icarus", "verilator")
RTL_LIMIT = {"icarus": 1024, "verilator": 256}     # cells
MIN_SIDE = 3


def add_arguments(p):
    p.add_argument("map", metavar="MAP", help="map file (.map, .txt, .pgm, .png)")
    p.add_argument("--dfar", type=int, required=True, help="d_far: robot radius in pixels (cfr: d_i > d_far)")
    p.add_argument("--goal", action="append", required=True, metavar="R,C", help="goal pixel (repeatable)")
    p.add_argument("--start", metavar="R,C", help="start pixel (without it: no path)")
    p.add_argument("--engine", choices=ENGINES, default="model", help="model (default), icarus or verilator")
    p.add_argument("--json", metavar="OUT", help="write the results as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="plot distance map, cfr and path")


def _check_args(args):
    grid = load_grid(args.map)
    if args.dfar < 0:
        raise CliError(f"--dfar {args.dfar}: must be >= 0")
    goals = [check_cell(grid, parse_cell(g, "--goal"), "goal", free=False) for g in args.goal]
    start = check_cell(grid, parse_cell(args.start, "--start"), "start", free=False) if args.start else None
    if args.engine != "model":
        h, w = grid.shape
        if h * w > RTL_LIMIT[args.engine] or min(h, w) < MIN_SIDE:
            raise CliError(f"the map is {h}x{w}: --engine {args.engine} supports maps of {MIN_SIDE}x{MIN_SIDE} "
                           f"up to {RTL_LIMIT[args.engine]} cells (the array is as large as the map); "
                           f"use --engine model or a smaller map")
    if args.plot and not args.plot.lower().endswith(".png"):
        raise CliError(f"--plot {args.plot}: expected a .png file name")
    return grid, goals, start


def run_rtl(grid, goals, start, dfar, sim, work):
    """Run sim/rtl/edt_bfs_job.py on the core at the map's size; returns its decoded result."""
    from .rtl.runner import run
    job, result = work / "job.json", work / "result.json"
    job.write_text(json.dumps({"obstacle": grid.tolist(), "goals": [list(g) for g in goals],
                               "start": list(start) if start else None, "dfar": dfar}))
    h, w = grid.shape
    run("edt_bfs", {"height": h, "width": w}, sim, "navcores.sim.rtl.edt_bfs_job",
        env={"EDT_JOB": job, "EDT_RESULT": result}, log_file=work / "sim.log")
    return json.loads(result.read_text())


def _matches(rtl, model):
    keys = ("distance", "nearest", "cfr", "parent", "visited")
    same = all(np.array_equal(np.asarray(rtl[k]), np.asarray(getattr(model, k))) for k in keys)
    return (same and [tuple(p) for p in rtl["path"]] == model.path
            and rtl["iterations_edt"] == model.iterations_edt
            and rtl["iterations_bfs"] == model.iterations_bfs and rtl["cycles"] == model.cycles)


def to_json(res, engine, h, w):
    nearest = [[None if res_n[0] < 0 else [int(res_n[0]), int(res_n[1])] for res_n in row]
               for row in np.asarray(res["nearest"] if isinstance(res, dict) else res.nearest)]
    get = (lambda k: res[k]) if isinstance(res, dict) else (lambda k: getattr(res, k))
    return {
        "height": h, "width": w, "engine": engine,
        "iterations_edt": int(get("iterations_edt")), "iterations_bfs": int(get("iterations_bfs")),
        "cycles": int(get("cycles")),
        "distance": np.asarray(get("distance")).astype(int).tolist(),
        "nearest": nearest,
        "cfr": np.asarray(get("cfr")).astype(int).tolist(),
        "path": [[int(r), int(c)] for r, c in get("path")],
        "path_found": bool(get("path_found")),
    }


def plot(out, grid, data, goals, start, dfar):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    dist = np.asarray(data["distance"], dtype=float)
    dist[dist < 0] = np.nan
    fig, axes = plt.subplots(1, 2, figsize=(11, 5))
    im = axes[0].imshow(dist, cmap="viridis")
    fig.colorbar(im, ax=axes[0], shrink=0.8, label="d_i")
    axes[0].set_title("integer distance d_i")
    cfr = np.asarray(data["cfr"])
    axes[1].imshow(np.where(grid, 0, np.where(cfr, 2, 1)), cmap="Greys_r", vmin=0, vmax=2)
    axes[1].set_title(f"obstacles (black), d_i <= {dfar} (grey), cfr (white)")
    for ax in axes:
        if data["path"]:
            p = np.array(data["path"])
            ax.plot(p[:, 1], p[:, 0], "r-", lw=2)
        for g in goals:
            ax.plot(g[1], g[0], "g*", ms=12)
        if start:
            ax.plot(start[1], start[0], "bo", ms=7)
    fig.suptitle(f"{data['engine']}: {'path of ' + str(len(data['path']) - 1) + ' steps' if data['path_found'] else 'no path'}")
    fig.tight_layout()
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)


def run(args):
    grid, goals, start = _check_args(args)
    h, w = grid.shape
    model = plan_path(grid, goals, start, args.dfar)
    if args.engine == "model":
        data = to_json(model, "model", h, w)
    else:
        with tempfile.TemporaryDirectory(prefix="sim_edt_") as tmp:
            rtl = run_rtl(grid, goals, start, args.dfar, args.engine, Path(tmp))
        data = to_json(rtl, args.engine, h, w)
        data["rtl_matches_model"] = bool(_matches(rtl, model))
    print(f"{args.map}: {h}x{w}, engine {args.engine}: EDT {data['iterations_edt']} iterations, "
          f"BFS {data['iterations_bfs']} iterations, {data['cycles']} cycles; "
          + (f"path of {len(data['path']) - 1} steps to {tuple(data['path'][-1])}" if data["path_found"]
             else "no path" if start else "no start given"))
    if "rtl_matches_model" in data:
        print(f"RTL bit-exact against the model: {'yes' if data['rtl_matches_model'] else 'NO'}")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(data))
    if args.plot:
        plot(args.plot, grid, data, goals, start, args.dfar)
    return 0 if data.get("rtl_matches_model", True) else 1
