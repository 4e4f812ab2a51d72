"""``python -m sim track`` and ``python -m sim navigate``: runs, JSON keys, bad input.

* track on the bundled line: reaches the end, the JSON has the documented keys
  and its figures are consistent (cross-track recomputed from the poses).
* navigate with both planners on a small ASCII map (a wall with a gap and a
  pillar, so the plan turns; to a goal back under the start it U-turns, so
  it needs two chains): reaches the goal, 0 collisions, chains strictly
  monotone and joined end to start, the polyline never enters an obstacle.
* navigate on the bundled maze map (EDT plan, 8 chains): goal, no collision.
* Bad input, each a one-line error, exit status 2, no traceback: a chain that
  is not monotone, a malformed CSV line, a too-short path, a bad --start; an
  unreachable goal (both planners), a start on an obstacle, a goal next to
  the start (too short to track), a bad cell argument.
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from navcores.models.navigation import segment_clear
from navcores.models.swam import Swam
from navcores.models.tracker import distance_to_chain
from navcores.sim.cli import main

ROOT = Path(__file__).resolve().parents[2]

MAP = """\
..........................
..........................
..........................
..........................
..........................
##########.###############
..........................
..........................
.................###......
.................###......
..........................
..........................
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("track_cli")
    (d / "room.txt").write_text(MAP)
    (d / "walled.txt").write_text(MAP.replace("##########.####", "###############"))
    (d / "u.csv").write_text("x,y\n0,0\n1,0\n1,1\n0,1\n")
    (d / "bad.csv").write_text("x,y\n0,0\n1;0\n")
    (d / "short.csv").write_text("x,y\n0,0\n0.05,0\n")
    return d


def test_track_json(tmp_path, capsys):
    out = tmp_path / "line.json"
    assert main(["track", str(ROOT / "paths" / "line.csv"), "--speed", "0.1", "--json", str(out),
                 "--start", "0,0.03,-20"]) == 0
    r = json.loads(out.read_text())
    for key in ("reached_end", "steps", "max_cross_track", "rms_cross_track", "odometry_max_cross_track",
                "curvature", "pose", "odometry", "approach_m", "curvature_codes"):
        assert key in r, key
    assert r["reached_end"] and len(r["curvature"]) == r["steps"] == len(r["curvature_codes"])
    assert len(r["pose"]) == len(r["odometry"]) == r["steps"] + 1
    d = distance_to_chain(np.array(r["pose"]), np.array([[0, 0], [1.0, 0.5]]))
    assert r["max_cross_track"] <= d.max() and r["max_cross_track"] in set(d.tolist())
    assert r["approach_m"] > 0 and r["max_cross_track"] < 0.002
    assert "reached the end" in capsys.readouterr().out


@pytest.mark.parametrize("planner,goal,chains", [("harmonic", "10,2", 2), ("edt", "10,24", 1), ("edt", "10,2", 2)])
def test_navigate(files, tmp_path, planner, goal, chains):
    out = tmp_path / "nav.json"
    png = tmp_path / "nav.png"
    rc = main(["navigate", str(files / "room.txt"), "--start", "1,1", "--goal", goal, "--planner", planner,
               "--cell", "0.1", "--speed", "0.2", "--json", str(out), "--plot", str(png)])
    r = json.loads(out.read_text())
    print(planner, {k: r[k] for k in ("reached_goal", "collisions", "max_cross_track", "steps")}, len(r["chains"]))
    assert rc == 0 and r["reached_goal"] and r["collisions"] == 0
    assert png.stat().st_size > 10_000
    obstacle = np.array([[ch == "#" for ch in row] for row in MAP.splitlines()])
    poly = np.array(r["polyline"])
    assert all(segment_clear(obstacle, a, b, 0.1, 0.0) for a, b in zip(poly[:-1], poly[1:]))
    for a, b in zip(r["chains"][:-1], r["chains"][1:]):
        assert a[-1] == b[0]
    assert sum(len(c) - 1 for c in r["chains"]) == len(poly) - 1
    for c in r["chains"]:
        Swam(c)                                          # strictly monotone, or this raises
    assert len(r["chains"]) >= chains and len(poly) >= 3   # the gap makes the plan turn (and U-turn)
    assert r["max_cross_track"] < 0.02


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "sim", *map(str, args)], cwd=ROOT, capture_output=True, text=True)


def test_track_errors(files):
    out = _cli("track", files / "u.csv")
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "not strictly monotone: its edge directions span 180.0 degrees" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


def test_track_error_messages(files, capsys):
    for args, msg in (
        ([files / "bad.csv"], "bad.csv:3: expected two numbers x,y"),
        ([files / "short.csv"], "too short to track"),
        ([ROOT / "paths" / "line.csv", "--start", "1,2"], "expected X,Y,THETA"),
        ([ROOT / "paths" / "line.csv", "--speed", "3"], "--speed 3.0: must be in (0, 1]"),
    ):
        assert main(["track", *map(str, args)]) == 2
        err = capsys.readouterr().err
        assert msg in err and err.startswith("sim track: error:"), (msg, err)


def test_navigate_errors(files, capsys):
    room, walled = files / "room.txt", files / "walled.txt"
    out = _cli("navigate", walled, "--start", "1,1", "--goal", "10,24", "--planner", "edt")
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "goal (10, 24) cannot be reached from start (1, 1)" in out.stderr
    for args, msg in (
        ([walled, "--start", "1,1", "--goal", "10,24"], "goal (10, 24) cannot be reached from start (1, 1)"),
        ([room, "--start", "5,0", "--goal", "10,24"], "start (5, 0) is on an obstacle"),
        ([room, "--start", "1,1", "--goal", "1,1"], "too short to track"),
        ([room, "--start", "1,1", "--goal", "40,1"], "goal (40, 1) is outside the 12x26 map"),
        ([room, "--start", "1", "--goal", "3,3"], "--start '1': expected ROW,COL"),
        ([room, "--start", "1,1", "--goal", "3,3", "--cell", "0"], "--cell 0.0: must be > 0"),
    ):
        assert main(["navigate", *map(str, args)]) == 2, msg
        err = capsys.readouterr().err
        assert msg in err and err.startswith("sim navigate: error:"), (msg, err)


def test_navigate_bundled_maze(tmp_path):
    """A bundled benchmark map whose plan needs many chains: goal reached, no collision."""
    out = tmp_path / "maze.json"
    rc = main(["navigate", str(ROOT / "maps" / "maze-32-32-2.map"), "--start", "1,10", "--goal", "8,26",
               "--planner", "edt", "--speed", "0.2", "--json", str(out)])
    r = json.loads(out.read_text())
    print("maze", len(r["chains"]), "chains", r["steps"], "periods", f"max {r['max_cross_track'] * 1e3:.1f} mm")
    assert rc == 0 and r["reached_goal"] and r["collisions"] == 0 and r["odometry_collisions"] == 0
    assert len(r["chains"]) >= 5
    assert r["max_cross_track"] < 0.03              # the worst case is a 90-degree joint at 0.2 m/s
