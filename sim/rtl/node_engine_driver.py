"""The cocotb driver of the node-exponent engine (hdl/harmonic/node_exponent_engine.py).

One job: the command, the map's cells, then the field read back; the
status (iterations, fixed point, cycles) read after the last word.  The
streams are :mod:`.stream`'s; ``set_stalls`` adds random idle cycles to the
command and the cells and back-pressure to the read-out.
"""

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import RisingEdge, SimTimeoutError, with_timeout

from navcores.hdl.harmonic.node_exponent_engine import CELL_FREE, CELL_GOAL, CELL_OBSTACLE, NodeExponentEngine
from navcores.models.harmonic.node_exponents import engine_cycles

from .clock import PERIOD_NS
from .stream import Streams, pauses

__all__ = ["NodeEngineDriver", "cells_of"]


def cells_of(obstacle, goals):
    """The ``cells`` stream of a map: reading order, 0 free, 1 obstacle, 2 goal."""
    codes = np.where(np.asarray(obstacle, dtype=bool), CELL_OBSTACLE, CELL_FREE)
    for g in goals:
        codes[tuple(g)] = CELL_GOAL
    return [int(x) for x in codes.ravel()]


class NodeEngineDriver:
    """``params``: the engine's (max_h, max_w, p, e_max, headroom)."""

    def __init__(self, dut, params):
        self.dut = dut
        layouts = NodeExponentEngine(**params)
        self.streams = Streams(dut)
        self.cmd = self.streams.source("cmd", layouts.cmd.payload.shape())
        self.cells = self.streams.source("cells", 2)
        self.field = self.streams.sink("field", layouts.field.payload.shape())

    def set_stalls(self, rng=None, idle=0.0, back_pressure=0.0):
        """Random idle cycles before each command and cell (probability
        ``idle``) and ready low on the read-out (``back_pressure``), from ``rng``."""
        self.cmd.pause = pauses(rng, idle)
        self.cells.pause = pauses(rng, idle)
        self.field.set_pause(pauses(rng, back_pressure))

    async def start(self):
        cocotb.start_soon(Clock(self.dut.clk, PERIOD_NS, unit="ns").start())
        await self.streams.apply_reset()

    def submit(self, obstacle, goals, max_iter):
        """Queue a job's command and cells (no waiting)."""
        h, w = np.shape(obstacle)
        self.cmd.put({"height": h, "width": w, "max_iter": max_iter})
        self.cells.extend(cells_of(obstacle, goals))

    async def job(self, obstacle, goals, max_iter, expect_iterations=None):
        """Run one job; returns {mantissa, exponents (H x W lists), iterations,
        fixed, cycles}.  ``expect_iterations`` bounds the wait (a hang fails
        with the engine's status instead of running forever)."""
        h, w = np.shape(obstacle)
        self.submit(obstacle, goals, max_iter)
        bound = 2 * engine_cycles(h, w, expect_iterations or max_iter) + 40 * h * w + 1000
        words = []
        d = self.dut
        for k in range(h * w):
            try:
                words.append(await with_timeout(self.field.recv(), bound * PERIOD_NS, "ns"))
            except SimTimeoutError:
                raise AssertionError(f"{k} of {h * w} words after {bound} cycles: busy {d.busy.value}, "
                                     f"iterations {int(d.iterations.value)}, cycles {int(d.cycles.value)}") from None
        await RisingEdge(d.clk)                 # the last beat's edge ended the job: the status is final
        return {"mantissa": [[wd["v"] for wd in words[r * w:(r + 1) * w]] for r in range(h)],
                "exponents": [[wd["e"] for wd in words[r * w:(r + 1) * w]] for r in range(h)],
                "iterations": int(d.iterations.value), "fixed": bool(int(d.fixed.value)),
                "cycles": int(d.cycles.value), "busy": bool(int(d.busy.value)), "error": bool(int(d.error.value))}
