"""Pieces shared by ``sim track``, ``sim navigate`` and the demo: options, engines, path files, plots.

* :func:`add_drive_options`: the options of a drive, spelt once (``--engine``,
  ``--speed``, ``--lookahead``, ``--slip``, ``--seed``), checked with the
  tracker's own ranges (models.tracker.check_run).
* :func:`run_loop`: the closed loop (models.tracker.ClosedLoop) over a list of
  chains with the DFLC golden model (``engine="model"``) or the DFLC RTL in
  Icarus / Verilator (``sim/rtl/track_job.py`` runs the whole loop inside
  the simulator through the DFLC cocotb driver, one inference per control
  period).  Same result dictionary either way.  The loop is built (and so
  checked) here first; a run estimated at more than 10 minutes says so, and
  a terminal shows its periods.
* :func:`read_path_csv`: a chain's vertices from a CSV file.
* :func:`plot_track`: the paper's Fig. 13/14 view (reference, odometry and
  true paths, the start where the robot starts, the approach phase marked;
  cross-track distance versus path length).
"""

import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from navcores.models.tracker import (MAX_LOOKAHEAD, MAX_SLIP, MAX_SPEED, MIN_SPEED, RangeError, TrackerParams,
                                     check_run, distance_to_chain, loop_from_job, loop_job, run_model)

from .cli import ENGINES, CliError, add_engine, finite_numbers, integer, number, read_lines, save_figure
from .progress import Progress, Ticker, announce

MAX_PATH_BYTES = 64 << 20
MAX_COORDINATE = 1e5      # m: 100 km, four times what the longest run (MAX_PERIODS at 1 m/s) drives
# periods a second (measured on this 2-core machine): the golden model, and
# the loop in the simulator with the DFLC RTL (docs/tracking.md: about 10,000
# periods in 3 min on Icarus, 1.5 min on Verilator)
PERIODS_PER_SECOND = {"model": 1500.0, "icarus": 55.0, "verilator": 110.0}


def add_drive_options(p):
    """--engine, --speed, --lookahead, --slip, --seed: the same in every command that drives."""
    add_engine(p, "the DFLC RTL in that simulator, one inference per control period")
    p.add_argument("--speed", type=number(MIN_SPEED, MAX_SPEED, unit="m/s",
                                          why="the Khepera II moves in steps of 8 mm/s up to 1 m/s"),
                   default=TrackerParams.speed, help="linear speed, m/s (default %(default)s)")
    p.add_argument("--lookahead", type=number(0, MAX_LOOKAHEAD, lo_open=True, unit="m"),
                   default=TrackerParams.lookahead, help="look-ahead distance, m (default %(default)s)")
    p.add_argument("--slip", type=number(0, MAX_SLIP, unit="(relative)", why="0.5 loses half of every wheel turn"),
                   default=0.0, help="wheel slip level s, relative, e.g. 0.01 (default 0)")
    p.add_argument("--seed", type=integer(0, 2 ** 63 - 1), default=0, help="slip noise seed, >= 0 (default 0)")


def tracker_params(args):
    """TrackerParams of ``args`` (checked with the tracker's ranges; a CliError names the option)."""
    try:
        check_run(args.speed, args.lookahead, args.slip, args.seed)
        return TrackerParams(speed=args.speed, lookahead=args.lookahead)
    except RangeError as e:
        raise CliError(f"--{e}") from None


def load_dflc():
    """The paper's Table 1 controller (models/dflc_table1.fll), the golden model."""
    from navcores.models.dflc import DEFAULT_FLL, Dflc
    return Dflc.from_fll(DEFAULT_FLL)


def run_loop(chains, engine="model", params=TrackerParams(), start=None, slip=0.0, seed=0, approach=None,
             log_file=None, prog=None):
    """Track ``chains`` (Swam list) one after another; returns ClosedLoop.result() (+ "engine").

    The loop is built here first (its checks: a start past the end of the
    path, the period bound), also for an RTL engine; ``prog`` (a command's
    name): announce a long run, show progress on a terminal."""
    if engine not in ENGINES:
        raise CliError(f"unknown engine {engine!r}: use one of {', '.join(ENGINES)}")
    job = loop_job(chains, params, start, slip, seed, approach)
    try:
        loop = loop_from_job(job, load_dflc())
    except ValueError as e:          # RangeError too: the period bound
        raise CliError(str(e)) from None
    if prog:
        length = sum(c.length for c in chains)
        periods = length / (params.speed * loop.robot.params.period)
        announce(prog, periods / PERIODS_PER_SECOND[engine], f"driving {length:.4g} m on the {engine}",
                 f"about {periods:.3g} control periods at {PERIODS_PER_SECOND[engine]:.0f} a second")
    if engine == "model":
        with Progress("tracking (model)", total=loop.max_steps, unit="periods at most") as bar:
            result = run_model(loop, progress=(lambda k, n: bar.update(k)) if prog else None)
    else:
        with Ticker(f"tracking with the DFLC RTL on {engine}"):
            result = run_loop_rtl(job, engine, log_file)
    result["engine"] = engine
    return result


def run_loop_rtl(job, sim, log_file=None):
    """The closed loop inside the simulator (sim/rtl/track_job.py) on the DFLC RTL.

    The simulator's output goes to ``log_file`` (default
    ``build/track/<sim>_track_rtl.log``); the runner's own chatter is muted.
    """
    import logging

    from .rtl.runner import BUILD, run
    from .rtl.track_job import DFLC_PARAMS, DFLC_TOP
    log_file = Path(log_file) if log_file else BUILD / "track" / f"{sim}_track_rtl.log"
    log_file.parent.mkdir(parents=True, exist_ok=True)
    loggers = [logging.getLogger(n) for n in ("Icarus", "Verilator")]

    def quiet(record):            # the runner resets its loggers' levels; a filter stays
        return record.levelno >= logging.ERROR
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        (work / "job.json").write_text(json.dumps(job))
        build_log = log_file.with_name(log_file.stem + "_build.log")
        sys.stdout.flush()
        sys.stderr.flush()
        saved = os.dup(1), os.dup(2)
        try:
            for lg in loggers:
                lg.addFilter(quiet)
            # the build tools (make, the compilers) write to the process's own
            # stdout/stderr: send them to a build log
            with open(build_log, "ab") as fh:
                os.dup2(fh.fileno(), 1)
                os.dup2(fh.fileno(), 2)
                run(DFLC_TOP, DFLC_PARAMS, sim, "navcores.sim.rtl.track_job",
                    env={"TRACK_JOB": work / "job.json", "TRACK_RESULT": work / "result.json"},
                    log_file=log_file)
        except (AssertionError, RuntimeError, SystemExit, OSError) as e:
            raise CliError(f"the DFLC run on {sim} failed ({e}); logs: {build_log}, {log_file}") from None
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            for lg in loggers:
                lg.removeFilter(quiet)
        return json.loads((work / "result.json").read_text())


def read_path_csv(path):
    """Vertices (n, 2) of a CSV chain file: a header line, then ``x,y`` rows in metres."""
    path = Path(path)
    lines = read_lines(path, MAX_PATH_BYTES, "path file")
    if not lines:
        raise CliError(f"{path}: empty file (expected a header line and x,y rows)")
    rows = []
    for n, text in enumerate(lines[1:], start=2):
        if not text.strip():
            continue
        xy = finite_numbers(text, 2)
        if xy is None:
            raise CliError(f"{path}:{n}: expected two numbers x,y (metres), got {text[:60]!r}")
        x, y = xy
        if max(abs(x), abs(y)) > MAX_COORDINATE:
            raise CliError(f"{path}:{n}: ({x:g}, {y:g}) is more than {MAX_COORDINATE / 1e3:.0f} km from the origin; "
                           "the longest run drives 25 km (2,000,000 periods at 1 m/s)")
        rows.append((x, y))
    if len(rows) < 2:
        raise CliError(f"{path}: a path needs at least 2 vertices, found {len(rows)}")
    return np.array(rows)


def plot_track(out, vertices, result, title, grid=None, frame=None):
    """Reference / odometry / true paths and their distance to the reference vs
    path length; the start dot where the robot starts (its true pose), the
    approach phase (before the cross-track figures count) drawn apart.
    ``grid`` / ``frame``: a map to draw under the paths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    true = np.array(result["pose"])
    odo = np.array(result["odometry"])
    k = int(result.get("approach_steps", 0))          # periods of the approach phase
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(7, 7.5), gridspec_kw={"height_ratios": [3, 1.3]})
    if grid is not None:
        X, Y = frame.corners()
        ax.pcolormesh(X, Y, np.where(grid, 1.0, np.nan), cmap="Greys", vmin=0, vmax=1.4, shading="flat")
    ax.plot(vertices[:, 0], vertices[:, 1], "k--", lw=1, label="reference")
    ax.plot(odo[:, 0], odo[:, 1], color="tab:blue", lw=1.2, label="odometry")
    ax.plot(true[k:, 0], true[k:, 1], color="tab:red", lw=1.2, label="true pose")
    if k:
        ax.plot(true[:k + 1, 0], true[:k + 1, 1], color="tab:red", lw=1.2, ls=":", alpha=0.8,
                label=f"approach ({result['approach_m'] * 1e3:.0f} mm of progress, not counted)")
        ax.plot(*true[k, :2], "|", color="black", ms=12, mew=2, label="approach ends")
    ax.plot(*true[0, :2], "o", color="tab:orange", ms=8, mec="black", label="start")
    ax.plot(*vertices[-1], "s", color="black", ms=6, mfc="none", label="path end")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=7)
    ax.set_title(title, fontsize=9)
    step = np.hypot(*np.diff(true[:, :2], axis=0).T)
    s = np.concatenate([[0], np.cumsum(step)])
    if k:
        bx.axvspan(0, s[k], color="0.88", label="approach (not counted)")
    bx.plot(s, 1e3 * distance_to_chain(odo, vertices), color="tab:blue", lw=1, label="odometry")
    bx.plot(s, 1e3 * distance_to_chain(true, vertices), color="tab:red", lw=1, label="true pose")
    bx.set_xlabel("path length driven (m)")
    bx.set_ylabel("distance to reference (mm)")
    bx.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, out, dpi=110)
    plt.close(fig)
