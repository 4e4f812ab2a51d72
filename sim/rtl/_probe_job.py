"""Scratch (not committed): the DRAM job with each visit's end cycle, by phase."""
import json
import os
from pathlib import Path

import cocotb
import numpy as np

from .edt_tile_driver import TileEngineDriver
from .litedram import start_litedram


@cocotb.test()
async def probe(dut):
    job = json.loads(Path(os.environ["EDT_JOB"]).read_text())
    drv = TileEngineDriver(dut, *(job[k] for k in ("t_r", "t_c", "max_h", "max_w")))
    stamps = []
    drv.on_visit = lambda n: stamps.append(drv.streams.cycle)
    await start_litedram(dut, job["sys_period_ns"], job["csrs"])
    await drv.start()
    img = np.array(job["obstacle"], dtype=bool)
    c0 = drv.streams.cycle
    raw = await drv.job(img, [tuple(g) for g in job["goals"]], tuple(job["start"]), job["dfar"], readout=False)
    got = drv.decode(raw, img.shape, readout=False)
    Path(os.environ["EDT_RESULT"]).write_text(json.dumps({"c0": c0, "end": drv.streams.cycle, "stamps": stamps,
                                                          "trace": [list(t) for t in got["trace"]],
                                                          "cycles": got["cycles"]}))
