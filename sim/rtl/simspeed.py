"""Simulation speed of any top: clock cycles per wall-clock second.

A cocotb module the benchmark runs through :func:`.runner.run` on any top:
it holds ``rst`` for two cycles, then lets the clock run for ``$SIMSPEED_CYCLES``
cycles with every other input at 0 (the clock is cocotb's GPI clock and the
wait is one Timer, so no Python runs per cycle), and writes ``{"cycles": n, "seconds": s}``
to ``$SIMSPEED_RESULT``.  With the inputs idle most cores sit in their idle
state, so the figure is the simulator's cost of the design's clocked logic,
the floor of what a test pays per cycle; it is not a test (it checks nothing
about the design).
"""

import json
import os
import time

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, Timer

from .clock import PERIOD_NS


@cocotb.test()
async def simspeed(dut):
    cycles = int(os.environ.get("SIMSPEED_CYCLES", "20000"))
    cocotb.start_soon(Clock(dut.clk, PERIOD_NS, unit="ns").start())
    if hasattr(dut, "rst"):
        dut.rst.value = 1
        await ClockCycles(dut.clk, 2)
        dut.rst.value = 0
    t0 = time.perf_counter()
    await Timer(cycles * PERIOD_NS, unit="ns")    # one wake-up: Python is not in the loop
    seconds = time.perf_counter() - t0
    with open(os.environ["SIMSPEED_RESULT"], "w") as f:
        json.dump({"cycles": cycles, "seconds": seconds}, f)
