"""LiteDRAM's controller under cocotb: its clock and its start-up over the control bus.

The generated core (scripts/litedram_core.py) starts with its DFII (the
PHY's command interface) under software control, as its BIOS would leave it
before calibrating.  In simulation (``litedram_gen --sim``: the DRAM is
LiteDRAM's model, with nothing to calibrate) start-up is two writes on the
``wb_ctrl`` Wishbone: the DFII to hardware control (``sdram_dfii_control`` =
0x0f: the controller drives the DRAM, CKE and ODT on, reset off), then
``ddrctrl_init_done`` = 1.  Without them every read answers zeros.
"""

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge

from .native_dram import native_ports

__all__ = ["NativeCount", "start_litedram"]

DFII_HARDWARE = 0x0F


async def _wb_write(dut, clk, byte_addr, value, timeout=1000):
    for name, v in (("adr", byte_addr >> 2), ("dat_w", value), ("sel", 0xF), ("we", 1), ("cyc", 1), ("stb", 1)):
        getattr(dut, f"wb_ctrl_{name}").value = v
    for _ in range(timeout):
        await ReadOnly()
        ack = dut.wb_ctrl_ack.value == 1
        await RisingEdge(clk)
        if ack:
            break
    else:
        raise TimeoutError(f"wb_ctrl: no ack for the write at {byte_addr:#x}")
    for name in ("we", "cyc", "stb"):
        getattr(dut, f"wb_ctrl_{name}").value = 0


async def start_litedram(dut, period_ns, csrs):
    """Clock ``dut.sys_clk`` at ``period_ns`` and start the controller
    (``csrs``: scripts/litedram_core.py's byte addresses); returns when
    ``init_done`` is high."""
    for name in ("cyc", "stb", "we", "cti", "bte", "sel", "adr", "dat_w"):
        getattr(dut, f"wb_ctrl_{name}").value = 0
    cocotb.start_soon(Clock(dut.sys_clk, round(period_ns * 1000), unit="ps").start())
    await ClockCycles(dut.sys_clk, 64)          # the core's own reset (its CRG) ends
    await _wb_write(dut, dut.sys_clk, csrs["sdram_dfii_control"], DFII_HARDWARE)
    await _wb_write(dut, dut.sys_clk, csrs["ddrctrl_init_done"], 1)
    await ClockCycles(dut.sys_clk, 16)
    await ReadOnly()
    assert dut.init_done.value == 1, "LiteDRAM: init_done did not rise"
    await RisingEdge(dut.sys_clk)


class NativeCount:
    """The native commands LiteDRAM's controller takes from the top's user ports (``dram__<i>__cmd``:
    valid and ready at a rising edge of ``dram_clk``, its user clock), and its clock's cycles, while
    ``on``: ``reads``, ``writes`` (each a 128-bit word over the DDR3's data bus), ``cycles``.  Started
    with :meth:`start` (a coroutine sampling every cycle: it slows the simulation)."""

    def __init__(self, dut):
        self.dut, self.on = dut, False
        self.reads = self.writes = self.cycles = 0
        self.ports = [tuple(getattr(dut, f"dram__{i}__cmd__{n}") for n in ("valid", "ready", "payload"))
                      for i in range(native_ports(dut))]
        if not self.ports:
            raise ValueError("no dram__<i>__cmd port on the top")

    def start(self):
        cocotb.start_soon(self._count())

    async def _count(self):
        clk = self.dut.dram_clk
        while True:
            await RisingEdge(clk)
            await ReadOnly()                # the values the next rising edge takes
            if not self.on:
                continue
            self.cycles += 1
            for valid, ready, payload in self.ports:
                if valid.value == 1 and ready.value == 1:
                    # the command's payload: Cat(addr, we), we its top bit
                    if payload.value.to_unsigned() >> (len(payload) - 1):
                        self.writes += 1
                    else:
                        self.reads += 1
