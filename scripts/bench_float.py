"""Benchmark (issue 22): harmonic planning where floating point fails.

maze512-1-0 (1-wide corridors) cropped to 64x64, 128x128 and 256x256 from
the top-left corner (goal (1, 1), the first free cell in reading order) and
whole with its longest scenario's goal (maps/maze512-1-0-longest.scen).
Per map:

* reachable cells and the longest BFS distance to the goal;
* float64: scipy's sparse direct solve of the same Dirichlet problem
  (tb/harmonic/dirichlet.py): reachable free cells whose potential is
  exactly 0 (no gradient: a float64 planner cannot route from them);
* log-space: the red-black Gauss-Seidel solver on logarithms in the style
  of Wray et al. (tb/harmonic/logspace.py, float64, tolerance 1e-9): wall
  time, sweeps, and from how many starts its ascent reaches the goal;
* the planner with block exponents, as the RTL runs it
  (models.harmonic.plan(..., block_exponents=True, rtl=True), the fast
  visit, e_max from the map: exponent_bound), schedule P1:64:P1+1024 with
  P1 the map's precision_estimate rounded to a multiple of 64: converged,
  final p, exponent range and register width, cycles, model run time, the
  ascent (exact) and the Decision module's paths (decision_paths) from the
  starts, and the starts where the two differ.  Hardware time needs the
  exponent planner's clock on a part it fits, which no fit has measured
  (it does not fit the iCE40-HX8K, BENCHMARKS.md "Hardware"; no ECP5 fit
  was run): the column says so.
* node exponents (models/harmonic/node_exponents.py, p = 16, h = 2, e_max
  from the map) on every map: converged, iterations, exponent range, state
  bits, model time, the exact ascent and the Decision module (block (1, 1))
  from the starts; and the red-black order's iterations to convergence and
  to a fixed point.

Starts: every reachable cell on the crops; on the whole map the starts
of the longest bucket's scenarios with the chosen goal (one) and 1,000
random reachable cells (seed 0).  The planner runs only on the maps named by --planner (default
the 64 and 128 crops: the 256 crop needs p of about 7,400 bits and about
9 M block iterations, an hour or more of model time on this machine;
the table gives precision_estimate's p for the others).

    python scripts/bench_float.py [--planner 64,128] [--out build/bench/float.md] [--md BENCHMARKS.md]

--md replaces (or appends) the section "Harmonic planner where floating
point fails (issue 22)" of that file.  `section()` returns the markdown;
scripts/bench.py puts it into BENCHMARKS.md.
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))       # tb/ (not installed): the references

from navcores.models.harmonic import (ascent_reaches, decision_paths, distances, exponent_bound,  # noqa: E402
                                      plan, plan_node_exponents, precision_estimate, trajectory, ascent_next)
from navcores.models.harmonic.node_exponents import engine_cycles  # noqa: E402
from navcores.models.maps import load_map, load_scenarios, longest_scenario  # noqa: E402
from tb.harmonic.dirichlet import dirichlet  # noqa: E402
from tb.harmonic.logspace import log_harmonic, order_field  # noqa: E402

TITLE = "Harmonic planner where floating point fails (issue 22)"
BLOCK, ITERS = (6, 12), 6
MAP = ROOT / "maps" / "maze512-1-0.map"
SCEN = ROOT / "maps" / "maze512-1-0-longest.scen"
CROPS = (64, 128, 256)
SAMPLE = 1000
# The fit flow's result for the exponent planner (scripts/fit.py harmonic_planner n=6 m=12 br=2 bc=2
# p_max=254 depth=1024 block_exponents=1 --part LFE5U-85F): its clock gives the hardware time.
FIT = ROOT / "build" / "fit" / "harmonic_planner_bc2_block_exponents1_br2_depth1024_m12_n6_pmax254--LFE5U-85F.json"


# The node-exponent engine sized for the 256x256 crop, exponents wide enough for the whole maze
# (scripts/fit.py harmonic_node_exponent_engine max_h=256 max_w=256 p=16 e_max=10288 --part LFE5U-85F).
ENGINE = {"max_h": 256, "max_w": 256, "p": 16, "e_max": 10288}
ENGINE_FIT = ROOT / "build" / "fit" / "harmonic_node_exponent_engine_e_max10288_max_h256_max_w256_p16--LFE5U-85F.json"


def fit_clock(path=FIT):
    """(MHz, part) of a fit (default: the exponent planner's), or None when it was not run or did not fit."""
    import json
    if not path.exists():
        return None
    fit = json.loads(path.read_text())
    return (fit["fmax_mhz"], fit["part"]) if fit.get("fits") and fit.get("fmax_mhz") else None


def jobs():
    """[(key, label, obstacle, goal, scenario starts or None)]."""
    grid = load_map(MAP)
    out = [(str(n), f"maze512-1-0 cropped to {n}x{n}, goal (1, 1)", grid[:n, :n], (1, 1), None) for n in CROPS]
    job = longest_scenario(MAP, grid, scen=SCEN)
    starts = [s.start for s in load_scenarios(SCEN, grid) if s.goal == job.goal] or [job.start]
    out.append(("512", f"the whole 512x512, goal {job.goal} (the longest scenario's, {job.optimal_length:.0f} steps)",
                grid, tuple(job.goal), starts))
    return out


def _starts(reach, scenario):
    if scenario is None:
        return [tuple(int(v) for v in x) for x in np.argwhere(reach)]
    cells = np.argwhere(reach)
    pick = np.random.default_rng(0).choice(len(cells), size=min(SAMPLE, len(cells)), replace=False)
    return list(scenario) + [tuple(int(v) for v in cells[k]) for k in sorted(pick)]


def _reached(field, goal, starts):
    mask = np.zeros(field.shape, dtype=bool)
    mask[tuple(zip(*starts))] = True
    return int(ascent_reaches(field, [goal], mask).sum())


def _decided(mantissa, exponents, block, p, h, goal, starts):
    """(starts whose Decision path reaches the goal, starts where it differs from the exact ascent on ``h``)."""
    pad_goal = np.zeros(mantissa.shape, dtype=bool)
    pad_goal[goal] = True
    decided = decision_paths(mantissa, exponents, block, p, pad_goal, starts)
    nxt = ascent_next(h)
    return (sum(ok for _, ok in decided),
            sum(path != trajectory(h, [goal], s, nxt=nxt).path for s, (path, _) in zip(starts, decided)))


def measure_nodes(obstacle, goal, starts, log=print):
    """The node-exponent field (plan_node_exponents, p = 16, h = 2, e_max from the map): its run and reach."""
    res = plan_node_exponents(obstacle, [goal], progress=lambda i, z, m: log(f"  node exponents: {i} iterations, "
                                                                            f"{z} nodes at 0") if i % 1024 == 0 else None)
    row = dict(n_converged=bool(res.converged), n_iterations=res.iterations, n_p=res.p, n_h=res.headroom,
               n_e_lo=res.e_lo, n_e_hi=res.e_hi, n_e_max=res.e_max, n_seconds=res.seconds,
               n_state_mbit=obstacle.size * (res.p + 1 + res.exponent_bits) / 1e6)
    # The in-place order a streaming engine would run (red-black), to convergence and to a fixed point.
    rb = plan_node_exponents(obstacle, [goal], order="red-black")
    rbf = plan_node_exponents(obstacle, [goal], order="red-black", until_fixed=True)
    fits = all(n <= ENGINE[k] for n, k in zip(obstacle.shape, ("max_h", "max_w")))
    row.update(engine_cycles=engine_cycles(*obstacle.shape, rbf.iterations) if fits else None)
    row.update(rb_iterations=rb.iterations, rb_converged=bool(rb.converged), rb_fixed=rbf.iterations,
               rb_same=bool(rbf.fixed_point and (rbf.key == res.key).all()) if res.fixed_point else None)
    row["n_reached"] = _reached(res.key, goal, starts)
    row["n_decision_reached"], row["n_decision_differs"] = _decided(
        res.mantissa, res.exponents, (1, 1), res.p, res.key, goal, starts)
    return row


def node_ram_bits(blocks, p, block=BLOCK):
    """Node RAM bits a planner of ``blocks`` (BR, BC) needs at word
    precision p: each 3x6 cluster of a block holds B words of p+2 bits
    (one bit per address, 18 nodes wide: B * (p+2) words of 18 bits)."""
    clusters = (block[0] // 3) * (block[1] // 6)
    return clusters * blocks[0] * blocks[1] * (p + 2) * 18


def measure(key, obstacle, goal, scenario, run_planner, log=print):
    dist = distances(obstacle, [goal])
    reach = dist >= 0
    starts = _starts(reach, scenario)
    row = {"key": key, "reachable": int(reach.sum()), "longest": int(dist.max()), "starts": len(starts),
           "shape": obstacle.shape}
    const = obstacle | ~reach
    gmask = np.zeros(obstacle.shape, dtype=bool)
    gmask[goal] = True
    t0 = time.perf_counter()
    free, _, x, _ = dirichlet(gmask.astype(float), const | gmask)
    row["spsolve_seconds"] = time.perf_counter() - t0
    row["f64_zero"] = int((x == 0).sum())
    row["f64_min"] = float(x[x > 0].min())
    t0 = time.perf_counter()
    u, sweeps, conv = log_harmonic(obstacle, [goal])
    row.update(log_seconds=time.perf_counter() - t0, log_sweeps=sweeps, log_converged=conv,
               log_reached=_reached(order_field(u), goal, starts))
    log(f"{key}: {row}")
    row.update(measure_nodes(obstacle, goal, starts, log))
    log(f"{key}: {row}")
    est, spread = precision_estimate(obstacle, [goal], BLOCK)
    row.update(p_estimate=est, spread=spread, e_max=exponent_bound(obstacle, [goal]))
    if not run_planner:
        return row
    p1 = max(64, 64 * round(est / 64))
    t0 = time.perf_counter()
    res = plan(obstacle, [goal], block=BLOCK, iters=ITERS, schedule=tuple(range(p1, p1 + 1025, 64)),
               block_exponents=True, rtl=True, fast=True, e_max=row["e_max"],
               progress=lambda r, p, cycles: log(f"  {key}: p = {p}, {r.sweeps} sweeps, {r.block_iterations} "
                                                 f"block iterations, {cycles} cycles") if r.sweeps % 200 == 0 else None)
    row["planner_seconds"] = time.perf_counter() - t0
    row["ram_mbit"] = node_ram_bits(res.blocks, res.p) / 1e6
    row.update(p1=p1, converged=bool(res.converged), p=res.p, e_lo=int(res.exponents.min()),
               e_hi=int(res.exponents.max()), at_e_max=res.at_e_max, cycles=res.cycles,
               block_iterations=res.block_iterations)
    row["ascent_reached"] = _reached(res.h, goal, starts)
    row["decision_reached"], row["decision_differs"] = _decided(res.mantissa, res.exponents, res.block, res.p,
                                                                res.h, goal, starts)
    log(f"{key}: {row}")
    return row


def section(planner=("64", "128"), log=print):
    t0 = time.time()
    clock = fit_clock()
    rows, labels = [], {}
    for key, label, obstacle, goal, scenario in jobs():
        labels[key] = label
        rows.append(measure(key, obstacle, goal, scenario, key in planner, log))
    lines = [
        f"maze512-1-0 (corridors 1 wide), cropped from the top-left corner and whole; starts: every reachable "
        f"cell of a crop, on the whole map the start of the longest bucket's scenario with that goal and "
        f"{SAMPLE:,} random reachable cells. float64: scipy spsolve of the Dirichlet problem (goal 1, obstacles 0; tb/harmonic/dirichlet.py). "
        "Log-space: red-black Gauss-Seidel on float64 logarithms (Wray et al., IROS 2016; "
        "tb/harmonic/logspace.py), stop when a sweep changes no log by 1e-9. Planner: block exponents as the RTL "
        f"runs them (plan(..., block_exponents=True, rtl=True)), block {BLOCK[0]}x{BLOCK[1]}, I = {ITERS}, "
        "schedule P1:64:P1+1024 from P1 = precision_estimate rounded to 64, e_max = exponent_bound (2 x the "
        "longest distance); ascent: the exact steepest ascent; Decision: the Decision module's paths "
        "(decision_paths). Node RAM: the planner's cluster RAMs at that p (4 clusters a 6x12 block, each "
        "B x (p+2) words of 18 bits; an ECP5-85 has 3.7 Mbit of block RAM). Hardware time: cycles over the "
        "exponent planner's clock from the fit flow, "
        + (f"{clock[0]} MHz on the {clock[1]} (scripts/fit.py: the 2x2-block exponent planner, p_max 254, "
           "e_max 255; the instances that run these jobs, with more blocks and wider exponents, were not placed)"
           if clock else "not measured (build/fit has no fit of the exponent planner)") + ".",
        "",
        "| map | reachable cells | longest BFS distance | float64 spsolve: cells at exactly 0 | log-space: time, "
        "sweeps, ascent reaches goal | p the blocks need (estimate; spread) | planner: converged, p, e_b range "
        "(e_max, register bits) | planner cycles | node RAM | hardware time | model time | planner ascent / Decision "
        "reach goal (Decision paths differing) | node exponents: converged, iterations, e range (e_max, bits) | "
        "node exponents: state, model time | node exponents: ascent / Decision reach goal (differing) | "
        "node exponents, red-black: iterations to converge / to a fixed point | node-exponent engine: cycles, "
        "hardware time |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    eclock = fit_clock(ENGINE_FIT)
    for r in rows:
        share = 100 * r["f64_zero"] / r["reachable"]
        log_col = (f"{r['log_seconds']:.2f} s, {r['log_sweeps']:,} sweeps"
                   + ("" if r["log_converged"] else " (NOT converged)")
                   + f", {r['log_reached']:,} of {r['starts']:,}")
        est = f"{r['p_estimate']:,} ({r['spread']:,} steps)"
        if "p" in r:
            conv = "converged" if r["converged"] else "NOT converged"
            plan_col = (f"{conv}, p = {r['p']:,}, e_b {r['e_lo']}..{r['e_hi']:,} (e_max {r['e_max']:,}, "
                        f"{r['e_max'].bit_length()} bits" + (f", {r['at_e_max']} blocks at it" if r["at_e_max"] else "")
                        + ")")
            hw = f"{r['cycles'] / (clock[0] * 1e6):.3g} s" if clock else "not measured"
            rest = (f"{r['cycles']:,} | {r['ram_mbit']:.1f} Mbit | {hw} | {r['planner_seconds']:.0f} s | "
                    f"{r['ascent_reached']:,} / "
                    f"{r['decision_reached']:,} of {r['starts']:,} ({r['decision_differs']})")
        else:
            plan_col = f"not run (e_max {r['e_max']:,}, {r['e_max'].bit_length()} bits)"
            blocks = [-(-s // b) for s, b in zip(r["shape"], BLOCK)]
            rest = (f"not run | about {node_ram_bits(blocks, r['p_estimate']) / 1e6:.0f} Mbit at the estimate | "
                    "not measured | - | -")
        nodes = (f"{'converged' if r['n_converged'] else 'NOT converged'}, {r['n_iterations']:,}, e "
                 f"{r['n_e_lo']}..{r['n_e_hi']:,} ({r['n_e_max']:,}, {r['n_e_max'].bit_length()} bits) | "
                 f"{r['n_state_mbit']:.2f} Mbit, {r['n_seconds']:.1f} s | {r['n_reached']:,} / "
                 f"{r['n_decision_reached']:,} of {r['starts']:,} ({r['n_decision_differs']}) | "
                 f"{r['rb_iterations']:,}{'' if r['rb_converged'] else ' (NOT converged)'} / {r['rb_fixed']:,} | ")
        if r["engine_cycles"] is None:
            nodes += f"beyond the engine's {ENGINE['max_h']}x{ENGINE['max_w']} RAM (state {r['n_state_mbit']:.1f} Mbit)"
        else:
            nodes += f"{r['engine_cycles']:,}, " + (f"{r['engine_cycles'] / (eclock[0] * 1e6):.3g} s" if eclock
                                                    else "clock not measured")
        lines.append(f"| {labels[r['key']]} | {r['reachable']:,} | {r['longest']:,} | {r['f64_zero']:,} ({share:.0f} %; "
                     f"smallest {r['f64_min']:.1e}) | {log_col} | {est} | {plan_col} | {rest} | {nodes} |")
    lines += ["", "One exponent serves a whole block, so a block's word must span the distances inside the block and "
              "its border rings: about 2 bits a step of that spread (precision_estimate). In a maze two corridors of "
              "one 6x12 block can be thousands of steps apart, so p grows with the maze as in fixed point "
              "(the longest distance) and the exponents only add the rest: the exponent width is small "
              "(bits of 2 x the longest distance), the word is not.",
              "",
              "Node exponents (models/harmonic/node_exponents.py: block exponents with blocks of one node, "
              "a 17-bit mantissa (p = 16, top h = 2 bits empty) and an exponent of the map's e_max bits per node, "
              "every node updated at once, eq. 2 floored; iterations to no local maximum with every reachable node "
              "non-zero) take the precision wall away: a node's word spans only its own neighbourhood (the "
              "spread is one step), so the mantissa does not grow with the maze. State: one mantissa and one "
              "exponent per cell of the map, in Mbit (the LFE5U-85F has 3.7 Mbit of block RAM). Red-black: "
              "the even cells (row + column) first, then the odd ones from their new values, in place: the order a "
              "streaming engine over one state RAM would run (half the iterations; its fixed point is Jacobi's, "
              "tested on the 64x64 crop). Engine: hdl/harmonic/node_exponent_engine.py, the red-black order in place "
              "to a fixed point, cycles = engine_cycles(H, W, iterations) (asserted against the RTL by the "
              "regression), its clock "
              + (f"{eclock[0]} MHz on the {eclock[1]} (scripts/fit.py harmonic_node_exponent_engine max_h=256 "
                 "max_w=256 p=16 e_max=10288: build/fit)" if eclock else "not measured (build/fit has no fit of it)")
              + "; the same iterations as the model with the map's own e_max (no exponent reaches either bound).",
              "", f"({time.time() - t0:.0f} s of runs)"]
    return "\n".join(lines) + "\n", rows


def replace_section(md, title, text):
    """Put ``## title`` with ``text`` into the markdown file ``md`` (replacing that section)."""
    path = Path(md)
    old = path.read_text() if path.exists() else ""
    head = f"## {title}\n"
    block = head + "\n" + text
    if head in old:
        start = old.index(head)
        nxt = old.find("\n## ", start + len(head))
        new = old[:start] + block + (old[nxt:] if nxt >= 0 else "")
    else:
        new = old.rstrip("\n") + "\n\n" + block
    path.write_text(new)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--planner", default="64,128", help="maps the planner runs on: 64,128,256,512 or none")
    ap.add_argument("--out", default=str(ROOT / "build" / "bench" / "float.md"))
    ap.add_argument("--md", default=None, help="also put the section into this markdown file (BENCHMARKS.md)")
    args = ap.parse_args(argv)
    planner = () if args.planner == "none" else tuple(args.planner.split(","))
    if set(planner) - {*map(str, CROPS), "512"}:
        print(f"bench_float: --planner {args.planner}: choose from 64,128,256,512 or none", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    text, _ = section(planner, log=lambda s: print(s, file=sys.stderr, flush=True))
    out.write_text(f"# {TITLE}\n\n" + text)
    print(text)
    print(f"wrote {out}")
    if args.md:
        replace_section(args.md, TITLE, text)
        print(f"wrote the section into {args.md}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
