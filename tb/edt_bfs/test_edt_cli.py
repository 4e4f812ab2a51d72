"""`python -m sim edt`: JSON keys and values against the model, errors, an RTL engine."""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from navcores.models.edt_bfs import plan_path
from navcores.models.edt_bfs_tiled import plan_path_tiled
from navcores.sim.cli import main
from navcores.models.maps import load_grid
from navcores.sim.rtl.runner import SIMULATORS

ROOT = Path(__file__).resolve().parents[2]
MAP = ROOT / "maps" / "room-32-32-4.map"
KEYS = {"height", "width", "engine", "array", "tile_visits", "iterations_edt", "iterations_bfs", "cycles",
        "distance", "nearest", "cfr", "path", "path_xy", "path_found", "frame"}


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
    assert data["iterations_edt"] == m.iterations_edt
    # 1024 cells: the default array is 8x8, the tile engine's cycles (with the map's read-out)
    t = plan_path_tiled(grid, [(30, 30), (2, 29)], (1, 1), 0, array=(8, 8), readout=True)
    assert data["array"] == [8, 8] and data["tile_visits"] == t.tile_visits > 16 and data["cycles"] == t.cycles
    r, c = np.argwhere(~grid)[0]
    assert data["nearest"][r][c] == m.nearest[r, c].tolist()
    assert png.stat().st_size > 10_000
    assert data["path_found"] and len(data["path"]) > 20


def test_array(tmp_path):
    """--array: as large as the map, the paper's untiled array (its cycles, no tile visits); smaller,
    the tile engine's figures; the results the same either way."""
    out = tmp_path / "r.json"
    grid = load_grid(MAP)
    m = plan_path(grid, [(30, 30)], (1, 1), 0)
    for array, want in (("32x32", None), ("40x99", None), ("5x7", (5, 7)), ("32x1", (32, 1))):
        assert main(["edt", str(MAP), "--dfar", "0", "--goal", "30,30", "--start", "1,1", "--array", array,
                     "--json", str(out)]) == 0
        data = json.loads(out.read_text())
        assert data["path"] == [list(p) for p in m.path] and np.array_equal(data["distance"], m.distance)
        if want is None:
            assert data["array"] == [32, 32] and data["tile_visits"] is None and data["cycles"] == m.cycles
        else:
            t = plan_path_tiled(grid, [(30, 30)], (1, 1), 0, array=want, readout=True)
            assert data["array"] == list(want) and data["tile_visits"] == t.tile_visits
            assert data["cycles"] == t.cycles != m.cycles


def test_no_obstacles_gives_null_nearest(tmp_path):
    txt = tmp_path / "e.txt"
    txt.write_text("\n".join(["." * 5] * 4) + "\n")
    out = tmp_path / "e.json"
    assert main(["edt", str(txt), "--dfar", "1", "--goal", "0,0", "--start", "3,4", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert all(v is None for row in data["nearest"] for v in row)
    assert all(v == -1 for row in data["distance"] for v in row) and data["path_found"]


@pytest.mark.parametrize("args, message", [
    (["--dfar=-1"], "--dfar: -1: must be >= 0"),
    (["--dfar", "45"], "--dfar 45: no distance d_i of a 32x32 map exceeds 44"),
    (["--goal", "32,0"], "outside the 32x32 map"),
    (["--goal", "a,b"], "expected ROW,COL"),
    (["--start", "1,1,1"], "expected ROW,COL"),
    (["--start", "1,1", "--start", "2,2"], "--start: one start only"),
    (["--start-xy", "1,1", "--start", "2,2"], "--start: one start only"),
    (["--goal-xy", "3.3,1"], r"--goal-xy 3.3,1: \(3.3, 1\) m is off the map \(x 0..3.2 m, y 0..3.2 m\)"),
    (["--engine", "icarus", "--array", "99x99", str(ROOT / "maps" / "den312d.map")],
     "with the whole map as the array supports maps"),
    (["--array", "0x8"], "--array: '0x8': expected RxC"),
    (["--array", "8"], "--array: '8': expected RxC"),
    (["--array", "1x8", "--engine", "verilator"], "the tile engine's array rows t_r 1: must be an integer in 2..32"),
    (["--array", "31x9", "--engine", "icarus"], "the tile engine's array 31x9 has 279 cells: at most 256"),
    (["--plot", "x.jpg"], "expected a .png, .pdf, .svg"),
])
def test_errors(args, message, capsys):
    base = {"--dfar": "0", "--goal": "30,30"}
    for k, v in base.items():
        if not any(a.startswith(k) for a in args):
            args = [*args, k, v]
    if not any(a.endswith(".map") for a in args):
        args = [str(MAP), *args]
    assert main(["edt", *args]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and re.search(message, err), err


def test_no_path_exits_1(tmp_path, capsys):
    """Ran, but no path: a start or goal on an obstacle, a walled-off goal,
    a start outside the cfr: exit status 1 with the reason, and the JSON."""
    out = tmp_path / "r.json"
    for args, why in [(["--start", "0,0", "--goal", "30,30"], r"start \(0, 0\) is on an obstacle"),
                      (["--start", "3,3", "--goal", "0,0"], r"goal \(0, 0\) is on an obstacle"),
                      (["--start", "3,3", "--goal", "30,30", "--dfar", "5"], r"start \(3, 3\) is not in the cfr")]:
        argv = ["edt", str(MAP), "--dfar", "0", *args, "--json", str(out)]
        if args.count("--dfar"):
            argv.remove("--dfar"), argv.remove("0")
        assert main(argv) == 1, args
        text = capsys.readouterr().out
        assert re.search("NO PATH: " + why, text), text
        assert json.loads(out.read_text())["path_found"] is False
    # without a start: no path asked for, done
    assert main(["edt", str(MAP), "--dfar", "0", "--goal", "30,30"]) == 0


def test_ros_map_and_xy(tmp_path):
    """The bundled ROS map (room-32-32-4.yaml, 0.1 m cells, origin (-1.6, -1.6)):
    --start-xy / --goal-xy in metres, the path in cells and in metres, the CSV."""
    out, csv = tmp_path / "r.json", tmp_path / "r.csv"
    yaml = ROOT / "maps" / "room-32-32-4.yaml"
    # cell (30, 30) of the map as drawn is 30 rows down from the top: y = -1.6 + (32 - 30 - 0.5) * 0.1
    assert main(["edt", str(yaml), "--dfar", "0", "--goal-xy", "1.45,-1.45", "--start-xy", "-1.43,1.42",
                 "--json", str(out), "--csv", str(csv)]) == 0
    data = json.loads(out.read_text())
    m = plan_path(load_grid(MAP), [(30, 30)], (1, 1), 0)
    assert data["path"] == [list(p) for p in m.path] and data["path"][0] == [1, 1]
    assert np.allclose(data["path_xy"][0], [-1.45, 1.45]) and np.allclose(data["path_xy"][-1], [1.45, -1.45])
    assert data["frame"]["origin"] == [-1.6, -1.6, 0.0] and data["frame"]["y_up"]
    rows = csv.read_text().splitlines()
    assert rows[0] == "row,col,x,y" and len(rows) == len(m.path) + 1
    r, c, x, y = rows[1].split(",")
    assert (int(r), int(c)) == (1, 1) and np.allclose([float(x), float(y)], [-1.45, 1.45])


def test_errors_as_subprocess(tmp_path):
    for argv, text in [
        (["edt", str(MAP), "--dfar", "1", "--goal", "99,0"], "outside"),
        (["edt", str(tmp_path / "missing.map"), "--dfar", "1", "--goal", "0,0"], "missing.map"),
    ]:
        res = subprocess.run([sys.executable, "-m", "sim", *argv], capture_output=True, text=True, cwd=ROOT)
        assert res.returncode != 0 and text in res.stderr and "Traceback" not in res.stderr
        assert len(res.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("sim", SIMULATORS)
def test_tile_rtl_engine(tmp_path, sim):
    """The tile engine's RTL: an 8x8 array on a 21x19 map (the engine test's 8x8 / 64x64 builds are
    reused: the RAM's sides are powers of two from 64), two goals, checked against the tiled model."""
    rng = np.random.default_rng(5)
    grid = rng.random((21, 19)) < 0.15
    grid[0, 0] = grid[20, 18] = grid[0, 18] = False
    txt = tmp_path / "m.txt"
    txt.write_text("\n".join("".join("#" if v else "." for v in row) for row in grid) + "\n")
    out = tmp_path / "m.json"
    code = main(["edt", str(txt), "--dfar", "0", "--goal", "20,18", "--goal", "0,18", "--start", "0,0",
                 "--array", "8x8", "--engine", sim, "--json", str(out)])
    data = json.loads(out.read_text())
    t = plan_path_tiled(grid, [(20, 18), (0, 18)], (0, 0), 0, array=(8, 8), readout=True)
    assert code == (0 if t.path_found else 1) and data["rtl_matches_model"] and data["engine"] == sim
    assert data["array"] == [8, 8] and data["tile_visits"] == t.tile_visits > 9 and data["cycles"] == t.cycles
    assert data["path"] == [list(p) for p in t.path] and np.array_equal(data["distance"], t.distance)


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
