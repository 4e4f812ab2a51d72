"""Counters unit against models.harmonic.counters / strobes, cycle by cycle.

Random precisions (restarted in mid-iteration), shift visits' padding, random
stalls of ``advance``: every cycle the three addresses must be those of the
model's read slot x (x advances with ``advance``, from 0 after ``start``) and,
from the first iteration's cycle 0 on (x = 2), the node strobes those of cycle
u = x - 2: an iteration is exactly L = iteration_cycles(p) advancing cycles
(p+2 from p = 4 on).
"""

import random

import cocotb
import pytest

from navcores.models.harmonic import counters, iteration_cycles, strobes
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.runner import SIMULATORS, run
from tb.harmonic.serial import next_cycle

P_MAX = 40
DEPTH = 200
STROBES = ("mask", "z", "ph1", "fl", "ph2", "wcyc")             # and mask_next, one cycle ahead


@cocotb.test()
async def counters_follow_model(dut):
    rng = random.Random(cocotb.RANDOM_SEED)
    await start(dut)
    dut.advance.value = 0
    runs = [(2, False), (3, False), (4, False), (P_MAX, False), (2, True), (5, True),
            *((p, rng.random() < 0.3) for p in rng.sample(range(3, P_MAX), 6))]
    for p, shift in runs:
        dut.p.value = p
        dut.shift.value = int(shift)
        base = rng.randrange(DEPTH - p - 1)
        dut.base.value = base
        dut.start.value = 1
        await next_cycle(dut)
        dut.start.value = 0
        dut.base.value = rng.randrange(DEPTH)            # read at start only
        L = iteration_cycles(p, shift)
        n = 0                                        # advancing cycles since start: slot x = n mod L
        for _ in range(rng.randint(2, 5) * L):
            x = n % L
            want = counters(x, p, shift)
            got = (int(dut.cntR.value), int(dut.r_cnt.value), int(dut.cntW.value))
            assert got == want, f"p={p} shift={shift} slot {x}: (cntR, r_cnt, cntW) = {got}, model {want}"
            absolute = (int(dut.addrR.value), int(dut.addrW.value))
            assert absolute == (base + want[0], base + want[2]), f"p={p} slot {x}: (addrR, addrW) = {absolute}"
            if n >= 1:
                want_next = strobes((x - 1) % L, p, shift)["mask"]
                assert bool(dut.mask_next.value) == want_next, f"p={p} shift={shift} slot {x}: mask_next"
            if n >= 2:
                s = strobes((x - 2) % L, p, shift)
                got_s = {k: bool(getattr(dut, k).value) for k in STROBES}
                assert got_s == {k: s[k] for k in STROBES}, f"p={p} shift={shift} u={(x - 2) % L}: {got_s}, model {s}"
            advanced = rng.random() < 0.8
            dut.advance.value = int(advanced)
            await next_cycle(dut)
            n += advanced
        dut.advance.value = 0


@pytest.mark.parametrize("sim", SIMULATORS)
def test_counters(sim):
    run("harmonic_counters", {"p_max": P_MAX, "depth": DEPTH}, sim, "test_counters")
