"""Benchmark: what the harmonic planner's hardware would spend on the bundled maps.

For each bundled map (goal of its longest scenario) the golden model runs the
increasing-precision loop of paper 000 (section 3.3.2): relax until stable,
raise p by 16 while local maxima remain.  One iteration of the whole grid
takes p+2 cycles in the node array (section 5.4), so the cycle count of a run
on a grid that fits the array in one block is sum(iterations x (p+2)).  The
report sets it beside a run at the final precision from the start, and gives
the time at the paper's 150 MHz.  Wall-clock seconds of the model are given
for reference.

    python scripts/bench.py [--out build/bench/report.md]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from models.harmonic import one, relax  # noqa: E402
from sim.demo import bfs, plan  # noqa: E402
from sim.mapfile import load_map, load_scenarios  # noqa: E402

CLOCK_HZ = 150e6


def bench(map_path):
    obstacle = load_map(map_path)
    scen_path = map_path.with_name(map_path.stem + "-even-10.scen")
    if scen_path.exists():
        goal = max(load_scenarios(scen_path, obstacle), key=lambda s: s.optimal_length).goal
    else:
        goal = tuple(np.argwhere(~obstacle)[0])
    obstacle = obstacle | (bfs(~obstacle, goal) < 0)
    t0 = time.time()
    h, const, p, levels = plan(obstacle, goal, 16, 16, 512)
    seconds = time.time() - t0
    increasing = sum(lv["iterations"] * (lv["p"] + 2) for lv in levels)
    h0 = np.zeros(obstacle.shape, dtype=object)
    h0[goal] = one(p)
    _, direct_iterations = relax(h0, const, p)
    direct = direct_iterations * (p + 2)
    return {
        "map": map_path.name, "nodes": obstacle.size, "final_p": p,
        "maxima_left": levels[-1]["local_maxima"],
        "levels": " ".join(f"{lv['p']}:{lv['iterations']}" for lv in levels),
        "increasing_cycles": increasing, "direct_cycles": direct,
        "model_s": seconds,
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="build/bench/report.md")
    args = ap.parse_args()
    rows = [bench(m) for m in sorted((ROOT / "maps").glob("*.map"))]
    lines = [
        "# Harmonic planner: cycles on the bundled maps (one block, p+2 cycles per iteration)",
        "",
        "| map | nodes | final p | maxima left | p:iterations per level | cycles, increasing p | "
        "cycles, final p from the start | µs at 150 MHz (increasing) | model s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['map']} | {r['nodes']} | {r['final_p']} | {r['maxima_left']} | {r['levels']} | "
                     f"{r['increasing_cycles']} | {r['direct_cycles']} | "
                     f"{r['increasing_cycles'] / CLOCK_HZ * 1e6:.1f} | {r['model_s']:.1f} |")
    text = "\n".join(lines) + "\n"
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
