"""Drive a DFLC stream top (hdl/dflc/top.py) from cocotb.

Shared by the regression (tb/dflc/test_dflc_stream.py), ``python -m sim dflc
--engine icarus|verilator`` (sim/dflc_job.py) and the path tracker, which runs
its closed loop inside the simulator::

    from dflc_bench import DflcStream
    bench = DflcStream(dut, config)           # config: models.dflc.DflcConfig
    await bench.start()                       # clock + reset
    y, zero = await bench.infer([c1, c2])     # one sample through the top
    outs = await bench.run(code_rows)         # many, pipelined, in order

The top for a .fll is emitted with ``hdl.emit.emit("dflc_stream", {"fll":
STEM_OR_PATH, ...}, out_dir)``; ``hdl.dflc.top.config_for(**params)`` gives
the matching config.

Pieces (cocotb-bus): :class:`StreamSource` (a BusDriver that presents one
sample per transaction and holds it until the handshake, with optional random
idle cycles), :class:`StreamMonitor` (a BusMonitor recording every output
handshake with its cycle), :class:`ReadyToggler` (random back-pressure on
``o_stream.ready``) and :class:`InputMonitor` (the input handshakes with their
cycles, for the cycle properties).
"""

import random

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge
from cocotb.utils import get_sim_time
from cocotb_bus.drivers import BusDriver
from cocotb_bus.monitors import BusMonitor

PERIOD_NS = 10
SIGNALS = ["valid", "ready", "payload"]


def pack(codes, ip_sz):
    """Input codes -> the i_stream payload (input j at bits j*ip_sz)."""
    return sum(int(c) << (j * ip_sz) for j, c in enumerate(codes))


class Cycles:
    """A free-running cycle counter (rising edges since start)."""

    def __init__(self, clk):
        self.clk, self.now = clk, 0
        cocotb.start_soon(self._count())

    async def _count(self):
        while True:
            await RisingEdge(self.clk)
            self.now += 1


class StreamSource(BusDriver):
    """Valid/ready source: each transaction (a payload integer) is held until
    accepted.  ``idle``: probability of an idle (valid low) cycle before each
    sample, drawn from ``rng``."""

    _signals = SIGNALS

    def __init__(self, dut, name, clock, rng=None, idle=0.0):
        super().__init__(dut, name, clock, bus_separator="__")
        self.rng, self.idle = rng or random.Random(0), idle
        self.bus.valid.value = 0
        self.bus.payload.value = 0
        self._edge_time = None
        self._abort = False

    async def _edge(self):
        await RisingEdge(self.clock)
        self._edge_time = get_sim_time()

    async def _driver_send(self, transaction, sync=True):
        if self._edge_time != get_sim_time():      # not right after an edge: align
            await self._edge()
        while self.idle and self.rng.random() < self.idle:
            self.bus.valid.value = 0
            await self._edge()
        self.bus.payload.value = transaction
        self.bus.valid.value = 1
        while True:
            await ReadOnly()
            done = int(self.bus.ready.value) == 1
            await self._edge()
            if done or self._abort:
                break
        self.bus.valid.value = 0

    def abort(self):
        """Drop the queue and the sample being presented (for a reset)."""
        self.clear()
        self._abort = True
        self.bus.valid.value = 0


class StreamMonitor(BusMonitor):
    """Records (cycle, payload) of every handshake on a valid/ready stream."""

    _signals = SIGNALS

    def __init__(self, dut, name, clock, cycles, reset=None, callback=None):
        self.cycles = cycles
        super().__init__(dut, name, clock, reset=reset, callback=callback, bus_separator="__")

    async def _monitor_recv(self):
        while True:
            await RisingEdge(self.clock)
            await ReadOnly()
            if self.in_reset:
                continue
            if int(self.bus.valid.value) and int(self.bus.ready.value):
                self._recv((self.cycles.now, int(self.bus.payload.value)))


InputMonitor = StreamMonitor


class ReadyToggler:
    """Drives ``<name>__ready``: high with probability ``p`` each cycle."""

    def __init__(self, signal, clock, rng=None, p=1.0):
        self.signal, self.clock, self.rng, self.p = signal, clock, rng or random.Random(0), p
        self.signal.value = 1
        self._task = cocotb.start_soon(self._run())

    async def _run(self):
        while True:
            await RisingEdge(self.clock)
            self.signal.value = int(self.p >= 1.0 or self.rng.random() < self.p)

    def set(self, p):
        self.p = p


class DflcStream:
    """A DFLC stream top under cocotb: start, reset, one sample or many."""

    def __init__(self, dut, config, rng=None, idle=0.0, ready_p=1.0):
        self.dut, self.config = dut, config
        self.rng = rng or random.Random(0)
        self.mask = (1 << config.op_sz) - 1
        self.cycles = Cycles(dut.clk)
        self.outputs = []                       # (cycle, y, zero)
        self.source = StreamSource(dut, "i_stream", dut.clk, rng=self.rng, idle=idle)
        self.in_mon = InputMonitor(dut, "i_stream", dut.clk, self.cycles, reset=dut.rst)
        self.out_mon = StreamMonitor(dut, "o_stream", dut.clk, self.cycles, reset=dut.rst,
                                     callback=self._got)
        self.sink = ReadyToggler(dut.o_stream__ready, dut.clk, rng=self.rng, p=ready_p)

    def _got(self, tr):
        cycle, payload = tr
        self.outputs.append((cycle, payload & self.mask, bool(payload >> self.config.op_sz)))

    def unpack(self, payload):
        return payload & self.mask, bool(payload >> self.config.op_sz)

    async def start(self):
        cocotb.start_soon(Clock(self.dut.clk, PERIOD_NS, unit="ns").start())
        await self.reset()

    async def reset(self, cycles=2):
        """Synchronous reset; drops whatever the source was presenting."""
        self.source.abort()
        self.dut.rst.value = 1
        await ClockCycles(self.dut.clk, cycles)
        self.dut.rst.value = 0
        await RisingEdge(self.dut.clk)
        self.source._abort = False
        self.outputs.clear()
        self.in_mon._recvQ.clear()

    async def infer(self, codes_row):
        """One sample through the top: (y code, zero flag)."""
        before = len(self.outputs)
        self.source.append(pack(codes_row, self.config.ip_sz))
        await self._wait_outputs(before + 1, 1)
        _, y, zero = self.outputs[before]
        return y, zero

    async def run(self, samples, timeout_cycles=None):
        """Many samples, pipelined; returns [(y, zero)] in order."""
        samples = [list(r) for r in samples]
        before = len(self.outputs)
        for row in samples:
            self.source.append(pack(row, self.config.ip_sz))
        await self._wait_outputs(before + len(samples), len(samples), timeout_cycles)
        return [(y, z) for _, y, z in self.outputs[before:before + len(samples)]]

    async def _wait_outputs(self, count, n_new, timeout_cycles=None):
        p = 1 << self.config.n
        limit = timeout_cycles or (n_new * (p + 2) * 20 + 200)
        start = self.cycles.now
        while len(self.outputs) < count:
            await RisingEdge(self.dut.clk)
            if self.cycles.now - start > limit:
                raise TimeoutError(f"DFLC stream: {len(self.outputs)} of {count} outputs after "
                                   f"{limit} cycles")
