"""make fit: does a top fit a real FPGA, and how fast does it run there?

    make fit TOP=<top> PARAMS="name=value ..." PART=<part>
    python scripts/fit.py TOP [name=value ...] --part PART [--seeds 3] [--first-seed 1] [--jobs 2]
                          [--router router1|router2] [--placer heap|static] [--density BETA]
                          [--out FILE]

Synthesizes the top (``python -m hdl.emit --list`` shows the tops and their
parameters) in the registered harness of scripts/fmax.py with yosys, places
and routes it with nextpnr once per seed (both from PyPI, scripts/toolchain.py;
results cached under build/cache), and writes ``build/fit/<module>--<part>.json``:

  module, top, params, part, family, package, speed_grade, board
  verilog_sha256  SHA-256 of the top's emitted Verilog that was placed (fmax.emitted):
                  a reader checks the JSON is of the Verilog it emits now
  fits            bool; when false, overflow lists what the part lacks, or
                  is empty and unplaceable holds nextpnr's error (every
                  resource within the part, but the cells do not place)
  lut4, ff, bram, dsp   the core's own cells (harness excluded)
  fmax_mhz        median over the seeds (null when it does not fit)
  seeds           [{seed, fmax_mhz}] of every place-and-route run
  critical_path   of the median seed: start and end cell and port, delay,
                  logic levels, nets (cells core.* are the core's)
  tools           yosys and nextpnr versions, as the tools report them
  router          nextpnr's router (--router; router1 unless asked)
  placer_density  nextpnr's placement density (--density; null: its default, 0.9)
  placer          nextpnr's placer (--placer; heap unless asked)
  cells, utilisation, target_mhz, synthesis, harness, seconds

and prints one summary line.  Parts (case-insensitive): LFE5U-12F / 25F /
45F / 85F (CABGA381, speed 6: the ULX3S boards), LFE5UM5G-85F (CABGA554,
speed 8: the ECPIX-5), iCE40-UP5K (SG48:
iCEBreaker), iCE40-HX8K (CT256).  A top that does not fit exits 0 with
fits false; a bad TOP, parameter or PART exits 2, a tool failure 1, each
with one line on stderr.
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

import fmax
import toolchain

PROG = "make fit"


def _fail(msg, code=2):
    toolchain.fail(PROG, msg, code)


def _progress():
    return toolchain.progress_printer("fit")


def parse_args(argv):
    ap = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    ap.add_argument("top", nargs="?", help="top name (python -m hdl.emit --list)")
    ap.add_argument("params", nargs="*", metavar="name=value", help="parameters of the top")
    ap.add_argument("--part", help="FPGA part: " + ", ".join(p.name for p in fmax.PARTS.values()))
    ap.add_argument("--seeds", type=int, default=3, help="place-and-route seeds, odd (default 3; the median is reported)")
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="seeds placed at once (default 2)")
    ap.add_argument("--router", default="router1", choices=fmax.ROUTERS,
                    help="nextpnr's router (default router1)")
    ap.add_argument("--first-seed", type=int, default=1, metavar="N",
                    help="the first seed (default 1): seeds N .. N + SEEDS - 1")
    ap.add_argument("--placer", default="heap", choices=fmax.PLACERS,
                    help="nextpnr's placer (default heap; static: its electrostatic placer)")
    ap.add_argument("--density", type=float, metavar="BETA",
                    help="the placer's largest share of a region's cells, 0.5..1 (nextpnr's --placer-heap-beta; "
                         "default its 0.9): lower spreads a crowded design for the router")
    ap.add_argument("--out", help="output JSON (default build/fit/<module>--<part>.json)")
    ap.error = _fail
    args = ap.parse_args(argv)
    if not args.top:
        _fail("give a TOP (make fit TOP=<top> PARAMS=\"name=value ...\" PART=<part>); "
              "tops: " + ", ".join(fmax.TOPS))
    if args.top not in fmax.TOPS:
        _fail(f"unknown top {args.top!r}; tops: {', '.join(fmax.TOPS)}")
    if not args.part:
        _fail("give a PART: " + ", ".join(p.name for p in fmax.PARTS.values()))
    if args.seeds < 1 or args.seeds % 2 == 0 or args.seeds > 99:
        _fail(f"--seeds {args.seeds}: must be odd, 1..99 (the median is one seed's figure)")
    if args.jobs < 1:
        _fail(f"--jobs {args.jobs}: must be >= 1")
    if not 1 <= args.first_seed <= 1000:
        _fail(f"--first-seed {args.first_seed}: must be 1..1000")
    if args.density is not None and not 0.5 <= args.density <= 1.0:
        _fail(f"--density {args.density}: must be 0.5..1 (a share of a region's cells)")
    if args.density is not None and args.placer != "heap":
        _fail(f"--density with --placer {args.placer}: the density is the heap placer's")
    try:
        args.part = fmax.part(args.part)
        args.params = fmax.parse(fmax.params_of(args.top)[0], args.params)
        fmax.manifest(args.top, args.params)        # the component checks its parameters
    except (ValueError, TypeError) as e:
        _fail(str(e).splitlines()[0] if str(e) else type(e).__name__)
    return args


def output_path(args):
    """The JSON's path, checked before any work: a writable file in a directory we can create."""
    module = fmax.top_name(args.top, args.params)
    out = Path(args.out) if args.out else fmax.ROOT / "build" / "fit" / f"{module}--{args.part.name}.json"
    if out.is_dir():
        _fail(f"--out {out}: is a directory")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        _fail(f"cannot create {out.parent}: {e.strerror}")
    probe = _temporary(out)
    try:                # the file is written as a temporary beside it, then renamed
        probe.touch()
        probe.unlink()
    except OSError as e:
        _fail(f"cannot write {out}: {e.strerror}")
    if out.exists() and not os.access(out, os.W_OK):
        _fail(f"cannot write {out}: not writable")
    return out


def _temporary(out):
    return out.with_name(f".{out.name}.{os.getpid()}")


def summary(r, out):
    res = f"{r['lut4']} LUT4, {r['ff']} FF, {r['bram']} BRAM, {r['dsp']} DSP"
    where = f"{r['module']} on {r['part']}" + (f" (speed {r['speed_grade']})" if r["speed_grade"] else "")
    if not r["fits"]:
        return f"{where}: does not fit ({fmax.shortfall(r)}); {res}; {out}"
    cp = r["critical_path"]
    path = f"; critical path {cp['from']['cell']} -> {cp['to']['cell']}" if cp else ""
    figures = ", ".join(f"{s['fmax_mhz']:.1f}" for s in r["seeds"])
    return (f"{where}: fits, {res}, {r['fmax_mhz']:.1f} MHz (median of {len(r['seeds'])} "
            f"seed{'s' * (len(r['seeds']) > 1)}: {figures}){path}; {out}")


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    out = output_path(args)
    try:
        seeds = tuple(range(args.first_seed, args.first_seed + args.seeds))
        result = fmax.fit(args.top, args.params, args.part, seeds=seeds,
                          jobs=args.jobs, progress=_progress(), router=args.router, density=args.density,
                          placer=args.placer)
    except (fmax.FlowError, toolchain.ToolError) as e:
        _fail(str(e).splitlines()[0], 1)
    except KeyboardInterrupt:
        _fail("interrupted", 130)
    result["generator"] = " ".join(["python scripts/fit.py", args.top,
                                    *(f"{k}={v}" for k, v in sorted(args.params.items())),
                                    "--part", args.part.name, "--seeds", str(args.seeds),
                                    *(("--router", args.router) if args.router != "router1" else ()),
                                    *(("--first-seed", str(args.first_seed)) if args.first_seed != 1 else ()),
                                    *(("--density", str(args.density)) if args.density is not None else ()),
                                    *(("--placer", args.placer) if args.placer != "heap" else ())])
    result["date"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    tmp = _temporary(out)
    tmp.write_text(json.dumps(result, indent=1) + "\n")
    os.replace(tmp, out)            # never a partial file
    shown = os.path.relpath(out)
    print(summary(result, out if shown.startswith("..") else shown))
    return 0


if __name__ == "__main__":
    sys.exit(main())
