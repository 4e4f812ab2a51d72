"""Demo (the main job): map -> plan -> track, with both planners, on a bundled benchmark map.

1. Load a Moving AI map and its longest scenario (start, goal).
2. Plan with each planner core's golden model: the harmonic planner
   (block-synchronous relaxation with increasing precision, then gradient
   ascent) and the EDT/BFS array (distance transform, collision-free region,
   BFS path).
3. Turn each cell path into a line-of-sight polyline, split it into strictly
   monotone chains and drive it with the fuzzy tracker (DFLC + strip-wise
   affine map) on a simulated Khepera II, without and with wheel slip
   (sim/navigate.py, models/tracker.py).  ``--engine icarus|verilator``
   runs the DFLC RTL in that simulator, one inference per control period, and
   checks that it commands the same curvature codes as the golden model (the
   runs without slip: slip does not change what the encoders, and so the
   controller, see, so the slip runs command the same codes and use the
   model).
4. Track paths/sine.csv (a curved path about 1 m long, like the paper's
   hand-drawn ones) without and with slip: the paper's section 8 experiment.
5. Write one plot per run (map, field, plan, driven trajectory; Fig. 13/14
   style for the sine path) and summary.txt / summary.json: planner figures,
   chains, collisions and the cross-track figures beside the paper's.

    python -m sim.demo [--out results/demo] [--engine model|icarus|verilator] [--map maps/room-32-32-4.map]

Exit status 0 when the runs without slip reached their goal with no collision
and, with an RTL engine, every run matched the model bit for bit.  (With slip
the true pose drifts away from the odometry the controller sees; over the
map's 5 m it may touch a wall: reported, not counted.)
"""

if __name__ == "__main__":
    # `python -m sim.demo` in a source tree, or `python -m navcores.sim.demo`:
    # run the module under its package name, so that every module is loaded
    # once, as navcores.sim.* (not a second time as the top-level sim's).
    import sys
    from navcores.sim.demo import cli
    sys.exit(cli())

import argparse
import json
import os
import textwrap
import sys
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]

from .cli import CliError  # noqa: E402
from navcores.models.maps import load_scenarios, longest_scenario  # noqa: E402

# The demo's planner settings (its summary's figures come from these): 6x12
# blocks (two clusters), I = 6, the doubling schedule 16, 32, ... 256.
DEMO_BLOCK, DEMO_ITERS, DEMO_SCHEDULE = "6x12", 6, "16,32,64,128,256"

def _mm(v):
    return "   n/a" if v is None else f"{v * 1e3:6.1f}"


def parser():
    from .cli import ENGINES, EXIT_STATUS, _Parser, integer, number
    from navcores.models.tracker import MAX_SLIP, MAX_SPEED, MIN_SPEED
    ap = _Parser(prog="python -m sim.demo", description=__doc__.split("\n\n")[0], epilog=EXIT_STATUS)
    ap.add_argument("--map", default=str(ROOT / "maps" / "room-32-32-4.map"),
                    help="map (default: maps/room-32-32-4.map)")
    ap.add_argument("--scen", help="scenario file (default: the map's *-even-*.scen)")
    ap.add_argument("--index", type=integer(-1), default=-1, help="scenario line, 0-based (default: the longest)")
    ap.add_argument("--engine", default="model", choices=ENGINES,
                    help="DFLC engine: golden model, or the RTL in Icarus / Verilator")
    ap.add_argument("--cell", type=number(0, 1000, lo_open=True, unit="m"), default=0.1,
                    help="cell size, metres (default 0.1; a ROS map gives its own)")
    ap.add_argument("--speed", type=number(MIN_SPEED, MAX_SPEED, unit="m/s"), default=0.1,
                    help="robot speed of the navigation runs, m/s (default 0.1)")
    ap.add_argument("--slip", type=number(0, MAX_SLIP), default=0.005,
                    help="wheel slip level of the navigation slip runs (default 0.005)")
    ap.add_argument("--track-slip", type=number(0, MAX_SLIP), default=0.02,
                    help="wheel slip level of the sine-path slip run (default 0.02)")
    ap.add_argument("--seed", type=integer(0, 2 ** 63 - 1), default=1, help="slip seed (default 1)")
    ap.add_argument("--out", default=str(ROOT / "results" / "demo"), help="output folder (default results/demo)")
    return ap


def main(argv=None):
    try:
        args = parser().parse_args(argv)
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else 2

    from navcores.models.maps import load
    from navcores.models.swam import Swam
    from navcores.models.tracker import TrackerParams, fired_rules
    from .cli import check_outputs, write_text
    from .navigate import navigate, plot_navigation, summary_line
    from .tracking import load_dflc, plot_track, read_path_csv, run_loop

    t_start = time.time()
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise CliError(f"--out {out}: is a file, expected a folder")
    # every file the demo writes, checked before any work (folder created, writable)
    check_outputs(argparse.Namespace(json=str(out / "summary.json"), plot=str(out / "track_sine.png")))
    gm = load(args.map)
    obstacle, frame = gm.obstacle, gm.frame_or(args.cell)
    if args.scen or args.index >= 0:
        scen_path = Path(args.scen) if args.scen else sorted(Path(args.map).parent.glob(
            Path(args.map).stem + "-even-*.scen"))[:1]
        if not scen_path:
            raise CliError(f"{args.map}: no scenario file beside it; give --scen")
        scen_path = scen_path if isinstance(scen_path, Path) else scen_path[0]
        scenarios = load_scenarios(scen_path, obstacle)
        if not scenarios:
            raise CliError(f"{scen_path}: no scenario")
        if args.index >= len(scenarios):
            raise CliError(f"--index {args.index}: {scen_path.name} has {len(scenarios)} scenarios (0..{len(scenarios) - 1})")
        scen = max(scenarios, key=lambda s: s.optimal_length) if args.index < 0 else scenarios[args.index]
    else:
        scen = longest_scenario(args.map, obstacle)
    start, goal = scen.start, scen.goal

    def rtl_check(result, rerun):
        # with an RTL engine, the same run with the golden model must command the same codes
        if args.engine != "model":
            result["bit_exact"] = rerun()["curvature_codes"] == result["curvature_codes"]

    runs = []
    for planner in ("harmonic", "edt"):
        for slip in (0.0, args.slip):
            # slip changes the ground, not what the encoders and so the controller see: a
            # slip run commands the codes of the run without slip (tb/track/test_track_loop.py),
            # so with an RTL engine only the runs without slip go through the simulator
            engine = args.engine if not slip else "model"
            nav = argparse.Namespace(planner=planner, engine=engine, cell=args.cell, speed=args.speed,
                                     lookahead=TrackerParams.lookahead, slip=slip, seed=args.seed,
                                     schedule=DEMO_SCHEDULE, block=DEMO_BLOCK, iters=DEMO_ITERS, dfar=0)
            t0 = time.time()
            result, field, label, cells, poly = navigate(obstacle, start, goal, nav, frame)
            result["seconds"] = round(time.time() - t0, 1)
            if engine != "model":
                rtl_check(result, lambda: navigate(obstacle, start, goal,
                                                   argparse.Namespace(**{**vars(nav), "engine": "model"}), frame)[0])
            name = f"navigate_{planner}" + ("_slip" if slip else "") + ".png"
            title = f"{Path(args.map).name}, slip {slip}, DFLC {engine}: {summary_line(result)}"
            plot_navigation(out / name, obstacle, field, label, cells, poly, result,
                            textwrap.fill(title, 115), frame)
            result["plot"] = name
            runs.append((planner, slip, result))

    # the paper's experiment: a hand-drawn-like curved path about 1 m long (paths/sine.csv)
    sine = read_path_csv(ROOT / "paths" / "sine.csv")
    tracks = []
    for slip in (0.0, args.track_slip):
        kw = dict(params=TrackerParams(speed=0.05), slip=slip, seed=args.seed)
        engine = args.engine if not slip else "model"
        result = run_loop([Swam(sine)], engine, **kw)
        if engine != "model":
            rtl_check(result, lambda: run_loop([Swam(sine)], "model", **kw))
        name = "track_sine" + ("_slip" if slip else "") + ".png"
        plot_track(out / name, sine, result,
                   f"paths/sine.csv, slip {slip}, DFLC {engine}: true max {_mm(result['max_cross_track'])} mm, "
                   f"odometry max {_mm(result['odometry_max_cross_track'])} mm")
        result["plot"] = name
        tracks.append((slip, result))

    length = (f"(scenario optimal length {scen.optimal_length:.1f} cells)" if scen.optimal_length == scen.optimal_length
              else "(no scenario: the first and last free cells)")
    lines = [f"map {Path(args.map).name}  start {start}  goal {goal}  cell {frame.resolution:g} m  {length}"]
    for planner, slip, r in runs:
        if slip:
            continue
        f = r["planner_figures"]
        if planner == "harmonic":
            lines.append(f"harmonic planner (model): p={f['p']} {'converged' if f['converged'] else 'NOT converged'} "
                         f"after {f['sweeps']} sweeps ({f['cycles']} RTL cycles); ascent {f['path_cells']} cells")
        else:
            lines.append(f"EDT/BFS planner (model): {f['iterations_edt']} EDT + {f['iterations_bfs']} BFS iterations "
                         f"({f['cycles']} RTL cycles); path {f['path_cells']} cells")
    lines += [
        f"navigation: Khepera II (L 53 mm, 0.08 mm ticks, 12.5 ms period), {args.speed} m/s, look-ahead {TrackerParams.lookahead * 1e3:.0f} mm, "
        f"DFLC engine {args.engine}",
        "  planner   slip   vertices chains periods goal collisions   cross-track (mm): odometry max  true max  true rms",
    ]
    ok = True
    for planner, slip, r in runs:
        if not slip:
            ok &= r["reached_goal"] and r["collisions"] == 0
        ok &= r.get("bit_exact", True)
        lines.append(f"  {planner:9s} {slip:5.3f}  {len(r['polyline']):8d} {len(r['chains']):6d} {r['steps']:7d} "
                     f"{'yes' if r['reached_goal'] else 'no ':4s} {r['collisions']:10d}  "
                     f"{_mm(r['odometry_max_cross_track']):>30s}  {_mm(r['max_cross_track']):>8s}  "
                     f"{_mm(r['rms_cross_track']):>8s}")
    lines.append(f"  (with slip the controller still sees only odometry: over {runs[0][2]['path_length']:.1f} m "
                 f"the true pose drifts away, as in the paper; slip runs do not count for the exit status)")
    lines.append("tracking paths/sine.csv (1.03 m, 0.05 m/s), the paper's section 8 experiment:")
    for slip, r in tracks:
        ok &= r["reached_end"] and r.get("bit_exact", True)
        lines.append(f"  slip {slip:5.3f}: odometry max {_mm(r['odometry_max_cross_track'])} mm, true max "
                     f"{_mm(r['max_cross_track'])} mm, true rms {_mm(r['rms_cross_track'])} mm")
    lines.append("  paper (hand-drawn paths, real Khepera II): odometry below 10 mm, camera (true pose) "
                 "about 50 mm worst case")
    dflc = load_dflc()
    fired = set()
    for r in [r for *_, r in runs] + [r for _, r in tracks]:
        fired |= fired_rules(dflc, r["input_codes"])
    lines.append(f"DFLC rules that fired over all runs: {len(fired)} of {len(dflc.config.rules)} (section 4: with a "
                 f"fixed look-ahead (φ1, φ2) stays in a strip, so part of Table 1 is never used)")
    if args.engine != "model":
        all_runs = [r for *_, r in runs if "bit_exact" in r] + [r for _, r in tracks if "bit_exact" in r]
        same = all(r["bit_exact"] for r in all_runs)
        lines.append(f"DFLC RTL ({args.engine}) vs golden model, curvature codes of every period of the "
                     f"{len(all_runs)} runs without slip: {'identical' if same else 'DIFFERENT'} "
                     f"({sum(r['steps'] for r in all_runs)} periods; the slip runs, which command the same codes, "
                     f"use the model)")
    plots = [r["plot"] for *_, r in runs] + [r["plot"] for _, r in tracks]
    lines.append(f"wrote {', '.join(plots)}, summary.txt, summary.json in {out} ({time.time() - t_start:.0f} s)")
    text = "\n".join(lines)
    write_text(out / "summary.txt", text + "\n")
    drop = ("pose", "odometry", "curvature", "curvature_codes", "input_codes")
    slim = [{k: v for k, v in r.items() if k not in drop} | {"planner": planner, "slip": slip}
            for planner, slip, r in runs]
    slim_t = [{k: v for k, v in r.items() if k not in drop} | {"path": "paths/sine.csv", "slip": slip}
              for slip, r in tracks]
    write_text(out / "summary.json", json.dumps({"map": Path(args.map).name, "start": start, "goal": goal,
                                                  "navigate": slim, "track": slim_t}, indent=1, default=str))
    print(text)
    return 0 if ok else 1


def cli(argv=None):
    """``python -m sim.demo``: main() with bad input as one line and exit status 2."""
    os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")
    from .cli import guarded
    return guarded("sim.demo", lambda: main(argv))
