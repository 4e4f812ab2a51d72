"""Pack a block RAM's read-data register into the ECP5 DP16KD output register (REGMODE OUTREG).

A registered RAM read written in the RTL as a synchronous read port followed
by a flip-flop on its data (read latency 2) is what Lattice's own synthesis
maps onto the EBR's output register; yosys 0.70 (``synth_ecp5``) always maps
``REGMODE_A/B = "NOREG"`` and leaves that flip-flop in the fabric, so the
path starts at the RAM's unregistered data output (nextpnr-ecp5: 5.8 ns
clock-to-out on speed 6) instead of its output register (about 1.1 ns).
:func:`pack` does that mapping on yosys' JSON netlist, before nextpnr:

for each DP16KD port (A, B) whose ``REGMODE`` is ``NOREG`` and whose every
used ``DO`` bit (unused bits of a narrower lane are skipped) drives exactly one cell, a ``TRELLIS_FF`` ``DI`` of the
core (its name starts with ``prefix``: the harness' capture registers never
move into a RAM) clocked by the port's clock on the same edge, with no
set/reset (``LSR`` tied 0) and one clock enable shared by the port's
flip-flops (or none), the flip-flops are removed, their ``Q`` nets are
driven by the RAM's ``DO`` bits, the port gets ``REGMODE = "OUTREG"`` and
its ``OCE`` is the flip-flops' enable.  Same cycle behaviour; the output
register powers up 0, as the flip-flops do (``REGSET RESET``, the RTL's
reset-less data register with init 0).  A port where any bit does not
qualify is left alone.

    python scripts/ecp5_pack.py IN.json OUT.json     # prints how many flip-flops moved
"""

import json
import sys

__all__ = ["pack"]


def _ff_ok(ff, clock):
    """A TRELLIS_FF that the output register can replace: same clock and edge, no set/reset."""
    p, c = ff["parameters"], ff["connections"]
    return (c.get("CLK") == clock and p.get("CLKMUX", "CLK") == "CLK"
            and c.get("LSR", ["0"]) == ["0"] and p.get("LSRMUX", "LSR") == "LSR"
            and p.get("REGSET", "RESET") == "RESET" and p.get("SRMODE", "LSR_OVER_CE") == "LSR_OVER_CE")


def _enable(ff):
    """The flip-flop's clock enable as a connection list (["1"]: always)."""
    mux = ff["parameters"].get("CEMUX", "1").strip()
    if mux == "1":
        return ["1"]
    if mux == "CE":
        return ff["connections"].get("CE", ["1"])
    return None                         # inverted enables: not packed


def pack(netlist, prefix="core."):
    """Pack in place; returns the number of flip-flops moved into output registers."""
    moved = 0
    for module in netlist["modules"].values():
        cells = module.get("cells", {})
        ports = {b for p in module.get("ports", {}).values() for b in p["bits"]}
        sinks = {}
        for name, cell in cells.items():
            for port, bits in cell["connections"].items():
                if cell["port_directions"].get(port) == "input":
                    for b in bits:
                        if isinstance(b, int):
                            sinks.setdefault(b, []).append((name, port))
        for ram_name, ram in list(cells.items()):
            if ram["type"] != "DP16KD":
                continue
            for side in "AB":
                if ram["parameters"].get(f"REGMODE_{side}", "NOREG") != "NOREG":
                    continue
                if ram["parameters"].get(f"CLK{side}MUX", f"CLK{side}") != f"CLK{side}":
                    continue
                clock = ram["connections"].get(f"CLK{side}")
                outs = {p: bits[0] for p, bits in ram["connections"].items()
                        if p.startswith(f"DO{side}") and isinstance(bits[0], int)}
                plan, enables = {}, set()
                for port, bit in outs.items():
                    s = sinks.get(bit, [])
                    if not s and bit not in ports:
                        continue                # an unused bit (a lane narrower than the RAM)
                    if bit in ports or len(s) != 1 or s[0][1] != "DI":
                        break
                    ff_name = s[0][0]
                    ff = cells[ff_name]
                    if ff["type"] != "TRELLIS_FF" or not ff_name.startswith(prefix) or not _ff_ok(ff, clock):
                        break
                    en = _enable(ff)
                    if en is None:
                        break
                    enables.add(json.dumps(en))
                    plan[port] = ff_name
                else:
                    if not plan or len(enables) != 1:
                        continue
                    for port, ff_name in plan.items():
                        ram["connections"][port] = cells[ff_name]["connections"]["Q"]
                        del cells[ff_name]
                    ram["parameters"][f"REGMODE_{side}"] = "OUTREG"
                    ram["connections"][f"OCE{side}"] = json.loads(enables.pop())
                    moved += len(plan)
    return moved


def main(argv):
    if len(argv) != 2:
        print("usage: python scripts/ecp5_pack.py IN.json OUT.json", file=sys.stderr)
        return 2
    with open(argv[0]) as f:
        netlist = json.load(f)
    n = pack(netlist)
    with open(argv[1], "w") as f:
        json.dump(netlist, f)
    print(f"{n} flip-flops moved into DP16KD output registers")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
