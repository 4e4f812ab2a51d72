"""Drive a DFLC stream top (hdl/dflc/top.py) from cocotb.

Shared by the regression (tb/dflc/test_dflc_stream.py), ``python -m sim dflc
--engine icarus|verilator`` (sim/rtl/dflc_job.py) and the path tracker, which
runs its closed loop inside the simulator (sim/rtl/track_job.py)::

    from navcores.sim.rtl.dflc_driver import DflcDriver
    drv = DflcDriver(dut, config)             # config: models.dflc.DflcConfig (None: Table 1)
    await drv.start()                         # clock + synchronous reset
    y, zero = await drv.infer([c1, c2])       # one sample through the top
    outs = await drv.run(code_rows)           # many, pipelined, in order

The top for a .fll is emitted with ``navcores.hdl.emit.emit("dflc_stream",
{"fll": STEM_OR_PATH, ...}, out_dir)``; ``navcores.hdl.dflc.top.config_for(**params)``
gives the matching config.

:class:`DflcStallDriver` holds the cocotb-bus pieces: :class:`StreamSource` (a
BusDriver that presents one sample per transaction and holds it until the
handshake, with optional random idle cycles), :class:`StreamMonitor` (a
BusMonitor recording every output handshake with its cycle),
:class:`ReadyToggler` (random back-pressure on ``o_stream.ready``) and
:class:`InputMonitor` (the input handshakes with their cycles, for the cycle
properties).
"""

import random

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge
from cocotb.utils import get_sim_time
from cocotb_bus.drivers import BusDriver
from cocotb_bus.monitors import BusMonitor

from .clock import PERIOD_NS

SIGNALS = ["valid", "ready", "payload"]


def pack(codes, ip_sz):
    """Input codes -> the i_stream payload (input j at bits j*ip_sz)."""
    return sum(int(c) << (j * ip_sz) for j, c in enumerate(codes))


class Cycles:
    """A free-running cycle counter (rising edges since start)."""

    def __init__(self, clk):
        self.clk, self.now = clk, 0
        self._task = cocotb.start_soon(self._count())

    def kill(self):
        self._task.cancel()

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
            if self.p < 1.0:
                self.signal.value = int(self.rng.random() < self.p)

    def set(self, p):
        self.p = p
        if p >= 1.0:
            self.signal.value = 1

    def kill(self):
        self._task.cancel()


class DflcDriver:
    """A DFLC stream top under cocotb: start, reset, one sample or many.

    ``infer`` / ``run`` drive the streams from one coroutine (two triggers per
    cycle: cheap enough for long sweeps and closed loops) with the output
    always ready; :class:`DflcStallDriver` adds the cocotb-bus driver, monitors
    and random stalls.  ``prefix`` selects an instance of a multi-configuration
    test top (``tb/dflc/multi.py``: ports ``<key>_i_stream__valid`` ...); ""
    for a plain ``dflc_stream_*`` top.  After ``run``, ``in_cycles`` /
    ``out_cycles`` hold the cycle of every input / output handshake.
    """

    def __init__(self, dut, config=None, prefix=""):
        if config is None:                      # the default controller (Table 1, Table 2 widths)
            from navcores.hdl.dflc.top import config_for
            config = config_for()
        self.dut, self.config = dut, config
        self.mask = (1 << config.op_sz) - 1
        self.i_name, self.o_name = f"{prefix}i_stream", f"{prefix}o_stream"
        self.i_valid = getattr(dut, f"{self.i_name}__valid")
        self.i_ready = getattr(dut, f"{self.i_name}__ready")
        self.i_payload = getattr(dut, f"{self.i_name}__payload")
        self.o_valid = getattr(dut, f"{self.o_name}__valid")
        self.o_ready = getattr(dut, f"{self.o_name}__ready")
        self.o_payload = getattr(dut, f"{self.o_name}__payload")
        self.i_valid.value = 0
        self.o_ready.value = 1
        self.in_cycles, self.out_cycles = [], []

    def unpack(self, payload):
        return payload & self.mask, bool(payload >> self.config.op_sz)

    async def start(self, clock=True):
        """Start the clock (unless ``clock`` is False: already running) and reset."""
        if clock:
            cocotb.start_soon(Clock(self.dut.clk, PERIOD_NS, unit="ns").start())
        await self.reset()

    async def reset(self, cycles=2):
        """Synchronous reset for ``cycles`` clocks; inputs idle, output ready."""
        self.i_valid.value = 0
        self.o_ready.value = 1
        self.dut.rst.value = 1
        await ClockCycles(self.dut.clk, cycles)
        self.dut.rst.value = 0
        await RisingEdge(self.dut.clk)

    async def infer(self, codes_row):
        """One sample through the top: (y code, zero flag)."""
        return (await self.run([codes_row]))[0]

    async def run(self, samples, timeout_cycles=None):
        """Many samples at full rate, output always ready; [(y, zero)] in order."""
        rows = [pack(r, self.config.ip_sz) for r in samples]
        n = len(rows)
        limit = timeout_cycles or (n * ((1 << self.config.n) + 2) + 200)
        out, self.in_cycles, self.out_cycles = [], [], []
        sent, cycle = 0, 0
        self.o_ready.value = 1
        while len(out) < n:
            if sent < n:
                self.i_payload.value = rows[sent]
                self.i_valid.value = 1
            else:
                self.i_valid.value = 0
            await ReadOnly()
            if sent < n and int(self.i_ready.value):
                self.in_cycles.append(cycle)
                sent += 1
            if int(self.o_valid.value):
                out.append(self.unpack(int(self.o_payload.value)))
                self.out_cycles.append(cycle)
            await RisingEdge(self.dut.clk)
            cycle += 1
            if cycle > limit:
                raise TimeoutError(f"DFLC stream: {len(out)} of {n} outputs after {limit} cycles")
        self.i_valid.value = 0
        return out


class DflcStallDriver:
    """cocotb-bus pieces around a DFLC stream top, for stall and reset tests:
    a :class:`StreamSource` (random idle cycles), a :class:`StreamMonitor` on
    each side and a :class:`ReadyToggler` (random back-pressure).  Outputs are
    collected in ``outputs`` as (cycle, y, zero)."""

    def __init__(self, dut, config, rng=None, idle=0.0, ready_p=1.0, prefix=""):
        self.dut, self.config = dut, config
        self.rng = rng or random.Random(0)
        self.mask = (1 << config.op_sz) - 1
        self.cycles = Cycles(dut.clk)
        self.outputs = []
        self.i_name, self.o_name = f"{prefix}i_stream", f"{prefix}o_stream"
        self.source = StreamSource(dut, self.i_name, dut.clk, rng=self.rng, idle=idle)
        self.in_mon = InputMonitor(dut, self.i_name, dut.clk, self.cycles, reset=dut.rst)
        self.out_mon = StreamMonitor(dut, self.o_name, dut.clk, self.cycles, reset=dut.rst,
                                     callback=self._got)
        self.sink = ReadyToggler(getattr(dut, f"{self.o_name}__ready"), dut.clk, rng=self.rng, p=ready_p)

    def _got(self, tr):
        self.outputs.append((tr[0], *self.unpack(tr[1])))

    def unpack(self, payload):
        return payload & self.mask, bool(payload >> self.config.op_sz)

    def stop(self):
        """End this driver's coroutines (before another driver takes the same DUT)."""
        for part in (self.source, self.in_mon, self.out_mon, self.sink, self.cycles):
            part.kill()
        self.source.bus.valid.value = 0

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

    async def run(self, samples, timeout_cycles=None):
        """Queue the samples on the source; wait for as many outputs; [(y, zero)]."""
        before = len(self.outputs)
        for row in samples:
            self.source.append(pack(row, self.config.ip_sz))
        n = len(samples)
        limit = timeout_cycles or (n * ((1 << self.config.n) + 2) * 20 + 200)
        start = self.cycles.now
        while len(self.outputs) < before + n:
            await RisingEdge(self.dut.clk)
            if self.cycles.now - start > limit:
                raise TimeoutError(f"DFLC stream: {len(self.outputs) - before} of {n} outputs "
                                   f"after {limit} cycles")
        return [(y, z) for _, y, z in self.outputs[before:before + n]]
