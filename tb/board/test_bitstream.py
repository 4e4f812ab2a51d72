"""make bitstream (scripts/bitstream.py): the DFLC on the iCEBreaker, built for
real, and the refusals.

The build runs the whole flow from PyPI (yosys, nextpnr-ice40, icepack;
every tool run cached in build/cache, so a rerun takes seconds) and checks
what it wrote against the tools and the part: an iCE40 UP5K image of the
right size with its preamble, the clock reached against the board's 12 MHz,
the logic cells within the part, the INFO text the bitstream answers with
(the one the host reads).  The other board/core pairs take minutes each on
two cores (the ULX3S-85F's chip database alone): ``make bitstreams``.

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
UP5K_IMAGE = 104090                 # bytes of an iCE40 UP5K bitstream (icepack)
PREAMBLE = bytes.fromhex("7EAA997E")


def bitstream(*args):
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, timeout=1800)


@pytest.mark.xdist_group("fpga-tools")
def test_icebreaker_dflc(tmp_path):
    r = bitstream("icebreaker", "dflc", "--out", tmp_path)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 1 and lines[0].startswith("icebreaker dflc on iCE40-UP5K, 115200 Bd (divisor 104)"), r.stdout
    image = (tmp_path / "icebreaker-dflc.bin").read_bytes()
    assert len(image) == UP5K_IMAGE and PREAMBLE in image[:32]
    d = json.loads((tmp_path / "icebreaker-dflc.json").read_text())
    assert (d["board"], d["core"], d["part"], d["clock_mhz"], d["divisor"]) == ("icebreaker", "dflc", "iCE40-UP5K", 12, 104)
    assert d["timing_met"] and d["fmax_mhz"] >= 12 and d["fmax_mhz"] == min(d["clocks"].values())
    assert f"reached {d['fmax_mhz']:.1f} MHz (met)" in lines[0]
    used, available = d["utilisation"]["ICESTORM_LC"]
    assert 1000 < used <= available == 5280 and f"{used}/5280 LC" in lines[0]
    info = P.parse_info(d["info"].encode())
    assert (info["core"], info["fll"], info["div"], info["baud"], info["clk"]) == ("dflc", "table1", 104, 115385,
                                                                                12_000_000)
    assert d["tools"]["packer"].startswith("icepack") and d["bitstream"].endswith("icebreaker-dflc.bin")


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
