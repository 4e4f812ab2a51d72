"""Track a polygonal path with the fuzzy tracker (DFLC + strip-wise affine map) on a simulated Khepera II.

    python -m sim track PATH.csv [--engine model|icarus|verilator] [--speed V] [--lookahead S]
        [--slip S] [--seed N] [--start X,Y,THETA] [--map MAP [--cell METRES] [--unknown ...]]
        [--json OUT] [--plot OUT.png]

PATH.csv holds the chain's vertices: a header line, then one "x,y" row per
vertex, in metres; the chain must be strictly monotone (paper 003, section 3).
The robot starts on the first vertex heading along the first edge unless
--start X,Y,THETA (metres, metres, degrees; the angle is wrapped) is given;
a start whose projection lies past the path's end is refused (nothing to
track).  Each 12.5 ms control period the odometric pose goes through Ψ⁻¹,
the DFLC gives the canonical curvature, Ω and eq. 14 give the wheel speeds
(models/tracker.py).  --speed is 0.008..1 m/s (the Khepera II moves in steps
of 8 mm/s up to 1 m/s); a run needing more than 2,000,000 periods (7 h of
driving) is refused, one estimated at more than 10 minutes says so first,
and a terminal shows the periods as they go.

--map MAP puts the path in a map's frame (a ROS map's, with its resolution;
else the drawing frame at --cell, default 0.1 m): the true poses inside an
obstacle cell or off the map are counted (JSON "collisions") and the plot
draws the map.

--engine model runs the DFLC golden model; icarus / verilator run the DFLC RTL
in that simulator, one inference per control period (same curvature codes).

JSON keys: reached_end, steps, max_cross_track and rms_cross_track (metres,
true pose, after the approach phase: models/tracker.py defines it),
odometry_max_cross_track, approach_m, approach_steps (periods of the
approach), curvature (κ_p per period, 1/m), curvature_codes (DFLC output
codes), pose (true [x, y, θ] list), odometry; with --map also collisions and
frame.  --plot: the paths (the start dot where the robot starts, the approach
dotted) and the cross-track distance along the way.

Exit status: 0 the robot reached the end of the path (and, with --map, hit
nothing); 1 it did not; 2 bad input.
"""

import json
import math
from pathlib import Path

from navcores.models.navigation import collisions
from navcores.models.swam import Swam, SwamError
from navcores.models.tracker import wrap_degrees

from .cli import CliError, Once, add_map, finite_numbers, add_outputs, load_map_arg, write_text
from .tracking import add_drive_options, plot_track, read_path_csv, run_loop, tracker_params


def add_arguments(p):
    p.add_argument("path", metavar="PATH.csv", help="chain vertices: header line, then x,y rows (metres)")
    add_drive_options(p)
    p.add_argument("--start", metavar="X,Y,THETA", action=Once,
                   help="start pose: metres, metres, degrees (once; default: the first vertex, along the first edge)")
    add_map(p, option=True)
    add_outputs(p, plot_help="plot paths and cross-track distance")


def parse_start(text):
    pose = finite_numbers(text, 3)
    if pose is None:
        raise CliError(f"--start {text!r}: expected X,Y,THETA (metres, metres, degrees)")
    x, y, th = pose
    return x, y, math.radians(wrap_degrees(th))


def make_chain(vertices, params):
    try:
        chain = Swam(vertices)
    except SwamError as e:
        raise CliError(str(e)) from None
    if chain.length < 2 * params.lookahead:
        raise CliError(f"the path is {chain.length * 1e3:.1f} mm long, too short to track "
                       f"(at least two look-ahead distances, {2e3 * params.lookahead:.0f} mm)")
    return chain


def run(args):
    params = tracker_params(args)
    start = parse_start(args.start) if args.start else None
    vertices = read_path_csv(args.path)
    chain = make_chain(vertices, params)
    grid = frame = None
    if args.map:
        gm, frame = load_map_arg(args)
        grid = gm.obstacle
    elif args.cell is not None:
        raise CliError("--cell without --map: the cell size is a map's")
    result = run_loop([chain], args.engine, params, start=start, slip=args.slip, seed=args.seed,
                      prog="sim track")
    hit = 0
    if grid is not None:
        hit = collisions(result["pose"], grid, frame)
        result.update(collisions=hit, frame=frame.as_dict())
    mm = lambda v: "n/a" if v is None else f"{v * 1e3:.2f} mm"   # noqa: E731
    print(f"{Path(args.path).name}: {len(vertices)} vertices, {chain.length:.3f} m; engine {args.engine}; "
          f"speed {params.speed} m/s, look-ahead {params.lookahead} m, slip {args.slip}")
    print(f"  {'reached the end' if result['reached_end'] else 'did NOT reach the end'} after "
          f"{result['steps']} periods ({result['steps'] * 0.0125:.2f} s); approach phase {result['approach_m']:.3f} m")
    print(f"  cross-track after the approach: true max {mm(result['max_cross_track'])} "
          f"rms {mm(result['rms_cross_track'])}; odometry max {mm(result['odometry_max_cross_track'])}")
    if grid is not None:
        print(f"  map {Path(args.map).name}: {hit} true poses in an obstacle cell or off the map")
    if args.json:
        write_text(args.json, json.dumps(result))
    if args.plot:
        title = (f"{Path(args.path).name}, {args.engine}, slip {args.slip}: true max "
                 f"{mm(result['max_cross_track'])}, odometry max {mm(result['odometry_max_cross_track'])}")
        plot_track(args.plot, vertices, result, title, grid, frame)
    return 0 if result["reached_end"] and hit == 0 else 1
