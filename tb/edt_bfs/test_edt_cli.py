"""`python -m sim edt`: JSON keys and values against the model, errors, an RTL engine."""

import json
import subprocess
import sys
from argparse import Namespace
from pathlib import Path

import numpy as np
import pytest

from navcores.models.edt_bfs import plan_path
from navcores.sim import edt as cmd
from navcores.sim.cli import CliError, main
from navcores.models.maps import load_grid
from navcores.sim.rtl.runner import SIMULATORS

ROOT = Path(__file__).resolve().parents[2]
MAP = ROOT / "maps" / "room-32-32-4.map"
KEYS = {"height", "width", "engine", "iterations_edt", "iterations_bfs", "cycles", "distance",
        "nearest", "cfr", "path", "path_found"}


def _args(**kw):
    base = dict(map=str(MAP), dfar=0, goal=["30,30"], start="1,1", engine="model", json=None, plot=None)
    base.update(kw)
    return Namespace(**base)


def test_model_json_and_plot(tmp_path):
    out, png = tmp_path / "r.json", tmp_path / "r.png"
    assert main(["edt", str(MAP), "--dfar", "0", "--goal", "30,30", "--goal", "2,29",
                 "--start", "1,1", "--json", str(out), "--plot", str(png)]) == 0
    data = json.loads(out.read_text())
    assert set(data) == KEYS and data["engine"] == "model"
    grid = load_grid(MAP)
    m = plan_path(grid, [(30, 30), (2, 29)], (1, 1), 0)
    assert np.array_equal(data["distance"], m.distance) and np.array_equal(data["cfr"], m.cfr.astype(int))
    assert data["path"] == [list(p) for p in m.path] and data["path_found"] == m.path_found
    assert data["cycles"] == m.cycles and data["iterations_edt"] == m.iterations_edt
    r, c = np.argwhere(~grid)[0]
    assert data["nearest"][r][c] == m.nearest[r, c].tolist()
    assert png.stat().st_size > 10_000
    assert data["path_found"] and len(data["path"]) > 20


def test_no_obstacles_gives_null_nearest(tmp_path):
    txt = tmp_path / "e.txt"
    txt.write_text("\n".join(["." * 5] * 4) + "\n")
    out = tmp_path / "e.json"
    assert main(["edt", str(txt), "--dfar", "1", "--goal", "0,0", "--start", "3,4", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert all(v is None for row in data["nearest"] for v in row)
    assert all(v == -1 for row in data["distance"] for v in row) and data["path_found"]


@pytest.mark.parametrize("kw, message", [
    (dict(dfar=-1), "--dfar -1"),
    (dict(goal=["32,0"]), "outside the 32x32 map"),
    (dict(goal=["a,b"]), "expected ROW,COL"),
    (dict(start="1,1,1"), "expected ROW,COL"),
    (dict(engine="icarus", map=str(ROOT / "maps" / "den312d.map")), "supports maps"),
    (dict(plot="x.jpg"), "expected a .png"),
])
def test_errors(kw, message):
    with pytest.raises(CliError, match=message):
        cmd.run(_args(**kw))


def test_errors_as_subprocess(tmp_path):
    for argv, text in [
        (["edt", str(MAP), "--dfar", "1", "--goal", "99,0"], "outside"),
        (["edt", str(tmp_path / "missing.map"), "--dfar", "1", "--goal", "0,0"], "missing.map"),
    ]:
        res = subprocess.run([sys.executable, "-m", "sim", *argv], capture_output=True, text=True, cwd=ROOT)
        assert res.returncode != 0 and text in res.stderr and "Traceback" not in res.stderr
        assert len(res.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("sim", SIMULATORS)
def test_rtl_engine(tmp_path, sim):
    """The RTL engines on an 8x8 map (the core test's 8x8 builds are reused)."""
    txt = tmp_path / "m.txt"
    txt.write_text("........\n..##....\n..##....\n........\n.....#..\n........\n.#......\n........\n")
    out = tmp_path / "m.json"
    assert main(["edt", str(txt), "--dfar", "0", "--goal", "7,7", "--goal", "0,7", "--start", "7,0",
                 "--engine", sim, "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    m = plan_path(load_grid(txt), [(7, 7), (0, 7)], (7, 0), 0)
    assert data["rtl_matches_model"] and data["engine"] == sim
    assert data["path"] == [list(p) for p in m.path] and data["cycles"] == m.cycles
