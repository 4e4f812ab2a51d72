"""The clock and the synchronous reset every cocotb driver and job starts a DUT with."""

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge

__all__ = ["PERIOD_NS", "start"]

PERIOD_NS = 10      # the simulated clock period (100 MHz); the RTL's timing is in cycles


async def start(dut):
    """Start ``dut.clk``, pulse the synchronous reset ``dut.rst`` for two
    cycles, return at the falling edge after it (inputs left as they are)."""
    cocotb.start_soon(Clock(dut.clk, PERIOD_NS, unit="ns").start())
    dut.rst.value = 1
    await ClockCycles(dut.clk, 2)
    await FallingEdge(dut.clk)
    dut.rst.value = 0
