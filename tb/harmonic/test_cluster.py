"""3x6 cluster against models.harmonic, bit-exact, every iteration.

A 3x6 region with a fixed boundary ring is loaded through the host port and
iterated from zero until the model says it is stable (or, rarely, caught in
the period-2 oscillation that lowering values by a new obstacle can cause),
with a goal and an obstacle set through Sel/Sat in mid-run and check iterations along the way (one early,
one after stabilization).  Every iteration the drv rebuilds all 18 stored
words from the ``h`` bus and compares them with the model; every ``done`` it
compares the stable and local-maximum flags (the Maximum compares LSB
first, so update iterations have it too).  Iteration k's flags must come
exactly (k+1)L + 5 cycles after the start request (two cycles of lead-in,
then L = iteration_cycles(p) cycles per iteration: p+2 from p = 4 on, 6 for
p = 2, 3).  At the end the RAM is read back through the host port and
compared with the model's image.  ``abort`` at the flags of the first stable
iteration (the Control module's early stop) leaves the RAM as that iteration
wrote it, and the cluster idle in the next cycle.
"""

import os
import random

import cocotb
import numpy as np
import pytest
from cocotb.triggers import ClockCycles

from navcores.hdl.harmonic.cluster import COLS, ROWS
from navcores.hdl.params import unelaborated
from navcores.models.harmonic import iteration_cycles, neighbours, one, ram_image, step
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.runner import SIMULATORS, run
from tb.harmonic.cluster_driver import ClusterDriver, Command
from tb.harmonic.serial import next_cycle

# Parameter sets of the regression: the cocotb side learns its set from the
# environment the pytest side passes.
SETS = {
    "small": ({"depth": 64, "p_max": 62}, "2,3,4,8,13,32,62"),
    "paper": ({"depth": 1024}, "100"),            # the paper's 1Kx18 RAM, p_max 1022
    # a deep RAM: a bank of 18 one-bit lanes and one of 16 words
    # (hdl/block_ram.py, whose own test, tb/test_block_ram.py, reads and
    # writes every bank on both simulators)
    "deep": ({"depth": 16400, "p_max": 62}, "13"),
}
DEPTH = int(os.environ.get("CLUSTER_DEPTH", "64"))
P_MAX = int(os.environ.get("CLUSTER_P_MAX", str(DEPTH - 2)))
PRECISIONS = [int(x) for x in os.environ.get("CLUSTER_P", "8").split(",")]
MAX_ITER = 2000


def _initial(rng, p):
    """Free values 0 (the planner starts from below), one goal and one
    obstacle, a random boundary ring."""
    h = np.zeros((ROWS, COLS), dtype=object)
    const = np.zeros((ROWS, COLS), dtype=bool)
    for cell, value in zip(rng.sample(range(ROWS * COLS), 2), (one(p), 0)):
        h.flat[cell] = value
        const.flat[cell] = True
    ring = np.array([rng.choice([0, 0, one(p), rng.randint(0, one(p))])
                     for _ in range((ROWS + 2) * (COLS + 2))], dtype=object).reshape(ROWS + 2, COLS + 2)
    return h, const, ring


class ModelRun:
    """The model's side of one run, and the plan of commands."""

    def __init__(self, p, h, const, ring, plan_sel=None, plan_check=()):
        """``plan_sel``: {iteration: (cell, Sat)}; ``plan_check``: check iterations."""
        self.p, self.ring = p, ring
        self.plan_sel = plan_sel or {}
        self.plan_check = set(plan_check)
        self.states = [(h, const)]     # words read by each iteration
        self.expected = []             # (stable, maximum) of each iteration
        self.commands = []
        self.settled = None            # iteration after which only a check and the stop remain
        self.outcome = None

    def decide(self, k):
        if self.settled is not None and k > self.settled + 1:
            cmd = Command(run=False, enable=False)
        elif self.settled is not None or k in self.plan_check:
            cmd = Command(enable=False)
        else:
            cmd = Command()
            if k in self.plan_sel:
                cell, cmd.sat = self.plan_sel[k]
                cmd.sel.flat[cell] = True
        self.commands.append(cmd)
        if cmd.run:
            h, const = self.states[k]
            hn, cn, stable, maximum = step(h, const, self.p, neighbours(h, self.ring),
                                           enable=cmd.enable, sel=cmd.sel, sat=cmd.sat)
            self.states.append((hn, cn))
            self.expected.append((stable, maximum))
            if self.settled is None and cmd.enable and k > max(self.plan_sel, default=-1):
                # Stable, or (after the obstacle lowered values) the period-2
                # oscillation a floored Jacobi iteration can fall into (paper
                # section 4.3.1): either way the RTL has matched it bit-exactly.
                if stable.all():
                    self.settled, self.outcome = k, "stable"
                elif k and all((a == b).all() for a, b in zip(self.states[k - 1], self.states[k + 1])):
                    self.settled, self.outcome = k, "period-2 oscillation"
        return cmd

    def check_words(self, k, h, const):
        want_h, want_c = self.states[k]
        assert (h == want_h).all() and (const == want_c).all(), (
            f"p={self.p} words read by iteration {k}:\n{h}\n{const}\nmodel:\n{want_h}\n{want_c}")

    def check_done(self, k, done):
        stable, maximum = self.expected[k]
        p = self.p
        assert (done.stable == stable).all(), f"p={p} iteration {k}: stable\n{done.stable}\nmodel\n{stable}"
        assert done.all_stable == stable.all()
        assert done.checked == (not self.commands[k].enable)
        assert (done.local_max == maximum).all(), f"p={p} iteration {k}: local_max\n{done.local_max}\nmodel\n{maximum}"
        assert done.any_max == maximum.any()
        assert done.cycle == (k + 1) * iteration_cycles(p) + 5, f"iteration {k} done at cycle {done.cycle}"


@cocotb.test()
@cocotb.parametrize(p=PRECISIONS)
async def cluster_until_stable(dut, p):
    rng = random.Random(cocotb.RANDOM_SEED * 7919 + p)
    dut._log.info(f"p={p} seed={cocotb.RANDOM_SEED}")
    await start(dut)
    h, const, ring = _initial(rng, p)
    free = np.flatnonzero(~const)
    model = ModelRun(p, h, const, ring, plan_sel={3: (rng.choice(free), 1), 6: (rng.choice(free), 0)},
                     plan_check={2, 5})
    drv = ClusterDriver(dut, p, ring)
    await drv.host_write(ram_image(h, const, p))
    assert await drv.host_read(p + 2) == ram_image(h, const, p), "host port readback before the run"
    await _run_and_check(dut, drv, model)
    dut._log.info(f"p={p}: {model.outcome} after {model.settled + 1} iterations, "
                  f"{len(model.expected)} run and compared, readback equal")


async def _run_and_check(dut, drv, model):
    """Iterate the cluster with the model's commands, check everything, read back."""
    p = model.p
    words = []

    def on_words(k, h, const):
        model.check_words(k, h, const)
        words.append(k)

    dones = await drv.iterate(model.decide, on_words=on_words, on_done=model.check_done,
                                max_cycles=MAX_ITER * iteration_cycles(p))
    assert model.settled is not None
    assert len(dones) == len(words) == len(model.states) - 1, (len(dones), len(words), len(model.states))
    assert np.diff([d.cycle for d in dones]).tolist() == [iteration_cycles(p)] * (len(dones) - 1)
    await ClockCycles(dut.clk, 2)
    await next_cycle(dut)
    assert not bool(dut.busy.value)
    assert await drv.host_read(p + 2) == ram_image(*model.states[-1], p), "RAM readback after the run"


@cocotb.test()
async def cluster_abort_after_stable(dut):
    """The early stop without a confirmation iteration: ``abort`` with the
    flags of the first stable update iteration (the next one has started):
    the cluster is idle in the next cycle and its RAM holds the stable
    words; the maxima came with the update iterations."""
    p = PRECISIONS[-1]
    rng = random.Random(cocotb.RANDOM_SEED * 31 + p)
    await start(dut)
    h, const, ring = _initial(rng, p)
    drv = ClusterDriver(dut, p, ring)
    model = ModelRun(p, h, const, ring)
    await drv.host_write(ram_image(h, const, p))
    seen_max = set()

    def stop_here(k, done):
        seen_max.add(done.any_max)
        return done.all_stable and not done.checked

    dones = await drv.iterate(model.decide, on_done=model.check_done, abort=stop_here,
                              max_cycles=MAX_ITER * iteration_cycles(p))
    assert model.outcome == "stable" and len(dones) == model.settled + 1
    assert await drv.host_read(p + 2) == ram_image(*model.states[model.settled + 1], p), "RAM after abort"
    assert True in seen_max, "the update iterations must show the starting plateau's maxima"
    dut._log.info(f"p={p}: aborted after stable iteration {model.settled}, RAM equal")


@cocotb.test()
async def cluster_increasing_precision(dut):
    """Stable at p1, then the same words continue at p2 > p1 (section 3.3.2):
    the layout keeps every stored bit in place, the new LSB addresses only
    need zeros, and the words read first at p2 are the p1 values << (p2-p1)."""
    p1, p2 = 6, min(20, P_MAX)
    rng = random.Random(cocotb.RANDOM_SEED)
    await start(dut)
    h, const, ring = _initial(rng, p1)
    drv = ClusterDriver(dut, p1, ring)
    model = ModelRun(p1, h, const, ring, plan_check={0})
    await drv.host_write(ram_image(h, const, p1))
    await _run_and_check(dut, drv, model)
    assert model.outcome == "stable"
    h1, c1 = model.states[-1]
    await drv.host_write([0] * (p2 - p1), base=p1 + 2)
    shift = 1 << (p2 - p1)
    ring2 = ring * shift
    model2 = ModelRun(p2, h1 * shift, c1, ring2)
    await _run_and_check(dut, ClusterDriver(dut, p2, ring2), model2)
    assert model2.outcome == "stable"
    dut._log.info(f"p={p1} stable after {model.settled + 1} iterations, then p={p2} after {model2.settled + 1}")


@cocotb.test()
async def cluster_refuses_bad_precision(dut):
    """p < 2 or p > p_max: no start, p_err raised; a good p starts and clears it."""
    await start(dut)
    for port in ("enable", "Sel", "Sat", "host_we", "clear", "base", "abort"):
        getattr(dut, port).value = 0
    too_big = [(P_MAX + 1, False)] if P_MAX + 1 < 1 << P_MAX.bit_length() else []
    for p, ok in [(1, False), (0, False), *too_big, (P_MAX, True), (2, True)]:
        dut.p.value = p
        dut.run.value = 1
        await ClockCycles(dut.clk, 3)
        await next_cycle(dut)
        assert bool(dut.busy.value) == ok and bool(dut.p_err.value) == (not ok), f"p={p}"
        dut.run.value = 0
        while bool(dut.busy.value):
            await next_cycle(dut)


# The paper set on Verilator only, the deep one on Icarus only: the
# cluster's logic is the same at every depth (the small set runs on both
# simulators), Icarus takes about a minute for the paper set's p = 100
# iterations, and Verilator's build grows with the deep set's 19 memories.
ONE_SIM = {("icarus", "paper"), ("verilator", "deep")}


@pytest.mark.parametrize("sim,name", [(sim, name) for name in SETS for sim in SIMULATORS
                                      if (sim, name) not in ONE_SIM])
def test_cluster(sim, name):
    params, precisions = SETS[name]
    depth = params["depth"]
    run("harmonic_cluster", params, sim, "test_cluster",
        env={"CLUSTER_DEPTH": depth, "CLUSTER_P_MAX": params.get("p_max", depth - 2), "CLUSTER_P": precisions})


@pytest.mark.parametrize("kwargs,message", [
    ({"depth": 1024, "p_max": 1023}, "p_max=1023 needs words of p_max\\+2=1025 bits.*RAM depth is 1024"),
    ({"depth": 64, "p_max": 63}, "p_max=63 needs words of p_max\\+2=65 bits.*RAM depth is 64"),
    ({"depth": 64, "p_max": 1}, r"p_max=1 is not supported: p must be in 2\.\."),
    ({"depth": 2}, r"RAM depth must be an integer in 4\.\.1048576, not 2"),
])
def test_elaboration_refuses(kwargs, message):
    from navcores.hdl.harmonic.cluster import Cluster
    with pytest.raises(ValueError, match=message):
        Cluster(**kwargs)


def test_elaboration_limits_accepted():
    from navcores.hdl.harmonic.cluster import Cluster
    assert unelaborated(Cluster(depth=64, p_max=62)).p_max == 62
    assert unelaborated(Cluster()).p_max == 1022    # the paper's 1Kx18 RAM, one block
