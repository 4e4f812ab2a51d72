"""Plan on a map and drive the plan: planner core -> polyline -> monotone chains -> fuzzy tracker.

1. Plan with the chosen core's golden model: ``harmonic`` (block-synchronous
   relaxation with increasing precision, models.harmonic.plan, then the
   steepest 4-neighbour ascent of the converged potential) or ``edt`` (EDT,
   collision-free region with --dfar, BFS and its path, models.edt_bfs).
2. Cells -> polyline in metres (cell centres, --cell metres per cell),
   shortened with line-of-sight checks that keep a quarter cell from every
   obstacle cell, split into maximal strictly monotone chains
   (models/navigation.py).
3. Track the chains one after another with the fuzzy tracker on a simulated
   Khepera II (models/tracker.py; --engine model or the DFLC RTL).

The map's cell (r, c) is the square [c, c+1) x [r, r+1) cells (y grows with
the row, as the map is drawn).  JSON: planner figures, chains (vertex lists),
reached_goal, collisions (true-pose samples in an obstacle cell), the
cross-track figures of ``sim track`` and the trajectories.  Exit status 0 when
the goal was reached without collision, 1 otherwise, 2 on bad input.
"""

import json
import math
import textwrap
from pathlib import Path

import numpy as np

from navcores.models.navigation import cell_centre, collisions, safe_cells, shorten, split_monotone
from navcores.models.swam import Swam
from navcores.models.tracker import TrackerParams

from .cli import CliError, check_cell, parse_cell
from navcores.models.maps import load_grid
from .tracking import ENGINES, run_loop

DEFAULT_SCHEDULE = "16,32,64,128,256"


def add_arguments(p):
    p.add_argument("map", metavar="MAP", help="map file (.map, .txt, .pgm, .png)")
    p.add_argument("--start", required=True, metavar="R,C", help="start cell")
    p.add_argument("--goal", required=True, metavar="R,C", help="goal cell")
    p.add_argument("--planner", default="harmonic", choices=("harmonic", "edt"))
    p.add_argument("--engine", default="model", choices=ENGINES, help="DFLC golden model or RTL simulator")
    p.add_argument("--cell", type=float, default=0.1, help="cell size, metres (default %(default)s)")
    p.add_argument("--speed", type=float, default=0.1, help="robot speed, m/s (default %(default)s)")
    p.add_argument("--lookahead", type=float, default=TrackerParams.lookahead,
                   help="tracker look-ahead, m (default %(default)s)")
    p.add_argument("--slip", type=float, default=0.0, help="wheel slip level (e.g. 0.02)")
    p.add_argument("--seed", type=int, default=0, help="slip noise seed")
    p.add_argument("--schedule", default=DEFAULT_SCHEDULE, help="harmonic: precisions (default %(default)s)")
    p.add_argument("--block", default="6,12", metavar="N,M", help="harmonic: block size (default %(default)s)")
    p.add_argument("--iters", type=int, default=6, help="harmonic: iterations per block visit")
    p.add_argument("--dfar", type=int, default=0, help="edt: collision-free region is distance > dfar")
    p.add_argument("--plot", metavar="OUT.png", help="map, field, plan and driven trajectory")
    p.add_argument("--json", metavar="OUT", help="write the run as JSON")


def _ints(text, what, n=None):
    try:
        vals = [int(v) for v in text.split(",")]
        if n is not None and len(vals) != n:
            raise ValueError
    except ValueError:
        raise CliError(f"{what} {text!r}: expected {'N,M' if n == 2 else 'comma-separated integers'}") from None
    return vals


def plan_harmonic(obstacle, start, goal, args):
    from navcores.models.harmonic import plan, reachable, trajectory
    if not reachable(obstacle, [goal])[start]:
        raise CliError(f"goal {goal} cannot be reached from start {start}")
    schedule = _ints(args.schedule, "--schedule")
    block = _ints(args.block, "--block", 2)
    try:
        res = plan(obstacle, [goal], block=tuple(block), iters=args.iters, schedule=schedule)
    except ValueError as e:
        raise CliError(str(e)) from None
    traj = trajectory(res.h, [goal], start)
    if not traj.reached_goal:
        raise CliError(f"gradient ascent stops at {traj.path[-1]} after {len(traj.path) - 1} steps "
                       f"(field not converged at p={res.p}, {res.maxima} local maxima): raise --schedule")
    with np.errstate(divide="ignore"):
        field = np.log10(np.maximum(res.potential(), 2.0 ** -res.p))
    figures = {"planner": "harmonic", "p": res.p, "converged": res.converged, "maxima": res.maxima,
               "sweeps": res.sweeps, "block_iterations": res.block_iterations, "cycles": res.cycles,
               "levels": res.levels, "path_cells": len(traj.path)}
    return traj.path, field, "log10 potential (goal = 1)", figures


def plan_edt(obstacle, start, goal, args):
    from navcores.models.edt_bfs import plan_path
    if args.dfar < 0:
        raise CliError(f"--dfar {args.dfar}: must be >= 0")
    res = plan_path(obstacle, [goal], start, args.dfar)
    if not res.cfr[goal]:
        raise CliError(f"goal {goal} is not in the collision-free region (distance > dfar={args.dfar})")
    if not res.cfr[start]:
        raise CliError(f"start {start} is not in the collision-free region (distance > dfar={args.dfar})")
    if not res.path_found:
        raise CliError(f"goal {goal} cannot be reached from start {start} in the collision-free region")
    field = np.where(res.distance < 0, np.nan, res.distance).astype(float)
    figures = {"planner": "edt", "dfar": args.dfar, "iterations_edt": res.iterations_edt,
               "iterations_bfs": res.iterations_bfs, "cycles": res.cycles, "path_cells": len(res.path)}
    return [tuple(int(v) for v in c) for c in res.path], field, "EDT distance (cells)", figures


def navigate(obstacle, start, goal, args):
    """Plan, build the chains, track; returns (result dict, field, field label, cells, polyline)."""
    if not args.cell > 0:
        raise CliError(f"--cell {args.cell}: must be > 0")
    if not (0 < args.speed <= 1.0):
        raise CliError(f"--speed {args.speed}: must be in (0, 1] m/s")
    if not args.lookahead > 0:
        raise CliError(f"--lookahead {args.lookahead}: must be > 0")
    if not (0 <= args.slip < 0.5):
        raise CliError(f"--slip {args.slip}: must be in [0, 0.5)")
    check_cell(obstacle, start, "start")
    check_cell(obstacle, goal, "goal")
    planner = plan_harmonic if args.planner == "harmonic" else plan_edt
    cells, field, label, figures = planner(obstacle, start, goal, args)
    cells = safe_cells(cells, obstacle)
    poly = shorten(cells, obstacle, args.cell)
    length = float(np.hypot(*np.diff(poly, axis=0).T).sum()) if len(poly) > 1 else 0.0
    params = TrackerParams(speed=args.speed, lookahead=args.lookahead)
    if length < 2 * params.lookahead:
        raise CliError(f"the planned path is {length * 1e3:.0f} mm long, too short to track "
                       f"(at least two look-ahead distances, {2e3 * params.lookahead:.0f} mm)")
    chains = [Swam(c) for c in split_monotone(poly)]
    first = poly[1] - poly[0]
    start_pose = (*poly[0], math.atan2(first[1], first[0]))
    result = run_loop(chains, args.engine, params, start=start_pose, slip=args.slip, seed=args.seed)
    true = np.array(result["pose"])
    gx, gy = cell_centre(goal, args.cell)
    end_err = float(np.hypot(true[-1, 0] - gx, true[-1, 1] - gy))
    result.update({
        "map_shape": list(obstacle.shape), "start": list(start), "goal": list(goal), "cell": args.cell,
        "planner_figures": figures, "polyline": poly.tolist(), "path_length": length,
        "chains": [c.vertices.tolist() for c in chains],
        "collisions": collisions(true, obstacle, args.cell),
        "odometry_collisions": collisions(np.array(result["odometry"]), obstacle, args.cell),
        "goal_distance": end_err,
        "reached_goal": bool(result["reached_end"] and end_err < args.cell),
    })
    return result, field, label, cells, poly


def plot_navigation(out, obstacle, field, label, cells, poly, result, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cell = result["cell"]
    H, W = obstacle.shape
    extent = (0, W * cell, H * cell, 0)
    fig, ax = plt.subplots(figsize=(7.2, 7.4))
    shown = np.where(obstacle, np.nan, field)
    im = ax.imshow(shown, cmap="viridis", extent=extent, interpolation="nearest")
    ax.imshow(np.where(obstacle, 1.0, np.nan), cmap="Greys", vmin=0, vmax=1, extent=extent,
              interpolation="nearest")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.03, label=label)
    cx = [(c + 0.5) * cell for _, c in cells]
    cy = [(r + 0.5) * cell for r, _ in cells]
    ax.plot(cx, cy, ":", color="silver", lw=1.2, label="planned cells")
    ax.plot(poly[:, 0], poly[:, 1], "--", color="black", lw=1.2, label="polyline (reference)")
    joints = np.array([ch[0] for ch in result["chains"]] + [result["chains"][-1][-1]])
    ax.plot(joints[:, 0], joints[:, 1], "s", color="black", ms=4, mfc="none", label="chain ends")
    odo = np.array(result["odometry"])
    true = np.array(result["pose"])
    ax.plot(odo[:, 0], odo[:, 1], color="tab:blue", lw=1.2, label="odometry")
    ax.plot(true[:, 0], true[:, 1], color="tab:red", lw=1.2, label="true pose")
    ax.plot(*poly[0], "o", color="tab:orange", ms=7, label="start")
    ax.plot(*poly[-1], "*", color="red", ms=13, label="goal")
    ax.set_xlim(0, W * cell)
    ax.set_ylim(H * cell, 0)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title, fontsize=8)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=4, fontsize=7, frameon=False)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
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
    obstacle = load_grid(args.map)
    start = parse_cell(args.start, "--start")
    goal = parse_cell(args.goal, "--goal")
    result, field, label, cells, poly = navigate(obstacle, start, goal, args)
    print(f"{Path(args.map).name} start {start} goal {goal}, cell {args.cell} m, engine {args.engine}, "
          f"slip {args.slip}")
    print("  " + summary_line(result))
    if args.json:
        Path(args.json).write_text(json.dumps(result, default=str))
    if args.plot:
        title = f"{Path(args.map).name}: {summary_line(result)}"
        plot_navigation(args.plot, obstacle, field, label, cells, poly, result,
                        textwrap.fill(title, 110))
    return 0 if result["reached_goal"] and result["collisions"] == 0 else 1
