"""Track a polygonal path with the fuzzy tracker (DFLC + strip-wise affine map) on a simulated Khepera II.

PATH.csv holds the chain's vertices: a header line, then one "x,y" row per
vertex, in metres; the chain must be strictly monotone (paper 003, section 3).
The robot starts on the first vertex heading along the first edge unless
--start X,Y,THETA (metres, metres, degrees) is given.  Each 12.5 ms control
period the odometric pose goes through Ψ⁻¹, the DFLC gives the canonical
curvature, Ω and eq. 14 give the wheel speeds (models/tracker.py).

--engine model runs the DFLC golden model; icarus / verilator run the DFLC RTL
in that simulator, one inference per control period (same curvature codes).

JSON keys: reached_end, steps, max_cross_track and rms_cross_track (metres,
true pose, after the approach phase: models/tracker.py defines it),
odometry_max_cross_track, approach_m, curvature (κ_p per period, 1/m),
curvature_codes (DFLC output codes), pose (true [x, y, θ] list), odometry.
Exit status 0 when the robot reached the end of the path, 1 when it did not.
"""

import json
import math
from pathlib import Path

from navcores.models.swam import Swam, SwamError
from navcores.models.tracker import TrackerParams

from .cli import CliError
from .tracking import ENGINES, plot_track, read_path_csv, run_loop


def add_arguments(p):
    p.add_argument("path", metavar="PATH.csv", help="chain vertices: header line, then x,y rows (metres)")
    p.add_argument("--engine", default="model", choices=ENGINES, help="DFLC golden model or RTL simulator")
    p.add_argument("--speed", type=float, default=TrackerParams.speed, help="linear speed, m/s (default %(default)s)")
    p.add_argument("--lookahead", type=float, default=TrackerParams.lookahead,
                   help="look-ahead distance, m (default %(default)s)")
    p.add_argument("--slip", type=float, default=0.0, help="wheel slip level s (relative, e.g. 0.01)")
    p.add_argument("--seed", type=int, default=0, help="slip noise seed")
    p.add_argument("--start", metavar="X,Y,THETA", help="start pose: metres, metres, degrees")
    p.add_argument("--json", metavar="OUT", help="write the run as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="plot paths and cross-track distance")


def parse_start(text):
    parts = text.split(",")
    try:
        if len(parts) != 3:
            raise ValueError
        x, y, th = (float(v) for v in parts)
        if not all(math.isfinite(v) for v in (x, y, th)):
            raise ValueError
    except ValueError:
        raise CliError(f"--start {text!r}: expected X,Y,THETA (metres, metres, degrees)") from None
    return x, y, math.radians(th)


def check_params(args):
    if not (0 < args.speed <= 1.0):
        raise CliError(f"--speed {args.speed}: must be in (0, 1] m/s (the Khepera II's top speed is 1 m/s)")
    if not args.lookahead > 0:
        raise CliError(f"--lookahead {args.lookahead}: must be > 0")
    if not (0 <= args.slip < 0.5):
        raise CliError(f"--slip {args.slip}: must be in [0, 0.5)")
    return TrackerParams(speed=args.speed, lookahead=args.lookahead)


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
    params = check_params(args)
    start = parse_start(args.start) if args.start else None
    vertices = read_path_csv(args.path)
    chain = make_chain(vertices, params)
    result = run_loop([chain], args.engine, params, start=start, slip=args.slip, seed=args.seed)
    mm = lambda v: "n/a" if v is None else f"{v * 1e3:.2f} mm"   # noqa: E731
    print(f"{Path(args.path).name}: {len(vertices)} vertices, {chain.length:.3f} m; engine {args.engine}; "
          f"speed {params.speed} m/s, look-ahead {params.lookahead} m, slip {args.slip}")
    print(f"  {'reached the end' if result['reached_end'] else 'did NOT reach the end'} after "
          f"{result['steps']} periods ({result['steps'] * 0.0125:.2f} s); approach phase {result['approach_m']:.3f} m")
    print(f"  cross-track after the approach: true max {mm(result['max_cross_track'])} "
          f"rms {mm(result['rms_cross_track'])}; odometry max {mm(result['odometry_max_cross_track'])}")
    if args.json:
        Path(args.json).write_text(json.dumps(result))
    if args.plot:
        title = (f"{Path(args.path).name}, {args.engine}, slip {args.slip}: true max "
                 f"{mm(result['max_cross_track'])}, odometry max {mm(result['odometry_max_cross_track'])}")
        plot_track(args.plot, vertices, result, title)
    return 0 if result["reached_end"] else 1
