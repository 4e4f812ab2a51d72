"""make bitstream: a core behind its UART bridge, built for a real board.

    make bitstream BOARD=ulx3s-85f|icebreaker CORE=harmonic|dflc|edt_bfs [BAUD=115200]
    make bitstreams                              # every board/core pair below, one after the other
    python scripts/bitstream.py BOARD CORE [--baud N] [--seed N] [--out DIR]
    python scripts/bitstream.py --all [--baud N]

The board top (hdl/board/board_top.py: the core at the board's
configuration, CONFIGS there, behind the UART and the bridge of
docs/protocol.md) is elaborated on the amaranth-boards platform (pins and
the clock constraint), synthesized with yosys (``synth_ecp5`` /
``synth_ice40 -device u``), placed and routed with nextpnr against the
board's clock, and packed with ecppack / icepack, all from PyPI
(scripts/toolchain.py; every tool run cached in build/cache).  Writes
``build/bitstream/<board>-<core>.bit`` (ECP5) or ``.bin`` (iCE40) and a
JSON report beside it (resources, the clock reached, the tools, the INFO
text the bitstream answers), and prints the resources and the clock
reached against the board's clock.  Bitstreams are build products, never
committed.

Pairs: ulx3s-85f with harmonic, dflc, edt_bfs; icebreaker with dflc (the
planner and the EDT/BFS array do not fit its UP5K).

Exit status: 0 built, timing met; 1 a tool failed or the clock is not met
(no bitstream written); 2 bad input (one line on stderr).
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

import fmax
import toolchain

from navcores.hdl.board.board_top import BAUDS, BOARDS, CONFIGS, BoardTop, divisor_for
from navcores.hdl.board.cores import CORES
from navcores.hdl.emit import verilog_text

PROG = "make bitstream"
ROOT = toolchain.ROOT
PAIRS = tuple(CONFIGS)
# Synthesis where the part's usual command (scripts/fmax.py PARTS) does not
# fit: the Table 1 DFLC has 9 multipliers, the UP5K 8 DSPs, so on the
# iCEBreaker they are all built from logic.
SYNTH = {("icebreaker", "dflc"): "synth_ice40 -device u"}


def _fail(msg, code=2):
    toolchain.fail(PROG, msg, code)


def _progress():
    return toolchain.progress_printer("bitstream")


def parse_args(argv):
    ap = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    ap.add_argument("board", nargs="?", default="", help="board: " + ", ".join(BOARDS))
    ap.add_argument("core", nargs="?", default="", help="core: " + ", ".join(CORES))
    ap.add_argument("--baud", default="115200", help="UART baud rate (default 115200)")
    ap.add_argument("--seed", type=int, default=1, help="nextpnr's seed (default 1)")
    ap.add_argument("--out", default=str(ROOT / "build" / "bitstream"), help="output folder (default build/bitstream)")
    ap.add_argument("--all", action="store_true", help="every board/core pair")
    ap.error = _fail
    args = ap.parse_args(argv)
    if args.all:
        if args.board or args.core:
            _fail("--all builds every pair: give no BOARD or CORE")
        args.board, args.core = PAIRS[0]
    if args.board not in BOARDS:
        _fail(f"BOARD={args.board!r}: expected one of {', '.join(BOARDS)}")
    if args.core not in CORES:
        _fail(f"CORE={args.core!r}: expected one of {', '.join(CORES)}")
    if (args.board, args.core) not in CONFIGS:
        has = [c for b, c in PAIRS if b == args.board]
        _fail(f"CORE={args.core} is not built for BOARD={args.board} (it does not fit its "
              f"{BOARDS[args.board].part}); {args.board} takes: {', '.join(has)}")
    try:
        args.baud = int(args.baud)
    except ValueError:
        _fail(f"BAUD={args.baud!r}: expected an integer, e.g. " + ", ".join(map(str, BAUDS)))
    try:
        divisor_for(BOARDS[args.board].clock_hz, args.baud)
    except ValueError as e:
        _fail(f"BAUD={args.baud}: {str(e).removeprefix(f'baud {args.baud}: ')}")
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".probe{os.getpid()}"
        probe.touch()
        probe.unlink()
    except OSError as e:
        _fail(f"--out {out}: cannot write there ({e.strerror or e})")
    return args


def elaborate(board, core, baud):
    """The platform's build plan of the board top: RTLIL, constraints; and
    the Verilog of modules the core instantiates by name."""
    b = BOARDS[board]
    try:
        platform = b.platform_class()()
    except ImportError:
        _fail("amaranth-boards is not installed: pip install -e '.[fpga]' (make bitstream does it)")
    top = BoardTop(board, core, baud, **CONFIGS[board, core])
    extra = {name: verilog_text(sub, name) for name, sub in top.top.instance_modules().items()}
    # No source locations: they hold this clone's absolute paths, so the RTLIL
    # (and the cached synthesis keyed by its content) would differ between clones.
    plan = platform.prepare(top, name="top", emit_src=False)
    return b, top, plan, extra


def build(board, core, baud=115200, seed=1, out=None, progress=None):
    """The bitstream of ``core`` on ``board``: a JSON-ready report (the
    bitstream's path in ``bitstream``, None when the clock is not met)."""
    b, top, plan, extra = elaborate(board, core, baud)
    prt = fmax.part(b.part)
    work = ROOT / "build" / "bitstream" / "work" / f"{board}-{core}-{baud}"
    work.mkdir(parents=True, exist_ok=True)
    inputs = {}
    for name, text in {**{f"{n}.v": t for n, t in extra.items()}, **plan.files}.items():
        if name.endswith((".il", ".v", ".lpf", ".pcf")) and not name.endswith(".debug.v"):
            (work / name).write_text(text)
            inputs[name.replace(".", "_")] = work / name
    reads = " ".join(f"read_verilog {{{k}}};" for k in inputs if k.endswith("_v"))
    synth = SYNTH.get((board, core), prt.synth)
    script = (f"{reads} read_rtlil {{top_il}}; {synth} -top top; "
              "tee -q -o stat.json stat -json; write_json top.json")
    if progress:
        progress(f"{board} {core}: yosys {synth}")
    syn = toolchain.run("yosys", ["-q", "-l", "yosys.log", "-p", script], inputs, progress)
    if syn.returncode:
        raise fmax.FlowError(f"yosys failed: {fmax._error_line(syn.text('yosys.log') + syn.text('stderr.txt'), 'yosys')}"
                             f" (see {syn.dir})")
    ecp5 = prt.family == "ecp5"
    pins = {"pins": inputs["top_lpf" if ecp5 else "top_pcf"]}
    args = [*prt.device_args, "--json", "{netlist}", "--lpf" if ecp5 else "--pcf", "{pins}",
            "--textcfg" if ecp5 else "--asc", "top.config" if ecp5 else "top.asc",
            "--seed", str(seed), "--timing-allow-fail", "--report", "report.json", "--log", "nextpnr.log", "-q"]
    if progress:
        progress(f"{board} {core}: {prt.nextpnr} on {prt.name}, seed {seed}")
    pnr = toolchain.run(prt.nextpnr, args, {"netlist": syn.dir / "top.json", **pins}, progress)
    log = pnr.text("nextpnr.log")
    util = fmax.utilisation(log)
    if pnr.returncode:
        over = {k: v for k, v in util.items() if v[0] > v[1]}
        what = ("does not fit: " + ", ".join(f"{k} {u}/{a}" for k, (u, a) in over.items()) if over
                else fmax._error_line(log + pnr.text("stderr.txt"), prt.nextpnr))
        raise fmax.FlowError(f"{prt.nextpnr} failed: {what} (see {pnr.dir})")
    report = json.loads(pnr.text("report.json"))
    clocks = {name: round(c["achieved"], 2) for name, c in report["fmax"].items()}
    reached = min(clocks.values())
    board_mhz = b.clock_hz / 1e6
    result = {
        "board": board, "core": core, "part": prt.name, "params": CONFIGS[board, core], "baud": baud,
        "divisor": top.divisor, "clock_mhz": board_mhz, "fmax_mhz": reached, "clocks": clocks,
        "timing_met": reached >= board_mhz, "seed": seed, "synthesis": synth,
        "utilisation": {k: list(v) for k, v in util.items()},
        "cells": _cells(syn.text("stat.json")),
        "critical_path": fmax.critical_path(report),
        "info": top.top.info.decode(),
        "tools": {"yosys": syn.version, "nextpnr": pnr.version},
        "seconds": {"synthesis": syn.seconds, "place_and_route": pnr.seconds, "cached": syn.cached and pnr.cached},
        "bitstream": None,
    }
    if not result["timing_met"]:
        return result
    packer = "ecppack" if ecp5 else "icepack"
    suffix = ".bit" if ecp5 else ".bin"
    if progress:
        progress(f"{board} {core}: {packer}")
    pack_args = (["--compress", "--input", "{config}", "--bit", "top.bit"] if ecp5 else ["{config}", "top.bin"])
    packed = toolchain.run(packer, pack_args, {"config": pnr.dir / ("top.config" if ecp5 else "top.asc")}, progress)
    if packed.returncode or not (packed.dir / f"top{suffix}").exists():
        raise fmax.FlowError(f"{packer} failed: {(packed.text('stderr.txt').strip() or 'no output')[-200:]}")
    out = Path(out or ROOT / "build" / "bitstream")
    out.mkdir(parents=True, exist_ok=True)         # make bench's folder is new in a fresh clone
    dest = out / f"{_name(board, core, baud)}{suffix}"
    tmp = dest.with_name(f".{dest.name}.{os.getpid()}")
    tmp.write_bytes((packed.dir / f"top{suffix}").read_bytes())
    os.replace(tmp, dest)
    result["bitstream"] = str(dest)
    result["tools"]["packer"] = packed.version
    return result


def _cells(stat):
    """The synthesized design's cells by type (yosys stat of the flattened top)."""
    modules = json.loads(stat)["modules"] if stat else {}
    top = modules.get("\\top", {})
    return dict(sorted((k, v) for k, v in top.get("num_cells_by_type", {}).items() if not k.startswith("$")))


def summary(r):
    u = r["utilisation"]
    ecp5 = r["part"].startswith("LFE5")
    keys = (("TRELLIS_COMB", "LUT4"), ("TRELLIS_FF", "FF"), ("DP16KD", "BRAM"), ("MULT18X18D", "DSP")) if ecp5 else \
        (("ICESTORM_LC", "LC"), ("ICESTORM_RAM", "BRAM"), ("ICESTORM_DSP", "DSP"), ("ICESTORM_SPRAM", "SPRAM"))
    res = ", ".join(f"{u[k][0]}/{u[k][1]} {name}" for k, name in keys if k in u)
    clock = (f"clock {r['clock_mhz']:g} MHz, reached {r['fmax_mhz']:.1f} MHz "
             + ("(met)" if r["timing_met"] else "(NOT met)"))
    where = f"{r['board']} {r['core']} on {r['part']}, {r['baud']} Bd (divisor {r['divisor']})"
    tail = f": {os.path.relpath(r['bitstream'])}" if r["bitstream"] else ": no bitstream written"
    return f"{where}: {res}; {clock}{tail}"


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    status = 0
    for board, core in PAIRS if args.all else [(args.board, args.core)]:
        try:
            r = build(board, core, args.baud, args.seed, args.out, _progress())
        except (fmax.FlowError, toolchain.ToolError) as e:
            _fail(f"{board} {core}: {str(e).splitlines()[0]}", 1)
        except KeyboardInterrupt:
            _fail("interrupted", 130)
        r["date"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        report = Path(args.out) / f"{_name(board, core, args.baud)}.json"
        tmp = report.with_name(f".{report.name}.{os.getpid()}")
        tmp.write_text(json.dumps(r, indent=1) + "\n")
        os.replace(tmp, report)
        print(summary(r), flush=True)
        status = max(status, 0 if r["timing_met"] else 1)
    return status


def _name(board, core, baud):
    return f"{board}-{core}" + ("" if baud == 115200 else f"-{baud}")


if __name__ == "__main__":
    sys.exit(main())
