"""make bitstream (scripts/bitstream.py): the DFLC on the ULX3S-85F, built for
real, and the refusals.

The build runs the whole flow from PyPI (yosys, nextpnr-ecp5, ecppack;
every tool run cached in build/cache, so a rerun takes seconds) and checks
what it wrote against the tools and the part: an ECP5 bitstream for the
LFE5U-85F (its header, the preamble, the part's IDCODE), the clock reached
against the board's 25 MHz, the resources within the part, the INFO text
the bitstream answers with (the one the host reads).  This pair is the
cheapest to build from nothing: 98 s of tool time on this two-core machine
(yosys 28 s, nextpnr 70 s; 376 s with a dozen other jobs on the cores),
where the iCEBreaker's DFLC, its multipliers in logic, took 160 s.  The other pairs take minutes each: ``make
bitstreams`` and ``make bench``.

In the tools' pytest-xdist group (tb/fpga/test_fit.py says why).
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from navcores.hdl.board import protocol as P

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "bitstream.py"
HEADER = b"\xff\x00Part: LFE5U-85F-6CABGA381\x00"   # ecppack's comment block
PREAMBLE = bytes.fromhex("FFFFBDB3")
VERIFY_ID = bytes.fromhex("E2000000 41113043")       # VERIFY_ID, the LFE5U-85F's IDCODE


def bitstream(*args):
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, timeout=1800)


@pytest.mark.xdist_group("fpga-tools")
def test_ulx3s_dflc(tmp_path):
    r = bitstream("ulx3s-85f", "dflc", "--out", tmp_path)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 1 and lines[0].startswith("ulx3s-85f dflc on LFE5U-85F, 115200 Bd (divisor 217)"), r.stdout
    image = (tmp_path / "ulx3s-85f-dflc.bit").read_bytes()
    start = image.find(PREAMBLE)        # after the header and ecppack's padding (0xFF)
    assert image.startswith(HEADER) and set(image[len(HEADER):start]) <= {0xFF} and start - len(HEADER) <= 4
    assert VERIFY_ID in image[:64] and len(image) > 50_000
    d = json.loads((tmp_path / "ulx3s-85f-dflc.json").read_text())
    assert (d["board"], d["core"], d["part"], d["clock_mhz"], d["divisor"]) == ("ulx3s-85f", "dflc", "LFE5U-85F", 25,
                                                                                217)
    assert d["timing_met"] and d["fmax_mhz"] >= 25 and d["fmax_mhz"] == min(d["clocks"].values())
    assert f"reached {d['fmax_mhz']:.1f} MHz (met)" in lines[0]
    used, available = d["utilisation"]["TRELLIS_COMB"]
    assert 500 < used <= available == 83640 and f"{used}/83640 LUT4" in lines[0]
    assert d["utilisation"]["MULT18X18D"][0] == 0          # the DFLC's products are in the fabric (issue 17)
    info = P.parse_info(d["info"].encode())
    assert (info["core"], info["fll"], info["divider"], info["div"], info["baud"], info["clk"]) == \
        ("dflc", "table1", "lut", 217, 115207, 25_000_000)
    assert "ecppack" in d["tools"]["packer"] and d["bitstream"].endswith("ulx3s-85f-dflc.bit")
    # make bench calls build() into a folder a fresh clone does not have yet (the same cached runs)
    new = tmp_path / "bench" / "bitstream"
    r = subprocess.run([sys.executable, "-c", "import sys; sys.path.insert(0, 'scripts'); import bitstream; "
                        "bitstream.build('ulx3s-85f', 'dflc', out=sys.argv[1])", str(new)],
                       capture_output=True, text=True, cwd=ROOT, timeout=1800)
    assert r.returncode == 0, r.stderr[-2000:]
    assert (new / "ulx3s-85f-dflc.bit").read_bytes() == image


@pytest.mark.parametrize("args,says", [
    (["ulx3s-12f", "dflc"], "BOARD='ulx3s-12f': expected one of ulx3s-85f, icebreaker"),
    (["icebreaker", "edt"], "CORE='edt': expected one of harmonic, dflc, edt_bfs"),
    (["icebreaker", "harmonic"], "CORE=harmonic is not built for BOARD=icebreaker"),
    (["ulx3s-85f", "dflc", "--baud", "fast"], "BAUD='fast': expected an integer"),
    (["icebreaker", "dflc", "--baud", "4000000"], "BAUD=4000000: a 12 MHz clock divides it 3.00 times"),
    ([], "BOARD='': expected one of"),
], ids=["board", "core", "pair", "baud-text", "baud-fast", "nothing"])
def test_refusals(tmp_path, args, says):
    r = bitstream(*args, "--out", tmp_path)
    assert r.returncode == 2 and r.stdout == "", (r.returncode, r.stdout)
    assert len(r.stderr.splitlines()) == 1 and says in r.stderr, r.stderr
    assert not list(tmp_path.iterdir())


def test_design_files_name_no_clone():
    """The files the synthesis reads (the board top's RTLIL, the Verilog of
    the modules it instantiates) hold no path of this clone: the cache keys
    a synthesis by their content, so a fresh clone of the same commit finds
    the bitstream built here (the EDT/BFS one takes 20 minutes)."""
    r = subprocess.run([sys.executable, "-c", "import sys; sys.path.insert(0, 'scripts'); import bitstream; "
                        "b, top, plan, extra = bitstream.elaborate('ulx3s-85f', 'dflc', 115200); "
                        "print('\\n'.join([*plan.files.values(), *extra.values()]))"],
                       capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "module" in r.stdout or "attribute" in r.stdout
    assert str(ROOT) not in r.stdout and "site-packages" not in r.stdout
