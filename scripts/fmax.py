"""Clock estimate of a top: Debian's yosys ``synth_ice40`` + ``nextpnr-ice40``.

The papers report Virtex-II / Spartan-3 / Virtex-4 clocks; the only open
place-and-route flow here is for Lattice iCE40, so the figure is an iCE40
HX8K (ct256 package) figure, not the paper's device.  To make it the core's
timing and not the pins', the top is wrapped in a harness
(:func:`harness`):

* every input bit of the core (``rst`` included, ``clk`` excepted) is a stage
  of one shift register fed by a single pin ``si``: each input comes straight
  from a flip-flop;
* every output bit is captured in a flip-flop, and the captured bits are
  XOR-reduced to a single pin ``so`` in a tree registered after every level of
  four, so the reduction is never longer than one LUT4 per stage.

So the critical path is one of: register -> core input logic, the core's own
register-to-register paths, core outputs -> capture register.  nextpnr's
``Max frequency for clock`` line is reported (seed 1, timing-driven
placement).  A design larger than the part is reported as not fitting.

    .venv/bin/python scripts/fmax.py TOP [name=value ...]
"""

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

YOSYS = shutil.which("yosys") or "/usr/bin/yosys"
NEXTPNR = shutil.which("nextpnr-ice40") or "/usr/bin/nextpnr-ice40"
PART = ("--hx8k", "--package", "ct256")
PART_NAME = "iCE40-HX8K (ct256), nextpnr-ice40 seed 1"
# --timing-allow-fail: the 50 MHz target only steers the placer; the reached
# maximum frequency is reported whether it meets the target or not.
NEXTPNR_FLAGS = ("--pcf-allow-unconstrained", "--seed", "1", "--freq", "50", "--timing-allow-fail")

def ports(verilog_text, module):
    """``[(direction, name, width)]`` of ``module`` in Amaranth's Verilog (hdl.emit's port parser)."""
    from navcores.hdl.emit import verilog_ports
    return [(d, name, w) for name, (d, w) in verilog_ports(verilog_text, module).items()]


def harness(verilog_text, module, clock="clk"):
    """Verilog of ``fmax_<module>``: the core between a serial input chain and an XOR tree."""
    ps = ports(verilog_text, module)
    ins = [(n, w) for d, n, w in ps if d == "input" and n != clock]
    outs = [(n, w) for d, n, w in ps if d == "output"]
    n_in = max(1, sum(w for _, w in ins))
    n_out = sum(w for _, w in outs)
    lines = [f"module fmax_{module}(input {clock}, input si, output so);",
             f"  reg [{n_in - 1}:0] chain;",
             f"  always @(posedge {clock}) chain <= {{chain[{max(n_in - 2, 0)}:0], si}};" if n_in > 1
             else f"  always @(posedge {clock}) chain <= si;"]
    conns, pos = [f".{clock}({clock})"], 0
    for name, w in ins:
        conns.append(f".{name}(chain[{pos + w - 1}:{pos}])")
        pos += w
    pos = 0
    lines.append(f"  wire [{n_out - 1}:0] q;")
    for name, w in outs:
        conns.append(f".{name}(q[{pos + w - 1}:{pos}])")
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


def fmax(name, params, work):
    """Synthesize and place ``name`` at ``params``; returns a dict of the figures."""
    from navcores.hdl.emit import emit, top_name
    module = top_name(name, params)
    work = Path(work) / module
    work.mkdir(parents=True, exist_ok=True)
    source = emit(name, params, work)
    wrap = work / f"fmax_{module}.v"
    wrap.write_text(harness(source.read_text(), module))
    netlist = work / "ice40.json"
    ys = subprocess.run([YOSYS, "-q", "-l", str(work / "synth_ice40.log"), "-p",
                         f"read_verilog {source} {wrap}; synth_ice40 -top fmax_{module} -json {netlist}"],
                        capture_output=True, text=True)
    if ys.returncode:
        return {"top": module, "fmax_mhz": None, "error": "yosys failed: " + ys.stderr.strip()[-300:]}
    pnr = subprocess.run([NEXTPNR, *PART, "--json", str(netlist), *NEXTPNR_FLAGS, "--log", str(work / "nextpnr.log")],
                         capture_output=True, text=True)
    log = (work / "nextpnr.log").read_text() if (work / "nextpnr.log").exists() else pnr.stderr
    util = dict(re.findall(r"Info:\s+(ICESTORM_LC|ICESTORM_RAM|SB_IO|SB_GB):\s+(\d+/\s*\d+)", log))
    if pnr.returncode:
        why = "does not fit the part" if re.search(r"Unable to place|too many|exceed", log, re.I) else "nextpnr failed"
        return {"top": module, "fmax_mhz": None, "error": why, "utilization": util}
    found = re.findall(r"Max frequency for clock\s+'[^']*':\s+([\d.]+) MHz", log)
    return {"top": module, "fmax_mhz": float(found[-1]) if found else None, "part": PART_NAME,
            "utilization": util}


def main(argv):
    if not argv:
        print(__doc__)
        return 2
    params = {}
    for kv in argv[1:]:
        k, v = kv.split("=", 1)
        params[k] = int(v) if v.lstrip("-").isdigit() else v
    print(json.dumps(fmax(argv[0], params, ROOT / "build" / "fmax"), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
