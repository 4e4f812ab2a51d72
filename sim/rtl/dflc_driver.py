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

The streams are :mod:`.stream`'s: a source on ``i_stream`` (samples packed
by ``hdl.dflc.core.sample_layout``) and a sink on ``o_stream`` (results
unpacked by ``result_layout``).  Without stalls they run at full rate, the
output always ready (the sweeps and the closed loop); with ``rng`` and
``idle`` / ``back_pressure`` probabilities the source waits random idle
cycles before a sample and the sink drops ready at random.
"""

from cocotb.clock import Clock

from navcores.hdl.dflc.core import result_layout, sample_layout

from .clock import PERIOD_NS
from .stream import Streams, pauses

__all__ = ["DflcDriver"]


class DflcDriver:
    """A DFLC stream top under cocotb: start, reset, one sample or many.

    ``prefix`` selects an instance of a multi-configuration test top
    (``tb/dflc/multi.py``: ports ``<key>_i_stream__valid`` ...); "" for a
    plain ``dflc_stream_*`` top.  ``source`` / ``sink`` are the
    :class:`.stream.StreamSource` / :class:`.stream.StreamSink` (their
    ``beats``: every handshake with its cycle; ``idle``, ``stalls``: the
    stalls that happened).  After ``run``, ``in_cycles`` / ``out_cycles``
    hold the cycle of every input / output handshake of that run.
    """

    def __init__(self, dut, config=None, prefix="", rng=None, idle=0.0, back_pressure=0.0):
        if config is None:                      # the default controller (Table 1, Table 2 widths)
            from navcores.hdl.dflc.top import config_for
            config = config_for()
        self.dut, self.config = dut, config
        self.streams = Streams(dut, prefix=prefix)
        self.source = self.streams.source("i_stream", sample_layout(config), pause=pauses(rng, idle))
        self.sink = self.streams.sink("o_stream", result_layout(config), pause=pauses(rng, back_pressure))
        self.in_cycles, self.out_cycles = [], []

    def result(self, value):
        """An ``o_stream`` value as (y code, zero flag)."""
        return value["y"], bool(value["zero"])

    async def start(self, clock=True):
        """Start the clock (unless ``clock`` is False: already running) and reset."""
        if clock:
            Clock(self.dut.clk, PERIOD_NS, unit="ns").start()
        await self.reset()

    async def reset(self, cycles=2):
        """Synchronous reset for ``cycles`` clocks (:meth:`.stream.Streams.apply_reset`):
        drops whatever the source holds; records and counts start afresh."""
        await self.streams.apply_reset(cycles)

    def stop(self):
        """End this driver's coroutine (before another driver takes the same DUT)."""
        self.streams.stop()

    async def infer(self, codes_row):
        """One sample through the top: (y code, zero flag)."""
        return (await self.run([codes_row]))[0]

    async def run(self, samples, timeout_cycles=None):
        """Send the samples (rows of n input codes), return their outputs in
        order: [(y, zero)].  ``timeout_cycles``: TimeoutError after that many
        (default: 2^n + 2 per sample and 200, times 20 with stalls)."""
        n = len(samples)
        if timeout_cycles is None:
            stalled = self.source.pause is not None or self.sink.pause is not None
            timeout_cycles = (n * ((1 << self.config.n) + 2) + 200) * (20 if stalled else 1)
        first_in, first_out = len(self.source.beats), len(self.sink.beats)
        self.source.extend([[int(c) for c in row] for row in samples])
        out = await self.sink.take(n, timeout_cycles)
        self.in_cycles = [c for c, _ in self.source.beats[first_in:first_in + n]]
        self.out_cycles = [c for c, _ in self.sink.beats[first_out:first_out + n]]
        return [self.result(v) for v in out]
