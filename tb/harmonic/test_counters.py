"""Counters unit against models.harmonic.counters, cycle by cycle.

Random precisions (restarted in mid-iteration), random stalls of
``advance``: every cycle the three addresses and the ph0/ph1/ph2 strobes must
be those of the model's iteration cycle, so an iteration is exactly p+2
advancing cycles.
"""

import random

import cocotb
import pytest

from navcores.models.harmonic import counters
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.runner import SIMULATORS, run
from tb.harmonic.serial import next_cycle

P_MAX = 40


@cocotb.test()
async def counters_follow_model(dut):
    rng = random.Random(cocotb.RANDOM_SEED)
    await start(dut)
    dut.advance.value = 0
    for p in [2, P_MAX, *rng.sample(range(3, P_MAX), 6)]:
        dut.p.value = p
        dut.start.value = 1
        await next_cycle(dut)
        dut.start.value = 0
        c = p + 1                                    # lead-in state
        for _ in range(rng.randint(2, 5) * (p + 2)):
            want = counters(c, p)
            got = (int(dut.cntR.value), int(dut.r_cnt.value), int(dut.cntW.value))
            assert got == want, f"p={p} c={c}: (cntR, r_cnt, cntW) = {got}, model {want}"
            strobes = [int(getattr(dut, f"ph{i}").value) for i in range(3)]
            want_strobes = [int(c == i) for i in range(3)]
            assert strobes == want_strobes, f"p={p} c={c}: ph0..2 = {strobes}, want {want_strobes}"
            advanced = rng.random() < 0.8
            dut.advance.value = int(advanced)
            await next_cycle(dut)
            if advanced:
                c = (c + 1) % (p + 2)
        dut.advance.value = 0


@pytest.mark.parametrize("sim", SIMULATORS)
def test_counters(sim):
    run("harmonic_counters", {"p_max": P_MAX}, sim, "test_counters")
