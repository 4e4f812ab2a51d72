"""The DRAM job's whole top in the fit flow (scripts/fit_dram_top.py): the harness's own pins, the ECPIX-5's LPF.

The place-and-route itself is a benchmark (BENCHMARKS.md, the DRAM
section); here: a core's pins (a second clock, an inout bus, outputs)
leave the harness's input chain and XOR tree and become the harness's own
ports, connected by name, with their widths and directions; the LPF puts
every DDR3 pad the ECPIX-5's resource names at its site, once, with its
I/O standard, the two the board does not wire at spare pads, and the
controller's PLL input at the board's 100 MHz oscillator; the command's refusals (exit 2, one line, before any work).
"""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))

import fit_dram_top  # noqa: E402
import fmax  # noqa: E402
import toolchain  # noqa: E402
from amaranth_boards.ecpix5 import ECPIX585Platform  # noqa: E402

from navcores.hdl.edt_bfs.tile_litedram import DDR3_PINS  # noqa: E402

# A core as Amaranth emits it: ports declared in the body.
CORE = """module core(clk, a, b, q, pad, bus, clk2);
  input clk;
  wire clk;
  input [3:0] a;
  input b;
  output [2:0] q;
  output [1:0] pad;
  inout [7:0] bus;
  input clk2;
endmodule
"""


def test_harness_pins():
    text = fmax.harness(CORE, "core", pins={"pad", "bus", "clk2"})
    head = text.splitlines()[0]
    assert head == ("module fmax_core(input clk, input si, output so, output [1:0] pad, inout [7:0] bus, "
                    "input clk2);"), head
    inst = next(line for line in text.splitlines() if line.strip().startswith("core core"))
    for pin in ("pad", "bus", "clk2"):
        assert f".{pin}({pin})" in inst, inst
    # a and b (5 bits) in the chain, q (3 bits) into the XOR tree; the pins in neither
    assert "reg [4:0] chain;" in text and "wire [2:0] q;" in text, text
    assert ".a(chain[3:0])" in inst and ".b(chain[4:4])" in inst and ".q(q[2:0])" in inst, inst
    # without pins, every input is in the chain and an inout is nobody's
    plain = fmax.harness(CORE, "core")
    assert plain.splitlines()[0] == "module fmax_core(input clk, input si, output so);"
    assert "reg [5:0] chain;" in plain and "wire [4:0] q;" in plain and ".bus(" not in plain


def test_lpf_ecpix5():
    lpf = fit_dram_top.lpf()
    located = dict(re.findall(r'^LOCATE COMP "([^"]+)" SITE "([^"]+)";$', lpf, re.M))
    iobuf = dict(re.findall(r'^IOBUF PORT "([^"]+)" (.+);$', lpf, re.M))
    board = {(r.name, r.number): r for r in ECPIX585Platform.resources}
    ddr3 = {s.name: s for s in board["ddr3", 0].ios}
    n = 0
    for pin, name in fit_dram_top.BOARD_NAMES.items():
        io = ddr3[name].ios[0]
        sites = io.p.names if hasattr(io, "p") else io.names
        width = DDR3_PINS[pin][0]
        assert len(sites) == width
        for i, site in enumerate(sites):
            port = f"ddram_{pin}[{i}]" if width > 1 else f"ddram_{pin}"
            assert located[port] == site, (port, site)
            assert "IO_TYPE=SSTL15" in iobuf[port], iobuf[port]
            n += 1
    assert "IO_TYPE=SSTL15D_I" in iobuf["ddram_dqs_p[1]"] and "IO_TYPE=SSTL15D_I" in iobuf["ddram_clk_p"]
    assert located["sys_clk"] == board["clk100", 0].ios[0].names[0] == "K23"
    assert 'FREQUENCY PORT "sys_clk" 100 MHZ;' in lpf
    assert f'FREQUENCY PORT "clk" {fit_dram_top.ENGINE_MHZ} MHZ;' in lpf      # the engine's, not --freq's
    # the pins the board does not wire, at spare pads
    assert set(DDR3_PINS) - set(fit_dram_top.BOARD_NAMES) == set(fit_dram_top.SPARE_PADS) == {"cs_n", "reset_n"}
    for pin, site in fit_dram_top.SPARE_PADS.items():
        assert located[f"ddram_{pin}"] == site and "IO_TYPE=SSTL15_I" in iobuf[f"ddram_{pin}"]
    assert len(located) == n + 3 == 47 and len(set(located.values())) == len(located)    # no site twice


def test_refusals():
    for args, says in ((["--part", "LFE5U-25F"], "needs an 85F ECP5"), (["--part", "XC7A35T"], "unknown part"),
                       (["--seeds", "0"], "--seeds 0: must be 1..9"), (["--first-seed", "0"], "must be 1 or more"),
                       (["--array", "3y8"], "must be RxC"), (["--array", "1x8"], "t_r 1")):
        r = subprocess.run([sys.executable, str(ROOT / "scripts" / "fit_dram_top.py"), *args], capture_output=True,
                           text=True, cwd=ROOT, timeout=120)
        assert r.returncode == 2 and r.stdout == "", (args, r.returncode, r.stdout)
        assert len(r.stderr.splitlines()) == 1 and says in r.stderr, (args, r.stderr)


def test_clocks():
    """The engine's clock is the harness's clk (nextpnr names it by its net); each other clock is checked
    against its own target (the PLL's 25 MHz init clock against 25, not against the system clock's 75);
    medians over the seeds."""
    def seed(s, e, c, init):
        return {"seed": s, "clocks": {"$glbnet$clk$TRELLIS_IO_IN": e, "$glbnet$core.dram.sys_clk": c,
                                      "$glbnet$core.dram.crg_clkout1": init, "$glbnet$sys_clk$TRELLIS_IO_IN": 300.0},
                "clock_targets": {"$glbnet$clk$TRELLIS_IO_IN": 300, "$glbnet$core.dram.sys_clk": 75.0,
                                  "$glbnet$core.dram.crg_clkout1": 25, "$glbnet$sys_clk$TRELLIS_IO_IN": 100}}
    fit = {"seeds": [seed(s, e, c, i) for s, (e, c, i) in enumerate([(25.0, 80.0, 60.0), (27.0, 76.0, 50.0),
                                                                     (26.0, 90.0, 40.0)], 1)]}
    engine, others = fit_dram_top.clocks(fit)
    assert engine == 26.0 and others == {"sys_clk": (80.0, 75.0), "crg_clkout1": (50.0, 25),
                                         "sys_clk (pin)": (300.0, 100)}, others
    assert fit_dram_top.missed(others) == ""
    fit["seeds"][0]["clocks"]["$glbnet$core.dram.sys_clk"] = 70.0
    fit["seeds"][1]["clocks"]["$glbnet$core.dram.crg_clkout1"] = 20.0
    fit["seeds"][2]["clocks"]["$glbnet$core.dram.crg_clkout1"] = 20.0
    assert fit_dram_top.missed(fit_dram_top.clocks(fit)[1]) == "crg_clkout1 20.0 MHz of 25"
    fit["seeds"][2]["clocks"]["$glbnet$core.dram.sys_clk"] = 74.0
    assert fit_dram_top.missed(fit_dram_top.clocks(fit)[1]) == "crg_clkout1 20.0 MHz of 25, sys_clk 74.0 MHz of 75"
    for bad in ({"sys_clk": 100.0, "crg_clkout": 80.0}, {"clk": 25.0}):
        try:
            fit_dram_top.clocks({"seeds": [{"seed": 1, "clocks": bad}]})
        except ValueError as e:
            assert "not one engine clock" in str(e)
        else:
            raise AssertionError(f"{bad}: accepted")
    old = {"seeds": [{"seed": 1, "clocks": {"clk": 25.0, "sys_clk": 80.0}}]}
    try:
        fit_dram_top.clocks(old)
    except ValueError as e:
        assert "no clock targets" in str(e)
    else:
        raise AssertionError("a fit without clock targets accepted")


def test_verilog_sha256_covers_the_controller(tmp_path):
    """A fit of the whole top is of its Verilog and LiteDRAM's core: either changed voids it."""
    top, core = tmp_path / "top.v", tmp_path / "litedram_core.v"
    top.write_text("module top; endmodule\n")
    core.write_text("module litedram_core; endmodule\n")
    first = fmax.sources_sha256(top, core)
    assert first == fmax.sources_sha256(top, core) and len(first) == 64
    core.write_text("module litedram_core; wire w; endmodule\n")
    second = fmax.sources_sha256(top, core)
    top.write_text("module top; wire w; endmodule\n")
    assert len({first, second, fmax.sources_sha256(top, core)}) == 3
    assert fmax.sources_sha256(top) == toolchain.digest(top)       # a top without a library: its own digest


def test_buffered_command_buffers_refused(monkeypatch):
    """LiteDRAM's buffered command buffers gave wrong results through the tile engine: refused."""
    import litedram_core
    monkeypatch.setitem(litedram_core.CONFIG, "cmd_buffer_buffered", True)
    try:
        litedram_core.config(4)
    except ValueError as e:
        assert "cmd_buffer_buffered" in str(e)
    else:
        raise AssertionError("cmd_buffer_buffered accepted")
    monkeypatch.setitem(litedram_core.CONFIG, "cmd_buffer_buffered", False)
    assert litedram_core.config(4)["user_ports"].keys() == {f"native_{i}" for i in range(4)}
