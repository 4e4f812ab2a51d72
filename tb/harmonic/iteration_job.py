"""cocotb job: how many clock cycles one Laplace iteration takes on the cluster RTL.

The performance report (scripts/drv.py) runs it on the harmonic cluster top
at the paper's precision ($ITER_P, default 128) for $ITER_N iterations (default
4) and writes the cycle at which each iteration's ``done`` rose, counted from
the start request, to $ITER_RESULT.  The border ring holds a rising ramp so the
nodes have something to relax towards.  It checks nothing: the cluster
regression (test_cluster.py) asserts the p+2 cycles; this job only measures
them for the report.
"""

import json
import os

import cocotb
import numpy as np

from navcores.hdl.harmonic.cluster import COLS, ROWS
from navcores.sim.rtl.clock import start
from tb.harmonic.cluster_driver import ClusterDriver, Command


@cocotb.test()
async def iteration_job(dut):
    p = int(os.environ.get("ITER_P", "128"))
    n = int(os.environ.get("ITER_N", "4"))
    await start(dut)
    ring = np.zeros((ROWS + 2, COLS + 2), dtype=object)
    ring[:, -1] = [(1 << p) * (r + 1) // (ROWS + 3) for r in range(ROWS + 2)]
    drv = ClusterDriver(dut, p, ring)
    dones = await drv.iterate(lambda k: Command(run=k < n))
    with open(os.environ["ITER_RESULT"], "w") as f:
        json.dump({"p": p, "done_cycles": [d.cycle for d in dones]}, f)
