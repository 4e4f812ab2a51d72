"""The tile engine and LiteDRAM's controller placed as one top on the ECPIX-5's part (issue 18).

    python scripts/fit_dram_top.py [--part LFE5UM5G-85F] [--seeds 1] [--first-seed 1] [--jobs 1]
                                   [--router router2|router1] [--placer static|heap] [--array RxC]

The DRAM job's whole top: :class:`~hdl.edt_bfs.tile_litedram.TileLiteDram`
at the catalog's ``edt_tile_dram`` parameters (the tile engine, its
StateCdc and DramStores; ``--array``: another T_r x T_c) with LiteDRAM's
controller and PHY generated for
the part (scripts/litedram_core.py without ``--sim``), in scripts/fmax.py's
registered harness on the engine's clock ``clk``, the DDR3's pads and the
controller's ``sys_clk`` (its PLL's 100 MHz input) the top's own pins at
the ECPIX-5's sites (amaranth-boards' ``ddr3`` and ``clk100``: the LPF
written here).  Synthesized with yosys and placed and routed with nextpnr
as ``make fit`` does (router2 and the static placer by default: what
routes the largest engines; scripts/fit.py's JSON, its results cached), into
``build/fit/edt_tile_litedram_<params>--<part>.json``, with each clock's
MHz per seed (``seeds[].clocks``: the engine's ``clk``; the controller's
from its PLL, each with its target: ``seeds[].clock_targets``) and a
``verilog_sha256`` of the top's Verilog and LiteDRAM's core together.  Exit 2 on bad
arguments or without litedram (``pip install -e .[dram]``), 1 when a tool
fails.
"""

import argparse
import json
import os
import re
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")

import fmax  # noqa: E402
import litedram_core  # noqa: E402
import toolchain  # noqa: E402
from amaranth.back import verilog  # noqa: E402

from navcores.hdl import catalog  # noqa: E402
from navcores.hdl.edt_bfs.tile_litedram import DDR3_PINS, TileLiteDram  # noqa: E402

PROG = "fit_dram_top"
TOP = "edt_tile_litedram"
PART = "LFE5UM5G-85F"           # the ECPIX-5's
PARAMS = {k: v for k, v in catalog.get("edt_tile_dram").params.items() if k != "store"}
SYS_CLK_PIN = "sys_clk"
# The ECPIX-5's pads (amaranth-boards' ddr3 resource) of each of LiteDRAM's ddram_* pins.
BOARD_NAMES = {"a": "a", "ba": "ba", "ras_n": "ras", "cas_n": "cas", "we_n": "we", "dm": "dm", "dq": "dq",
               "dqs_p": "dqs", "clk_p": "clk", "cke": "clk_en", "odt": "odt"}
# The board does not wire cs_n and reset_n (neither amaranth-boards' resource nor LiteX-boards' ECPIX-5
# platform has them), but litedram_gen always makes them, through output registers (IOLOGIC) that
# nextpnr places only at a constrained pad: two pads of the DDR3's bank the board leaves free.
SPARE_PADS = {"cs_n": "M4", "reset_n": "N2"}
# The engine's clock (the harness's ``clk``) constrained at about what the 3x8 engine reaches in this top
# (37.2 MHz placed, 2026-12-06): with the fit flow's --freq (300 MHz) on it the timing-driven placer
# weighs the engine's paths, hopeless at that target, over the controller's, which then miss their 75 MHz
# (the placer's estimate 66.9-68.9 MHz with the engine's at 300).
ENGINE_MHZ = 36
ENGINE_CLK_PIN = "clk"


def lpf():
    """The LPF of the top's pins: sites and I/O standards from amaranth-boards' ECPIX-5, the PLL's input
    frequency, the engine's clock's target (ENGINE_MHZ)."""
    from amaranth_boards.ecpix5 import ECPIX585Platform
    res = {(r.name, r.number): r for r in ECPIX585Platform.resources}
    ddr3, clk = res["ddr3", 0], res["clk100", 0]
    common = dict(ddr3.attrs)
    subs = {s.name: s for s in ddr3.ios}
    lines = ["BLOCK RESETPATHS;", "BLOCK ASYNCPATHS;"]
    for pin, name in BOARD_NAMES.items():
        sub = subs[name]
        io = sub.ios[0]
        names = io.p.names if hasattr(io, "p") else io.names      # a differential pair: its p pads
        attrs = {**common, **dict(sub.attrs)}
        width = DDR3_PINS[pin][0]
        assert len(names) == width, (pin, names)
        for i, site in enumerate(names):
            port = f"ddram_{pin}[{i}]" if width > 1 else f"ddram_{pin}"
            lines.append(f'LOCATE COMP "{port}" SITE "{site}";')
            lines.append(f'IOBUF PORT "{port}" ' + " ".join(f"{k}={v}" for k, v in attrs.items()) + ";")
    for pin, site in SPARE_PADS.items():
        lines += [f'LOCATE COMP "ddram_{pin}" SITE "{site}";', f'IOBUF PORT "ddram_{pin}" IO_TYPE=SSTL15_I;']
    site = clk.ios[0].names[0]
    lines += [f'LOCATE COMP "{SYS_CLK_PIN}" SITE "{site}";',
              f'IOBUF PORT "{SYS_CLK_PIN}" ' + " ".join(f"{k}={v}" for k, v in dict(clk.attrs).items()) + ";",
              f'FREQUENCY PORT "{SYS_CLK_PIN}" {litedram_core.CONFIG["input_clk_freq"] / 1e6:g} MHZ;',
              f'FREQUENCY PORT "{ENGINE_CLK_PIN}" {ENGINE_MHZ} MHZ;']
    return "\n".join(lines) + "\n"


def source(prt, params=PARAMS):
    """The top's Verilog for Part ``prt`` (TileLiteDram at ``params`` with the DRAM's pads, module
    top_name(TOP, params)), written under build/fit/work only when its text changed: its path."""
    module = fmax.top_name(TOP, params)
    work = fmax.ROOT / "build" / "fit" / "work" / f"{module}--{prt.name}"
    work.mkdir(parents=True, exist_ok=True)
    return fmax.write_changed(work / f"{module}.v",
                              verilog.convert(TileLiteDram(**params, sim=False), name=module, emit_src=False))


def current_sha256(prt):
    """The fit's verilog_sha256 (fmax.sources_sha256: the top's Verilog and LiteDRAM's core) of the
    catalog's top and the controller generated now for Part ``prt``."""
    library, _ = litedram_core.generate(sim=False, ports=PARAMS["dram_ports"])
    return fmax.sources_sha256(source(prt), library)


def clock_name(net):
    """A clock's short name from nextpnr's global net (``$glbnet$core.dram.sys_clk`` -> ``sys_clk``)."""
    return re.sub(r"\$TRELLIS_IO_IN$", " (pin)", net.split("$glbnet$")[-1].split(".")[-1])


def clocks(fit):
    """(the engine's MHz, {each other clock's short name: (its MHz, its target MHz)}) of a fit JSON of this
    top, medians over its seeds.  The engine's clock is the harness's ``clk``; the others are the
    controller's (its PLL's outputs and its input pin), each checked against its own target (the LPF's
    100 MHz input, from which nextpnr derives each PLL output's)."""
    engine, other = [], {}
    for seed in fit["seeds"]:
        mine = [k for k in seed["clocks"] if re.search(r"(^|\$)clk(\$|$)", k)]
        theirs = [k for k in seed["clocks"] if k not in mine]
        if len(mine) != 1 or not theirs:
            raise ValueError(f"seed {seed['seed']}: not one engine clock and the controller's: {sorted(seed['clocks'])}")
        if "clock_targets" not in seed:
            raise ValueError(f"seed {seed['seed']}: no clock targets (a fit before they were kept: run it again)")
        engine.append(seed["clocks"][mine[0]])
        for k in theirs:
            other.setdefault(clock_name(k), []).append((seed["clocks"][k], seed["clock_targets"][k]))
    return statistics.median(engine), {k: (statistics.median(a for a, _ in v), v[0][1]) for k, v in other.items()}


def missed(others):
    """The clocks of clocks()' second item below their targets, as text ('' when none)."""
    return ", ".join(f"{k} {mhz:.1f} MHz of {target:g}" for k, (mhz, target) in sorted(others.items())
                     if mhz < target)


def main(argv=None):
    ap = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    ap.add_argument("--part", default=PART, help=f"an ECP5 part (default: {PART}, the ECPIX-5's)")
    ap.add_argument("--seeds", type=int, default=1, help="place-and-route runs (1..9, default 1)")
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--router", choices=fmax.ROUTERS, default="router2")
    ap.add_argument("--placer", choices=fmax.PLACERS, default="static")
    ap.add_argument("--array", help="T_RxT_C instead of the catalog's (edt_tile_dram)")
    args = ap.parse_args(argv)
    params = dict(PARAMS)
    if args.array is not None:
        if not re.fullmatch(r"\d+x\d+", args.array.lower()):
            toolchain.fail(PROG, f"--array {args.array}: must be RxC (e.g. 3x8)")
        params["t_r"], params["t_c"] = (int(v) for v in args.array.lower().split("x"))
        try:
            TileLiteDram(**params)              # its parameters checked
        except ValueError as e:
            toolchain.fail(PROG, f"--array {args.array}: {e}")
    try:
        prt = fmax.part(args.part)
    except ValueError as e:
        toolchain.fail(PROG, str(e))
    if prt.family != "ecp5" or not prt.name.endswith("85F"):
        toolchain.fail(PROG, f"--part {args.part}: the DRAM top needs an 85F ECP5 (LFE5U-85F, LFE5UM5G-85F)")
    if not 1 <= args.seeds <= 9:
        toolchain.fail(PROG, f"--seeds {args.seeds}: must be 1..9")
    if args.first_seed < 1 or args.jobs < 1:
        toolchain.fail(PROG, f"--first-seed {args.first_seed}, --jobs {args.jobs}: must be 1 or more")
    try:
        library, _ = litedram_core.generate(sim=False, ports=params["dram_ports"])
    except litedram_core.NotInstalled as e:
        toolchain.fail(PROG, str(e))
    progress = toolchain.progress_printer("fit")
    module = fmax.top_name(TOP, params)
    top = source(prt, params)
    constraints = fmax.write_changed(top.with_suffix(".lpf"), lpf())
    pins = {f"ddram_{k}" for k in DDR3_PINS} | {SYS_CLK_PIN}
    t0 = time.time()
    try:
        out = fmax.fit(TOP, params, prt, seeds=tuple(range(args.first_seed, args.first_seed + args.seeds)),
                       jobs=args.jobs, progress=progress, router=args.router, placer=args.placer,
                       source=top, pins=pins, library=library, lpf=constraints)
    except fmax.FlowError as e:
        toolchain.fail(PROG, str(e), 1)
    out.update({"litedram": str(library.relative_to(library.parents[3])), "lpf": constraints.name,
                "generator": "python scripts/fit_dram_top.py " + " ".join(argv if argv is not None else sys.argv[1:]),
                "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "seconds": round(time.time() - t0)})
    dest = fmax.ROOT / "build" / "fit" / f"{module}--{prt.name}.json"
    dest.write_text(json.dumps(out, indent=1) + "\n")
    if out["fits"]:
        engine, others = clocks(out)
        short = missed(others)
        what = (f"{out['lut4']} LUT4, {out['ff']} FF, {out['bram']} BRAM; the engine {engine:.1f} MHz; "
                + (f"below their targets: {short}" if short else "the controller's clocks at their targets: "
                   + ", ".join(f"{k} {mhz:.1f} MHz" for k, (mhz, _) in sorted(others.items()))))
    else:
        what = "does not fit"
    print(f"{module} on {prt.name}: {what} ({dest})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
