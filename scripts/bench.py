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
   counted per instance), the other tops flattened.
2. Cycles per job, from simulations: the cluster RTL's cycles per iteration
   at p = 128 (tb/harmonic/iteration_job.py), the `python -m sim` commands'
   RTL engines (planner, DFLC stream, EDT/BFS array) on Icarus and Verilator,
   which must equal the cycle-exact models (the report says "DIFFERENT" and
   the run exits 1 otherwise); whole-map cycle counts of maps too large to
   simulate come from the models, whose cycle counts the regression proves
   equal to the RTL's.  Time per job = cycles / the top's iCE40 clock.
3. The software a user would pick instead (scripts/software.py), timed on
   the same inputs: median of several repeats (the count is in the table).
4. Simulation speed: simulated cycles per wall second, from the cocotb
   results of the runs above (sim_time / wall time of the test, build
   excluded), and an idle-clock probe (sim/rtl/simspeed.py) for tops without a job.
5. The regression's wall time (build/regression.json, written by make test).
6. The harmonic schedule study (scripts/bench_harmonic.py) and, when present,
   the block-exponent comparison (scripts/bench_exponents.py).
7. The board bitstreams (scripts/bitstream.py, ``make bitstreams``): every
   board/core pair built, its resources and the clock reached against the
   board's (the bitstreams go to build/bench/bitstream, not committed).

yosys and nextpnr come from PyPI (scripts/toolchain.py); their runs are
cached under build/cache by the hash of the Verilog, the tool's version and
the options (a re-run only redoes what changed).

    python scripts/bench.py [--md BENCHMARKS.md] [--json build/bench/results.json]
                            [--skip study,simspeed,...]
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
import software  # noqa: E402
import synth  # noqa: E402
import toolchain  # noqa: E402
from navcores.hdl import catalog  # noqa: E402
from navcores.hdl.emit import emit, top_name  # noqa: E402
from navcores.models.maps import load_map, longest_scenario  # noqa: E402

OUT = ROOT / "build" / "bench"
PERIOD_NS = 10                  # every cocotb bench here clocks at 10 ns
HX8K_LCS = 7680
CLOCK_PART = fmax_mod.part("iCE40-HX8K")     # the part of the clock column
PY = sys.executable
PARTS = ("hardware", "harmonic", "dflc", "edt", "simspeed", "study", "boards")

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


def hardware(jobs=2):
    """{key: {ff, lut4, mult, bram, fmax_mhz, ...}} for every top of TOPS."""
    def one(top):
        s = synthesize(top)
        return {**s, **place(top, s.get("lut4"))}
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        return dict(zip([t[0] for t in TOPS], pool.map(one, TOPS)))


# Tops that do not fit the HX8K, and the placed top whose clock their jobs use.
CLOCK_FROM = {
    "planner": ("block", "the planner top does not fit the HX8K, so its jobs use the 6x12 block's clock, "
                         "the array every iteration runs on; Control and Decision are not timed"),
    "planner_exp": ("block", "as the planner top: the 6x12 block's clock (the exponent option's Control "
                             "and border conversion are not timed)"),
    "edt_8x8": ("edt_cell", "the arrays do not fit the HX8K: their jobs use the cell's clock (its inputs are "
                            "registered in the harness as its neighbours' registers drive them in the array)"),
    "edt_16x16": ("edt_cell", "the arrays do not fit the HX8K: their jobs use the cell's clock (its inputs are "
                              "registered in the harness as its neighbours' registers drive them in the array)"),
}


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


def row(hw, core, job, top_key, cycles, cycles_source, software_=None, sw_seconds=None,
        paper="-", note=""):
    """One job: resources of ``top_key``'s top; its clock, or where that top
    does not fit the HX8K the clock named in CLOCK_FROM (and the note says so)."""
    h = hw.get(top_key, {})
    mhz = h.get("fmax_mhz")
    if mhz is None and top_key in CLOCK_FROM and hw.get(CLOCK_FROM[top_key][0], {}).get("fmax_mhz"):
        mhz = hw[CLOCK_FROM[top_key][0]]["fmax_mhz"]
        note = "; ".join(x for x in (note, CLOCK_FROM[top_key][1]) if x)
    t = hw_time(cycles, mhz)
    return {"core": core, "job": job, "top": h.get("top") or top_key,
            "ff": h.get("ff"), "lut4": h.get("lut4"), "mult": h.get("mult"), "bram": h.get("bram"),
            "fmax_mhz": mhz, "cycles": cycles, "cycles_source": cycles_source,
            "hw_seconds": t, "software": software_, "sw_seconds": sw_seconds,
            "speedup": sw_seconds / t if t and sw_seconds else None, "paper": paper, "note": note}


# --- 2-3. jobs: harmonic --------------------------------------------------------

HARMONIC_MAPS = ("room-32-32-4.map", "random-32-32-10.map", "maze-32-32-4.map", "maze-32-32-2.map",
                 "room-64-64-8.map", "random-64-64-10.map", "den312d.map")
HARMONIC_SCHEDULE = tuple(range(16, 257, 16))      # the command line's default 16:16:256
HARMONIC_BLOCK, HARMONIC_I = (6, 12), 6           # the synthesized planner's block, plan()'s I


def harmonic_jobs(hw, speeds, problems):
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
    rows.append(row(hw, "harmonic", "one iteration, 36x66 block, p = 128", "block", per_iter,
                    "cluster RTL (icarus), done-to-done", sw["software"] + " (10% random obstacles)",
                    sw["sw_seconds"], catalog.PAPER_JOBS["harmonic_iteration"],
                    "clock: the 6x12 block top's (a 36x66 block is the same array, larger)"))
    # Whole maps: the model's cycles (cycle-exact), one confirmed on the RTL below.
    for name in HARMONIC_MAPS:
        ob, goal, _ = bundled(name)
        log(f"harmonic model on {name}")
        r = plan(ob, [goal], block=HARMONIC_BLOCK, iters=HARMONIC_I, schedule=HARMONIC_SCHEDULE)
        sw = software.dirichlet_solve(ob, [goal])
        rows.append(row(hw, "harmonic", f"converged field, {name[:-4]} ({ob.shape[0]}x{ob.shape[1]}), p = {r.p}",
                        "planner", r.cycles if r.converged else None,
                        f"model (cycle-exact), {HARMONIC_BLOCK[0]}x{HARMONIC_BLOCK[1]} blocks, I = {HARMONIC_I}, "
                        f"p 16:16:{r.p}, {r.block_iterations} block iterations", sw["software"], sw["sw_seconds"],
                        catalog.PAPER_JOBS["harmonic_map"],
                        "resources: the synthesized planner top's (6x12 blocks, 2x2, depth 256); this map "
                        "needs more blocks and a deeper RAM"))
    # The model's cycle count confirmed on the planner RTL (3x6 blocks: it simulates in minutes).
    ob, goal, _ = bundled("empty-16-16.map")
    model = plan(ob, [goal], block=(3, 6), iters=HARMONIC_I, schedule=HARMONIC_SCHEDULE)
    for sim in ("icarus", "verilator"):
        out, speed = sim_cli(["harmonic", "maps/empty-16-16.map", "--goal", f"{goal[0]},{goal[1]}"],
                             sim, "harmonic_planner")
        cyc = out.get("cycles")
        if cyc != model.cycles:
            problems.append(f"planner RTL on {sim}: {out.get('error') or cyc} cycles, model {model.cycles}")
        _job_speed(speeds, speed, sim, "harmonic_planner", planner_params(ob.shape, (3, 6), HARMONIC_SCHEDULE[-1]))
        rows.append(row(hw, "harmonic", f"converged field, empty-16-16, 3x6 blocks, p = {model.p}", "planner",
                        cyc, f"planner RTL ({sim}); model {model.cycles}"
                        + ("" if cyc == model.cycles else " DIFFERENT"),
                        paper="-"))
    return rows


# --- jobs: DFLC --------------------------------------------------------------------

def dflc_jobs(hw, speeds, problems):
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
    for key, par in (("dflc", False), ("dflc_par", True)):
        want_cps = 1 if par else 1 << model.config.n
        want_lat = stream_latency(model.config, par)
        got = {}
        for sim in ("icarus", "verilator"):
            out, speed = sim_cli(["dflc", "--input", str(csv)] + (["--parallel"] if par else []), sim, "dflc_stream")
            got[sim] = (out.get("cycles_per_sample"), out.get("latency"))
            if got[sim] != (want_cps, want_lat):
                problems.append(f"DFLC {key} on {sim}: {out.get('error') or got[sim]}, model {(want_cps, want_lat)}")
            _job_speed(speeds, speed, sim, "dflc_stream", rtl_params(fll, model.config, "lut", par))
        cps, lat = got["verilator"] if got["verilator"][0] else got["icarus"]
        what = "parallel option" if par else "Table 1 controller"
        src = (f"DFLC stream RTL (icarus, verilator): {cps} clocks/sample, latency {lat}"
               + ("" if all(g == (want_cps, want_lat) for g in got.values()) else " DIFFERENT"))
        paper = "-" if par else catalog.PAPER_JOBS["dflc_sample"]
        rows.append(row(hw, "dflc", f"one sample, {what}, single call", key, cps, src,
                        sw["software"] + " (one call per sample)", sw["sw_seconds"], paper))
        rows.append(row(hw, "dflc", f"one sample, {what}, vectorized", key, cps, src,
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
EDT_BIG_NOTE = ("resources: the 16x16 array's (the largest synthesized); a map's job needs an array of the "
                "map's size, 4x (32x32) or 16x (64x64) the cells")


def _free_corners(grid):
    free = np.argwhere(~grid)
    return tuple(int(x) for x in free[0]), tuple(int(x) for x in free[-1])


def edt_jobs(hw, speeds, problems):
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
                                  "--start", f"{start[0]},{start[1]}"], sim, f"edt_bfs_height{size}_width{size}")
            cyc = out.get("cycles")
            if cyc is None:
                note = f"not simulated: {out.get('error')}"
                log(f"EDT {size}x{size} on {sim}: {note}")
            elif cyc != model.cycles:
                problems.append(f"EDT/BFS {size}x{size} on {sim}: {cyc} cycles, model {model.cycles}")
            _job_speed(speeds, speed, sim, "edt_bfs", {"height": size, "width": size})
            if cyc is not None:
                rows.append(row(hw, "edt_bfs", f"room-32-32-4 crop {size}x{size}: EDT, cfr, BFS, path, read-out",
                                "edt_8x8" if size == 8 else "edt_16x16", cyc, f"EDT/BFS RTL ({sim}); model {model.cycles}"
                                + ("" if cyc == model.cycles else " DIFFERENT"),
                                note="" if size <= 16 else EDT_BIG_NOTE))
    for name in EDT_MAPS:
        ob, goal, start = bundled(name)
        model = plan_path(ob, [goal], start, EDT_DFAR)
        sw = software.edt_bfs(ob, [goal], EDT_DFAR)
        compute = model.iterations_edt + 1 + model.iterations_bfs
        rows.append(row(hw, "edt_bfs", f"{name[:-4]} ({ob.shape[0]}x{ob.shape[1]}): whole job", "edt_16x16",
                        model.cycles, f"model (cycle-exact): EDT {model.iterations_edt} + cfr 1 + BFS "
                        f"{model.iterations_bfs} iterations, path {len(model.path)}, load and read-out",
                        sw["software"], sw["sw_seconds"], catalog.PAPER_JOBS["edt_job"],
                        EDT_BIG_NOTE))
        rows.append(row(hw, "edt_bfs", f"{name[:-4]} ({ob.shape[0]}x{ob.shape[1]}): EDT + cfr + BFS only", "edt_16x16",
                        compute, "model (cycle-exact): the computing cycles, without load, path and read-out",
                        sw["software"], sw["sw_seconds"], catalog.PAPER_JOBS["edt_job"],
                        EDT_BIG_NOTE))
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
        "register-to-register timing.", "",
        "| top | family | FF | LUT4 | MULT18X18 | BRAM | iCE40 clock (MHz) | iCE40 logic cells | paper |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for key, core, name, params, family, hier, paper in TOPS:
        h = hw[key]
        util = (h.get("utilization") or {}).get("ICESTORM_LC", "").replace(" ", "")
        clock = _fmt(h.get("fmax_mhz")) if h.get("fmax_mhz") else h.get("error", "—")
        lines.append(f"| {top_name(name, params)}{' (hierarchical)' if hier else ''} | {family} | {_fmt(h.get('ff'))} | "
                     f"{_fmt(h.get('lut4'))} | {_fmt(h.get('mult'))} | {_fmt(h.get('bram'))} | {clock} | {util or '—'} | {paper} |")
    lines += ["", "## Jobs: hardware time against the software a user would pick", "",
              f"Hardware time = cycles / the top's iCE40 clock above. Software: median of "
              f"{software.REPEATS} runs after a warm-up (pyfuzzylite single calls: 3 runs of 50 calls; "
              "vectorized: 3 runs), on this machine.", "",
              "| core | job | cycles | cycles from | clock (MHz) | hardware time | software | software time | "
              "speed-up | paper |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        lines.append(f"| {r['core']} | {r['job']} | {_fmt(r['cycles'])} | {r['cycles_source']} | {_fmt(r['fmax_mhz'])} | "
                     f"{_fmt(r['hw_seconds'], 's')} | {r['software'] or '—'} | {_fmt(r['sw_seconds'], 's')} | "
                     f"{_fmt(r['speedup'])}{'×' if r['speedup'] else ''} | {r['paper']} |")
    notes = sorted({r["note"] for r in data["rows"] if r["note"]})
    if notes:
        lines += ["", "Notes: " + "; ".join(notes) + "."]
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


def study_sections():
    """The harmonic schedule study and the block-exponent comparison, as markdown."""
    import bench_harmonic
    out = []
    lines = []
    parts = []
    for name in ("maze-32-32-2.map", "random-32-32-10.map"):
        part, summary = bench_harmonic.cycles_section(name)
        lines += part
        parts.append(summary)
    lines += ["Summary: " + "; ".join(
        f"{s['map']}: the paper's algorithm {s['paper']:.2f}x, best variation {s['best']:.2f}x ({s['best_what']})"
        for s in parts), ""]
    bits, _ = bench_harmonic.bits_section()
    out.append(("Harmonic planner: block-synchronous schedule against one block (paper 4.5.2)", "\n".join(lines)))
    out.append(("Harmonic planner: bits of precision against the longest distance (paper 3.2.2)", "\n".join(bits)))
    try:
        import bench_exponents
    except ImportError:
        return out
    text, _ = bench_exponents.comparison()
    out.append(("Harmonic planner: fixed point against block exponents", text))
    return out


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
    args = ap.parse_args(argv)
    skip = {s for s in args.skip.split(",") if s}
    if skip - set(PARTS):
        ap.error(f"--skip: unknown part(s) {sorted(skip - set(PARTS))}; parts: {','.join(PARTS)}")
    OUT.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    hw = hardware() if "hardware" not in skip else {t[0]: {} for t in TOPS}
    for (key, core, name, params, *_), h in zip(TOPS, hw.values()):
        h["top"] = top_name(name, params)
    speeds, problems, rows = {}, [], []
    for part, fn in (("harmonic", harmonic_jobs), ("dflc", dflc_jobs), ("edt", edt_jobs)):
        if part not in skip:
            rows += fn(hw, speeds, problems)
    if "simspeed" not in skip:
        probes(speeds)
    extra = study_sections() if "study" not in skip else []
    boards = []
    if "boards" not in skip:
        section, boards = board_section(problems)
        extra.append(section)
    reg_file = ROOT / "build" / "regression.json"
    reg = json.loads(reg_file.read_text()) if reg_file.exists() else {}
    data = {
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "machine": f"{platform.node()}: {platform.processor() or platform.machine()}, "
                   f"{os.cpu_count()} CPUs, Python {platform.python_version()}, {_cpu_model()}",
        "rows": rows,
        "regression_seconds": reg.get("seconds") if reg.get("passed") else None,
        "regression_jobs": reg.get("jobs"), "regression_date": reg.get("date"),
        "sim_cycles_per_second": {top: {s: by.get(s, {}).get("probe") for s in ("icarus", "verilator")}
                                  for top, by in speeds.items()},
        "sim_cycles_per_second_detail": speeds,
        "hardware": hw,
        "bitstreams": boards,
        "problems": problems,
        "bench_seconds": None,
    }
    data["bench_seconds"] = round(time.time() - t0)
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(data, indent=1, default=str))
    Path(args.md).write_text(markdown(data, hw, extra) + f"\nBench run time: {data['bench_seconds']} s.\n")
    log(f"wrote {args.md} and {args.json} in {data['bench_seconds']} s")
    for p in problems:
        log(f"PROBLEM: {p}")
    return 1 if problems else 0


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
