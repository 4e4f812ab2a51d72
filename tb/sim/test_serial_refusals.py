"""``--engine serial:PORT[@BAUD]`` and ``sim board`` with no board here:
each bad port is refused before any work with one line on stderr and exit
status 2, naming what is wrong.  A missing port for every command, the
other faults on one.  The commands run as subprocesses: under pytest,
tb/harmonic/ (on its pythonpath) holds a module named ``serial`` that
would hide pyserial.  A board that is there is tested through a
pseudo-terminal on the simulated board tops (tb/board/test_board_*.py,
host_engine)."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MAP = "maps/room-32-32-4.map"


def commands(tmp_path):
    csv = tmp_path / "in.csv"
    csv.write_text("phi1,phi2\n30,-45\n")
    return {
        "dflc": ["dflc", "--input", str(csv), "--engine"],
        "edt": ["edt", MAP, "--goal", "3,3", "--dfar", "1", "--engine"],
        "harmonic": ["harmonic", MAP, "--goal", "3,3", "--engine"],
        "board": ["board"],
    }


MISSING = ("serial:/dev/nonexistent", "no serial port /dev/nonexistent (is the board plugged in?")


@pytest.mark.parametrize("command,spec,says", [
    *[(c, *MISSING) for c in ("dflc", "edt", "harmonic", "board")],
    ("dflc", "serial:/dev/null", "serial port /dev/null: cannot open it"),
    ("dflc", "serial:/dev/ttyUSB0@12", "baud '12' must be an integer in 300..12000000"),
    ("board", "serial:", "give the board's serial port, e.g. serial:/dev/ttyUSB0[@115200]"),
], ids=["missing-dflc", "missing-edt", "missing-harmonic", "missing-board", "not-a-tty", "baud", "empty"])
def test_refused(tmp_path, command, spec, says):
    out = tmp_path / "out.json"
    r = subprocess.run([sys.executable, "-m", "sim", *commands(tmp_path)[command], spec, "--json", str(out)],
                       cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert r.stderr.count("\n") == 1 and r.stderr.startswith(f"sim {command}: error: ") and says in r.stderr, \
        r.stderr
    assert r.stdout == "" and not out.exists()
