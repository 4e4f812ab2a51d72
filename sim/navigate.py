"""Plan on a map and drive the plan: planner core -> polyline -> monotone chains -> fuzzy tracker.

    python -m sim navigate MAP (--start R,C | --start-xy X,Y) (--goal R,C | --goal-xy X,Y)
        [--planner harmonic|edt] [--engine model|icarus|verilator] [--cell METRES] [--unknown ...]
        [--speed V] [--lookahead S] [--slip S] [--seed N]
        [--block NxM] [--schedule ...] [--iters I] [--dfar D] [--json OUT] [--csv OUT] [--plot OUT.png]

1. Plan with the chosen core's golden model: ``harmonic`` (block-synchronous
   relaxation with increasing precision, models.harmonic.plan, then the
   steepest 4-neighbour ascent of the converged potential) or ``edt`` (EDT,
   collision-free region with --dfar, BFS and its path, models.edt_bfs).
2. Cells -> polyline in metres (cell centres), shortened with line-of-sight
   checks that keep a quarter cell from every obstacle cell, split into
   maximal strictly monotone chains (models/navigation.py).
3. Track the chains one after another with the fuzzy tracker on a simulated
   Khepera II (models/tracker.py; --engine model or the DFLC RTL).

MAP as for `sim harmonic` (.map, .txt, .pgm/.png, or a ROS map's .yaml).
The drive happens in the map's frame: a ROS map's own (x right along the
image, y up, its origin and yaw, its resolution as the cell size), else the
drawing frame (cell (r, c) is the square [c, c+1) x [r, r+1) cells, y growing
with the row as the map is drawn, --cell metres a cell, default 0.1).  One
start and one goal, each as a cell or as a point in metres in that frame.
The harmonic options (--block, default 3x6; --schedule, default 16:16:256;
--iters, default 6) and the drive options (--speed 0.008..1 m/s, default
0.05; --lookahead; --slip; --seed) are spelt and defaulted as in `sim
harmonic` and `sim track`.  A drive needing more than 2,000,000 control
periods is refused; a plan or drive estimated at more than 10 minutes says
so first, and a terminal shows progress.

JSON: planner figures, cells (the planned path) and path_xy (its cell
centres in metres), polyline and chains (metres, map frame), reached_goal,
collisions (true-pose samples in an obstacle cell), the cross-track figures
of ``sim track``, the trajectories (pose, odometry: x, y, θ in the map
frame) and frame; --csv: the planned path as rows row,col,x,y.

Exit status: 0 the goal was reached without collision; 1 it was not (or
the planner found no path: no path in the cfr, the gradient ascent stuck);
2 bad input.
"""

import json
import math
import textwrap
from pathlib import Path

import numpy as np

from navcores.models.navigation import cell_centre, collisions, safe_cells, shorten, split_monotone
from navcores.models.swam import Swam

from .cli import (CliError, add_block, add_map, add_outputs, add_place, add_schedule, check_cell, integer,
                  load_map_arg, parse_block, parse_schedule, path_csv, path_xy, places, save_figure,
                  write_text)
from .harmonic import DEFAULT_BLOCK, DEFAULT_ITERS, DEFAULT_SCHEDULE, MAX_ITERS
from .harmonic import estimate as harmonic_estimate
from .progress import Progress, announce
from .tracking import add_drive_options, run_loop, tracker_params


class NoPath(CliError):
    """The planner ran and found no path: exit status 1 (not bad input)."""


def add_arguments(p):
    add_map(p)
    add_place(p, "start", required=True, help="start")
    add_place(p, "goal", required=True, help="goal")
    p.add_argument("--planner", default="harmonic", choices=("harmonic", "edt"))
    add_drive_options(p)
    add_block(p, DEFAULT_BLOCK)
    add_schedule(p, DEFAULT_SCHEDULE)
    p.add_argument("--iters", type=integer(1, MAX_ITERS, "the planner's START command carries I in 8 bits"),
                   default=DEFAULT_ITERS, metavar="I", help="harmonic: iterations per block visit (default %(default)s)")
    p.add_argument("--dfar", type=integer(0), default=0, metavar="D",
                   help="edt: the collision-free region is distance > D (default %(default)s)")
    add_outputs(p, csv=True, plot_help="map, field, plan and driven trajectory")


def plan_harmonic(obstacle, start, goal, args):
    from navcores.models.harmonic import plan, reachable, trajectory
    if not reachable(obstacle, [goal])[start]:
        raise NoPath(f"goal {goal} cannot be reached from start {start}")
    schedule = parse_schedule(args.schedule)
    block = parse_block(args.block)
    seconds, basis = harmonic_estimate(obstacle, [goal], "model")
    announce("sim navigate", seconds, f"the harmonic plan of {obstacle.shape[0]}x{obstacle.shape[1]}", basis)
    try:
        with Progress("harmonic plan (model)") as bar:
            res = plan(obstacle, [goal], block=block, iters=args.iters, schedule=schedule,
                       progress=lambda r, p, cycles: bar.update(note=f"p = {p}, {r.sweeps} sweeps"))
    except ValueError as e:
        raise CliError(str(e)) from None
    traj = trajectory(res.h, [goal], start)
    if not traj.reached_goal:
        raise NoPath(f"gradient ascent stops at {traj.path[-1]} after {len(traj.path) - 1} steps "
                     f"(field not converged at p={res.p}, {res.maxima} local maxima): raise --schedule")
    with np.errstate(divide="ignore"):
        field = np.log10(np.maximum(res.potential(), 2.0 ** -res.p))
    figures = {"planner": "harmonic", "p": res.p, "converged": res.converged, "maxima": res.maxima,
               "sweeps": res.sweeps, "block_iterations": res.block_iterations, "cycles": res.cycles,
               "levels": res.levels, "path_cells": len(traj.path)}
    return traj.path, field, "log10 potential (goal = 1)", figures


def plan_edt(obstacle, start, goal, args):
    from navcores.models.edt_bfs import plan_path
    with Progress("EDT/BFS plan (model)", unit="iterations") as bar:
        res = plan_path(obstacle, [goal], start, args.dfar, progress=lambda stage, k: bar.update(k, stage))
    if not res.cfr[goal]:
        raise NoPath(f"goal {goal} is not in the collision-free region (distance > dfar={args.dfar})")
    if not res.cfr[start]:
        raise NoPath(f"start {start} is not in the collision-free region (distance > dfar={args.dfar})")
    if not res.path_found:
        raise NoPath(f"goal {goal} cannot be reached from start {start} in the collision-free region")
    field = np.where(res.distance < 0, np.nan, res.distance).astype(float)
    figures = {"planner": "edt", "dfar": args.dfar, "iterations_edt": res.iterations_edt,
               "iterations_bfs": res.iterations_bfs, "cycles": res.cycles, "path_cells": len(res.path)}
    return [tuple(int(v) for v in c) for c in res.path], field, "EDT distance (cells)", figures


def navigate(obstacle, start, goal, args, frame=None, prog=None):
    """Plan, build the chains, track; returns (result dict, field, field label, cells, polyline).

    ``frame``: the map frame (default: the drawing frame at ``args.cell``);
    a CliError for bad input, a :class:`NoPath` when the planner finds none."""
    from navcores.models.maps import MapFrame
    if frame is None:
        frame = MapFrame.drawing(*obstacle.shape, args.cell)
    params = tracker_params(args)
    check_cell(obstacle, start, "start")
    check_cell(obstacle, goal, "goal")
    planner = plan_harmonic if args.planner == "harmonic" else plan_edt
    cells, field, label, figures = planner(obstacle, start, goal, args)
    cells = safe_cells(cells, obstacle)
    poly = shorten(cells, obstacle, frame)
    length = float(np.hypot(*np.diff(poly, axis=0).T).sum()) if len(poly) > 1 else 0.0
    if length < 2 * params.lookahead:
        raise CliError(f"the planned path is {length * 1e3:.0f} mm long, too short to track "
                       f"(at least two look-ahead distances, {2e3 * params.lookahead:.0f} mm)")
    chains = [Swam(c) for c in split_monotone(poly)]
    first = poly[1] - poly[0]
    start_pose = (*poly[0], math.atan2(first[1], first[0]))
    result = run_loop(chains, args.engine, params, start=start_pose, slip=args.slip, seed=args.seed, prog=prog)
    true = np.array(result["pose"])
    gx, gy = cell_centre(goal, frame)
    end_err = float(np.hypot(true[-1, 0] - gx, true[-1, 1] - gy))
    result.update({
        "map_shape": list(obstacle.shape), "start": list(start), "goal": list(goal), "cell": frame.resolution,
        "frame": frame.as_dict(), "start_xy": list(cell_centre(start, frame)), "goal_xy": [gx, gy],
        "planner_figures": figures, "cells": [list(c) for c in cells], "path_xy": path_xy(frame, cells),
        "polyline": poly.tolist(), "path_length": length,
        "chains": [c.vertices.tolist() for c in chains],
        "collisions": collisions(true, obstacle, frame),
        "odometry_collisions": collisions(np.array(result["odometry"]), obstacle, frame),
        "goal_distance": end_err,
        "reached_goal": bool(result["reached_end"] and end_err < frame.resolution),
    })
    return result, field, label, cells, poly


def plot_navigation(out, obstacle, field, label, cells, poly, result, title, frame=None):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    from navcores.models.maps import MapFrame
    frame = frame or MapFrame.drawing(*obstacle.shape, result["cell"])
    X, Y = frame.corners()
    fig, ax = plt.subplots(figsize=(7.2, 7.4))
    shown = np.where(obstacle, np.nan, field)
    im = ax.pcolormesh(X, Y, shown, cmap="viridis", shading="flat")
    ax.pcolormesh(X, Y, np.where(obstacle, 1.0, np.nan), cmap=ListedColormap(["#555555"]), shading="flat")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.03, label=label)
    cxy = np.array(path_xy(frame, cells))
    ax.plot(cxy[:, 0], cxy[:, 1], ":", color="silver", lw=1.2, label="planned cells")
    ax.plot(poly[:, 0], poly[:, 1], "--", color="black", lw=1.2, label="polyline (reference)")
    joints = np.array([ch[0] for ch in result["chains"]] + [result["chains"][-1][-1]])
    ax.plot(joints[:, 0], joints[:, 1], "s", color="black", ms=4, mfc="none", label="chain ends")
    odo = np.array(result["odometry"])
    true = np.array(result["pose"])
    ax.plot(odo[:, 0], odo[:, 1], color="tab:blue", lw=1.2, label="odometry")
    ax.plot(true[:, 0], true[:, 1], color="tab:red", lw=1.2, label="true pose")
    ax.plot(*true[0, :2], "o", color="tab:orange", ms=7, mec="black", label="start")
    ax.plot(*result["goal_xy"], "*", color="red", ms=13, label="goal")
    ax.set_xlim(X.min(), X.max())
    ax.set_ylim(Y.min(), Y.max())
    if not frame.y_up:
        ax.invert_yaxis()                   # the drawing frame: y grows down the map, as drawn
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title, fontsize=8)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=4, fontsize=7, frameon=False)
    fig.tight_layout()
    save_figure(fig, out, dpi=110)
    plt.close(fig)


def summary_line(result):
    f = result["planner_figures"]
    mm = lambda v: "n/a" if v is None else f"{v * 1e3:.1f} mm"   # noqa: E731
    return (f"{f['planner']}: {f['path_cells']} cells -> {len(result['polyline'])} vertices, "
            f"{result['path_length']:.2f} m, {len(result['chains'])} chains; "
            f"{'reached the goal' if result['reached_goal'] else 'did NOT reach the goal'} in "
            f"{result['steps']} periods ({result['steps'] * 0.0125:.1f} s), {result['collisions']} collisions; "
            f"cross-track true max {mm(result['max_cross_track'])} rms {mm(result['rms_cross_track'])}, "
            f"odometry max {mm(result['odometry_max_cross_track'])}")


def run(args):
    gm, frame = load_map_arg(args)
    obstacle = gm.obstacle
    start = places(args, "start", obstacle, frame)
    goal = places(args, "goal", obstacle, frame)
    for role, given in (("start", start), ("goal", goal)):
        if not given:
            raise CliError(f"no {role}: give --{role} R,C or --{role}-xy X,Y")
    start, goal = start[0], goal[0]
    try:
        result, field, label, cells, poly = navigate(obstacle, start, goal, args, frame, prog="sim navigate")
    except NoPath as e:
        print(f"{Path(args.map).name} start {start} goal {goal}: NO PATH: {e}")
        return 1
    print(f"{Path(args.map).name} start {start} goal {goal}, cell {frame.resolution:g} m, engine {args.engine}, "
          f"slip {args.slip}")
    print("  " + summary_line(result))
    if args.json:
        write_text(args.json, json.dumps(result, default=str))
    if args.csv:
        write_text(args.csv, "\n".join(["row,col,x,y", *path_csv(frame, cells)]) + "\n")
    if args.plot:
        title = f"{Path(args.map).name}: {summary_line(result)}"
        plot_navigation(args.plot, obstacle, field, label, cells, poly, result, textwrap.fill(title, 110), frame)
    return 0 if result["reached_goal"] and result["collisions"] == 0 else 1
