"""Benchmark (issue 18): the tiled EDT/BFS model's cost on the bundled maps, against scipy.

For each map and array (default: maze512-1-0, den312d, room-64-64-8,
random-64-64-10 on 8x8 and 16x16 arrays) one job of the tiled model
(models.edt_bfs_tiled.plan_path_tiled, RAM words of one tile row, 3 banks,
the default Timing; d_far 0; the goal and start of the map's longest
scenario, else its last and first free cell): EDT levels, tile visits,
array iterations, RAM words moved against the floor (every visit reading
and writing each pixel of its tile once), the job's cycles (load, EDT,
cfr and goals, BFS, path; no map read-out) and the model's own run time.
Beside it the software a user would run instead, on the same machine in
the same run: scipy.ndimage.distance_transform_edt(return_indices=True)
plus a scipy.sparse.csgraph BFS over the cfr (scripts/software.py, median
of 3 runs, graph construction included).  "Break-even" is the clock at
which the job's cycles take as long as the software (cycles / software
seconds): any clock above it is faster.  No RTL exists yet, so there is no
clock of its own to put here.

Memory: bits of state per pixel (models.edt_bfs_tiled.state_bits) times the
map, the EBRs that needs (8 pixels a word), and the largest square map the
LFE5U-85F's 208 EBRs hold.

    python scripts/bench_edt_tiled.py [--out build/bench/edt_tiled.md] [--maps NAME,...] [--arrays 8x8,16x16]

`comparison()` returns (markdown text, rows as a list of dicts) for the
`make bench` report to include.
"""

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import software  # noqa: E402
from navcores.models.edt_bfs_tiled import (EBR_BITS, LFE5U_85F_EBR, largest_map, plan_path_tiled,  # noqa: E402
                                  ram_blocks, state_bits)
from navcores.models.maps import load_map, longest_scenario  # noqa: E402

MAPS = ("maze512-1-0", "den312d", "room-64-64-8", "random-64-64-10")
ARRAYS = ((8, 8), (16, 16))
DFAR = 0


def job(name):
    """(obstacle, goal, start) of maps/NAME.map: its job (models.maps.longest_scenario)."""
    path = ROOT / "maps" / f"{name}.map"
    obstacle = load_map(path)
    s = longest_scenario(path, obstacle)
    return obstacle, tuple(s.goal), tuple(s.start)


def measure(name, arrays=ARRAYS, repeats=3):
    obstacle, goal, start = job(name)
    h, w = obstacle.shape
    sw = software.edt_bfs(obstacle, [goal], DFAR, bfs=("csgraph",), repeats=repeats)
    bits = state_bits(h, w)
    ebr = ram_blocks(h, w, 8)["blocks"]
    rows = []
    for array in arrays:
        t0, c0 = time.perf_counter(), time.process_time()
        res = plan_path_tiled(obstacle, [goal], start, DFAR, array=array)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        st = res.stats
        rows.append({
            "map": name, "shape": (h, w), "array": array, "goal": goal, "start": start,
            "path_steps": len(res.path) - 1 if res.path else None, "bfs_depth": res.iterations_bfs - 1,
            "levels": st["levels"], "tiles": st["tiles"],
            "visits_edt": st["visits_edt"], "visits_bfs": st["visits_bfs"],
            "iterations_edt": st["array_iterations_edt"], "iterations_bfs": st["array_iterations_bfs"],
            "words_moved": st["words_moved"], "words_floor": st["words_floor"], "cycles": res.cycles,
            "cycles_split": st["cycles"], "model_wall_s": wall, "model_cpu_s": cpu,
            "sw_seconds": sw["sw_seconds"], "sw_edt_s": sw["edt_seconds"], "sw_bfs_s": sw["bfs_csgraph_seconds"],
            "break_even_mhz": res.cycles / sw["sw_seconds"] / 1e6,
            "state_bits": bits["total"], "ebr": ebr,
        })
    return rows


def comparison(maps=MAPS, arrays=ARRAYS, progress=print):
    rows = []
    for name in maps:
        progress(f"{name} ...")
        rows += measure(name, arrays)
    lines = [
        "| map | array | levels | visits EDT / BFS (tiles) | array iterations EDT / BFS | words moved (floor) "
        "| cycles: load / EDT / goals+BFS / path = total | model s (CPU) | scipy EDT + csgraph BFS | break-even |",
        "|---|---|---:|---|---|---|---|---|---|---:|",
    ]
    for r in rows:
        c = r["cycles_split"]
        lines.append(
            f"| {r['map']} ({r['shape'][0]}x{r['shape'][1]}) | {r['array'][0]}x{r['array'][1]} | {r['levels']} "
            f"| {r['visits_edt']:,} / {r['visits_bfs']:,} ({r['tiles']:,}) "
            f"| {r['iterations_edt']:,} / {r['iterations_bfs']:,} "
            f"| {r['words_moved']:,} ({r['words_floor']:,}) "
            f"| {c['load'] + c['scan']:,} / {c['edt']:,} / {c['goals'] + c['bfs']:,} / {c['path']:,} "
            f"= {r['cycles']:,} "
            f"| {r['model_wall_s']:.2f} ({r['model_cpu_s']:.2f}) "
            f"| {r['sw_seconds'] * 1e3:.2f} ms ({r['sw_edt_s'] * 1e3:.2f} + {r['sw_bfs_s'] * 1e3:.2f}) "
            f"| {r['break_even_mhz']:.1f} MHz |")
    n = largest_map(LFE5U_85F_EBR, 8)
    lines += ["", "| map | bits / pixel | state | EBRs (8 pixels a word) | fits the LFE5U-85F (208 EBR)? |",
              "|---|---:|---:|---:|---|"]
    seen = set()
    for r in rows:
        if r["map"] in seen:
            continue
        seen.add(r["map"])
        h, w = r["shape"]
        lines.append(f"| {r['map']} | {r['state_bits']} | {h * w * r['state_bits'] / 8192:,.0f} KiB "
                     f"| {r['ebr']} | {'yes' if r['ebr'] <= LFE5U_85F_EBR else 'no'} |")
    lines += ["", f"Largest square map whose state fits the LFE5U-85F's {LFE5U_85F_EBR} EBRs "
              f"({LFE5U_85F_EBR * EBR_BITS:,} bits): {n}x{n} at {state_bits(n, n)['total']} bits a pixel "
              f"(worklist FIFOs and line buffers not counted)."]
    return "\n".join(lines), rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "build" / "bench" / "edt_tiled.md"))
    ap.add_argument("--maps", default=",".join(MAPS))
    ap.add_argument("--arrays", default=",".join(f"{r}x{c}" for r, c in ARRAYS))
    args = ap.parse_args(argv)
    arrays = [tuple(int(v) for v in a.split("x")) for a in args.arrays.split(",")]
    text, _ = comparison(args.maps.split(","), arrays)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
