"""The ``python -m sim`` frame: usage errors and bad cells are one line, non-zero."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sim.cli import CliError, check_cell, parse_cell

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


def test_no_command_is_a_usage_error():
    out = subprocess.run([sys.executable, "-m", "sim"], cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 2 and "Traceback" not in out.stderr and "COMMAND" in out.stderr
