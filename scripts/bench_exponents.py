"""Benchmark (issue 10): block exponents against fixed point, on every bundled map.

All runs are the golden model (models.harmonic.plan), whose cycle counts
follow the planner RTL's timing table (a block visit of K iterations at word
precision p costs K*(p+2) + VISIT_OVERHEAD, a check pass one iteration per
block); the block-exponent runs add the re-picks' shift visits, as its
docstring (plan_exponents) states.  Same block (6x12, the
RTL's 2x2-cluster block and plan()'s default), I = 6, the goal of each map's
longest scenario (the last free cell where a map has no scenario file), and
the same increasing precision schedule (STEP:STEP:512): the run stops at the
first level without a local maximum, so "bits" is the word precision p the
map needs at that granularity.

Capacity: the node RAM of every cluster holds block b's words (p+2 bits, one
per address) at base b*(p+2), so a 1K-deep RAM holds floor(1024 / (p+2))
blocks; with block exponents the word is still p+2 bits (the exponents live
in the Control module, one register per block), so the capacity follows the
p the map needs.  The capacity figure is for maps of the same kind: p grows
with the map (Fig. 3), so a larger map of the kind needs at least this p.

    python scripts/bench_exponents.py [--out build/bench/exponents.md] [--only MAP]

Block exponents run twice: the model's rule, and the planner RTL's variant,
plan(..., rtl=True) (the Maximum on converted values, the clamp scans,
shift visits of ceil(d/3) iterations), the one
Planner(..., block_exponents=True) matches bit for bit.

`comparison()` returns (markdown text, rows as a list of dicts); the
`make bench` report imports and calls it.
"""

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from navcores.models.harmonic import plan  # noqa: E402
from navcores.models.maps import load_map, longest_scenario  # noqa: E402

BLOCK, ITERS = (6, 12), 6
STEP = 16
SCHEDULE = tuple(range(STEP, 513, STEP))
RAM_DEPTH = 1024


def bundled_maps(maps_dir=None, names=None):
    """[(name, obstacle, [goal])] for every maps/*.map (or those ``names``,
    stems), the goal of the map's job (models.maps.longest_scenario, as
    scripts/bench_harmonic.py picks it)."""
    out = []
    for path in sorted(Path(maps_dir or ROOT / "maps").glob("*.map")):
        if names and path.stem not in names:
            continue
        obstacle = load_map(path)
        out.append((path.stem, obstacle, [tuple(longest_scenario(path, obstacle).goal)]))
    return out


def capacity(p, block=BLOCK, depth=RAM_DEPTH):
    """(blocks, nodes) a depth-deep node RAM holds at word precision p."""
    blocks = depth // (p + 2)
    return blocks, blocks * block[0] * block[1]


def _row(name, obstacle, scheme, res, seconds):
    blocks, nodes = capacity(res.p)
    return {
        "map": name, "size": f"{obstacle.shape[0]}x{obstacle.shape[1]}",
        "blocks": res.blocks[0] * res.blocks[1], "scheme": scheme, "p": res.p,
        "converged": bool(res.converged), "sweeps": res.sweeps, "iterations": res.block_iterations,
        "cycles": res.cycles, "capacity_blocks": blocks, "capacity_nodes": nodes,
        "max_exponent": int(res.exponents.max()) if res.exponents is not None else 0,
        "frac_bits": res.frac_bits if res.frac_bits is not None else res.p,
        "repicks": res.repicks, "seconds": round(seconds, 2),
    }


def comparison(maps_dir=None, names=None):
    """Run fixed point, block exponents (the model's rule) and block
    exponents as the planner RTL does them (plan(..., rtl=True)) on every
    bundled map: (markdown, rows; three rows per map, in that order)."""
    rows = []
    schemes = (("fixed point", {}), ("block exponents", {"block_exponents": True}),
               ("block exponents, RTL", {"block_exponents": True, "rtl": True}))
    for name, obstacle, goals in bundled_maps(maps_dir, names):
        for scheme, kw in schemes:
            t0 = time.time()
            res = plan(obstacle, goals, block=BLOCK, iters=ITERS, schedule=SCHEDULE, **kw)
            rows.append(_row(name, obstacle, scheme, res, time.time() - t0))
    lines = [
        f"Block {BLOCK[0]}x{BLOCK[1]}, I = {ITERS}, schedule {STEP}:{STEP}:512 for all three, goal of the "
        "longest scenario; cycles by the planner RTL's timing model (block exponents, the model's "
        "rule: + one shift visit per re-pick; RTL: plan(..., rtl=True), what "
        "Planner(block_exponents=True) does bit for bit: clamp scans, shift visits of ceil(d/3) "
        f"iterations, Maximum on converted values); capacity: blocks of {BLOCK[0]}x{BLOCK[1]} a "
        f"{RAM_DEPTH}-deep node RAM holds at that p (floor(1024/(p+2))), and nodes.",
        "",
        "| map | blocks | fixed p | exp p (max e_b) | fixed iterations | exp iterations | fixed cycles | "
        "exp cycles | exp cycles, RTL | cycles fixed/exp | fixed/exp, RTL | capacity fixed | capacity exp |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    triples = list(zip(rows[0::3], rows[1::3], rows[2::3]))
    for fx, ex, rt in triples:
        conv = "" if fx["converged"] and ex["converged"] else " (not converged)"
        # the RTL variant's p and iterations, where they differ from the rule's
        same = (rt["p"], rt["iterations"], rt["converged"]) == (ex["p"], ex["iterations"], ex["converged"])
        rtl_note = "" if same else f" (p {rt['p']}, {rt['iterations']} iterations)"
        lines.append(
            f"| {fx['map']} ({fx['size']}){conv} | {fx['blocks']} | {fx['p']} | {ex['p']} ({ex['max_exponent']}) | "
            f"{fx['iterations']} | {ex['iterations']} | {fx['cycles']:,} | {ex['cycles']:,} | "
            f"{rt['cycles']:,}{rtl_note} | **{fx['cycles'] / ex['cycles']:.2f}** | "
            f"**{fx['cycles'] / rt['cycles']:.2f}** | {fx['capacity_blocks']} ({fx['capacity_nodes']:,}) | "
            f"{ex['capacity_blocks']} ({ex['capacity_nodes']:,}) |")
    better = [fx["map"] for fx, ex, _ in triples if ex["cycles"] < fx["cycles"]]
    better_rtl = [fx["map"] for fx, _, rt in triples if rt["cycles"] < fx["cycles"]]
    larger = [fx["map"] for fx, ex, _ in triples if ex["capacity_nodes"] > fx["capacity_nodes"]]
    lines += ["", f"Fewer cycles with block exponents: {', '.join(better) or 'none'} "
              f"(RTL variant: {', '.join(better_rtl) or 'none'}); larger capacity: "
              f"{', '.join(larger) or 'none'}."]
    return "\n".join(lines) + "\n", rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "build" / "bench" / "exponents.md"))
    ap.add_argument("--maps", default=None, help="directory of .map files (default: maps/)")
    ap.add_argument("--only", action="append", default=None, metavar="NAME", help="map stem (repeatable)")
    args = ap.parse_args(argv)
    t0 = time.time()
    text, rows = comparison(args.maps, args.only)
    text = "# Block exponents against fixed point (issue 10)\n\n" + text + \
        f"\n({time.time() - t0:.0f} s of model runs)\n"
    print(text)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
