"""SkidBuffer (hdl/skid_buffer.py): every beat out once, in order, a beat a cycle, and no path through it.

A source with random idle cycles and a sink with random back-pressure, in
phases from none to heavy; the sink's beats must be the source's, in order.
With neither idle nor back-pressure the beats must come one a cycle (full
throughput). The structure: in every cycle ``o.valid`` and ``o.payload``
are what they were after the last edge (registers: no change while only
``o.ready`` and ``i`` move within a cycle), and ``i.ready`` is its register
too; checked by moving ``o.ready`` and ``i.valid`` between edges.
"""

import random

import cocotb
import pytest
from cocotb.triggers import ReadOnly, RisingEdge, Timer

from navcores.hdl.skid_buffer import SkidBuffer
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.runner import SIMULATORS, run, seed_from_env
from navcores.sim.rtl.stream import Streams, pauses

WIDTH = 12
PHASES = ((0.0, 0.0), (0.3, 0.0), (0.0, 0.5), (0.4, 0.4), (0.1, 0.8))      # (idle, back-pressure)
BEATS = 300


@cocotb.test()
async def order_and_throughput(dut):
    seed = seed_from_env()
    rng = random.Random(seed)
    dut._log.info(f"seed {seed} (replay with SEED={seed})")
    await start(dut)
    streams = Streams(dut)
    src, snk = streams.source("i"), streams.sink("o")
    sent, stalls = [], 0
    for idle, busy in PHASES:
        src.pause, snk.pause = pauses(rng, idle), pauses(rng, busy)
        snk.set_pause(snk.pause)
        values = [rng.getrandbits(WIDTH) for _ in range(BEATS)]
        sent += values
        start_cycle = streams.cycle
        src.extend(values)
        got = await snk.take(BEATS, timeout_cycles=100 * BEATS)
        assert got == values, f"phase idle {idle} back-pressure {busy}: beats lost, doubled or reordered"
        took = streams.cycle - start_cycle
        if idle == busy == 0:
            assert took <= BEATS + 3, f"{took} cycles for {BEATS} beats: not a beat a cycle"
        stalls += snk.paused
    assert stalls > BEATS, f"back-pressure too rare to fill the skid: {stalls} cycles"
    streams.stop()

    # registers only: within a cycle, o's valid / payload and i's ready do not follow o.ready or i.valid
    dut.i__payload.value = 5
    for _ in range(200):
        await RisingEdge(dut.clk)
        await ReadOnly()
        before = (int(dut.o__valid.value), int(dut.o__payload.value), int(dut.i__ready.value))
        await Timer(1, unit="ns")
        dut.o__ready.value, dut.i__valid.value = rng.getrandbits(1), rng.getrandbits(1)
        dut.i__payload.value = rng.getrandbits(WIDTH)
        await ReadOnly()
        after = (int(dut.o__valid.value), int(dut.o__payload.value), int(dut.i__ready.value))
        assert after == before, f"a combinational path through the buffer: {before} -> {after}"


@pytest.mark.parametrize("sim", SIMULATORS)
def test_skid_buffer(sim):
    run("skid_buffer", {"width": WIDTH}, sim, "tb.test_skid_buffer", factory=lambda width: SkidBuffer(width))
