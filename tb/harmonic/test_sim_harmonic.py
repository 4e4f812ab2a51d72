"""``python -m sim harmonic``: results, the JSON contract, and every bad input.

Most cases call ``sim.cli.main([...])`` in-process (fast); a few run the
command as a subprocess to check the exit code and that no traceback leaks.
"""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from navcores.sim.cli import main

ROOT = Path(__file__).resolve().parents[2]
ROOM = str(ROOT / "maps" / "room-32-32-4.map")
KEYS = {"height", "width", "engine", "precision", "converged", "sweeps", "block_iterations",
        "node_updates", "cycles", "potential", "unreachable", "trajectories"}

# 7 x 13 (not a multiple of 6x12): a pocket at the right no goal reaches.
ASCII = """\
.............
.#####.###...
.#.......#...
.#.###...####
.#...#...#...
.....#...#...
.....#...#...
"""


def _run(args, capsys):
    rc = main(["harmonic", *args])
    out = capsys.readouterr()
    assert "Traceback" not in out.err
    return rc, out.out, out.err


@pytest.fixture
def ascii_map(tmp_path):
    path = tmp_path / "grid.txt"
    path.write_text(ASCII)
    return path


def test_json_contract_and_padding(ascii_map, tmp_path, capsys):
    out = tmp_path / "r.json"
    rc, text, _ = _run([str(ascii_map), "--goal", "0,0", "--start", "6,8", "--start", "2,2",
                        "--block", "6x12", "--iters", "3", "--schedule", "8:8:64", "--json", str(out)], capsys)
    assert rc == 0, text
    r = json.loads(out.read_text())
    assert KEYS <= set(r) and r["engine"] == "model"
    assert (r["height"], r["width"]) == (7, 13) and r["padded"] == [12, 24]
    pot = np.array(r["potential"])
    assert pot.shape == (7, 13) and pot.min() >= 0 and pot.max() <= 1
    grid = np.array([[ch == "#" for ch in row] for row in ASCII.splitlines()])
    free = ~grid
    free[0, 0] = False
    assert (pot[grid] == 0).all() and pot[0, 0] == 1.0 and (pot[free] < 1).all()
    assert r["converged"] and r["precision"] in (8, 16, 24, 32, 40, 48, 56, 64)
    assert r["sweeps"] > 0 and r["block_iterations"] > 0 and r["cycles"] > 0
    assert r["node_updates"] == r["block_iterations"] * 72
    # the pocket right of column 9, rows 4..6, and the cells behind it
    assert [4, 10] in r["unreachable"] and all(pot[rc_[0], rc_[1]] == 0 for rc_ in r["unreachable"])
    t0, t1 = r["trajectories"]
    assert t0["start"] == [6, 8] and t0["reached_goal"] and t0["path"][-1] == [0, 0]
    assert t1["start"] == [2, 2] and t1["reached_goal"]
    for t in (t0, t1):
        values = [pot[r_, c_] for r_, c_ in t["path"]]
        assert all(b > a for a, b in zip(values, values[1:]))
        assert all(abs(r1 - r0) + abs(c1 - c0) == 1 for (r0, c0), (r1, c1) in zip(t["path"], t["path"][1:]))
    assert "reaches goal (0, 0)" in text


def test_same_field_any_block(ascii_map, tmp_path, capsys):
    """The block schedule changes the cost, not the field (bound test, part 2)."""
    fields = []
    for block, iters in (("6x12", "6"), ("3x3", "1"), ("7x13", "100")):
        out = tmp_path / f"{block}.json"
        assert _run([str(ascii_map), "--goal", "0,0", "--block", block, "--iters", iters,
                     "--schedule", "16,32,48", "--json", str(out)], capsys)[0] == 0
        fields.append(json.loads(out.read_text()))
    assert fields[0]["potential"] == fields[1]["potential"] == fields[2]["potential"]
    assert len({f["cycles"] for f in fields}) == 3


def test_image_map_and_plot(tmp_path, capsys):
    from PIL import Image
    grid = np.array([[ch == "#" for ch in row] for row in ASCII.splitlines()])
    img = tmp_path / "grid.png"
    Image.fromarray(np.where(grid, 0, 255).astype(np.uint8)).save(img)
    pgm = tmp_path / "grid.pgm"
    Image.fromarray(np.where(grid, 0, 255).astype(np.uint8)).save(pgm)
    plot = tmp_path / "out" / "plot.png"
    results = []
    for path in (img, pgm):
        out = tmp_path / (path.suffix[1:] + ".json")
        extra = ["--plot", str(plot)] if path is img else []
        rc, text, _ = _run([str(path), "--goal", "0,12", "--start", "6,0", "--schedule", "16:16:64",
                            "--json", str(out), *extra], capsys)
        assert rc == 0, text
        results.append(json.loads(out.read_text()))
    assert results[0]["potential"] == results[1]["potential"]
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and plot.stat().st_size > 10_000


def test_unreachable_start_is_reported(ascii_map, tmp_path, capsys):
    out = tmp_path / "r.json"
    rc, text, err = _run([str(ascii_map), "--goal", "0,0", "--start", "5,11", "--start", "6,0",
                          "--json", str(out)], capsys)
    assert rc == 1 and err == ""
    t = json.loads(out.read_text())["trajectories"]
    assert t[0].pop("path_xy")[0] == pytest.approx([1.15, 0.55])       # the drawing frame, 0.1 m a cell
    assert t[0] == {"start": [5, 11], "path": [[5, 11]], "reached_goal": False, "reachable": False}
    assert t[1]["reached_goal"]
    assert "start (5, 11): no goal can reach this cell" in text


def test_not_converged_is_reported(tmp_path, capsys):
    from harmonic_small_maps import corridor
    grid, goals = corridor(30)
    path = tmp_path / "corridor.txt"
    path.write_text("\n".join("".join("#" if x else "." for x in row) for row in grid) + "\n")
    out = tmp_path / "r.json"
    rc, text, _ = _run([str(path), "--goal", "1,30", "--start", "1,1", "--schedule", "8,16",
                        "--json", str(out)], capsys)
    r = json.loads(out.read_text())
    assert rc == 1 and not r["converged"] and r["precision"] == 16
    assert not r["trajectories"][0]["reached_goal"] and "NOT converged" in text and "STUCK" in text


BAD_MAP = "type octile\nheight 2\nwidth 3\nmap\n.@.\n.x.\n"


@pytest.mark.parametrize("args,message", [
    (["{missing}", "--goal", "0,0"], "no such map file"),
    (["{bad_map}", "--goal", "0,0"], r"bad.map:6: unknown terrain 'x'"),
    (["{bad_txt}", "--goal", "0,0"], r"bad.txt:2: row has 2 cells"),
    (["{bad_png}", "--goal", "0,0"], "not a readable image"),
    (["{bad_suffix}", "--goal", "0,0"], "unknown map format"),
    ([ROOM], "no goal"),
    ([ROOM, "--goal", "0,0"], r"goal \(0, 0\) is on an obstacle"),
    ([ROOM, "--goal", "32,5"], r"goal \(32, 5\) is outside the 32x32 map"),
    ([ROOM, "--goal=-1,5"], r"goal \(-1, 5\) is outside"),
    ([ROOM, "--goal", "3;3"], "--goal '3;3': expected ROW,COL"),
    ([ROOM, "--goal", "3,3", "--start", "0,0"], r"start \(0, 0\) is on an obstacle"),
    ([ROOM, "--goal", "3,3", "--start", "3,40"], r"start \(3, 40\) is outside"),
    ([ROOM, "--goal", "3,3", "--start", "x"], "--start 'x'"),
    ([ROOM, "--goal", "3,3", "--schedule", "32,16"], "must increase"),
    ([ROOM, "--goal", "3,3", "--schedule", "16,a"], "expected P1,P2"),
    ([ROOM, "--goal", "3,3", "--schedule", "8:0:16"], "STEP must be >= 1"),
    ([ROOM, "--goal", "3,3", "--schedule", "32:8:16"], "below P1"),
    ([ROOM, "--goal", "3,3", "--schedule", "1,8"], r"2\.\.1022"),
    ([ROOM, "--goal", "3,3", "--schedule", "16:16:2048"], r"2\.\.1022"),
    ([ROOM, "--goal", "3,3", "--schedule", "2:1:99999999999"], r"2\.\.1022"),
    ([ROOM, "--goal", "3,3", "--schedule", "8:8"], "expected P1,P2"),
    ([ROOM, "--goal", "3,3", "--block", "6"], "--block '6': expected NxM"),
    ([ROOM, "--goal", "3,3", "--block", "0x4"], ">= 1"),
    ([ROOM, "--goal", "3,3", "--block", "100000x6"], "above 4096"),
    ([ROOM, "--goal", "3,3", "--iters", "0"], "--iters: 0: must be in 1..255"),
    ([ROOM, "--goal", "3,3", "--iters", "256"], "--iters: 256: must be in 1..255 .*8 bits"),
    ([ROOM, "--goal", "3,3", "--iters", "many"], "--iters: 'many' is not an integer"),
])
def test_bad_input_is_one_line(tmp_path, capsys, args, message):
    (tmp_path / "bad.map").write_text(BAD_MAP)
    (tmp_path / "bad.txt").write_text("...\n..\n")
    (tmp_path / "bad.png").write_bytes(b"not a png at all")
    (tmp_path / "bad.xyz").write_text("...\n")
    files = {"missing": tmp_path / "none.map", "bad_map": tmp_path / "bad.map", "bad_txt": tmp_path / "bad.txt",
             "bad_png": tmp_path / "bad.png", "bad_suffix": tmp_path / "bad.xyz"}
    args = [a.format(**files) for a in args]
    rc, text, err = _run(args, capsys)
    assert rc == 2 and text == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and re.match("(python -m )?sim harmonic: error: ", lines[0]), err
    assert re.search(message, lines[0]), lines[0]


def test_rtl_engine_refuses_what_the_rtl_cannot_run(capsys):
    """A block that is not whole 3x6 clusters, a schedule that is not
    arithmetic: one line from the driver / Planner checks, before any build."""
    for extra, message in ((["--block", "4x6"], "multiple of 3"), (["--block", "3x4"], "multiple of 6"),
                           (["--block", "3x6", "--schedule", "4,8,16"], "arithmetic")):
        rc, text, err = _run([ROOM, "--goal", "3,3", "--engine", "icarus", *extra], capsys)
        assert rc == 2 and message in err and len(err.strip().splitlines()) == 1, err


def _sub(*args):
    return subprocess.run([sys.executable, "-m", "sim", "harmonic", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)


def test_subprocess_ok_and_errors(tmp_path):
    ok = _sub(ROOM, "--goal", "30,31", "--start", "3,3", "--block", "16x16", "--iters", "4",
              "--schedule", "16:16:128", "--json", str(tmp_path / "r.json"))
    assert ok.returncode == 0 and "reaches goal (30, 31)" in ok.stdout, ok.stderr
    assert json.loads((tmp_path / "r.json").read_text())["precision"] == 96
    for args in ([ROOM, "--goal", "0,0"], ["nowhere.map", "--goal", "1,1"]):
        bad = _sub(*args)
        assert bad.returncode == 2 and "Traceback" not in bad.stderr
        assert len(bad.stderr.strip().splitlines()) == 1, bad.stderr
    # argparse's own usage errors are one line too (sim/cli.py)
    bad = _sub(ROOM, "--goal", "3,3", "--engine", "fpga")
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert bad.stderr.strip().splitlines() == [bad.stderr.strip()] and "invalid choice: 'fpga'" in bad.stderr


# --- --paper-schedule (issue 19) -----------------------------------------------

@pytest.mark.parametrize("exponents", [False, True], ids=["fixed", "exponents"])
def test_paper_schedule(ascii_map, tmp_path, capsys, exponents):
    """--paper-schedule runs plan(..., paper_schedule=True): the same field,
    the paper's cycles and check iterations (the default: still blocks, no
    check pass, fewer cycles); the JSON and the summary say which ran."""
    from navcores.models.harmonic import plan
    grid = np.array([[ch == "#" for ch in row] for row in ASCII.splitlines()])
    extra = ["--block-exponents", "--e-max", "255"] if exponents else []
    opts = {"block_exponents": True, "rtl": True, "e_max": 255} if exponents else {}
    args = [str(ascii_map), "--goal", "0,0", "--start", "6,8", "--block", "3x6", "--iters", "3",
            "--schedule", "8:8:32", *extra]
    runs = {}
    for paper in (False, True):
        out = tmp_path / f"{paper}.json"
        rc, text, _ = _run([*args, *(["--paper-schedule"] if paper else []), "--json", str(out)], capsys)
        assert rc == 0, text
        r = runs[paper] = json.loads(out.read_text())
        want = plan(grid, [(0, 0)], block=(3, 6), iters=3, schedule=(8, 16, 24, 32), paper_schedule=paper, **opts)
        got = {k: r[k] for k in ("cycles", "check_iterations", "block_iterations", "sweeps", "precision")}
        assert got == {"cycles": want.cycles, "check_iterations": want.check_iterations,
                       "block_iterations": want.block_iterations, "sweeps": want.sweeps,
                       "precision": want.p}, (paper, got)
        assert r["block_schedule"] == ("paper" if paper else "still blocks")
        assert ("the paper's schedule" if paper else "still blocks") in text.splitlines()[0]
    still, paper = runs[False], runs[True]
    assert paper["potential"] == still["potential"] and paper["precision"] == still["precision"]
    # the paper's check passes and confirmation iterations cost cycles the default saves
    assert paper["check_iterations"] > 0 == still["check_iterations"]
    assert paper["cycles"] > still["cycles"] and paper["block_iterations"] > still["block_iterations"]


def test_paper_schedule_refused_on_the_board(capsys):
    rc, text, err = _run([ROOM, "--goal", "3,3", "--engine", "serial:/dev/nonexistent", "--paper-schedule"],
                         capsys)
    assert rc == 2 and text == "" and len(err.strip().splitlines()) == 1, err
    assert "--paper-schedule: the board's planner" in err


# --- --block-exponents (issue 10) ----------------------------------------------

RANDOM = str(ROOT / "maps" / "random-32-32-10.map")


def test_block_exponents_json(tmp_path, capsys):
    """The JSON gains "exponents" (BR x BC) and "frac_bits"; the field is the
    model's, on the common scale; at p = 16, where fixed point still has
    local maxima on this map, every start reaches the goal."""
    from navcores.models.harmonic import plan
    from navcores.models.maps import load_map
    out = tmp_path / "e.json"
    args = [RANDOM, "--goal", "29,6", "--start", "0,31", "--start", "31,31", "--block", "6x12",
            "--schedule", "16", "--json", str(out)]
    rc, text, _ = _run([*args, "--block-exponents"], capsys)
    assert rc == 0, text
    r = json.loads(out.read_text())
    res = plan(load_map(RANDOM), [(29, 6)], block=(6, 12), schedule=(16,), block_exponents=True, rtl=True)
    assert r["precision"] == 16 and r["converged"] and r["cycles"] == res.cycles
    assert r["exponents"] == res.exponents.tolist() and np.array(r["exponents"]).shape == (6, 3)
    assert r["exponents"][4][0] == 0 and r["frac_bits"] == 16 + max(map(max, r["exponents"])) > 16
    pot = np.array(r["potential"])
    assert pot.shape == (32, 32) and pot[29, 6] == 1.0
    assert np.array_equal(pot, res.potential())
    assert all(t["reached_goal"] for t in r["trajectories"]) and len(r["trajectories"]) == 2
    assert "block exponents e_b: 0.." in text
    # the same command in fixed point: no exponents in the JSON, and p = 16 is not enough
    rc, text, _ = _run(args, capsys)
    r = json.loads(out.read_text())
    assert rc == 1 and not r["converged"] and "exponents" not in r and "frac_bits" not in r


def test_block_exponents_rtl_engine_bad_schedule_is_one_line(capsys):
    """The RTL engines with exponents: a schedule the RTL cannot run is a
    one-line error before any build (the RTL run itself: test_sim_harmonic_rtl)."""
    for engine in ("icarus", "verilator"):
        rc, text, err = _run([ROOM, "--goal", "3,3", "--engine", engine, "--block-exponents",
                              "--schedule", "4,8,16"], capsys)
        assert rc == 2 and text == "" and len(err.strip().splitlines()) == 1, err
        assert f"--engine {engine}:" in err and "arithmetic schedules only" in err


def test_block_exponents_subprocess(tmp_path):
    ok = _sub(ROOM, "--goal", "30,31", "--start", "3,3", "--block", "6x12", "--schedule", "16:16:128",
              "--block-exponents", "--json", str(tmp_path / "r.json"))
    assert ok.returncode == 0 and "reaches goal (30, 31)" in ok.stdout, ok.stderr
    r = json.loads((tmp_path / "r.json").read_text())
    assert len(r["exponents"]) == 6 and r["frac_bits"] > r["precision"]
    bad = _sub(ROOM, "--goal", "3,3", "--engine", "verilator", "--block-exponents", "--schedule", "4,8,16")
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1 and "arithmetic schedules only" in bad.stderr


def test_block_exponents_decision_trajectories(tmp_path, capsys):
    """Issue 22: with --block-exponents the trajectories are the Decision
    module's (models.harmonic.decision_paths), each beside the exact ascent
    and the step where they part; e_max from the map (at least 255) in the
    JSON and the summary; --e-max sets it (a bound the run reaches is named)."""
    from navcores.models.harmonic import decision_paths, e_max_for, plan, trajectory
    from navcores.models.maps import load_map
    out = tmp_path / "d.json"
    args = [RANDOM, "--goal", "29,6", "--start", "0,0", "--start", "31,31", "--block", "6x12", "--schedule", "16",
            "--block-exponents", "--json", str(out)]
    rc, text, _ = _run(args, capsys)
    assert rc == 0, text
    r = json.loads(out.read_text())
    grid = load_map(RANDOM)
    assert r["e_max"] == e_max_for(grid, [(29, 6)]) == 255 and "e_max 255 (8-bit exponent registers)" in text
    res = plan(grid, [(29, 6)], block=(6, 12), schedule=(16,), block_exponents=True, rtl=True)
    goal = np.zeros(res.mantissa.shape, dtype=bool)
    goal[29, 6] = True
    want = decision_paths(res.mantissa, res.exponents, res.block, res.p, goal, [(0, 0), (31, 31)])
    parted = 0
    for tr, (path, ok) in zip(r["trajectories"], want):
        assert tr["path"] == [list(c) for c in path] and tr["reached_goal"] == ok is True
        assert tr["ascent"] == [list(c) for c in trajectory(res.h, [(29, 6)], tr["start"]).path]
        k = tr["differs_at"]
        assert (k is None) == (tr["path"] == tr["ascent"])
        if k is not None:
            assert tr["path"][:k] == tr["ascent"][:k] and tr["path"][k] != tr["ascent"][k]
            assert f"parting from the exact ascent ({len(tr['ascent']) - 1} steps) at step {k}" in text
            parted += 1
    assert parted == 2, "on this map the Decision's paths part from the exact ascent (both starts)"
    rc, text, _ = _run([*args[:-2], "--e-max", "20"], capsys)
    assert "e_max 20 (5-bit exponent registers)" in text and "block(s) at e_max" in text


def _serpentine(tmp_path, rows=21, cols=60):
    """A serpentine corridor (tb/harmonic/planner_maps.corridor) as an ASCII map: its far end is
    about 2**-1250 below the goal, beyond float64 (2**-1074)."""
    from planner_maps import corridor
    ob, goals = corridor(rows, cols)
    path = tmp_path / "serp.txt"
    path.write_text("\n".join("".join("#" if v else "." for v in row) for row in ob) + "\n")
    return path, ob, goals[0]


def test_node_exponents(tmp_path, capsys):
    """Issue 22: --node-exponents runs models.harmonic.plan_node_exponents,
    the trajectories are the Decision module's on blocks of one node, the
    JSON carries the exponents and log2 potentials (float64 holds 0 there)."""
    from navcores.models.harmonic import decision_paths, plan_node_exponents, reachable
    path, ob, goal = _serpentine(tmp_path)
    out = tmp_path / "n.json"
    rc, text, _ = _run([str(path), "--goal", f"{goal[0]},{goal[1]}", "--start", "0,0", "--node-exponents",
                        "--p", "12", "--json", str(out), "--plot", str(tmp_path / "n.png")], capsys)
    assert rc == 0, text
    r = json.loads(out.read_text())
    res = plan_node_exponents(ob, [goal], p=12)
    assert r["node_exponents"] and r["precision"] == 12 and r["converged"] and r["iterations"] == res.iterations
    assert r["exponents"] == res.exponents.tolist() and r["e_max"] == res.e_max
    lg = np.array([[np.nan if x is None else x for x in row] for row in r["log2_potential"]])
    reach = reachable(ob, [goal])
    assert np.isfinite(lg[reach]).all() and np.isnan(lg[~reach]).all() and lg[reach].min() < -1074
    assert (np.array(r["potential"])[reach] == 0).any()          # float64 underflows where the exponents do not
    gm = np.zeros(ob.shape, dtype=bool)
    gm[goal] = True
    (want, ok), = decision_paths(res.mantissa, res.exponents, (1, 1), 12, gm, [(0, 0)])
    tr, = r["trajectories"]
    assert ok and tr["reached_goal"] and tr["path"] == [list(c) for c in want] and tr["differs_at"] is None
    assert f"reaches goal ({goal[0]}, {goal[1]}) in {len(want) - 1} steps" in text
    assert (tmp_path / "n.png").stat().st_size > 0
    rc, text, _ = _run([str(path), "--goal", f"{goal[0]},{goal[1]}", "--start", "0,0", "--node-exponents",
                        "--e-max", "40"], capsys)       # too small a range: the far end stays 0
    assert rc == 1 and "NOT converged" in text and "STUCK" in text


@pytest.mark.parametrize("extra,message", [
    (["--node-exponents", "--engine", "serial:/dev/ttyUSB9"], "no board runs it"),
    (["--node-exponents", "--engine", "icarus", "--e-max", "70000"], r"--engine icarus: e_max"),
    (["--node-exponents", "--block-exponents"], "choose one"),
    (["--p", "16"], "only with --node-exponents"),
    (["--node-exponents", "--p", "3"], r"--p: 3: must be in 4\.\.48"),
    (["--node-exponents", "--p", "49"], r"must be in 4\.\.48"),
    (["--node-exponents", "--e-max", "0"], "e_max = 0"),
])
def test_node_exponents_refusals(capsys, extra, message):
    rc, text, err = _run([ROOM, "--goal", "3,3", *extra], capsys)
    assert rc == 2 and text == "" and len(err.strip().splitlines()) == 1 and re.search(message, err), err
