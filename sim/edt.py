"""EDT/NNT + BFS path planning on a map (paper 004): distance map, cfr, path.

    python -m sim edt MAP --dfar D (--goal R,C | --goal-xy X,Y) [...] [--start R,C | --start-xy X,Y]
        [--engine model|icarus|verilator|serial:PORT[@BAUD]] [--cell METRES] [--unknown obstacle|free]
        [--json OUT] [--csv OUT] [--plot OUT.png]

Runs Parallel_Path_Plan on MAP (.map, .txt, .pgm/.png or a ROS map's .yaml,
as for `sim harmonic`): the Euclidean distance transform with nearest
obstacles, the collision-free region (integer distance d_i > --dfar), a BFS
from the goal(s) (repeatable) and the path from the one start to the
nearest goal.  --engine model uses models/edt_bfs.py; icarus / verilator run
the RTL core (an array as large as the map, built on demand; at most 32x32
= 1024 cells on Icarus and 16x16 = 256 on Verilator, whose build grows with
the cell count) and check it against the model; serial:PORT[@BAUD] runs the
job on a board with the EDT/BFS bitstream (make bitstream CORE=edt_bfs;
the map must be the size of its array, 8x8 on the ULX3S-85F) and checks
it against the model.  Start and goal may lie on
an obstacle (the core takes any pixel): there is then no path.  The model's
work grows with the cells times the iterations (about the map's height plus
width): a run estimated at more than 10 minutes says so first, and a
terminal shows the iterations as they go.

JSON (--json): height, width, engine, iterations_edt, iterations_bfs, cycles,
distance (d_i; 0 on obstacles, -1 where never reached, i.e. a map without
obstacles), nearest ([r, c] of the nearest obstacle, null where none), cfr
(0/1), path ([r, c] from start to goal), path_xy (the path in metres in the
map frame), path_found, frame, rtl_matches_model (RTL and serial engines); --csv: the
path as rows row,col,x,y; --plot: the distance map (obstacles and
unreached cells in their own colours) and the cfr with the path.

Exit status: 0 done (a path found, or no start given); 1 ran, but no path
from the start (no path in the cfr, or start or goal on an obstacle or
outside the cfr), or an RTL engine or the board differs from the model; 2
bad input (for the serial engine also a port or a board that does not
answer, runs another core or an array of another size).
"""

import json
import tempfile
from pathlib import Path

import numpy as np

from navcores.models.edt_bfs import plan_path, widths

from . import serial_engine
from .cli import (CliError, add_engine, add_map, add_outputs, add_place, integer, load_map_arg, path_csv,
                  path_xy, places, save_figure, write_text)
from .progress import Progress, Ticker, announce

RTL_LIMIT = {"icarus": 1024, "verilator": 256}     # cells
MIN_SIDE = 3
# measured on maze512-1-0 and den312d: 65..100 ns a cell and iteration (the
# model's numpy planes); iterations: about the height plus width (EDT: the
# largest distance, BFS: the longest path), at least.
NS_PER_CELL_ITERATION = 80.0


def add_arguments(p):
    add_map(p)
    p.add_argument("--dfar", type=integer(0), required=True, metavar="D",
                   help="d_far: robot radius in pixels (cfr: d_i > d_far)")
    add_place(p, "goal", many=True, required=True, help="goal")
    add_place(p, "start", help="start (without it: no path read-out)")
    add_engine(p, "the EDT/BFS core's RTL in that simulator (maps up to 1024 / 256 cells)", serial=True)
    add_outputs(p, csv=True, plot_help="plot distance map, cfr and path")


def _check_args(args):
    if serial_engine.is_serial(args.engine):
        serial_engine.check(args.engine)        # the port exists, before any work
    gm, frame = load_map_arg(args)
    grid = gm.obstacle
    h, w = grid.shape
    k_di = widths(h, w)["k_di"]
    if args.dfar > k_di:
        raise CliError(f"--dfar {args.dfar}: no distance d_i of a {h}x{w} map exceeds {k_di} "
                       "(the largest, the diagonal's): every cell would be outside the cfr")
    goals = places(args, "goal", grid, frame, free=False)
    if not goals:
        raise CliError("no goal: give at least one --goal R,C or --goal-xy X,Y")
    starts = places(args, "start", grid, frame, free=False)
    if args.engine in RTL_LIMIT:
        if h * w > RTL_LIMIT[args.engine] or min(h, w) < MIN_SIDE:
            raise CliError(f"the map is {h}x{w}: --engine {args.engine} supports maps of {MIN_SIDE}x{MIN_SIDE} "
                           f"up to {RTL_LIMIT[args.engine]} cells (the array is as large as the map); "
                           f"use --engine model or a smaller map")
    return grid, frame, goals, starts[0] if starts else None


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
    """Distance map (obstacles and unreached cells outside the colour map)
    and the cfr with the path."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    dist = np.asarray(data["distance"], dtype=float)
    unreached = ~grid & (dist < 0)
    shown = np.where(grid | unreached, np.nan, dist)
    fig, axes = plt.subplots(1, 2, figsize=(11, 5.4))
    im = axes[0].imshow(shown, cmap="viridis", interpolation="nearest",
                        vmin=1, vmax=max(1.0, np.nanmax(shown)) if np.isfinite(shown).any() else 1)
    fig.colorbar(im, ax=axes[0], shrink=0.8, label="d_i (cells)")
    axes[0].imshow(np.where(grid, 1.0, np.nan), cmap=ListedColormap(["#d62728"]), interpolation="nearest")
    axes[0].imshow(np.where(unreached, 1.0, np.nan), cmap=ListedColormap(["#f4c2d7"]), interpolation="nearest")
    axes[0].set_title("integer distance d_i")
    handles = [Patch(color="#d62728", label="obstacle (d_i = 0)")]
    if unreached.any():
        handles.append(Patch(color="#f4c2d7", label="never reached (no obstacle)"))
    axes[0].legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.04), ncol=2, fontsize=8,
                   frameon=False)
    cfr = np.asarray(data["cfr"])
    axes[1].imshow(np.where(grid, 0, np.where(cfr, 2, 1)), cmap="Greys_r", vmin=0, vmax=2,
                   interpolation="nearest")
    axes[1].set_title(f"obstacles (black), d_i <= {dfar} (grey), cfr (white)")
    for ax in axes:
        if data["path"]:
            p = np.array(data["path"])
            ax.plot(p[:, 1], p[:, 0], color="tab:orange", lw=2)
        for g in goals:
            ax.plot(g[1], g[0], "*", color="tab:green", ms=12, mec="black")
        if start:
            ax.plot(start[1], start[0], "o", color="tab:blue", ms=7, mec="black")
    what = f"path of {len(data['path']) - 1} steps" if data["path_found"] else "no path" if start else "no start"
    fig.suptitle(f"{data['engine']}: {what}")
    fig.tight_layout()
    save_figure(fig, out, dpi=100)
    plt.close(fig)


def no_path_reason(grid, data, goals, start, dfar):
    """Why there is no path from ``start`` (one line)."""
    cfr = np.asarray(data["cfr"], dtype=bool)
    if grid[start]:
        return f"start {start} is on an obstacle"
    on = [g for g in goals if grid[g]]
    if len(on) == len(goals):
        return f"goal {on[0]} is on an obstacle" if len(on) == 1 else "every goal is on an obstacle"
    if not cfr[start]:
        return f"start {start} is not in the cfr (its distance d_i <= d_far = {dfar})"
    if not any(cfr[g] for g in goals):
        return f"no goal is in the cfr (distance d_i > d_far = {dfar})"
    return f"no goal can be reached from start {start} inside the cfr"


def run(args):
    grid, frame, goals, start = _check_args(args)
    h, w = grid.shape
    seconds = (h + w) * h * w * NS_PER_CELL_ITERATION * 1e-9
    announce("sim edt", seconds, f"the model on {h}x{w}",
             f"at least {h + w} iterations of {h * w} cells at {NS_PER_CELL_ITERATION:.0f} ns")
    with Progress("edt model", total=None, unit="iterations") as bar:
        model = plan_path(grid, goals, start, args.dfar,
                          progress=lambda stage, k: bar.update(k, f"{stage}"))
    data = to_json(model, "model", h, w)
    if serial_engine.is_serial(args.engine):
        with Ticker(f"EDT/BFS on the board ({args.engine})"):
            rtl = serial_engine.run_edt(args.engine, grid, goals, start, args.dfar)
    elif args.engine != "model":
        with Ticker(f"EDT/BFS RTL on {args.engine}"), tempfile.TemporaryDirectory(prefix="sim_edt_") as tmp:
            rtl = run_rtl(grid, goals, start, args.dfar, args.engine, Path(tmp))
    if args.engine != "model":
        data = to_json(rtl, args.engine, h, w)
        data["rtl_matches_model"] = bool(_matches(rtl, model))
    data["path_xy"] = path_xy(frame, data["path"])
    data["frame"] = frame.as_dict()
    found = data["path_found"]
    why = None if found or start is None else no_path_reason(grid, data, goals, start, args.dfar)
    print(f"{args.map}: {h}x{w}, engine {args.engine}: EDT {data['iterations_edt']} iterations, "
          f"BFS {data['iterations_bfs']} iterations, {data['cycles']} cycles; "
          + (f"path of {len(data['path']) - 1} steps to {tuple(data['path'][-1])}" if found
             else f"NO PATH: {why}" if start else "no start given"))
    if "rtl_matches_model" in data:
        print(f"RTL bit-exact against the model: {'yes' if data['rtl_matches_model'] else 'NO'}")
    if args.json:
        write_text(args.json, json.dumps(data))
    if args.csv:
        write_text(args.csv, "\n".join(["row,col,x,y", *path_csv(frame, data["path"])]) + "\n")
    if args.plot:
        plot(args.plot, grid, data, goals, start, args.dfar)
    return 0 if data.get("rtl_matches_model", True) and (found or start is None) else 1
