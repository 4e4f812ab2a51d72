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
        ([ROOT / "paths" / "line.csv", "--speed", "3"], "--speed: 3: must be in [0.008, 1] m/s (the Khepera II"),
    ):
        assert main(["track", *map(str, args)]) == 2
        err = capsys.readouterr().err
        assert msg in err and err.startswith("sim track: error:"), (msg, err)


def test_navigate_errors(files, capsys):
    room, walled = files / "room.txt", files / "walled.txt"
    # ran, but no path: exit status 1 with the reason on stdout, nothing on stderr
    out = _cli("navigate", walled, "--start", "1,1", "--goal", "10,24", "--planner", "edt")
    assert out.returncode == 1 and out.stderr == ""
    assert "NO PATH: goal (10, 24) cannot be reached from start (1, 1)" in out.stdout
    assert main(["navigate", str(walled), "--start", "1,1", "--goal", "10,24"]) == 1
    assert "NO PATH: goal (10, 24) cannot be reached from start (1, 1)" in capsys.readouterr().out
    for args, msg in (
        ([room, "--start", "5,0", "--goal", "10,24"], "start (5, 0) is on an obstacle"),
        ([room, "--start", "1,1", "--goal", "1,1"], "too short to track"),
        ([room, "--start", "1,1", "--goal", "40,1"], "goal (40, 1) is outside the 12x26 map"),
        ([room, "--start", "1", "--goal", "3,3"], "--start '1': expected ROW,COL"),
        ([room, "--start", "1,1", "--goal", "3,3", "--cell", "0"], "--cell: 0: must be in (0, 1000] m"),
        ([room, "--start", "1,1", "--goal", "3,3", "--cell", "inf"], "--cell: inf: must be a finite number"),
        ([room, "--start", "1,1", "--goal", "3,3", "--goal", "4,4"], "--goal: one goal only"),
        ([room, "--start", "1,1", "--goal", "3,3", "--start-xy", "0.5,0.5"], "--start-xy: one start only"),
        ([room, "--start", "1,1", "--goal", "3,3", "--seed", "-5", "--slip", "0.01"], "--seed: -5: must be in 0.."),
        ([room, "--start", "1,1", "--goal", "3,3", "--block", "6,x"], "--block '6,x': expected NxM"),
        ([room, "--start", "1,1", "--goal", "3,3", "--schedule", "16,8"], "precisions must increase"),
        ([room, "--start-xy", "9,9", "--goal", "3,3"], "--start-xy 9,9: (9, 9) m is off the map (x 0..2.6 m, y 0..1.2 m)"),
        # 100 m cells: a 2 km drive at 0.05 m/s is more control periods than any run may take
        ([room, "--start", "1,1", "--goal", "10,24", "--cell", "100", "--planner", "edt"], "at most 2000000 are run"),
        ([room, "--start", "1,1", "--goal", "10,24", "--plot", "p.xyz"], "--plot p.xyz: expected a .png, .pdf, .svg"),
    ):
        assert main(["navigate", *map(str, args)]) == 2, msg
        err = capsys.readouterr().err
        assert msg in err and err.startswith("sim navigate: error:") and len(err.splitlines()) == 1, (msg, err)


def test_navigate_ros_map_in_metres(tmp_path):
    """The bundled ROS map: start and goal in metres, the resolution as the cell
    size, the drive and the path in the map frame (y up, origin (-1.6, -1.6))."""
    out, csv = tmp_path / "sub" / "nav.json", tmp_path / "sub" / "nav.csv"
    yaml = ROOT / "maps" / "room-32-32-4.yaml"
    rc = main(["navigate", str(yaml), "--start-xy", "-1.25,1.25", "--goal-xy", "1.45,-1.45", "--planner", "edt",
               "--speed", "0.2", "--json", str(out), "--csv", str(csv)])
    r = json.loads(out.read_text())
    assert rc == 0 and r["reached_goal"] and r["collisions"] == 0
    assert r["start"] == [3, 3] and r["goal"] == [30, 30] and r["cell"] == 0.1
    assert r["frame"]["y_up"] and r["frame"]["origin"] == [-1.6, -1.6, 0.0]
    assert np.allclose(r["path_xy"][0], [-1.25, 1.25]) and np.allclose(r["path_xy"][-1], [1.45, -1.45])
    assert np.allclose(r["pose"][0][:2], r["polyline"][0]) and np.allclose(r["polyline"][0], [-1.25, 1.25])
    assert np.hypot(*(np.array(r["pose"][-1][:2]) - [1.45, -1.45])) < 0.1     # ends at the goal, in metres
    rows = csv.read_text().splitlines()
    assert rows[0] == "row,col,x,y" and len(rows) == len(r["cells"]) + 1
    # the same drive on the Moving AI map at 0.1 m (drawing frame): the same cells
    r2 = tmp_path / "nav2.json"
    assert main(["navigate", str(ROOT / "maps" / "room-32-32-4.map"), "--start", "3,3", "--goal", "30,30",
                 "--planner", "edt", "--speed", "0.2", "--json", str(r2)]) == 0
    assert json.loads(r2.read_text())["cells"] == r["cells"]


def test_track_probes(files, tmp_path, capsys):
    """The track probes: a start past the end of the path, a negative seed, a
    plot name matplotlib cannot write, a speed below the robot's, a path of
    1e9 m, a 30 km path, a repeated --start: one line, exit status 2, nothing
    written; the output folder is created."""
    line = ROOT / "paths" / "line.csv"
    (tmp_path / "far.csv").write_text("x,y\n0,0\n1e9,1\n")
    (tmp_path / "long.csv").write_text("x,y\n0,0\n30000,1\n")
    (tmp_path / "bin.csv").write_bytes(b"x,y\n\x00\x01\x02\xff\n")
    out = tmp_path / "o.json"
    for args, msg in (
        ([line, "--start=2,1,0"], "lies past the end of the path"),
        ([line, "--seed", "-5", "--slip", "0.01"], "--seed: -5: must be in 0.."),
        ([line, "--slip", "0.6"], "--slip: 0.6: must be in [0, 0.5]"),
        ([line, "--plot", "p.xyz"], "--plot p.xyz: expected a .png, .pdf, .svg"),
        ([line, "--speed", "0.0001"], "--speed: 0.0001: must be in [0.008, 1] m/s"),
        ([line, "--start", "0,0,0", "--start", "0,0,10"], "--start: given twice"),
        ([line, "--cell", "0.1"], "--cell without --map"),
        ([tmp_path / "far.csv"], "more than 100 km from the origin"),
        ([tmp_path / "long.csv"], "at most 2000000 are run"),
        ([tmp_path / "bin.csv"], "bin.csv:2: byte 0x00: binary data"),
        ([line, "--json", tmp_path], "is a folder"),
        ([line, "--json", line], "that is an input file"),
    ):
        assert main(["track", *map(str, args), "--json", str(out)] if "--json" not in map(str, args)
                    else ["track", *map(str, args)]) == 2, msg
        err = capsys.readouterr().err
        assert msg in err and err.startswith("sim track: error:") and len(err.splitlines()) == 1, (msg, err)
        assert not out.exists()
    deep = tmp_path / "a" / "b" / "t.json"
    assert main(["track", str(line), "--speed", "0.2", "--json", str(deep)]) == 0 and deep.exists()


def test_track_start_pose_and_map(files, tmp_path):
    """--start is where the robot starts (the first true pose), the approach
    phase is counted in periods; with --map the poses are checked against the map."""
    out = tmp_path / "t.json"
    (tmp_path / "p.csv").write_text("x,y\n0.2,0.25\n2.4,0.25\n")
    # the room map at 0.1 m (drawing frame): row 2 is y 0.2..0.3, free; the wall is row 5 (y 0.5..0.6)
    assert main(["track", str(tmp_path / "p.csv"), "--start", "0.15,0.35,-400", "--speed", "0.2",
                 "--map", str(files / "room.txt"), "--json", str(out), "--plot", str(tmp_path / "t.png")]) == 0
    r = json.loads(out.read_text())
    assert np.allclose(r["pose"][0], [0.15, 0.35, np.radians(-40)])       # -400 degrees wrapped to -40
    assert r["approach_steps"] > 0 and r["collisions"] == 0 and r["frame"]["resolution"] == 0.1
    (tmp_path / "w.csv").write_text("x,y\n0.2,0.55\n2.4,0.55\n")        # along the wall row
    assert main(["track", str(tmp_path / "w.csv"), "--speed", "0.2", "--map", str(files / "room.txt"),
                 "--json", str(out)]) == 1
    assert json.loads(out.read_text())["collisions"] > 0


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
