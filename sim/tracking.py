"""Pieces shared by ``sim track``, ``sim navigate`` and the demo: engines, path files, plots.

* :func:`run_loop`: the closed loop (models.tracker.ClosedLoop) over a list of
  chains with the DFLC golden model (``engine="model"``) or the DFLC RTL in
  Icarus / Verilator (``sim/rtl/track_job.py`` runs the whole loop inside
  the simulator through the DFLC cocotb driver, one inference per control
  period).  Same result dictionary either way.
* :func:`read_path_csv`: a chain's vertices from a CSV file.
* :func:`plot_track`: the paper's Fig. 13/14 view (reference, odometry and
  true paths; cross-track distance versus path length).
"""

import json
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from navcores.models.tracker import TrackerParams, distance_to_chain, loop_from_job, loop_job, run_model

from .cli import CliError

ENGINES = ("model", "icarus", "verilator")


def load_dflc():
    """The paper's Table 1 controller (models/dflc_table1.fll), the golden model."""
    from navcores.models.dflc import DEFAULT_FLL, Dflc
    return Dflc.from_fll(DEFAULT_FLL)


def run_loop(chains, engine="model", params=TrackerParams(), start=None, slip=0.0, seed=0, approach=None,
             log_file=None):
    """Track ``chains`` (Swam list) one after another; returns ClosedLoop.result() (+ "engine")."""
    if engine not in ENGINES:
        raise CliError(f"unknown engine {engine!r}: use one of {', '.join(ENGINES)}")
    job = loop_job(chains, params, start, slip, seed, approach)
    if engine == "model":
        result = run_model(loop_from_job(job, load_dflc()))
    else:
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
    lines = path.read_text().splitlines()
    if not lines:
        raise CliError(f"{path}: empty file (expected a header line and x,y rows)")
    rows = []
    for n, text in enumerate(lines[1:], start=2):
        if not text.strip():
            continue
        parts = [p.strip() for p in text.split(",")]
        try:
            if len(parts) != 2:
                raise ValueError
            x, y = float(parts[0]), float(parts[1])
            if not (math.isfinite(x) and math.isfinite(y)):
                raise ValueError
        except ValueError:
            raise CliError(f"{path}:{n}: expected two numbers x,y (metres), got {text!r}") from None
        rows.append((x, y))
    if len(rows) < 2:
        raise CliError(f"{path}: a path needs at least 2 vertices, found {len(rows)}")
    return np.array(rows)


def plot_track(out, vertices, result, title):
    """Reference / odometry / true paths and their distance to the reference vs path length."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    true = np.array(result["pose"])
    odo = np.array(result["odometry"])
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(7, 7.5), gridspec_kw={"height_ratios": [3, 1.3]})
    ax.plot(vertices[:, 0], vertices[:, 1], "k--", lw=1, label="reference")
    ax.plot(odo[:, 0], odo[:, 1], color="tab:blue", lw=1.2, label="odometry")
    ax.plot(true[:, 0], true[:, 1], color="tab:red", lw=1.2, label="true pose")
    ax.plot(*vertices[0], "o", color="tab:orange")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=9)
    step = np.hypot(*np.diff(true[:, :2], axis=0).T)
    s = np.concatenate([[0], np.cumsum(step)])
    bx.plot(s, 1e3 * distance_to_chain(odo, vertices), color="tab:blue", lw=1, label="odometry")
    bx.plot(s, 1e3 * distance_to_chain(true, vertices), color="tab:red", lw=1, label="true pose")
    bx.set_xlabel("path length driven (m)")
    bx.set_ylabel("distance to reference (mm)")
    bx.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
