"""cocotb job: one EDT/BFS job on the emitted tile engine (hdl/edt_bfs/tile_engine.py).

Reads the job (map, goals, start, d_far and the engine's parameters t_r,
t_c, max_h, max_w) from the JSON file named by $EDT_JOB, runs it through
:class:`.edt_tile_driver.TileEngineDriver` (sources always valid, sink
always ready: the model's cycle count) and writes the decoded results to
$EDT_RESULT.  While it runs it rewrites $EDT_PROGRESS (if set) every 64 tile
visits with ``visits cycle`` (the command shows them on a terminal).  It
checks nothing itself: sim/edt.py compares the result with the golden
model.  With the engine behind LiteDRAM (a top with ``wb_ctrl``) the job
also names the controller's clock (``sys_period_ns``, against the engine's
PERIOD_NS) and CSRs (``csrs``), and the controller starts first.  With
``path_only_too`` the same job runs again without the map read-out (the
whole job up to the path, as the benches time it): ``path_only`` in the
result holds its cycles, path and trace, and behind LiteDRAM ``native``:
the native reads and writes the controller took in that job and its
clock's cycles (:class:`.litedram.NativeCount`); with ``states`` also
``states``: the engine's cycles in its FSM states in that job, by the model's cycle terms
(:class:`.engine_states.EngineStates`: a build with every signal visible).
"""

import json
import os
from pathlib import Path

import cocotb
import numpy as np

from .edt_tile_driver import TileEngineDriver
from .engine_states import EngineStates
from .litedram import NativeCount, start_litedram


@cocotb.test()
async def edt_tile_job(dut):
    job = json.loads(Path(os.environ["EDT_JOB"]).read_text())
    drv = TileEngineDriver(dut, *(job[k] for k in ("t_r", "t_c", "max_h", "max_w")))
    progress = os.environ.get("EDT_PROGRESS")
    if progress:
        def show(visits):
            if visits % 64 == 0:
                Path(progress).write_text(f"{visits} {drv.streams.cycle}\n")
        drv.on_visit = show
    litedram = hasattr(dut, "wb_ctrl_cyc")  # the engine with LiteDRAM (hdl/edt_bfs/tile_litedram.py)
    if litedram:
        await start_litedram(dut, job["sys_period_ns"], job["csrs"])
    await drv.start()
    start = tuple(job["start"]) if job["start"] is not None else None
    res = await drv.plan(np.array(job["obstacle"], dtype=bool), [tuple(g) for g in job["goals"]], start,
                         job["dfar"])
    out = {k: getattr(res, k) for k in ("distance", "nearest", "cfr", "parent", "visited", "path", "path_found",
                                         "iterations_edt", "iterations_bfs", "cycles", "tile_visits")}
    out = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in out.items()}
    out["path"] = [list(p) for p in res.path]
    out["trace"] = [list(t) for t in res.trace]
    if job.get("path_only_too"):            # the same job again without the map read-out: its cycles and path
        img = np.array(job["obstacle"], dtype=bool)
        native = NativeCount(dut) if litedram else None     # counting only this job (it costs time)
        states = EngineStates(dut) if job.get("states") else None
        if native is not None:
            native.on = True
            native.start()
        if states is not None:
            states.start()
        raw = await drv.job(img, [tuple(g) for g in job["goals"]], start, job["dfar"], readout=False)
        got = drv.decode(raw, img.shape, readout=False)
        out["path_only"] = {"cycles": got["cycles"], "path": [list(p) for p in got["path"]],
                            "trace": [list(t) for t in got["trace"]]}
        if states is not None:
            states.stop()
            out["path_only"]["states"] = states.terms()
        if native is not None:
            native.on = False
            out["path_only"]["native"] = {"reads": native.reads, "writes": native.writes,
                                          "controller_cycles": native.cycles}
    Path(os.environ["EDT_RESULT"]).write_text(json.dumps(out))
