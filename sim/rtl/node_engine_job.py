"""cocotb job: one map on the emitted node-exponent engine (hdl/harmonic/node_exponent_engine.py).

Reads the job (obstacle, goals, max_iter, the engine's parameters) from the
JSON file named by $NODE_JOB, runs it through
:class:`.node_engine_driver.NodeEngineDriver` (sources always valid, sink
always ready) and writes the result to $NODE_RESULT.  It checks nothing
itself: sim/harmonic.py compares the result with the golden model.
"""

import json
import os
from pathlib import Path

import cocotb

from .node_engine_driver import NodeEngineDriver


@cocotb.test()
async def node_engine_job(dut):
    job = json.loads(Path(os.environ["NODE_JOB"]).read_text())
    drv = NodeEngineDriver(dut, job["params"])
    await drv.start()
    out = await drv.job(job["obstacle"], [tuple(g) for g in job["goals"]], job["max_iter"])
    Path(os.environ["NODE_RESULT"]).write_text(json.dumps(out))
