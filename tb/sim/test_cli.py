"""The ``python -m sim`` frame: usage errors and bad cells are one line, non-zero."""

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
