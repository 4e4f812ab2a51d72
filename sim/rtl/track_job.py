"""cocotb job: the tracker's closed loop with the DFLC RTL inside the simulator.

Reads a closed-loop job (chains, tracker parameters, start, slip, seed:
models.tracker.loop_job) from the JSON file named by $TRACK_JOB, runs the
loop of models/tracker.py with one inference per control period through the
emitted DFLC stream top (:class:`.dflc_driver.DflcDriver` drives it), and
writes the loop's result to $TRACK_RESULT.  It checks nothing itself: the callers compare
the curvature codes with the golden model's run.
"""

import json
import os
from pathlib import Path

import cocotb

from navcores.hdl.dflc.top import config_for
from navcores.models.dflc import Dflc
from navcores.models.tracker import loop_from_job

from .dflc_driver import DflcDriver

DFLC_TOP = "dflc_stream"
DFLC_PARAMS = {"fll": "table1"}      # the paper's Table 1 controller, Table 2 widths


async def closed_loop(dut, job):
    """Run the job's loop on the RTL (the DFLC_TOP at DFLC_PARAMS); returns ClosedLoop.result()."""
    config = config_for(**DFLC_PARAMS)
    driver = DflcDriver(dut, config)
    await driver.start()
    loop = loop_from_job(job, Dflc(config))
    while (codes := loop.inputs()) is not None:
        y, zero = await driver.infer([int(c) for c in codes])
        loop.advance(y, zero)
    return loop.result()


@cocotb.test()
async def track_job(dut):
    job = json.loads(Path(os.environ["TRACK_JOB"]).read_text())
    result = await closed_loop(dut, job)
    Path(os.environ["TRACK_RESULT"]).write_text(json.dumps(result))
