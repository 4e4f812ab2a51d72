"""EDT/NNT + BFS path planning on a map (paper 004): distance map, cfr, path.

    python -m sim edt MAP --dfar D (--goal R,C | --goal-xy X,Y) [...] [--start R,C | --start-xy X,Y]
        [--array RxC] [--engine model|icarus|verilator|serial:PORT[@BAUD]] [--cell METRES] [--unknown obstacle|free]
        [--json OUT] [--csv OUT] [--plot OUT.png]

Runs Parallel_Path_Plan on MAP (.map, .txt, .pgm/.png or a ROS map's .yaml,
as for `sim harmonic`): the Euclidean distance transform with nearest
obstacles, the collision-free region (integer distance d_i > --dfar), a BFS
from the goal(s) (repeatable) and the path from the one start to the
nearest goal.

--array RxC: the physical array of the paper's cells.  Default: the whole
map when it has at most 256 cells, else 8x8.  An array as large as the map
(or larger) is the paper's design: models/edt_bfs.py, and on icarus /
verilator the untiled core (built on demand at the map's size; at most
32x32 = 1024 cells on Icarus and 16x16 = 256 on Verilator, whose build
grows with the cell count).  A smaller array is the tile engine (issue
18): models/edt_bfs_tiled.py, and on icarus / verilator the tile engine's
RTL (hdl/edt_bfs/tile_engine.py, 2..32 cells a side, at most 256; its RAM
holds any map up to 2^20 pixels; one build per array and RAM size, the
RAM's sides powers of two from 64).  serial:PORT[@BAUD] runs the job on a
board with the EDT/BFS bitstream (make bitstream CORE=edt_bfs; the untiled
array, so the map must be the size of its array: 8x8 on the ULX3S-85F).  Results are the same either way (the
tiled engine's invariant); cycles and tile visits are the engine's.  The
RTL engines are checked against the model of the same array.  The
untiled model's work grows with the cells times the iterations (about the
map's height plus width), an RTL run with the simulated cycles: a run
estimated at more than 10 minutes says so first, and a terminal shows the
iterations or the tile visits as they go.

JSON (--json): height, width, engine, array ([rows, columns]), tile_visits
(null for the untiled array), iterations_edt, iterations_bfs, cycles (the
whole job: load, EDT, goals, BFS, path, map read-out), distance (d_i; 0 on
obstacles, -1 where never reached, i.e. a map without obstacles), nearest
([r, c] of the nearest obstacle, null where none), cfr (0/1), path ([r, c]
from start to goal), path_xy (the path in metres in the map frame),
path_found, frame, rtl_matches_model (RTL and serial engines); --csv: the path as rows
row,col,x,y; --plot: the distance map (obstacles and unreached cells in
their own colours) and the cfr with the path.

Exit status: 0 done (a path found, or no start given); 1 ran, but no path
from the start (no path in the cfr, or start or goal on an obstacle or
outside the cfr), or an RTL engine or the board differs from the model; 2
bad input (for the serial engine also a port or a board that does not
answer, runs another core or an array of another size).
"""

import argparse
import json
import re
import tempfile
from pathlib import Path

import numpy as np

from navcores.models.edt_bfs import plan_path, widths
from navcores.models.edt_bfs_tiled import plan_path_tiled

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
# The tile engine's RTL under cocotb, simulated cycles a second (8x8 array,
# 64x64 RAM, the shared 2-core machine at load 7: sim edt on room-64-64-8)
# and the build, for the estimate a long run announces.
CYCLES_PER_SECOND = {"icarus": 200.0, "verilator": 700.0}
BUILD_SECONDS = {"icarus": 90.0, "verilator": 240.0}
WHOLE_MAP_CELLS = 256       # --array's default: the whole map up to this many cells, else DEFAULT_ARRAY
DEFAULT_ARRAY = (8, 8)
RAM_SIDE = 64               # the tile engine's RAM: sides powers of two from this (shared builds)


def parse_array(text):
    """``RxC`` -> (R, C), both >= 1."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m or min(int(m[1]), int(m[2])) < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: expected RxC with R, C >= 1, e.g. 8x8")
    return int(m[1]), int(m[2])


def ram_for(h, w):
    """The tile engine's RAM (max_h, max_w) for an h x w map: powers of two
    from RAM_SIDE (one build serves many maps), the map's own size where
    those would exceed the engine's pixel limit."""
    from navcores.hdl.edt_bfs.tile_engine import MAX_PIXELS

    def side(n):
        s = RAM_SIDE
        while s < n:
            s *= 2
        return s
    ram = side(h), side(w)
    return ram if ram[0] * ram[1] <= MAX_PIXELS and max(ram) <= 4096 else (max(h, RAM_SIDE), max(w, RAM_SIDE))


def add_arguments(p):
    add_map(p)
    p.add_argument("--dfar", type=integer(0), required=True, metavar="D",
                   help="d_far: robot radius in pixels (cfr: d_i > d_far)")
    add_place(p, "goal", many=True, required=True, help="goal")
    add_place(p, "start", help="start (without it: no path read-out)")
    p.add_argument("--array", type=parse_array, metavar="RxC",
                   help="the physical array of cells (default: the whole map up to 256 cells, else 8x8); "
                        "smaller than the map: the tile engine")
    add_engine(p, "the RTL in that simulator: the untiled core (maps up to 1024 / 256 cells) or, with an "
                  "array smaller than the map, the tile engine (maps up to 2^20 pixels)", serial=True)
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
    serial = serial_engine.is_serial(args.engine)
    if serial and args.array and tuple(args.array) != (h, w):
        raise CliError(f"--array {args.array[0]}x{args.array[1]}: --engine {args.engine} runs the board's "
                       f"untiled array, as large as the map")
    # the board's array is untiled: it takes a map of its own size (it says so when asked)
    array = args.array or ((h, w) if h * w <= WHOLE_MAP_CELLS or serial else DEFAULT_ARRAY)
    tiled = array[0] < h or array[1] < w          # else the whole map is the array: the untiled design
    array = array if tiled else (h, w)
    if args.engine in RTL_LIMIT and not tiled:
        if h * w > RTL_LIMIT[args.engine] or min(h, w) < MIN_SIDE:
            raise CliError(f"the map is {h}x{w}: --engine {args.engine} with the whole map as the array supports "
                           f"maps of {MIN_SIDE}x{MIN_SIDE} up to {RTL_LIMIT[args.engine]} cells; "
                           f"use a smaller --array (the tile engine), --engine model or a smaller map")
    if args.engine in RTL_LIMIT and tiled:
        from navcores.hdl.edt_bfs.tile_engine import TileEngine
        from navcores.hdl.params import check
        try:
            check(TileEngine.PARAMS, TileEngine.CONSTRAINTS, t_r=array[0], t_c=array[1], max_h=max(h, RAM_SIDE),
                  max_w=max(w, RAM_SIDE))
        except ValueError as e:
            raise CliError(f"--array {array[0]}x{array[1]} on a {h}x{w} map: the tile engine's {e}") from None
    return grid, frame, goals, starts[0] if starts else None, array, tiled


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


def run_tile_rtl(grid, goals, start, dfar, array, sim, work, ticker=None):
    """Run sim/rtl/edt_tile_job.py on the tile engine (``array``, the RAM of
    :func:`ram_for`); returns its decoded result.  ``ticker``: a
    :class:`.progress.Ticker` whose line shows the tile visits."""
    from .rtl.runner import run
    job, result, progress = work / "job.json", work / "result.json", work / "progress"
    max_h, max_w = ram_for(*grid.shape)
    params = {"t_r": array[0], "t_c": array[1], "max_h": max_h, "max_w": max_w}
    job.write_text(json.dumps({"obstacle": grid.tolist(), "goals": [list(g) for g in goals],
                               "start": list(start) if start else None, "dfar": dfar, **params}))
    if ticker is not None:
        def poll():
            try:
                visits, cycles = progress.read_text().split()
            except (OSError, ValueError):
                return None
            return f"{visits} tile visits, {cycles} cycles"
        ticker.poll = poll
    run("edt_tile_engine", params, sim, "navcores.sim.rtl.edt_tile_job",
        env={"EDT_JOB": job, "EDT_RESULT": result, "EDT_PROGRESS": progress}, log_file=work / "sim.log")
    return json.loads(result.read_text())


def _matches(rtl, model):
    keys = ("distance", "nearest", "cfr", "parent", "visited")
    same = all(np.array_equal(np.asarray(rtl[k]), np.asarray(getattr(model, k))) for k in keys)
    tiles = "tile_visits" not in rtl or (rtl["tile_visits"] == model.tile_visits
                                         and [tuple(t) for t in rtl["trace"]] == list(model.trace))
    return (same and tiles and [tuple(p) for p in rtl["path"]] == model.path
            and rtl["iterations_edt"] == model.iterations_edt
            and rtl["iterations_bfs"] == model.iterations_bfs and rtl["cycles"] == model.cycles)


def to_json(res, engine, h, w, array):
    nearest = [[None if res_n[0] < 0 else [int(res_n[0]), int(res_n[1])] for res_n in row]
               for row in np.asarray(res["nearest"] if isinstance(res, dict) else res.nearest)]
    get = (lambda k: res[k]) if isinstance(res, dict) else (lambda k: getattr(res, k))
    return {
        "height": h, "width": w, "engine": engine, "array": list(array),
        "tile_visits": int(get("tile_visits")) if array != (h, w) else None,
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
    grid, frame, goals, start, array, tiled = _check_args(args)
    h, w = grid.shape
    if tiled:
        # the tiled model: seconds on 512x512 (scripts/bench_edt_tiled.py); its cost follows the wave
        with Progress("edt tiled model", total=None, unit="tile visits") as bar:
            model = plan_path_tiled(grid, goals, start, args.dfar, array=array, readout=True,
                                    progress=lambda phase, visits: bar.update(visits, phase))
    else:
        seconds = (h + w) * h * w * NS_PER_CELL_ITERATION * 1e-9
        announce("sim edt", seconds, f"the model on {h}x{w}",
                 f"at least {h + w} iterations of {h * w} cells at {NS_PER_CELL_ITERATION:.0f} ns")
        with Progress("edt model", total=None, unit="iterations") as bar:
            model = plan_path(grid, goals, start, args.dfar,
                              progress=lambda stage, k: bar.update(k, f"{stage}"))
    data = to_json(model, "model", h, w, array)
    if serial_engine.is_serial(args.engine):
        with Ticker(f"EDT/BFS on the board ({args.engine})"):
            rtl = serial_engine.run_edt(args.engine, grid, goals, start, args.dfar)
        data = to_json(rtl, args.engine, h, w, array)
    elif args.engine != "model":
        what = f"the {array[0]}x{array[1]} tile engine" if tiled else "the EDT/BFS core"
        if tiled:
            rate = CYCLES_PER_SECOND[args.engine] * 64 / (array[0] * array[1])
            announce("sim edt", BUILD_SECONDS[args.engine] + model.cycles / rate,
                     f"{what} on {args.engine}, {h}x{w}",
                     f"{model.cycles} cycles at about {rate:.0f} a second, and the build")
        with Ticker(f"EDT/BFS RTL ({what}) on {args.engine}") as ticker, \
                tempfile.TemporaryDirectory(prefix="sim_edt_") as tmp:
            if tiled:
                rtl = run_tile_rtl(grid, goals, start, args.dfar, array, args.engine, Path(tmp), ticker)
            else:
                rtl = run_rtl(grid, goals, start, args.dfar, args.engine, Path(tmp))
        data = to_json(rtl, args.engine, h, w, array)
    if args.engine != "model":
        data["rtl_matches_model"] = bool(_matches(rtl, model))
    data["path_xy"] = path_xy(frame, data["path"])
    data["frame"] = frame.as_dict()
    found = data["path_found"]
    why = None if found or start is None else no_path_reason(grid, data, goals, start, args.dfar)
    tiles = f"{data['tile_visits']} tile visits, " if tiled else ""
    print(f"{args.map}: {h}x{w}, engine {args.engine}, array {array[0]}x{array[1]}: EDT {data['iterations_edt']} "
          f"iterations, BFS {data['iterations_bfs']} iterations, {tiles}{data['cycles']} cycles; "
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
