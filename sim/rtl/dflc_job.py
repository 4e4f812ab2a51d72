"""cocotb job: run samples through an emitted DFLC stream top.

Reads the job (top parameters, input code rows) from the JSON file named by
$DFLC_JOB, sends the rows through the stream at full rate with
:class:`.dflc_driver.DflcDriver` and writes the outputs and the handshake
cycles to $DFLC_RESULT.  It checks nothing itself: ``python -m sim dflc``
reports what the RTL produced.
"""

import json
import os
from pathlib import Path

import cocotb

from navcores.hdl.dflc.top import config_for, split_params

from .dflc_driver import DflcDriver


@cocotb.test()
async def dflc_job(dut):
    job = json.loads(Path(os.environ["DFLC_JOB"]).read_text())
    params, _, _ = split_params(job["params"])
    driver = DflcDriver(dut, config_for(**params))
    await driver.start()
    out = await driver.run(job["codes"])
    Path(os.environ["DFLC_RESULT"]).write_text(json.dumps({
        "y": [y for y, _ in out], "zero": [z for _, z in out],
        "in_cycles": driver.in_cycles, "out_cycles": driver.out_cycles,
    }))
