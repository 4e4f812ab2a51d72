"""A top on a real part: resources, whether it fits, and its clock, from yosys + nextpnr (scripts/toolchain.py).

To make the clock the core's timing and not the pins', the top is wrapped
in a harness (:func:`harness`):

* every input bit of the core (``rst`` included, ``clk`` excepted) is a stage
  of one shift register fed by a single pin ``si``: each input comes straight
  from a flip-flop;
* every output bit is captured in a flip-flop, and the captured bits are
  XOR-reduced to a single pin ``so`` in a tree registered after every level of
  four, so the reduction is never longer than one LUT4 per stage.

So the critical path is one of: register -> core input logic, the core's own
register-to-register paths, core outputs -> capture register.  Cells named
``core.*`` are the core's, the others the harness's (``chain*``: input
registers, ``s0*``: output capture registers).

Flow (:func:`fit`): yosys ``synth_ecp5`` / ``synth_ice40`` of the core and
the harness, the core kept as its own module (``keep_hierarchy``) so that its
cell counts are its own (the LUT4 / FF / BRAM / DSP figures exclude the
harness), then flattened for nextpnr (on ECP5, a block RAM's registered
read moves into the DP16KD output register: scripts/ecp5_pack.py); nextpnr places and routes it once per
seed (timing-driven, ``--freq`` = the part's target: it steers the placer;
the reached frequency is reported whether or not it meets the target).  A
design larger than the part does not fit: nextpnr's utilisation says which
resource overflowed, and no seed is run after the first.

The command is scripts/fit.py (``make fit``); scripts/bench.py and
scripts/synth.py call :func:`fit` and :func:`synthesize`.
"""

import hashlib
import json
import os
import re
import statistics
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import ecp5_pack
import toolchain

os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")

# The project's code, imported here only (fit.py, synth.py and bench.py use these names).
from navcores.hdl.emit import TOPS, emit, manifest, params_of, top_name, verilog_ports  # noqa: E402,F401
from navcores.hdl.ram_init import strip_zero_init  # noqa: E402
from navcores.hdl.params import parse  # noqa: E402,F401

ROOT = toolchain.ROOT

__all__ = ["Part", "PARTS", "part", "ports", "harness", "RESOURCES", "resources", "synthesize", "FlowError",
           "write_changed",
           "utilisation", "critical_path", "place", "pack_ecp5", "emitted", "fit",
           # the project's code, for fit.py, synth.py and bench.py
           "TOPS", "emit", "manifest", "params_of", "parse", "top_name"]


@dataclass(frozen=True)
class Part:
    """An FPGA the fit flow targets, named as the vendor writes it."""

    name: str
    family: str                 # "ecp5" or "ice40"
    package: str
    speed_grade: str | None     # iCE40 parts have none
    board: str
    device_args: tuple          # nextpnr's device selection
    synth: str                  # the yosys synthesis command
    target_mhz: int             # nextpnr --freq

    @property
    def nextpnr(self):
        return f"nextpnr-{self.family}"


def _ecp5(size, board):
    return Part(f"LFE5U-{size}F", "ecp5", "CABGA381", "6", board,
                (f"--{size}k", "--package", "CABGA381", "--speed", "6"), "synth_ecp5", 300)


PARTS = {p.name.lower(): p for p in (
    _ecp5(12, "ULX3S-12F"), _ecp5(25, "ULX3S-25F"), _ecp5(45, "ULX3S-45F"), _ecp5(85, "ULX3S-85F"),
    # The ECPIX-5's: the LFE5U-85F's fabric (with SERDES) at speed grade 8, the only grade it comes in.
    Part("LFE5UM5G-85F", "ecp5", "CABGA554", "8", "ECPIX-5", ("--um5g-85k", "--package", "CABGA554", "--speed", "8"),
         "synth_ecp5", 300),
    # UP5K: synthesis for its timing (-device u) and its SB_MAC16 DSPs; the HX has no DSP.
    Part("iCE40-UP5K", "ice40", "SG48", None, "iCEBreaker", ("--up5k", "--package", "sg48"),
         "synth_ice40 -device u -dsp", 150),
    Part("iCE40-HX8K", "ice40", "CT256", None, "iCE40-HX8K breakout board", ("--hx8k", "--package", "ct256"),
         "synth_ice40", 150),
)}


def part(name):
    """The Part named ``name`` (case-insensitive), else ValueError listing the parts."""
    try:
        return PARTS[name.lower()]
    except KeyError:
        raise ValueError(f"unknown part {name!r}; parts: {', '.join(p.name for p in PARTS.values())}") from None


# -- the harness

def ports(verilog_text, module):
    """``[(direction, name, width)]`` of ``module`` in Amaranth's Verilog (hdl.emit's port parser)."""
    return [(d, name, w) for name, (d, w) in verilog_ports(verilog_text, module).items()]


def _port(name):
    """A port name in a connection: an escaped identifier (a port named like a keyword, ``\\reg``)
    ends at white space."""
    return name + " " if name.startswith("\\") else name


def harness(verilog_text, module, clock="clk", pins=()):
    """Verilog of ``fmax_<module>``: the core between a serial input chain and an XOR tree.

    ``pins``: the core's ports that are the harness's own ports instead (a
    second clock, a memory's pads: placed at the part's pins by the fit's
    constraints)."""
    ps = ports(verilog_text, module)
    ins = [(n, w) for d, n, w in ps if d == "input" and n != clock and n not in pins]
    outs = [(n, w) for d, n, w in ps if d == "output" and n not in pins]
    own = [(d, n, w) for d, n, w in ps if n in pins]
    n_in = max(1, sum(w for _, w in ins))
    n_out = sum(w for _, w in outs)
    decl = "".join(f", {d} " + (f"[{w - 1}:0] " if w > 1 else "") + n for d, n, w in own)
    lines = [f"module fmax_{module}(input {clock}, input si, output so{decl});",
             f"  reg [{n_in - 1}:0] chain;",
             f"  always @(posedge {clock}) chain <= {{chain[{max(n_in - 2, 0)}:0], si}};" if n_in > 1
             else f"  always @(posedge {clock}) chain <= si;"]
    conns, pos = [f".{clock}({clock})"] + [f".{_port(n)}({n})" for _, n, _ in own], 0
    for name, w in ins:
        conns.append(f".{_port(name)}(chain[{pos + w - 1}:{pos}])")
        pos += w
    pos = 0
    lines.append(f"  wire [{n_out - 1}:0] q;")
    for name, w in outs:
        conns.append(f".{_port(name)}(q[{pos + w - 1}:{pos}])")
        pos += w
    lines.append(f"  {module} core ({', '.join(conns)});")
    lines.append(f"  reg [{n_out - 1}:0] s0;")
    lines.append(f"  always @(posedge {clock}) s0 <= q;")
    width, level = n_out, 0
    while width > 1:
        nxt = (width + 3) // 4
        lines.append(f"  reg [{nxt - 1}:0] s{level + 1};")
        for i in range(nxt):
            hi = min(4 * i + 3, width - 1)
            lines.append(f"  always @(posedge {clock}) s{level + 1}[{i}] <= ^s{level}[{hi}:{4 * i}];")
        width, level = nxt, level + 1
    lines.append(f"  assign so = s{level}[0];")
    lines.append("endmodule")
    return "\n".join(lines) + "\n"


# -- synthesis

# Resources of a core from its mapped cells: (key, [(cell type, LUT4s or units per cell)]).
# ECP5: a CCU2C carry cell is two LUT4s; a TRELLIS_DPR16X4 (16x4 LUT RAM) takes three slices, six
# LUT4 places (two slices of RAM, one of its write port; nextpnr counts 13 TRELLIS_COMB for two).
RESOURCES = {
    "ecp5": (("lut4", (("LUT4", 1), ("CCU2C", 2), ("TRELLIS_DPR16X4", 6))),
             ("ff", (("TRELLIS_FF", 1),)),
             ("bram", (("DP16KD", 1), ("PDPW16KD", 1))),
             ("dsp", (("MULT18X18D", 1), ("ALU54B", 1)))),
    "ice40": (("lut4", (("SB_LUT4", 1),)),
              ("ff", (("SB_DFF*", 1),)),
              ("bram", (("SB_RAM40_4K", 1), ("SB_SPRAM256KA", 1))),
              ("dsp", (("SB_MAC16", 1),))),
}


def resources(family, cells):
    """{lut4, ff, bram, dsp} from a core's cell counts (``SB_DFF*`` matches every SB_DFF variant)."""
    out = {}
    for key, kinds in RESOURCES[family]:
        out[key] = sum(n * k for cell, n in cells.items() for kind, k in kinds
                       if cell == kind or kind.endswith("*") and cell.startswith(kind[:-1]))
    return out


class FlowError(RuntimeError):
    """A tool failed for another reason than the design's size (exit 1: no result)."""


def _error_line(text, tool):
    errors = [line for line in text.splitlines() if line.startswith("ERROR") or "Error" in line[:40]]
    if errors:
        return errors[-1].strip()
    tail = [line for line in text.splitlines() if line.strip()]
    if any("call stack exhausted" in line for line in tail):
        return f"{tool} ran out of WebAssembly stack (a very deep netlist)"
    return tail[-1].strip() if tail else f"{tool} failed without a message"


def write_changed(path, text):
    """Write ``text`` to ``path`` unless it already holds it (its time stamp stays); returns path."""
    if not path.exists() or path.read_text() != text:
        path.write_text(text)
    return path


def synthesize(name, params, family_synth, work, progress=None, source=None, pins=(), library=None):
    """Emit ``name`` at ``params`` into ``work`` (unless ``source``, its
    Verilog, is given), wrap it in the harness (with ``pins``: :func:`harness`)
    and synthesize it with ``family_synth`` (e.g. ``synth_ecp5``), with
    ``library`` (a Verilog file of modules the core instances) beside it.
    Returns (module, toolchain.Run, the core's cell counts: with the
    library's modules it instances)."""
    module = top_name(name, params)
    work = Path(work)
    work.mkdir(parents=True, exist_ok=True)
    source = source or emit(name, params, work, with_manifest=False)
    wrap = work / f"fmax_{module}.v"
    core = source.read_text()
    text = harness(core, module, pins=pins)
    # The block RAMs' all-zero init lines, dropped: the same hardware on these
    # parts, and yosys' read_verilog stalls on them (hdl/ram_init.strip_zero_init).
    synth_core = strip_zero_init(core)
    if synth_core != core:
        source = write_changed(work / f"synth_{module}.v", synth_core)
    write_changed(wrap, text)
    inputs = {"core": source, "harness": wrap, **({"library": library} if library is not None else {})}
    script = (f"read_verilog {' '.join('{' + k + '}' for k in inputs)}; "
              f"setattr -mod -set keep_hierarchy 1 {module}; "
              f"{family_synth} -top fmax_{module}; tee -q -o stat.json stat -json; "
              f"setattr -mod -unset keep_hierarchy {module}; flatten; write_json netlist.json")
    if progress:
        progress(f"{module}: yosys {family_synth}")
    run = toolchain.run("yosys", ["-q", "-l", "yosys.log", "-p", script],
                        inputs, progress)
    if run.returncode or not (run.dir / "netlist.json").exists():
        raise FlowError(f"yosys failed on {module}: "
                        + _error_line(run.text("yosys.log") + run.text("stderr.txt"), "yosys")
                        + f" (see {run.dir})")
    stat = json.loads(run.text("stat.json"))
    cells = stat["modules"]["\\" + module]["num_cells_by_type"]
    return module, run, {k: v for k, v in cells.items() if not k.startswith("$")}


# -- place and route

_UTIL = re.compile(r"^Info:\s+(\w+):\s+(\d+)/\s*(\d+)\s+\d+%", re.M)


def utilisation(log):
    """{resource: (used, available)} of nextpnr's last 'Device utilisation' table."""
    if "Device utilisation:" not in log:
        return {}
    table = log.rsplit("Device utilisation:", 1)[1]
    return {k: (int(u), int(a)) for k, u, a in _UTIL.findall(table.split("\n\n", 1)[0])}


def critical_path(report):
    """The clock-to-clock critical path of a nextpnr report: its start and end cells."""
    paths = [p for p in report.get("critical_paths", [])
             if p["from"].startswith(("posedge", "negedge")) and p["to"].startswith(("posedge", "negedge"))]
    if not paths:
        return None
    steps = max(paths, key=lambda p: sum(s["delay"] for s in p["path"]))["path"]
    return {"from": {"cell": steps[0]["from"]["cell"], "port": steps[0]["from"]["port"]},
            "to": {"cell": steps[-1]["to"]["cell"], "port": steps[-1]["to"]["port"]},
            "delay_ns": round(sum(s["delay"] for s in steps), 3),
            "logic_levels": sum(s["type"] == "logic" for s in steps),
            "nets": [s["net"] for s in steps if s.get("net")]}


ROUTERS = ("router1", "router2")
PLACERS = ("heap", "static")


# nextpnr's error when the resources are within the part but the packed cells do not place
UNPLACEABLE = "Unable to find legal placement"


def shortfall(r):
    """Why a fit (or one place() run) does not fit, in a few words: what
    overflowed, or that the cells did not place with the fullest resource's
    share; '' when it fits."""
    if "overflow" not in r or r.get("fits"):
        return ""
    if r["overflow"]:
        return ", ".join(f"{o['resource']} {o['used']:,}/{o['available']:,}" for o in r["overflow"])
    name, (used, available) = max(r["utilisation"].items(), key=lambda kv: kv[1][0] / kv[1][1])
    return f"no legal placement, {name} {used:,}/{available:,} ({100 * used / available:.0f} %)"


def _does_not_fit(run):
    """Whether a failed nextpnr Run failed by the design's size (a resource
    beyond the part, or no legal placement): a result, kept in the cache."""
    log = run.text("nextpnr.log")
    return (any(u > a for u, a in utilisation(log).values())
            or UNPLACEABLE in log + run.text("stderr.txt"))


def place(netlist, prt, seed, progress=None, router="router1", density=None, placer="heap", lpf=None):
    """One nextpnr run of ``netlist`` on ``prt`` with ``seed``: a dict with
    seed, fmax_mhz, critical_path, utilisation and, when it does not fit, overflow
    (what the part lacks; empty with ``unplaceable``, nextpnr's error, when
    every resource is within the part but the cells do not place).

    ``router`` is nextpnr's router: router1 (its default, used for every
    figure unless a JSON says otherwise) or router2 (faster on large
    designs; neither routed a harmonic block of 18x36 or more here:
    hdl/harmonic/README.md).  ``density``: the placer's largest share of a
    region's cells (nextpnr's ``--placer-heap-beta``; None: its default,
    0.9); lower spreads a crowded design, for the router's sake.  ``placer``:
    nextpnr's placer, heap (its default, every figure unless a JSON says
    otherwise) or static (its electrostatic placer: spreads by a density
    field, for designs the heap placer leaves too crowded to route).
    ``lpf``: an ECP5 constraint file (pins, clocks' frequencies) for a top
    with pins of its own (:func:`harness`'s ``pins``); ``clocks`` in the
    result then holds each clock's achieved MHz (fmax_mhz is the lowest) and
    ``clock_targets`` each one's constraint in MHz (the LPF's, a PLL
    output's derived from its input; ``--freq``'s for a clock without one),
    so that each is checked against its own."""
    if router not in ROUTERS:
        raise ValueError(f"router {router!r}: one of {', '.join(ROUTERS)}")
    if placer not in PLACERS:
        raise ValueError(f"placer {placer!r}: one of {', '.join(PLACERS)}")
    if density is not None and placer != "heap":
        raise ValueError("density is the heap placer's (--placer-heap-beta)")
    pin_flag = "--lpf-allow-unconstrained" if prt.family == "ecp5" else "--pcf-allow-unconstrained"
    if lpf is not None and prt.family != "ecp5":
        raise ValueError("lpf: an ECP5 part's constraints")
    pins = ("--lpf", "{lpf}") if lpf is not None else ()
    args = [*prt.device_args, "--json", "{netlist}", pin_flag, *pins, "--seed", str(seed),
            "--freq", str(prt.target_mhz), "--timing-allow-fail", "--report", "report.json",
            "--log", "nextpnr.log", "-q", *(("--router", router) if router != "router1" else ()),
            *(("--placer-heap-beta", str(density)) if density is not None else ()),
            *(("--placer", placer) if placer != "heap" else ())]
    inputs = {"netlist": netlist, **({"lpf": lpf} if lpf is not None else {})}
    run = toolchain.run(prt.nextpnr, args, inputs, progress, result_failure=_does_not_fit)
    log = run.text("nextpnr.log")
    util = utilisation(log)
    out = {"seed": seed, "seconds": run.seconds, "cached": run.cached, "version": run.version,
           "utilisation": {k: list(v) for k, v in util.items() if v[0]}}
    if run.returncode:
        over = {k: v for k, v in util.items() if v[0] > v[1]}
        error = _error_line(log + run.text("stderr.txt"), prt.nextpnr)
        if not _does_not_fit(run):
            raise FlowError(f"{prt.nextpnr} failed: {error} (see {run.dir})")
        out["overflow"] = [{"resource": k, "used": u, "available": a} for k, (u, a) in over.items()]
        if not over:
            # Every resource is within the part, yet nextpnr finds no legal
            # placement (the 7x7 EDT/BFS tile engine at 92 % of TRELLIS_COMB):
            # at the part's limit, so it does not fit; no resource overflowed.
            out["unplaceable"] = error
        return out
    report = json.loads(run.text("report.json"))
    out["fmax_mhz"] = round(min(c["achieved"] for c in report["fmax"].values()), 2)
    if lpf is not None:
        out["clocks"] = {k: round(c["achieved"], 2) for k, c in report["fmax"].items()}
        out["clock_targets"] = {k: round(c["constraint"], 2) for k, c in report["fmax"].items()}
    out["critical_path"] = critical_path(report)
    return out


def pack_ecp5(netlist, work):
    """yosys' ECP5 netlist with the block RAMs' read-data registers in their
    output registers (:func:`ecp5_pack.pack`), written to ``work`` (rewritten
    only when it changes, so the place-and-route cache holds): (path, the
    number of flip-flops moved)."""
    data = json.loads(Path(netlist).read_text())
    moved = ecp5_pack.pack(data)
    out = Path(work) / "netlist_packed.json"
    text = json.dumps(data)
    if not out.exists() or out.read_text() != text:
        out.write_text(text)
    return out, moved


def _took(run):
    """' (cached)' or ' (12 s)' for a progress line (a Run or a place() dict)."""
    cached, seconds = (run["cached"], run["seconds"]) if isinstance(run, dict) else (run.cached, run.seconds)
    return " (cached)" if cached else f" ({seconds:.0f} s)"


def _work(name, params, prt):
    return ROOT / "build" / "fit" / "work" / f"{top_name(name, params)}--{prt.name}"


def emitted(name, params, prt):
    """The Verilog file of ``name`` at ``params`` that :func:`fit` synthesizes
    for Part ``prt``, emitted now (rewritten only when its text changed).  A
    fit's ``verilog_sha256`` is this file's toolchain.digest: a fit JSON
    whose hash differs from it is of other Verilog (scripts/bench_edt_tiled.py
    refuses it)."""
    return emit(name, params, _work(name, params, prt), with_manifest=False)


def counts(name, params, prt, progress=None, source=None, pins=(), library=None):
    """The synthesis that :func:`fit` places: (toolchain.Run, the netlist to
    place, read registers packed, the core's cells, {lut4, ff, bram, dsp}).
    ``source``: the top's Verilog when already emitted (:func:`emitted`);
    ``pins``, ``library``: :func:`synthesize`'s."""
    module = top_name(name, params)
    work = _work(name, params, prt)
    _, syn, cells = synthesize(name, params, prt.synth, work, progress, source=source or emitted(name, params, prt),
                               pins=pins, library=library)
    netlist = syn.dir / "netlist.json"
    packed = 0
    if prt.family == "ecp5":
        # Registered block-RAM reads into the DP16KD output registers (yosys
        # leaves them in the fabric: scripts/ecp5_pack.py).
        netlist, packed = pack_ecp5(netlist, work)
        cells = {**cells, "TRELLIS_FF": cells.get("TRELLIS_FF", 0) - packed}
    res = resources(prt.family, cells)
    if progress:
        progress(f"{module}: {res['lut4']} LUT4, {res['ff']} FF, {res['bram']} BRAM, {res['dsp']} DSP"
                 f"{_took(syn)}" + (f"; {packed} read-data flip-flops packed into DP16KD output registers"
                                    if packed else ""))
    return syn, netlist, packed, cells, res


def sources_sha256(source, library=None):
    """What a fit is of (its JSON's ``verilog_sha256``): the toolchain.digest of the top's Verilog, or
    with a ``library`` (a core the top instances, read with it: LiteDRAM's) the SHA-256 of both
    digests, so that a new library voids the fit as a new top does."""
    if library is None:
        return toolchain.digest(source)
    return hashlib.sha256((toolchain.digest(source) + toolchain.digest(library)).encode()).hexdigest()


def fit(name, params, prt, seeds=(1, 2, 3), jobs=2, progress=None, router="router1", density=None, placer="heap",
        source=None, pins=(), library=None, lpf=None):
    """The fit of ``name`` at ``params`` on Part ``prt``: a JSON-ready dict
    (see scripts/fit.py).  Raises FlowError when a tool fails otherwise than
    by the design's size, toolchain.ToolError when a tool is missing.
    A top outside the catalog: ``source`` (its Verilog, module
    top_name(name, params)), with ``pins`` of its own, ``library`` and
    ``lpf`` (:func:`synthesize`, :func:`place`)."""
    module = top_name(name, params)
    source = source or emitted(name, params, prt)
    verilog_sha256 = sources_sha256(source, library)    # what the figures are of, hashed before the tools read it
    syn, netlist, packed, cells, res = counts(name, params, prt, progress, source, pins, library)
    if progress:
        progress(f"{module}: nextpnr on {prt.name}, seed{'s' * (len(seeds) > 1)} {', '.join(map(str, seeds))}")

    def one(seed):
        if progress:
            progress(f"{module} on {prt.name}, seed {seed}: placing and routing")
        r = place(netlist, prt, seed, progress, router, density, placer, lpf)
        if progress:
            what = f"{r['fmax_mhz']:.1f} MHz" if "fmax_mhz" in r else "does not fit: " + shortfall(r)
            progress(f"{module} on {prt.name}, seed {seed}: {what}{_took(r)}")
        return r

    first = one(seeds[0])               # a design that does not fit stops here
    runs = [first]
    if "overflow" not in first and len(seeds) > 1:
        with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
            runs += list(pool.map(one, seeds[1:]))
    fits = "overflow" not in first
    fmax = statistics.median(r["fmax_mhz"] for r in runs) if fits else None
    median_run = next((r for r in runs if r.get("fmax_mhz") == fmax), None)
    return {
        "module": module, "top": name, "params": params,
        "verilog_sha256": verilog_sha256,
        "part": prt.name, "family": prt.family, "package": prt.package, "speed_grade": prt.speed_grade,
        "board": prt.board,
        "fits": fits,
        "overflow": first.get("overflow", []),
        **({"unplaceable": first["unplaceable"]} if "unplaceable" in first else {}),
        **res,
        "fmax_mhz": fmax,
        "target_mhz": prt.target_mhz,
        "seeds": [{"seed": r["seed"], "fmax_mhz": r["fmax_mhz"],
                   **{k: r[k] for k in ("clocks", "clock_targets") if k in r}}
                  for r in runs] if fits else [],
        "critical_path": {"seed": median_run["seed"], **median_run["critical_path"]}
        if median_run and median_run.get("critical_path") else None,
        "cells": dict(sorted(cells.items())),
        "utilisation": first["utilisation"],
        "harness": "registered: inputs from a shift register, outputs into capture registers (scripts/fmax.py)",
        "synthesis": prt.synth + (f" (+ {packed} read registers packed into DP16KD OUTREG: scripts/ecp5_pack.py)"
                                   if packed else ""),
        "tools": {"yosys": syn.version, "nextpnr": first["version"]},
        "router": router,
        "placer_density": density,
        "placer": placer,
        "seconds": {"synthesis": syn.seconds, "place_and_route": [r["seconds"] for r in runs],
                    "cached": syn.cached and all(r["cached"] for r in runs)},
    }
