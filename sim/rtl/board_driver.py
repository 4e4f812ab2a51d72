"""The host's end of a board top's UART in cocotb: the line, and the runner
that performs :mod:`navcores.hdl.board.protocol`'s I/O operations on it.

The same protocol client and the same per-core jobs
(:mod:`.board_jobs`) run here and on a real serial port
(``--engine serial:PORT``): only the transport differs.

    line = UartLine(dut, divisor)            # drives dut.rx, listens on dut.tx
    await start(dut)                         # clock and reset (.clock)
    info = await perform(link.read_info(), line)

:class:`UartLine` drives and samples on clock edges only (a bit is ``divisor``
rising edges of ``dut.clk``), so Icarus and Verilator run it alike; only
:meth:`UartLine.read`'s time limit is a Timer.
"""

from collections import deque

import cocotb
from cocotb.triggers import ClockCycles, Event, FallingEdge, First, RisingEdge, Timer

from navcores.hdl.board.protocol import Receive, Send

from .clock import PERIOD_NS, start

__all__ = ["UartLine", "perform", "start"]


class UartLine:
    """8N1 at ``divisor`` clocks a bit: :meth:`write` drives ``dut.rx``; a
    background task samples ``dut.tx`` in the middle of each bit into a
    buffer that :meth:`read` drains.  ``timeout_bits``: how long
    :meth:`read` waits for a first byte.  ``framing_errors`` counts stop
    bits the board sent low (never, if it works)."""

    def __init__(self, dut, divisor, timeout_bits=20_000):
        self.dut, self.div, self.timeout_bits = dut, divisor, timeout_bits
        self.buffer = deque()
        self.arrived = Event()
        self.framing_errors = 0
        dut.rx.value = 1
        self._task = cocotb.start_soon(self._listen())

    async def write(self, data, stop_bits=1, bad_stop=False):
        """Send ``data`` on ``dut.rx``, bytes back to back (``stop_bits``
        idle bits after each; ``bad_stop``: the stop bits low, a framing
        error)."""
        clk = self.dut.clk
        for b in bytes(data):
            for bit in (0, *((b >> i) & 1 for i in range(8)), *([int(not bad_stop)] * stop_bits)):
                self.dut.rx.value = bit
                await ClockCycles(clk, self.div)
        self.dut.rx.value = 1

    async def idle(self, bits):
        """The line idle (high) for ``bits`` bit times."""
        self.dut.rx.value = 1
        await ClockCycles(self.dut.clk, bits * self.div)

    async def _listen(self):
        clk, tx = self.dut.clk, self.dut.tx
        while True:
            await FallingEdge(tx)
            await ClockCycles(clk, self.div // 2)
            if int(tx.value):
                continue                            # not a start bit
            byte = 0
            for i in range(8):
                await ClockCycles(clk, self.div)
                byte |= int(tx.value) << i
            await ClockCycles(clk, self.div)
            if not int(tx.value):
                self.framing_errors += 1
                continue
            self.buffer.append(byte)
            self.arrived.set()

    async def read(self, timeout_bits=None):
        """The bytes received so far; waits up to ``timeout_bits`` bit
        times for a first one (b"" when none came)."""
        if not self.buffer:
            self.arrived.clear()
            # A Timer, not ClockCycles: counting edges would wake Python on
            # every clock while the core works; the edge after restores the
            # alignment.
            limit = Timer((timeout_bits or self.timeout_bits) * self.div * PERIOD_NS, unit="ns")
            await First(self.arrived.wait(), limit)
            await RisingEdge(self.dut.clk)
        data = bytes(self.buffer)
        self.buffer.clear()
        return data

    def stop(self):
        self._task.cancel()


async def perform(job, line):
    """Run ``job`` (a coroutine awaiting :class:`protocol.Send` /
    :class:`protocol.Receive`, e.g. a :class:`protocol.Link` method or a
    :mod:`.board_jobs` job) on the simulated line; returns its result.
    The counterpart of :func:`protocol.run_blocking`."""
    value = None
    while True:
        try:
            op = job.send(value)
        except StopIteration as done:
            return done.value
        if isinstance(op, Send):
            await line.write(op.data)
            value = None
        elif isinstance(op, Receive):
            value = await line.read()
        else:
            raise TypeError(f"a job awaited {op!r}: only Send and Receive are performed")
