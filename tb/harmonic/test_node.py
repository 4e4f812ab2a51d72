"""Node module against models.harmonic, bit-exact, every iteration.

The test plays the node's surroundings as a cluster would: the node's own
word and its four neighbours' words are stored one bit per address and read
through the Counters' address sequences with one cycle of RAM latency; the
node's ``w`` output is written back into its own word at ``cntW``, so an error
compounds into the following iterations.  The neighbours' values are chosen
at random for every iteration (held, random, all goals, equal to the node,
zero; their constant flags at random, which the node must ignore), the node
is saturated through Sel/Sat in mid-run, and about one iteration in seven is
a check iteration.  The MSB-first streams come from the words as they were at
the start of the iteration, as a RAM not being written gives them.  After
every iteration the node's stored word and its stable / local-max flags are
compared with ``models.harmonic.step``.
"""

import os
import random

import cocotb
import numpy as np
import pytest

from navcores.models.harmonic import one, step
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.runner import SIMULATORS, run
from tb.harmonic.serial import SerialWord, cnt_w, next_cycle, read_offsets, settle

DIRS = ("N", "E", "W", "S")
PRECISIONS = [int(x) for x in os.environ.get("NODE_P", "8,16,32,64").split(",")]
EPISODES = int(os.environ.get("NODE_EPISODES", "4"))
WINDOWS = int(os.environ.get("NODE_WINDOWS", "24"))


def _next_neighbours(rng, p, own, prev):
    """Neighbour (value, flag) pairs for the next iteration, and the mode used."""
    mode = rng.choices(["hold", "random", "goals", "own", "zero"], [40, 35, 13, 7, 5])[0]
    if prev is not None and all(v == one(p) for v, _ in prev.values()):
        mode = "random"    # the carry left by four goals must not leak into the next sum
    value = {"goals": lambda: one(p), "own": lambda: own, "zero": lambda: 0,
             "random": lambda: rng.randint(0, one(p))}
    if mode == "hold":
        return prev, mode
    return {d: (value[mode](), rng.random() < 0.5) for d in DIRS}, mode


def _drive(dut, own, nbrs, msb_src, window, c, p):
    """Drive cycle c's inputs."""
    a, b = read_offsets(c, p)
    dut.h.value = own.bits[a]
    dut.hm.value = msb_src["own"][b]
    for d in DIRS:
        getattr(dut, f"h_{d}").value = nbrs[d].bits[a]
        getattr(dut, f"m_{d}").value = msb_src[d][b]
    dut.ph0.value = int(c == 0)
    dut.ph1.value = int(c == 1)
    dut.ph2.value = int(c == 2)
    dut.enable.value = int(window is not None and window["enable"])
    dut.Sel.value = int(window is not None and window["sel"])
    dut.Sat.value = window["sat"] if window is not None else 0


async def _episode(dut, p, rng, seen):
    """From reset: a free node with a random value, then WINDOWS iterations."""
    await start(dut)
    model_v, model_c = rng.randint(0, one(p)), False
    own = SerialWord(model_v, model_c, p)
    nbr_vals = {d: (rng.randint(0, one(p)), False) for d in DIRS}
    nbrs = {d: SerialWord(v, f, p) for d, (v, f) in nbr_vals.items()}
    sel_at = {rng.randrange(3, WINDOWS // 2): 1,
              rng.randrange(WINDOWS // 2, WINDOWS - 2): rng.randint(0, 1)}
    msb_src = {"own": list(own.bits), **{d: list(nbrs[d].bits) for d in DIRS}}
    window = None
    for it in range(WINDOWS + 1):
        for c in range(p + 2):
            if c == 2:
                if window is not None:
                    # Iteration it-1 has written its last bit: check it.  The
                    # flags are register outputs, valid from the clock edge.
                    want = window["expect"]
                    got = (own.value(), own.flag(), bool(dut.stable.value), bool(dut.local_max.value))
                    assert got == want, (
                        f"p={p} iteration {it - 1} ({window['what']}): "
                        f"(value, const, stable, local_max) = {got}, model {want}")
                    model_v, model_c = want[0], want[1]
                    seen["stable"].add(got[2])
                    seen["max"].add(got[3])
                if it == WINDOWS:
                    return
                enable = rng.random() >= 1 / 7
                sel = enable and it in sel_at
                sat = sel_at.get(it, 0)
                if enable:
                    new_vals, mode = _next_neighbours(rng, p, model_v, nbr_vals)
                else:
                    new_vals, mode = nbr_vals, "check"
                h_new, c_new, st, mx = step(
                    np.array([model_v], dtype=object), np.array([model_c]), p,
                    tuple(np.array([nbr_vals[d][0]], dtype=object) for d in DIRS),
                    enable=enable, sel=np.array([sel]), sat=sat)
                window = {
                    "enable": enable, "sel": sel, "sat": sat,
                    "next": {d: SerialWord(v, f, p) for d, (v, f) in new_vals.items()},
                    "expect": (h_new[0], bool(c_new[0]), bool(st[0]), bool(mx[0])),
                    "what": ("Sel goal" if sat else "Sel obstacle") if sel else mode,
                }
                if enable and not (model_c or sel) and all(v == one(p) for v, _ in nbr_vals.values()):
                    seen["carry"] = True
                seen["sel"] |= sel
                seen["check"] |= not enable
                nbr_vals = new_vals
                msb_src = {"own": list(own.bits), **{d: list(nbrs[d].bits) for d in DIRS}}
            _drive(dut, own, nbrs, msb_src, window, c, p)
            if window is not None and window["enable"]:
                # Port B writes the node's output, two bit positions behind;
                # the neighbours' words take their next values likewise.
                await settle()
                addr = cnt_w(c, p)
                own.bits[addr] = int(dut.w.value)
                for d in DIRS:
                    nbrs[d].bits[addr] = window["next"][d].bits[addr]
            await next_cycle(dut)


@cocotb.test()
@cocotb.parametrize(p=PRECISIONS)
async def node_against_model(dut, p):
    """Random neighbour streams, Sel/Sat in mid-run, flags, every iteration."""
    rng = random.Random(cocotb.RANDOM_SEED * 1009 + p)
    dut._log.info(f"p={p} seed={cocotb.RANDOM_SEED}")
    seen = {"stable": set(), "max": set(), "carry": False, "sel": False, "check": False}
    for _ in range(EPISODES):
        await _episode(dut, p, rng, seen)
    # The run must have exercised what it claims to check.
    assert seen["stable"] == {False, True}, f"stable flag values seen: {seen['stable']}"
    assert seen["max"] == {False, True}, f"local-max flag values seen: {seen['max']}"
    assert seen["sel"] and seen["check"] and seen["carry"], seen


@pytest.mark.parametrize("sim", SIMULATORS)
def test_node(sim):
    run("harmonic_node", {}, sim, "test_node")
