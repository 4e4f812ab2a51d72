"""The ``python -m sim`` frame: usage errors and bad cells are one line, non-zero."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from navcores.sim.cli import CliError, check_cell, parse_cell

ROOT = Path(__file__).resolve().parents[2]


def test_parse_and_check_cell():
    assert parse_cell("3,4") == (3, 4)
    for bad in ("3", "3,4,5", "a,b", ""):
        with pytest.raises(CliError, match="ROW,COL"):
            parse_cell(bad, "--goal")
    grid = np.zeros((4, 5), dtype=bool)
    grid[1, 1] = True
    assert check_cell(grid, (3, 4), "goal") == (3, 4)
    with pytest.raises(CliError, match=r"goal \(4, 0\) is outside the 4x5 map"):
        check_cell(grid, (4, 0), "goal")
    with pytest.raises(CliError, match=r"start \(1, 1\) is on an obstacle"):
        check_cell(grid, (1, 1), "start")


@pytest.mark.parametrize("argv,message", [
    ([], "required: COMMAND"),
    (["fly"], "invalid choice: 'fly'"),
    (["harmonic", "maps/empty-16-16.map", "--goal", "1,1", "--engine", "fpga"], "invalid choice: 'fpga'"),
])
def test_usage_errors_are_one_line(argv, message):
    out = subprocess.run([sys.executable, "-m", "sim", *argv], cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 2 and out.stdout == ""
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and message in lines[0] and "Traceback" not in out.stderr, out.stderr


def test_binary_map_is_refused_by_every_command(tmp_path, capsys):
    """issue 20: a binary file given as a map (once a UnicodeDecodeError, exit 70)."""
    from navcores.sim.cli import main
    bad = tmp_path / "bin.map"
    bad.write_bytes(bytes(range(256)) * 4)
    line = str(ROOT / "paths" / "line.csv")
    for argv in (["harmonic", str(bad), "--goal", "1,1"], ["edt", str(bad), "--dfar", "0", "--goal", "1,1"],
                 ["navigate", str(bad), "--start", "1,1", "--goal", "2,2"], ["track", line, "--map", str(bad)]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert len(err.splitlines()) == 1 and "bin.map:1: a NUL byte: not a text file" in err, err


def test_long_runs_say_so_first(tmp_path, capsys, monkeypatch):
    """A run estimated at hours says so on stderr before it starts (the run
    itself is stopped here right after the note): harmonic on a 512x512 maze,
    EDT on a 4000x4000 image."""
    from PIL import Image
    from navcores.sim import edt, harmonic
    from navcores.sim.cli import main

    def stop(*a, **k):
        raise CliError("stopped by the test")
    monkeypatch.setattr(harmonic, "plan_map", stop)
    monkeypatch.setattr(edt, "plan_path", stop)
    assert main(["harmonic", str(ROOT / "maps" / "maze512-1-0.map"), "--goal", "1,1"]) == 2
    note, err = capsys.readouterr().err.splitlines()
    assert re.match(r"sim harmonic: note: planning 512x512 on the model will take about [\d.]+ (h|days) "
                    r"\(about [\d.e+]+ node updates: \d+ free cells, \d+ cells to the farthest", note), note
    assert "stopped by the test" in err
    Image.fromarray(np.full((4000, 4000), 255, dtype=np.uint8)).save(tmp_path / "big.png")
    # the untiled array (the paper's, one cell a pixel) as large as the map
    assert main(["edt", str(tmp_path / "big.png"), "--dfar", "0", "--goal", "1,1", "--array", "4000x4000"]) == 2
    note = capsys.readouterr().err.splitlines()[0]
    assert re.match(r"sim edt: note: the model on 4000x4000 will take about [\d.]+ h \(at least 8000 iterations",
                    note), note
    # a small run says nothing
    assert main(["edt", str(ROOT / "maps" / "room-32-32-4.map"), "--dfar", "0", "--goal", "30,30",
                 "--array", "32x32"]) == 2
    assert capsys.readouterr().err.splitlines()[0].endswith("stopped by the test")


def test_progress_only_on_a_terminal(monkeypatch):
    """The progress line: on a terminal (SIM_PROGRESS=1 stands for one), after
    its delay, rewritten in place and cleared at the end; nothing when piped."""
    import io
    from navcores.sim.progress import Progress, duration
    monkeypatch.delenv("SIM_PROGRESS", raising=False)
    piped = io.StringIO()
    with Progress("x", total=10, delay=0, interval=0, stream=piped) as bar:
        bar.update(5, "half")
    assert piped.getvalue() == ""
    monkeypatch.setenv("SIM_PROGRESS", "1")
    tty = io.StringIO()
    with Progress("harmonic model", total=10, unit="sweeps", delay=0, interval=0, stream=tty) as bar:
        bar.update(5, "p = 32")
    text = tty.getvalue()
    assert text.startswith("\r\033[Kharmonic model: 5/10 sweeps (50 %") and "p = 32" in text
    assert text.endswith("\r\033[K")                          # cleared: the summary follows on a clean line
    assert (duration(40), duration(600), duration(3 * 3600), duration(5 * 86400)) == ("40 s", "10 min", "3.0 h",
                                                                                       "5.0 days")
