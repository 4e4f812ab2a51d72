"""The tile engine with its state in a DDR3 through LiteDRAM, simulated on Verilator: whole jobs timed (issue 18).

``python scripts/bench_dram.py [MAP ...] [--json FILE]`` runs each map's job
(scripts/bench_edt_tiled.job: the map's longest scenario) on
:class:`~hdl.edt_bfs.tile_litedram.TileLiteDram` (the 4x8 engine over maps
up to 512x512 with ``store="dram"``, and LiteDRAM's generated controller
with its DRAM model: scripts/litedram_core.py) in Verilator, checks the
results against models.edt_bfs_tiled (distances, vectors, cfr, parents,
hop counts, path, tile visits and their trace: the same; cycles: more), and
reports the job's engine cycles and its time at the engine's clock
ENGINE_MHZ with the controller at litedram_core.SYS_CLK_HZ (the two clocks
in that ratio in the simulation), against scipy on the same machine in the
same run.  Needs ``pip install -e .[dram]``; exit 2 without it.
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_edt_tiled as B  # noqa: E402
import litedram_core  # noqa: E402
import software  # noqa: E402

from navcores.hdl.edt_bfs.tile_litedram import TileLiteDram  # noqa: E402
from navcores.models.edt_bfs_tiled import plan_path_tiled  # noqa: E402
from navcores.sim.rtl.clock import PERIOD_NS  # noqa: E402
from navcores.sim.rtl.runner import run  # noqa: E402

WORK = B.ROOT / "build" / "bench_dram"
ARRAY = (4, 8)
RAM = B.EXT_RAM
# The engine's clock: the 4x8 engine over 512x512 with an external store placed on the LFE5U-85F
# (BENCHMARKS.md's tile-engine section); the DramStore and the crossing FIFOs in front of the
# controller are not placed with it.
ENGINE_MHZ = 22.1
KEYS = ("distance", "nearest", "cfr", "parent", "visited", "path", "iterations_edt", "iterations_bfs",
        "tile_visits", "trace")


def sys_period_ns():
    """The controller's period in the simulation, where the engine's is PERIOD_NS: their real ratio (even ps)."""
    ps = PERIOD_NS * 1000 * ENGINE_MHZ * 1e6 / litedram_core.SYS_CLK_HZ
    return 2 * round(ps / 2) / 1000


def rtl_job(obstacle, goal, start, core, csrs, work):
    params = {"t_r": ARRAY[0], "t_c": ARRAY[1], "max_h": RAM[0], "max_w": RAM[1]}
    job, result = work / "job.json", work / "result.json"
    job.write_text(json.dumps({"obstacle": obstacle.tolist(), "goals": [list(goal)], "start": list(start),
                               "dfar": B.DFAR, "sys_period_ns": sys_period_ns(), "csrs": csrs,
                               "path_only_too": True, **params}))
    run("edt_tile_litedram", params, "verilator", "navcores.sim.rtl.edt_tile_job",
        env={"EDT_JOB": job, "EDT_RESULT": result}, log_file=work / "sim.log",
        factory=lambda **p: TileLiteDram(**p),
        build_args=[str(core), "-Wno-fatal", "-Wno-lint", "-Wno-style", "-Wno-WIDTH", "-Wno-MULTIDRIVEN",
                    "-CFLAGS", "-O1"])
    return json.loads(result.read_text())


def measure(name, core, csrs, work):
    obstacle, goal, start = B.job(name)
    model = plan_path_tiled(obstacle, [goal], start, B.DFAR, array=ARRAY)
    sw = software.edt_bfs(obstacle, [goal], B.DFAR, bfs=("csgraph",), repeats=3)
    t0 = time.perf_counter()
    rtl = rtl_job(obstacle, goal, start, core, csrs, work)
    wall = time.perf_counter() - t0
    same = {k: (np.array_equal(np.asarray(rtl[k]), np.asarray(getattr(model, k))) if k not in ("path", "trace")
                else [tuple(p) for p in rtl[k]] == list(getattr(model, k))) for k in KEYS}
    po = rtl["path_only"]                   # the job without the map read-out: what is timed
    if [tuple(p) for p in po["path"]] != model.path or [tuple(t) for t in po["trace"]] != list(model.trace):
        same["path_only"] = False
    bad = [k for k, ok in same.items() if not ok]
    ms = po["cycles"] / ENGINE_MHZ / 1e3
    return {"map": name, "shape": list(obstacle.shape), "tile_visits": model.tile_visits,
            "cycles_dram": po["cycles"], "cycles_bram_timing": model.cycles,
            "cycles_dram_with_readout": rtl["cycles"], "ms_dram": ms,
            "ms_bram_timing": model.cycles / ENGINE_MHZ / 1e3, "scipy_ms": sw["sw_seconds"] * 1e3,
            "speedup": sw["sw_seconds"] * 1e3 / ms,
            "engine_mhz": ENGINE_MHZ, "sys_mhz": litedram_core.SYS_CLK_HZ / 1e6, "same_as_model": not bad,
            "differs": bad, "sim_seconds": round(wall, 1)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="*", default=["room-64-64-8", "maze512-1-0"], help="maps/NAME.map (default: %(default)s)")
    ap.add_argument("--json", type=Path, help="write the rows here")
    args = ap.parse_args(argv)
    if args.json is not None and not args.json.parent.is_dir():
        print(f"bench_dram: {args.json.parent}: no such folder", file=sys.stderr)
        return 2
    try:
        core, csrs = litedram_core.generate(sim=True)
    except litedram_core.NotInstalled as e:
        print(f"bench_dram: {e}", file=sys.stderr)
        return 2
    rows = []
    for name in args.maps:
        work = WORK / name                  # the job, its result and the simulator's log, kept
        work.mkdir(parents=True, exist_ok=True)
        row = measure(name, core, csrs, work)
        rows.append(row)
        print(json.dumps(row), flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0 if all(r["same_as_model"] for r in rows) else 1


if __name__ == "__main__":
    os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")
    sys.exit(main())
