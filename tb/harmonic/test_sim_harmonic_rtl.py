"""``python -m sim harmonic --engine icarus|verilator``: the planner RTL through
the command line gives the model's JSON (values, counters, cycles,
trajectories), on a map that needs padding.

The parameters are the planner regression's "b3x6" set (tb/harmonic/
test_planner.py: 3x3 blocks of 3x6 nodes, p_max 16, RAM depth 256), so the
builds are shared with it on both simulators.
"""

import json

import numpy as np
import pytest

from navcores.sim.cli import main
from navcores.sim.rtl.runner import SIMULATORS

# (map shape before padding, block, schedule, I): the padded map is the
# regression's 3x3 blocks of 3x6 at p_max 16.
CASES = {
    "icarus": ((8, 17), "3x6", "8,16", "3"),
    "verilator": ((8, 17), "3x6", "4:4:16", "2"),
}


def _map(shape, seed=5):
    rng = np.random.default_rng(seed)
    grid = rng.random(shape) < 0.2
    grid[0, :] = False                      # a free top row: goal and starts connected
    grid[:, 0] = False
    return grid



def _model_and_rtl(args, sim, tmp_path, capsys):
    """``python -m sim harmonic ARGS`` with the model and with ``sim``: their JSON (plus "rc")."""
    out = {}
    for engine in ("model", sim):
        rc = main(["harmonic", *args, "--engine", engine, "--json", str(tmp_path / f"{engine}.json")])
        assert "Traceback" not in capsys.readouterr().err
        out[engine] = json.loads((tmp_path / f"{engine}.json").read_text())
        out[engine]["rc"] = rc
    return out["model"], out[sim]

@pytest.mark.parametrize("sim", SIMULATORS)
def test_rtl_engine_matches_model(sim, tmp_path, capsys):
    shape, block, schedule, iters = CASES[sim]
    grid = _map(shape)
    path = tmp_path / "m.txt"
    path.write_text("\n".join("".join("#" if x else "." for x in row) for row in grid) + "\n")
    goal, starts = "0,0", ["0,%d" % (shape[1] - 1), "%d,0" % (shape[0] - 1)]
    args = [str(path), "--goal", goal, "--block", block, "--schedule", schedule, "--iters", iters]
    for s in starts:
        args += ["--start", s]
    model, rtl = _model_and_rtl(args, sim, tmp_path, capsys)
    assert rtl["engine"] == sim and rtl["padded"] != [rtl["height"], rtl["width"]]
    compared = 0
    for key in ("rc", "height", "width", "precision", "converged", "maxima", "sweeps", "block_iterations",
                "check_iterations", "node_updates", "cycles", "potential", "unreachable", "trajectories"):
        assert rtl[key] == model[key], key
        compared += 1
    assert compared == 14 and model["cycles"] > 0 and len(model["trajectories"]) == 2


@pytest.mark.parametrize("sim", SIMULATORS)
def test_rtl_engine_paper_schedule_matches_model(sim, tmp_path, capsys):
    """``--paper-schedule`` on the RTL engines builds Planner(paper_schedule=True)
    (the regression's ``b3x6_paper`` build) and gives the model engine's JSON
    with the paper's schedule: more cycles than the default, check passes."""
    grid = _map((8, 17), seed=7)
    path = tmp_path / "m.txt"
    path.write_text("\n".join("".join("#" if x else "." for x in row) for row in grid) + "\n")
    args = [str(path), "--goal", "0,0", "--start", "7,16", "--block", "3x6", "--schedule", "8:8:16",
            "--iters", "3"]
    model, rtl = _model_and_rtl([*args, "--paper-schedule"], sim, tmp_path, capsys)
    assert rtl["engine"] == sim and rtl["block_schedule"] == model["block_schedule"] == "paper"
    compared = 0
    for key in ("rc", "precision", "converged", "maxima", "sweeps", "block_iterations", "check_iterations",
                "cycles", "potential", "trajectories"):
        assert rtl[key] == model[key], key
        compared += 1
    still = main(["harmonic", *args, "--json", str(tmp_path / "still.json")])
    still = json.loads((tmp_path / "still.json").read_text())
    assert compared == 10 and model["check_iterations"] > 0 and model["cycles"] > still["cycles"]
    assert model["potential"] == still["potential"]


@pytest.mark.parametrize("sim", SIMULATORS)
def test_rtl_engine_block_exponents_matches_model(sim, tmp_path, capsys):
    """``--block-exponents`` on the RTL engines: the Planner's exponent option
    (the build of tb/harmonic/test_planner_exponents.py: 3x3 blocks of 3x6,
    p_max 14, depth 256) gives the model engine's JSON, exponents included,
    on a padded map whose exponents move and whose blocks saturate."""
    grid = _map((8, 17))
    path = tmp_path / "m.txt"
    path.write_text("\n".join("".join("#" if x else "." for x in row) for row in grid) + "\n")
    model, rtl = _model_and_rtl([str(path), "--goal", "0,0", "--start", "7,16", "--block", "3x6",
                                 "--schedule", "6:4:14", "--iters", "3", "--block-exponents"],
                                sim, tmp_path, capsys)
    assert rtl["engine"] == sim and max(map(max, model["exponents"])) > 0
    compared = 0
    for key in ("rc", "precision", "converged", "maxima", "sweeps", "block_iterations", "check_iterations",
                "cycles", "potential", "exponents", "frac_bits", "trajectories"):
        assert rtl[key] == model[key], key
        compared += 1
    assert compared == 12 and model["converged"] and model["trajectories"][0]["reached_goal"]


@pytest.mark.parametrize("sim", SIMULATORS)
def test_node_exponent_engine_command(sim, tmp_path, capsys):
    """--node-exponents --engine icarus|verilator: the node-exponent engine
    sized for the map (the engine regression's build: 9x16, p 12, e_max 255)
    runs it, the command checks it against the model (red-black to a fixed
    point) and reports the Decision's path on the RTL's field."""
    from planner_maps import corridor
    from navcores.models.harmonic import plan_node_exponents
    from navcores.models.harmonic.node_exponents import engine_cycles
    ob, goals = corridor(9, 16)
    path = tmp_path / "serp.txt"
    path.write_text("\n".join("".join("#" if v else "." for v in row) for row in ob) + "\n")
    out = tmp_path / "n.json"
    rc = main(["harmonic", str(path), "--goal", "8,15", "--start", "0,0", "--node-exponents", "--p", "12",
               "--e-max", "255", "--engine", sim, "--json", str(out)])
    text = capsys.readouterr().out
    assert rc == 0, text
    r = json.loads(out.read_text())
    model = plan_node_exponents(ob, goals, p=12, e_max=255, order="red-black", until_fixed=True)
    assert r["engine"] == sim and r["order"] == "red-black" and r["rtl_matches_model"] and r["fixed_point"]
    assert r["exponents"] == model.exponents.tolist() and r["iterations"] == model.iterations
    assert r["cycles"] == engine_cycles(9, 16, model.iterations)
    assert "RTL bit-exact and cycle-exact against the model: yes" in text
    assert r["trajectories"][0]["reached_goal"]
