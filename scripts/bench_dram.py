"""The tile engine with its state in a DDR3 through LiteDRAM, simulated on Verilator: whole jobs timed (issue 18).

``python scripts/bench_dram.py [MAP ...] [--md FILE]`` runs each map's job
(scripts/bench_edt_tiled.job: the map's longest scenario) on
:class:`~hdl.edt_bfs.tile_litedram.TileLiteDram` (the catalog's
``edt_tile_dram``: a 3x8 engine over maps up to 512x512 with
``store="dram"``, and LiteDRAM's generated controller with its DRAM
model: scripts/litedram_core.py) in Verilator, checks the results against
models.edt_bfs_tiled (distances, vectors, cfr, parents, hop counts, path,
tile visits and their trace: the same; cycles: the DRAM's), and reports
the job's engine cycles and its time at the engine's clock (:func:`clock`:
the whole top placed on the ECPIX-5's part by scripts/fit_dram_top.py, or
else the same engine with store=external placed alone) with the controller
at litedram_core.SYS_CLK_HZ (the two clocks in that ratio in the
simulation), against scipy on the same machine in the same run.
``--md FILE`` writes the rows as BENCHMARKS.md's section (scripts/bench.py
``--only dram`` does that within make bench).  ``--states`` also prints
where the engine's cycles go: its cycles in its FSM states by the model's
cycle terms, against the model's at StateRam's timing (a build with every signal visible: slower,
:class:`sim.rtl.engine_states.EngineStates`).  Needs ``pip install -e
.[dram]``; exit 2 without it.
"""

import argparse
import json
import os
import re
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_edt_tiled as B  # noqa: E402
import fit_dram_top  # noqa: E402
import kept  # noqa: E402
import litedram_core  # noqa: E402
import software  # noqa: E402

from navcores.hdl import catalog  # noqa: E402
from navcores.hdl.edt_bfs.tile_engine import model_timing  # noqa: E402
from navcores.hdl.edt_bfs.tile_litedram import TileLiteDram  # noqa: E402
from navcores.models.edt_bfs_tiled import plan_path_tiled  # noqa: E402
from navcores.sim.rtl.clock import PERIOD_NS  # noqa: E402
from navcores.sim.rtl.runner import run  # noqa: E402

WORK = B.ROOT / "build" / "bench_dram"
# The engine: the catalog's edt_tile_dram (a 3x8 array over maps up to 512x512, four native ports, prefetch,
# skip_clean, bfs_slots)
PARAMS = dict(catalog.get("edt_tile_dram").params)
ARRAY = (PARAMS["t_r"], PARAMS["t_c"])
RAM = (PARAMS["max_h"], PARAMS["max_w"])
PORTS = PARAMS["dram_ports"]
NAME = f"{ARRAY[0]}x{ARRAY[1]} / {RAM[0]}x{RAM[1]}"
# the DRAM side's own parameters (an engine with store=external has none of them), and the engine's others
SIDE = {k: PARAMS[k] for k in ("dram_ports", "bfs_slots") if k in PARAMS}
ENGINE = {k: v for k, v in PARAMS.items() if k not in ("t_r", "t_c", "max_h", "max_w", "store", *SIDE)}
TIMING = model_timing(PARAMS.get("iter_cycles", 1))     # the model's cycle constants for that engine
VISIT_TERMS = ("sched", "read", "iterate", "store")     # the cycle model's visit(t), term by term
# The clocks' ratio in the simulation when the engine has no current clock (clock() gives None): what the
# 3x8 engine reached in the whole top on the ECPIX-5's part before the skid buffers (2026-12-06, BENCHMARKS.md;
# fit_dram_top.ENGINE_MHZ is its target there); no job time is given then.
RATIO_MHZ = 37.2
MAPS = ("room-64-64-8", "maze512-1-0")
SECTION = "EDT/BFS tile engine through LiteDRAM's DDR3 controller, simulated (issue 18)"
KEYS = ("distance", "nearest", "cfr", "parent", "visited", "path", "iterations_edt", "iterations_bfs",
        "tile_visits", "trace")


def sys_period_ns(mhz):
    """The controller's period in the simulation, where the engine's (at ``mhz``) is PERIOD_NS: their real
    ratio (even ps)."""
    ps = PERIOD_NS * 1000 * mhz * 1e6 / litedram_core.SYS_CLK_HZ
    return 2 * round(ps / 2) / 1000


def states_text(name, terms, model):
    """The engine's cycles by the model's cycle terms through LiteDRAM (``terms``: EngineStates.terms())
    against the model's at StateRam's timing, as lines."""
    ref, visits = model.stats["cycle_terms"], model.tile_visits
    lines = [f"{name}: the engine's cycles by the model's terms through LiteDRAM (at StateRam's timing: the "
             f"model's), and a visit's"]
    for term, got in terms.items():
        per = f"; {got / visits:.1f} ({ref[term] / visits:.1f}) a visit" if term in VISIT_TERMS else ""
        lines.append(f"  {term:8s} {got:>11,} ({ref[term]:,}){per}")
    lines.append(f"  total    {sum(terms.values()):>11,} ({model.cycles:,})")
    return lines


def rtl_job(obstacle, goal, start, core, csrs, work, mhz, states=False):
    params = {k: v for k, v in PARAMS.items() if k != "store"}
    job, result = work / "job.json", work / "result.json"
    job.write_text(json.dumps({"obstacle": obstacle.tolist(), "goals": [list(goal)], "start": list(start),
                               "dfar": B.DFAR, "sys_period_ns": sys_period_ns(mhz), "csrs": csrs,
                               "path_only_too": True, "states": states, **params}))
    run("edt_tile_litedram", params, "verilator", "navcores.sim.rtl.edt_tile_job",
        env={"EDT_JOB": job, "EDT_RESULT": result}, log_file=work / "sim.log",
        factory=lambda **p: TileLiteDram(**p),
        build_args=[str(core), "-Wno-fatal", "-Wno-lint", "-Wno-style", "-Wno-WIDTH", "-Wno-MULTIDRIVEN",
                    "-CFLAGS", "-O1"])
    return json.loads(result.read_text())


def measure(name, core, csrs, work, mhz, states=False):
    obstacle, goal, start = B.job(name)
    model = plan_path_tiled(obstacle, [goal], start, B.DFAR, array=ARRAY, timing=TIMING)
    sw = software.edt_bfs(obstacle, [goal], B.DFAR, bfs=("csgraph",), repeats=3)
    t0 = time.perf_counter()
    rtl = rtl_job(obstacle, goal, start, core, csrs, work, mhz or RATIO_MHZ, states)
    if states:
        print("\n".join(states_text(name, rtl["path_only"]["states"], model)), flush=True)
    wall = time.perf_counter() - t0
    same = {k: (np.array_equal(np.asarray(rtl[k]), np.asarray(getattr(model, k))) if k not in ("path", "trace")
                else [tuple(p) for p in rtl[k]] == list(getattr(model, k))) for k in KEYS}
    po = rtl["path_only"]                   # the job without the map read-out: what is timed
    if [tuple(p) for p in po["path"]] != model.path or [tuple(t) for t in po["trace"]] != list(model.trace):
        same["path_only"] = False
    bad = [k for k, ok in same.items() if not ok]
    ms = po["cycles"] / mhz / 1e3 if mhz else None
    native = po["native"]
    words = native["reads"] + native["writes"]
    return {"map": name, "shape": list(obstacle.shape), "tile_visits": model.tile_visits,
            "cycles_dram": po["cycles"], "cycles_bram_timing": model.cycles,
            "cycles_dram_with_readout": rtl["cycles"], "ms_dram": ms,
            "scipy_ms": sw["sw_seconds"] * 1e3, "speedup": sw["sw_seconds"] * 1e3 / ms if ms else None,
            "native_reads": native["reads"], "native_writes": native["writes"],
            "controller_cycles": native["controller_cycles"],
            "bus_busy": words * litedram_core.BURST_SYS_CYCLES / native["controller_cycles"],
            "engine_mhz": mhz, "sys_mhz": litedram_core.SYS_CLK_HZ / 1e6, "same_as_model": not bad,
            "differs": bad, "sim_seconds": round(wall, 1)}


def engine_mhz():
    """The engine's clock, if placed alone: the catalog engine's logic with store=external placed on the
    ECPIX-5's part, the whole top's (its fit JSON's median of seeds; the engine's logic is the same, the
    DramStore and StateCdc run on the controller's clock), or None if it has not been placed (for its
    current Verilog)."""
    fit = B.fit_result(ARRAY, RAM, part=fit_dram_top.PART, store="external", extra=ENGINE)
    return fit["fmax_mhz"] if fit and fit["fits"] else None


def top_fit():
    """The whole top placed (scripts/fit_dram_top.py: the engine with its DRAM side and LiteDRAM's
    controller and PHY on the ECPIX-5's part), for its current Verilog, or None."""
    return B.fit_result(ARRAY, RAM, part=fit_dram_top.PART, top=fit_dram_top.TOP, store=None,
                        extra={**SIDE, **ENGINE})


def seeds(fit):
    """A fit's placement seeds as text: 'seed 4', or 'median of 3 seeds: 1, 2, 3'."""
    n = [str(r["seed"]) for r in fit["seeds"]]
    return f"seed {n[0]}" if len(n) == 1 else f"median of {len(n)} seeds: {', '.join(n)}"


def clock(sys_mhz):
    """(the engine's MHz or None, the text saying where it comes from): the whole top's engine clock when
    it is placed and each of its controller's clocks reaches its target (``sys_mhz`` its system clock's),
    else the engine placed alone (with its DRAM side placed alone beside it)."""
    top = top_fit()
    if top is not None:
        if not top["fits"]:
            return None, f"the whole top does not fit the {fit_dram_top.PART} (scripts/fit_dram_top.py): no job times"
        engine, others = fit_dram_top.clocks(top)
        where = (f"the whole top (the engine, its StateCdc and DramStores, LiteDRAM's controller and PHY, the "
                 f"DDR3's pads at the board's pins) placed on the {fit_dram_top.PART} (the ECPIX-5's, speed "
                 f"{top['speed_grade']}; `{top['generator']}`, {seeds(top)}): {top['lut4']:,} LUT4, "
                 f"{top['ff']:,} FF, {top['bram']} "
                 f"DP16KD")
        short = fit_dram_top.missed(others)
        if short:
            return None, f"{where}; the controller's clocks below their targets ({short}): no job times"
        sys_at = others["sys_clk"][0] if "sys_clk" in others else min(mhz for mhz, _ in others.values())
        where += f", the controller's system clock {sys_at:.1f} MHz (its {sys_mhz:.0f} MHz met)"
        return engine, f"the engine at {engine:.1f} MHz: {where}"
    mhz = engine_mhz()
    text = (f"the engine at {mhz:.1f} MHz (the {NAME} engine with store=external, prefetch and skip_clean "
            f"placed alone on the {fit_dram_top.PART}, the ECPIX-5's: make fit; the same engine logic; the whole "
            "top not placed for its current Verilog)" if mhz else
            f"no engine clock (the {NAME} engine is not placed for its current Verilog: no job times)")
    side = stores_fit()
    if side and side["fits"]:
        meets = "at least" if side["fmax_mhz"] >= sys_mhz else "BELOW"
        text += (f"; its DRAM side (DramStores: {PORTS} DramStores and the RowRouter, on the controller's clock) "
                 f"placed alone on the {fit_dram_top.PART} at {side['fmax_mhz']:.1f} MHz ({meets} the controller's "
                 f"{sys_mhz:.0f} MHz), {side['lut4']:,} LUT4, {side['bram']} block RAMs (scripts/fit.py "
                 "edt_dram_stores); the crossing between the two clocks was not placed")
    else:
        text += "; its DRAM side (DramStores) not placed for its current Verilog"
    return mhz, text


def stores_fit():
    """The DRAM side (hdl/edt_bfs/dram_stores.py: a DramStore per port and the RowRouter) placed alone at its
    own clock (scripts/fit.py edt_dram_stores ...: its fit JSON), or None if it has not been placed."""
    return B.fit_result(ARRAY, RAM, part=fit_dram_top.PART, top="edt_dram_stores",
                        extra={**SIDE, "skip_clean": PARAMS["skip_clean"]})


def section(maps=MAPS, states=False):
    """The BENCHMARKS.md section (what ran, then a row per map: :func:`measure`) and the rows."""
    stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    try:
        core, csrs = litedram_core.generate(sim=True, ports=PORTS)
    except litedram_core.NotInstalled as e:
        return f"Not run on {stamp}: {e}.", []
    sys_mhz = litedram_core.SYS_CLK_HZ / 1e6
    mhz, where = clock(sys_mhz)
    if mhz is None:
        where += f"; the simulation's engine clock {RATIO_MHZ} MHz (bench_dram.RATIO_MHZ)"
    rows = []
    for name in maps:
        work = WORK / name
        work.mkdir(parents=True, exist_ok=True)
        rows.append(measure(name, core, csrs, work, mhz, states))
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    text = (f"Measured by `python scripts/bench_dram.py` on {stamp}, load average {load} on {os.cpu_count()} "
            f"cores. The {ARRAY[0]}x{ARRAY[1]} tile engine over maps up to {RAM[0]}x{RAM[1]} with store=dram on "
            f"{PORTS} native ports "
            "(hdl/edt_bfs/dram_stores.py, dram_store.py, row_router.py, state_cdc.py) and LiteDRAM's generated "
            "controller (scripts/litedram_core.py: a 16-bit DDR3, one "
            "MT41K256M16, on ECP5DDRPHY, the ECPIX-5's, system clock "
            f"{sys_mhz:.0f} MHz, read and write runs of up to {litedram_core.CONFIG['read_time']} and "
            f"{litedram_core.CONFIG['write_time']} cycles), simulated together on Verilator with LiteDRAM's model "
            "of the DRAM (`litedram_gen --sim` through scripts/litedram_gen_sim.py: the controller's timing the "
            "ECPIX-5's, a native word every 2 cycles, reads in 13; litedram_gen's own --sim core is a 1:4 PHY, "
            "twice the bus); "
            f"{where}; the two clocks in that ratio in the simulation. The job is the map's longest scenario "
            "(load, EDT, cfr, BFS, path read-out; no map read-out); its results (distances, vectors, cfr, hop "
            "counts, parents, path, the visit trace, with the map read-out in a first run) equal the tiled "
            "model's. Cycles are the engine's; StateRam's timing is the model's cycle count (a store that "
            "answers in 2 cycles and takes a command every cycle: what the block-RAM engine does). Native words: "
            "the reads and writes the controller took from the ports in the timed job (counted at its "
            "clock: sim/rtl/litedram.py's NativeCount); each holds the DDR3's data bus "
            f"{litedram_core.BURST_SYS_CYCLES} controller cycles (a burst of 8 on 16 bits), so *bus busy* is "
            "the share of the job's controller cycles the data bus carried a word: near 100 %, a faster engine "
            "would not make the job shorter, fewer words would.\n\n"
            "| map | tile visits | cycles, StateRam's timing | cycles through LiteDRAM | ratio | native words "
            "(reads + writes) | bus busy | job (ms) | scipy (ms) | speed-up | same as model |\n"
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n")
    for r in rows:
        ms = f"{r['ms_dram']:.1f}" if r["ms_dram"] is not None else "-"
        sp = f"{r['speedup']:.2f}x" if r["speedup"] is not None else "-"
        text += (f"| {r['map']} ({r['shape'][0]}x{r['shape'][1]}) | {r['tile_visits']:,} | "
                 f"{r['cycles_bram_timing']:,} | {r['cycles_dram']:,} | "
                 f"{r['cycles_dram'] / r['cycles_bram_timing']:.2f} | "
                 f"{r['native_reads']:,} + {r['native_writes']:,} | {100 * r['bus_busy']:.0f} % | {ms} | {r['scipy_ms']:.1f} | {sp} | "
                 f"{'yes' if r['same_as_model'] else 'NO: ' + ', '.join(r['differs'])} |\n")
    return text, rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="*", default=list(MAPS), help="maps/NAME.map (default: %(default)s)")
    ap.add_argument("--md", type=Path, help=f"replace the section '{SECTION}' of this markdown file")
    ap.add_argument("--states", action="store_true",
                    help="also print the engine's cycles by FSM state against the model's (a slower build)")
    args = ap.parse_args(argv)
    if args.md is not None and not args.md.is_file():
        print(f"bench_dram: {args.md}: no such file", file=sys.stderr)
        return 2
    for name in args.maps:
        base = re.sub(r"x\d+$", "", name)            # NAMExF: the map drawn F x F (bench_edt_tiled.job)
        if not (B.ROOT / "maps" / f"{base}.map").is_file():
            print(f"bench_dram: no map maps/{name}.map", file=sys.stderr)
            return 2
    try:
        litedram_core.generate(sim=True, ports=PORTS)
    except litedram_core.NotInstalled as e:
        print(f"bench_dram: {e}", file=sys.stderr)
        return 2
    if args.states:
        os.environ["NAVCORES_VERILATOR_PUBLIC"] = "1"     # the engine's state register visible (runner.py)
    text, rows = section(args.maps, args.states)
    print(text)
    if args.md is not None:
        kept.replace_section(args.md, SECTION, text)
    return 0 if all(r["same_as_model"] for r in rows) else 1


if __name__ == "__main__":
    os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")
    sys.exit(main())
