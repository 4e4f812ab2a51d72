"""The closed loop with the DFLC RTL: the same curvature codes as the golden model, bit for bit.

One cocotb test module, run on Icarus and Verilator on the DFLC
regression's own build of the paper's Table 1 controller
(``dflc_stream_table1``, which the DFLC stream and command tests also use),
so it costs no extra simulator build:

* ``rtl_closed_loop``: the whole closed loop runs inside the simulator
  (sim/rtl/track_job.py ``closed_loop``: odometry -> Ψ⁻¹ -> φ1, φ2 -> DFLC RTL,
  one sample per control period -> Ω -> eq. 14 -> robot), on a short curved
  chain from off the path, then the same job with the golden model
  (models.tracker.run_model); every period's output code and zero flag must
  be equal, and so the whole trajectory.  The run must have exercised the
  controller: a few hundred periods, many distinct input and output codes,
  both turning directions.
* on Icarus (a cheap build) the pytest function also runs ``python -m sim
  track --engine icarus`` on the bundled line (a subprocess: the command's
  own path through the runner and the same ``dflc_stream_table1`` top) and
  compares its curvature codes with the model engine's.  (The Verilator
  engine of the commands is the same code on another simulator; a second
  Verilator build only for it is not worth its ~60 s here.)
"""

import json
import math
import subprocess
import sys
from pathlib import Path

import cocotb
import numpy as np
import pytest

from navcores.sim.rtl.runner import SIMULATORS, run

ROOT = Path(__file__).resolve().parents[2]


def short_job():
    from navcores.models.swam import Swam
    from navcores.models.tracker import TrackerParams, loop_job
    t = np.linspace(0, 1, 12)
    chain = Swam(np.stack([0.35 * t, 0.05 * np.sin(2 * math.pi * t)], 1))
    # 0.1 m/s over ~0.4 m: about 300 control periods, started 2 cm off and turned away
    return loop_job([chain], TrackerParams(speed=0.1), start=(0.0, 0.02, math.radians(35)), slip=0.0, seed=0)


@cocotb.test()
async def rtl_closed_loop(dut):
    from navcores.models.tracker import loop_from_job, run_model
    from navcores.sim.rtl.track_job import closed_loop
    from navcores.sim.tracking import load_dflc

    job = short_job()
    rtl = await closed_loop(dut, job)
    ref = run_model(loop_from_job(job, load_dflc()))
    n = len(ref["curvature_codes"])
    assert rtl["steps"] == ref["steps"] == n
    assert 200 <= n <= 600, n
    mismatch = [k for k, (a, b) in enumerate(zip(rtl["curvature_codes"], ref["curvature_codes"])) if a != b]
    assert not mismatch, f"{len(mismatch)} of {n} periods differ, first at {mismatch[0]}"
    assert rtl["pose"] == ref["pose"] and rtl["reached_end"] and ref["reached_end"]
    codes = np.array(ref["curvature_codes"])
    mid = 2048
    assert len(set(codes.tolist())) > 50 and (codes > mid + 100).any() and (codes < mid - 100).any()
    dut._log.info(f"closed loop: {n} periods, {len(set(codes.tolist()))} distinct curvature codes, "
                  f"all equal to the golden model's")


@pytest.mark.parametrize("sim", SIMULATORS)
def test_track_rtl(sim, tmp_path):
    assert run("dflc_stream", {"fll": "table1"}, sim, "test_track_rtl") == 1
    if sim != "icarus":
        return
    # the command's --engine path (a subprocess)
    from navcores.models.swam import Swam
    from navcores.models.tracker import TrackerParams
    from navcores.sim.tracking import read_path_csv, run_loop
    line = ROOT / "paths" / "line.csv"
    ref = run_loop([Swam(read_path_csv(line))], "model", TrackerParams(speed=1.0),
                   start=(0.0, 0.02, math.radians(10)))
    js = tmp_path / f"{sim}.json"
    res = subprocess.run([sys.executable, "-m", "sim", "track", str(line), "--engine", sim, "--speed", "1.0",
                          "--start", "0,0.02,10", "--json", str(js)], cwd=ROOT, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert "Skipping compilation" not in res.stdout + res.stderr       # the runner's chatter is muted
    out = json.loads(js.read_text())
    assert out["engine"] == sim and 50 < out["steps"] < 200
    assert out["curvature_codes"] == ref["curvature_codes"]
