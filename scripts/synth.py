"""Synthesize the harmonic node and cluster for Virtex-II and compare with paper 000.

Paper 000 reports its resource use on an XC2V6000-5: the node module takes
11 FF and 22 LUT4 at 361 MHz (Table 1), the 3x6 cluster without its RAM takes
198 FF and 398 LUT4 at 300 MHz (Table 2).  This script measures the same
figures for our Amaranth design: it emits Verilog with :func:`hdl.emit.emit`,
runs Debian's yosys ``synth_xilinx -family xc2v`` (4-input LUTs, RAMB16) and
counts the cells of the final ``stat``.

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
* yosys does no timing, so there is no frequency to compare.
* EDT/BFS (paper 004): the cell and the 8x8 and 16x16 arrays with the
  hierarchy kept (EDT_TOPS, own table: glue + cells x count).
* DFLC (paper 003, section 7): the core alone (``dflc_core``, Table 2
  parameters, models/dflc_table1.fll) and its parallel option, on the paper's
  Spartan-3: ``synth_xilinx -family xc3s`` (DFLC_TOPS, own table).

    AMARANTH_USE_YOSYS=builtin .venv/bin/python scripts/synth.py [--out build/synth/report.md]
"""

import argparse
import os
import re
import shlex
import shutil
import subprocess
import sys
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")

from hdl.emit import emit  # noqa: E402

YOSYS = shutil.which("yosys") or "/usr/bin/yosys"
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
VARIANTS = {"": "", "-nowidelut": ".nowidelut"}  # extra synth_xilinx flags -> log suffix
SCRIPT = ("read_verilog {v}; synth_xilinx -family {family} -top {top} -flatten "
          "-noiopad -noclkbuf{flags}; stat")
GROUPS = [  # (group, cell type pattern); first match wins
    ("FF", r"FD\w*"), ("LUT", r"LUT[1-4]|INV"), ("BRAM", r"RAMB\w+"),
    ("LUTRAM", r"RAM\w+"), ("SRL", r"SRL\w+"), ("MUXF", r"MUXF\d"),
    ("carry", r"MUXCY|XORCY|MULT_AND|CARRY\w*"), ("other", r"\w+"),
]


def yosys_cmd(v, top, flags, log, family="xc2v"):
    return [YOSYS, "-q", "-l", str(log), "-p",
            SCRIPT.format(v=v, top=top, family=family, flags=f" {flags}" if flags else "")]


def run_yosys(v, top, flags, log, family="xc2v"):
    """Synthesize; return the cell counts of the last ``stat`` as a Counter."""
    res = subprocess.run(yosys_cmd(v, top, flags, log, family), capture_output=True, text=True)
    if res.returncode:
        sys.exit(f"yosys failed on {v} (see {log}):\n{res.stderr[-2000:]}")
    stat = log.read_text().rsplit("Printing statistics.", 1)[1]
    cells = stat.split("Number of cells:", 1)[1].split("\n\n", 1)[0]
    return Counter({k: int(n) for k, n in re.findall(r"^\s+(\w+)\s+(\d+)$", cells, re.M)})


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
    lines += ["    " + shlex.join(yosys_cmd(j["v"], j["top"], "", j["log"]))
              for j, _ in results if not j["flags"]]
    if dflc:
        lines += dflc_report(dflc)
    return "\n".join(lines) + "\n"


BREAKDOWN_SCRIPT = ("read_verilog {v}; synth_xilinx -family xc2v -top {top} -noiopad -noclkbuf "
                    "-nowidelut; stat")


def cluster_breakdown(v, top, log):
    """The cluster synthesized with its hierarchy kept (no -flatten, plain
    LUT4s): FF / LUT4 of the 18 node modules, of the Counters and of the
    cluster's own logic (host port multiplexers, per-iteration command and
    Sel registers, done/flag logic: the block control part)."""
    res = subprocess.run([YOSYS, "-q", "-l", str(log), "-p", BREAKDOWN_SCRIPT.format(v=v, top=top)],
                         capture_output=True, text=True)
    if res.returncode:
        sys.exit(f"yosys failed on {v} (see {log}):\n{res.stderr[-2000:]}")
    text = log.read_text().rsplit("Printing statistics.", 1)[1]
    parts = {"nodes": Counter(), "counters": Counter(), "cluster logic": Counter()}
    for name, body in re.findall(r"^=== (\S+) ===\n(.*?)(?=^=== |\Z)", text, re.M | re.S):
        if "design hierarchy" in name:
            continue
        cells = body.split("Number of cells:", 1)[1].split("\n\n", 1)[0] if "Number of cells:" in body else ""
        counts = Counter({k: int(n) for k, n in re.findall(r"^\s+(\w+)\s+(\d+)$", cells, re.M)})
        key = "nodes" if ".node_" in name else "counters" if name.endswith(".counters") else "cluster logic"
        parts[key] += group(counts)[0]
    return parts


EDT_SCRIPT = ("read_verilog {v}; synth_xilinx -family xc2v -top {top} -noiopad -noclkbuf "
              "-nowidelut; stat")


def edt_hier(v, name, params, paper):
    """One EDT top (emitted to ``v``) synthesized with its hierarchy kept: the
    group sums of the top module's own logic (``glue``) and of one cell
    module, the number of cells, and the total ``glue + cells x count``."""
    log = OUT_DIR / f"{v.stem}.hier.log"
    res = subprocess.run([YOSYS, "-q", "-l", str(log), "-p", EDT_SCRIPT.format(v=v, top=v.stem)],
                         capture_output=True, text=True)
    if res.returncode:
        sys.exit(f"yosys failed on {v} (see {log}):\n{res.stderr[-2000:]}")
    text = log.read_text().rsplit("Printing statistics.", 1)[1]
    glue, cell = Counter(), Counter()
    for mod, body in re.findall(r"^=== (\S+) ===\n(.*?)(?=^=== |\Z)", text, re.M | re.S):
        if "design hierarchy" in mod or "Number of cells:" not in body:
            continue
        cells = body.split("Number of cells:", 1)[1].split("\n\n", 1)[0]
        counts = group(Counter({k: int(n) for k, n in re.findall(r"^\s+(\w+)\s+(\d+)$", cells, re.M)}))[0]
        if mod.lstrip("\\").endswith(".proto"):
            cell = counts
        else:
            glue = counts
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
    lines += ["    " + shlex.join([YOSYS, "-p", EDT_SCRIPT.format(v=r["v"], top=r["top"])]) for r in rows]
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
    lines += ["    " + shlex.join(yosys_cmd(j["v"], j["top"], "", j["log"], j["family"]))
              for j, _ in results if not j["flags"]]
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(OUT_DIR / "report.md"), help="Markdown report")
    args = ap.parse_args()
    if not shutil.which(YOSYS):
        sys.exit(f"error: {YOSYS} not found; install it with `apt-get install yosys`")
    out = Path(args.out).resolve()
    os.chdir(ROOT)
    t0 = time.monotonic()
    version = subprocess.run([YOSYS, "-V"], capture_output=True, text=True).stdout.strip()
    jobs = []
    for family, tops in (("xc2v", TOPS), ("xc3s", DFLC_TOPS)):
        for name, params, paper in tops:
            v = emit(name, params, OUT_DIR)
            for flags, suffix in VARIANTS.items():
                jobs.append(dict(name=name, paper=paper, top=v.stem, flags=flags, v=v, family=family,
                                 log=OUT_DIR / f"{v.stem}{suffix}.log"))
    with ThreadPoolExecutor(max_workers=2) as pool:  # the yosys runs are independent
        cells = pool.map(lambda j: run_yosys(j["v"], j["top"], j["flags"], j["log"], j["family"]), jobs)
        results = list(zip(jobs, cells))
    text = report(results, version, time.monotonic() - t0)
    cl = next(j for j, _ in results if j["name"] == "harmonic_cluster")
    parts = cluster_breakdown(cl["v"], cl["top"], OUT_DIR / f"{cl['top']}.hier.log")
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
    print(text, end="")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)


if __name__ == "__main__":
    main()
