"""cocotb job: one EDT/BFS job on the emitted core (hdl/edt_bfs/edt_bfs.py).

Reads the job (image, goals, start, d_far) from the JSON file named by
$EDT_JOB, runs it through :class:`.edt_bfs_driver.EdtBfsDriver` and writes the
decoded results to $EDT_RESULT.  It checks nothing itself: sim/edt.py compares the
result with the golden model.
"""

import json
import os
from pathlib import Path

import cocotb
import numpy as np

from .edt_bfs_driver import EdtBfsDriver


@cocotb.test()
async def edt_bfs_job(dut):
    job = json.loads(Path(os.environ["EDT_JOB"]).read_text())
    img = np.array(job["obstacle"], dtype=bool)
    h, w = img.shape
    drv = EdtBfsDriver(dut, h, w)
    await drv.start()
    start = tuple(job["start"]) if job["start"] is not None else None
    got = await drv.job(img, [tuple(g) for g in job["goals"]], start, job["dfar"])
    out = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in got.items()}
    out["path"] = [list(p) for p in got["path"]]
    Path(os.environ["EDT_RESULT"]).write_text(json.dumps(out))
