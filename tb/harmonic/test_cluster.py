"""3x6 cluster against models.harmonic, bit-exact, every iteration.

A 3x6 region with a fixed boundary ring (border words emulated one bit per
address and read at the cluster's own cntR / r_cnt addresses) is loaded
through the host port and iterated until the model says it is stable, with
goals and obstacles set through Sel/Sat in mid-run and check iterations along
the way.  Every iteration the bench rebuilds all 18 stored words from the
``h`` bus and compares them with the model; every ``done`` it compares the
stable flags, every check iteration the local-maximum flags.  Iterations must
come exactly p+2 cycles apart.  At the end the RAM is read back through the
host port and compared with the model's image.
"""

import os
import random

import cocotb
import numpy as np
import pytest
from cocotb.triggers import ClockCycles

from hdl.harmonic.cluster import COLS, ROWS
from models.harmonic import from_ram_image, neighbours, one, ram_image, step
from tb.harmonic.serial import SerialWord, next_cycle, start
from tb.runner import SIMULATORS, run

PARAMS = {"depth": 64, "p_max": 62}
PRECISIONS = [int(x) for x in os.environ.get("CLUSTER_P", "2,8,13,32,62").split(",")]
MAX_ITER = 2000


def _bits(words, offset):
    """Integer whose bit i is bit ``offset`` of ``words[i]``."""
    return sum(w.bits[offset] << i for i, w in enumerate(words))


async def _host_write(dut, words):
    for addr, word in enumerate(words):
        dut.host_addr.value = addr
        dut.host_wdata.value = word
        dut.host_we.value = 1
        await next_cycle(dut)
    dut.host_we.value = 0


async def _host_read(dut, count):
    words = []
    for addr in range(count):
        dut.host_addr.value = addr
        await next_cycle(dut)       # read data one cycle after the address
        words.append(int(dut.host_rdata.value))
    return words


def _initial(rng, p):
    """Random free values, one goal and one obstacle; a random boundary ring."""
    h = np.array([rng.randint(0, one(p)) for _ in range(ROWS * COLS)], dtype=object).reshape(ROWS, COLS)
    const = np.zeros((ROWS, COLS), dtype=bool)
    cells = rng.sample(range(ROWS * COLS), 2)
    for cell, value in zip(cells, (one(p), 0)):
        h.flat[cell] = value
        const.flat[cell] = True
    ring = np.zeros((ROWS + 2, COLS + 2), dtype=object)
    choices = lambda: rng.choice([0, 0, one(p), rng.randint(0, one(p))])  # noqa: E731
    for r, c in [(0, c) for c in range(1, COLS + 1)] + [(ROWS + 1, c) for c in range(1, COLS + 1)] \
            + [(r, 0) for r in range(1, ROWS + 1)] + [(r, COLS + 1) for r in range(1, ROWS + 1)]:
        ring[r, c] = choices()
    return h, const, ring


@cocotb.test()
@cocotb.parametrize(p=PRECISIONS)
async def cluster_until_stable(dut, p):
    rng = random.Random(cocotb.RANDOM_SEED * 7919 + p)
    dut._log.info(f"p={p} seed={cocotb.RANDOM_SEED}")
    await start(dut)
    for port in ("run", "enable", "Sel", "Sat", "host_we", "p"):
        getattr(dut, port).value = 0

    h, const, ring = _initial(rng, p)
    border = {
        "N": [SerialWord(ring[0, c + 1], True, p) for c in range(COLS)],
        "S": [SerialWord(ring[ROWS + 1, c + 1], True, p) for c in range(COLS)],
        "W": [SerialWord(ring[r + 1, 0], True, p) for r in range(ROWS)],
        "E": [SerialWord(ring[r + 1, COLS + 1], True, p) for r in range(ROWS)],
    }
    await _host_write(dut, ram_image(h, const, p))
    assert await _host_read(dut, p + 2) == ram_image(h, const, p), "host port readback before the run"

    free = [i for i in range(ROWS * COLS) if not const.flat[i]]
    plan_sel = {3: (rng.choice(free), 1), 6: (rng.choice(free), 0)}
    plan_check = {2, 5}

    states = [(h, const)]      # model words before each iteration
    expected = []              # model (stable, maximum) of each iteration
    commands = []              # (run, enable) of each iteration
    settled = None             # iteration after which only the check and the stop remain
    image = [0] * (p + 2)
    snapshots = dones = 0
    done_cycles = []
    prev_addr = prev_raddr = None
    dut.p.value = p
    dut.run.value = 1
    t0 = None
    for cycle in range(MAX_ITER * (p + 2)):
        # Border words: data of the addresses the cluster presented last cycle.
        for side, words in border.items():
            getattr(dut, f"h_{side}_in").value = _bits(words, prev_addr) if prev_addr is not None else 0
            getattr(dut, f"m_{side}_in").value = _bits(words, prev_raddr) if prev_raddr is not None else 0
        busy = bool(dut.busy.value)
        if t0 is None and busy:
            t0 = cycle - 1          # the cycle run was seen while idle
        if bool(dut.take.value):
            k = len(commands)
            if settled is not None and k > settled + 1:
                cmd = (0, 0)                         # stop
            elif settled is not None or k in plan_check:
                cmd = (1, 0)                         # check iteration
            else:
                cmd = (1, 1)
            sel = np.zeros(ROWS * COLS, dtype=bool)
            sat = 0
            if cmd == (1, 1) and k in plan_sel:
                sel[plan_sel[k][0]] = True
                sat = plan_sel[k][1]
            dut.run.value, dut.enable.value = cmd
            dut.Sel.value = int(sum(int(b) << i for i, b in enumerate(sel)))
            dut.Sat.value = sat
            commands.append(cmd)
            if cmd[0]:
                hk, ck = states[k]
                hn, cn, st, mx = step(hk, ck, p, neighbours(hk, ring), enable=bool(cmd[1]),
                                      sel=sel.reshape(ROWS, COLS), sat=sat)
                states.append((hn, cn))
                expected.append((st, mx))
                if settled is None and cmd[1] and st.all() and k > max(plan_sel):
                    settled = k
        if bool(dut.done.value):
            k = dones
            st, mx = expected[k]
            got_st = int(dut.stable.value)
            want_st = sum(int(b) << i for i, b in enumerate(st.ravel()))
            assert got_st == want_st, f"p={p} iteration {k}: stable {got_st:018b}, model {want_st:018b}"
            assert bool(dut.all_stable.value) == bool(st.all())
            assert bool(dut.checked.value) == (commands[k][1] == 0)
            if commands[k][1] == 0:
                got_mx = int(dut.local_max.value)
                want_mx = sum(int(b) << i for i, b in enumerate(mx.ravel()))
                assert got_mx == want_mx, f"p={p} iteration {k}: local_max {got_mx:018b}, model {want_mx:018b}"
                assert bool(dut.any_max.value) == bool(mx.any())
            # Iteration k's flags come at cycle 2 of iteration k+1: exactly
            # the lead-in and cycles 0 and 1 come first.
            assert cycle - t0 == (k + 1) * (p + 2) + 4, f"iteration {k} done at cycle {cycle - t0}"
            done_cycles.append(cycle)
            dones += 1
            if commands[k + 1][0] == 0:
                break
        # The h bus carries the words read at the address presented last cycle;
        # offset 1 (bit p) is the last one of an iteration's read.
        if prev_addr is not None:
            image[prev_addr] = int(dut.h.value)
            if prev_addr == 1:
                got = from_ram_image(image, p, (ROWS, COLS))
                want = states[snapshots]
                assert all((got[0] == want[0]).ravel()) and (got[1] == want[1]).all(), (
                    f"p={p} words before iteration {snapshots}:\n{got[0]}\n{got[1]}\nmodel\n{want[0]}\n{want[1]}")
                snapshots += 1
        prev_addr = int(dut.cntR.value) if busy else None
        prev_raddr = int(dut.r_cnt.value) if busy else None
        await next_cycle(dut)
    else:
        raise AssertionError(f"p={p}: no stop after {MAX_ITER} iterations")

    assert np.diff(done_cycles).tolist() == [p + 2] * (len(done_cycles) - 1)
    assert settled is not None and snapshots == len(states) - 1
    await ClockCycles(dut.clk, 2)
    await next_cycle(dut)
    assert not bool(dut.busy.value)
    h_end, c_end = states[-1]
    assert await _host_read(dut, p + 2) == ram_image(h_end, c_end, p), "RAM readback after the run"
    dut._log.info(f"p={p}: stable after {settled + 1} iterations, {len(commands) - 1} run, "
                  f"{snapshots} words compared, readback equal")


@cocotb.test()
async def cluster_refuses_bad_precision(dut):
    """p < 2 or p > p_max: no start, p_err raised; a good p starts and clears it."""
    await start(dut)
    for port in ("enable", "Sel", "Sat", "host_we"):
        getattr(dut, port).value = 0
    for p, ok in ((1, False), (0, False), (PARAMS["p_max"] + 1, False), (PARAMS["p_max"], True), (2, True)):
        dut.p.value = p
        dut.run.value = 1
        await ClockCycles(dut.clk, 3)
        await next_cycle(dut)
        assert bool(dut.busy.value) == ok and bool(dut.p_err.value) == (not ok), f"p={p}"
        dut.run.value = 0
        while bool(dut.busy.value):
            await next_cycle(dut)


@pytest.mark.parametrize("sim", SIMULATORS)
def test_cluster(sim):
    run("harmonic_cluster", PARAMS, sim, "test_cluster")
