"""Node exponents' update pipeline (hdl/harmonic/node_exponents.py) against the model, bit-exact.

``NodeExponentUpdate(p=16, e_max=472)`` (the ``harmonic_node_exponents``
top; 472 = the ``e_max`` :func:`models.harmonic.plan_node_exponents` takes
on the 64x64 crop of maze512-1-0, goal (1, 1)) and a small word,
``p=6, e_max=31, headroom=3`` (5-bit exponents up to all ones; random
words only), two builds per simulator, driven through the project's
stream driver (navcores.sim.rtl.stream):

* ``latency_and_throughput``: no idle input, no back-pressure: every
  output handshake exactly ``LATENCY`` cycles after its input's, one
  input and one output every clock.
* ``full_pipeline``: the output held not ready: the pipeline takes exactly
  ``LATENCY`` inputs (one per stage) and then refuses; released, it delivers
  one output a clock and takes a new input in each of those cycles.
* ``random_stalls``: thousands of random neighbour words (zeros with any exponent, normal
  values, denormals at e_max and tiny ones, e = 0 values up to 2**p, close
  exponents, exponent gaps far beyond the word, any bits) and the real
  neighbourhoods of the 64x64 crop's field (converged, and twice while the
  wave is still out: zeros beside non-zeros), with random idle input cycles
  and random back-pressure: every output equals
  :func:`models.harmonic.node_exponents.node_update`'s, in order, none lost
  or duplicated (the stream monitors fail a beat dropped or changed while
  stalled).  Each kind of result (zero, denormal, normal, the headroom at
  e = 0, a wide gap, a denormal sum flushed to zero) must have occurred.
* ``reset_mid_stream``: a reset with the pipeline full and stalled: then
  no output, a defined payload (no X), and a fresh batch exactly.

The seed (random words and stalls) is printed; replay with ``SEED=``.
"""

import os
import random
from pathlib import Path

import cocotb
import numpy as np
import pytest
from cocotb.triggers import ClockCycles, RisingEdge

from node_words import format_word
from navcores.models.harmonic import distances
from navcores.models.harmonic.node_exponents import GUARD, node_update, plan_node_exponents
from navcores.models.maps import load_map
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.runner import SIMULATORS, run, seed_from_env
from navcores.sim.rtl.stream import Streams, pauses

ROOT = Path(__file__).resolve().parents[2]
P, H = 16, 2
CROP, GOALS = 64, [(1, 1)]
LATENCY = 9             # the timing table of NodeExponentUpdate's docstring
RANDOM_WORDS = int(os.environ.get("NODE_EXP_WORDS", "4000"))


def _crop():
    return load_map(ROOT / "maps" / "maze512-1-0.map")[:CROP, :CROP]


def field_e_max():
    """The e_max plan_node_exponents takes on the crop ("map": 2 x the longest distance)."""
    return max(1, 2 * int(distances(_crop(), GOALS).max()))


# The builds: the crop's (its field's neighbourhoods too), and a small word
# with a 5-bit exponent at its all-ones e_max and 3 headroom bits (clamps at
# both ends and gaps beyond the word are frequent; random words only).
SETS = {"crop": lambda: {"p": P, "e_max": field_e_max()},
        "small": lambda: {"p": 6, "e_max": 31, "headroom": 3}}


# --- stimuli ------------------------------------------------------------------

def random_word(rng, p, h, e_max):
    """One neighbour word (v, e): :func:`node_words.format_word` (the model
    test's words too), plus tiny denormals (sums
    that flush to zero), zeros with any exponent (node_update ignores a zero
    word's exponent) and words of any bits."""
    x = rng.random()
    if x < 0.1:
        return 0, e_max
    if x < 0.15:
        return 0, rng.randrange(0, e_max + 1)                       # a zero with any exponent: not the smallest
    if x < 0.2:
        return rng.randrange(1, 4), e_max                           # tiny denormal
    if x < 0.25:
        return rng.randrange(0, 1 << (p + 1)), rng.randrange(0, e_max + 1)     # any bits
    return format_word(rng, p, h, e_max)


def random_neighbourhoods(rng, n, p, h, e_max):
    out = []
    for _ in range(n):
        x = rng.random()
        if x < 0.25:                                                # close exponents: the guard bits matter
            base = rng.randrange(0, e_max - 4)
            words = [(rng.randrange(1 << (p - h), 1 << (p + 1 - h)), base + rng.randrange(1, 5)) for _ in range(4)]
        elif x < 0.35:                                              # a gap far beyond the word
            near = rng.randrange(0, e_max // 2)
            words = [(rng.randrange(1 << (p - h), 1 << (p + 1 - h)),
                      near if k == 0 else rng.randrange(near, e_max + 1)) for k in range(4)]
            rng.shuffle(words)
        elif x < 0.4:                                               # denormals only (flush to zero or not)
            top = 2 if rng.random() < 0.3 else 1 << rng.randrange(1, p - h + 1)
            words = [(rng.randrange(0, top), e_max) for _ in range(4)]
        else:
            words = [random_word(rng, p, h, e_max) for _ in range(4)]
        out.append(words)
    return out


def field_neighbourhoods(e_max):
    """The four neighbours (N, E, W, S; outside and obstacles (0, e_max)) of
    every reachable cell of the crop's field: converged, and after 40 and
    150 iterations (the wave still out)."""
    ob = _crop()
    out = []
    for max_iter in (40, 150, None):
        res = plan_node_exponents(ob, GOALS, p=P, headroom=H, max_iter=max_iter)
        assert res.e_max == e_max, (res.e_max, e_max)
        if max_iter is None:
            assert res.converged
        rows, cols = ob.shape
        v = np.zeros((rows + 2, cols + 2), dtype=np.int64)
        e = np.full((rows + 2, cols + 2), e_max, dtype=np.int64)
        v[1:-1, 1:-1], e[1:-1, 1:-1] = res.mantissa, res.exponents
        for r, c in np.argwhere(distances(ob, GOALS) >= 0):
            out.append([(int(v[r + 1 + dr, c + 1 + dc]), int(e[r + 1 + dr, c + 1 + dc]))
                        for dr, dc in ((-1, 0), (0, 1), (0, -1), (1, 0))])
    return out


def expected(hoods, p, h, e_max):
    vn = np.array([[w[0] for w in ws] for ws in hoods], dtype=np.int64)
    en = np.array([[w[1] for w in ws] for ws in hoods], dtype=np.int64)
    v, e = node_update(vn, en, p, e_max, h)
    return [{"v": int(a), "e": int(b)} for a, b in zip(v, e)]


def payload(words):
    return {k: {"v": v, "e": e} for k, (v, e) in zip(("N", "E", "W", "S"), words)}


def kinds(words, out, p, h, e_max):
    """The kinds of one update (for the coverage counts)."""
    v, e = out["v"], out["e"]
    nz = [b for a, b in words if a]
    k = set()
    if v == 0:
        k.add("zero")
        if nz:
            k.add("flushed")                # non-zero neighbours, a sum below the smallest denormal
    elif e == e_max and v < (1 << (p - h)):
        k.add("denormal")
    else:
        k.add("normal")
        if e == 0 and v >= (1 << (p + 1 - h)):
            k.add("headroom at e=0")
    if v and nz and max(nz) - min(nz) > p + GUARD + 2:
        k.add("wide gap")
    return k


KINDS = {"zero", "flushed", "denormal", "normal", "headroom at e=0", "wide gap"}


# --- the cocotb tests -----------------------------------------------------------

class Bench:
    def __init__(self, dut, rng, in_pause=0.0, out_pause=0.0):
        from navcores.hdl.harmonic.node_exponents import NodeExponentUpdate, neighbours_layout, word_layout
        self.p, self.e_max = int(os.environ["NODE_EXP_P"]), int(os.environ["NODE_EXP_E_MAX"])
        self.h = int(os.environ["NODE_EXP_H"])
        self.field = (self.p, self.h) == (P, H)         # the crop's build: its field's neighbourhoods too
        self.latency = NodeExponentUpdate.LATENCY
        assert self.latency == LATENCY and f"``LATENCY`` = {LATENCY}:" in NodeExponentUpdate.__doc__
        self.streams = Streams(dut)
        self.src = self.streams.source("i_stream", neighbours_layout(self.p, self.e_max), pauses(rng, in_pause))
        self.snk = self.streams.sink("o_stream", word_layout(self.p, self.e_max), pauses(rng, out_pause))

    async def run(self, hoods, timeout=None):
        """Send ``hoods``, return the outputs (in order)."""
        self.src.extend(payload(w) for w in hoods)
        return await self.snk.take(len(hoods), timeout_cycles=timeout or 20 * len(hoods) + 100)


def _rng(dut):
    seed = seed_from_env()
    dut._log.info(f"seed {seed} (replay with SEED={seed})")
    return random.Random(seed)


@cocotb.test()
async def latency_and_throughput(dut):
    rng = _rng(dut)
    await start(dut)
    b = Bench(dut, rng)
    hoods = random_neighbourhoods(rng, 300, b.p, b.h, b.e_max)
    got = await b.run(hoods)
    assert got == expected(hoods, b.p, b.h, b.e_max)
    ins = [c for c, _ in b.src.beats]
    outs = [c for c, _ in b.snk.beats]
    assert [o - i for i, o in zip(ins, outs)] == [b.latency] * len(hoods), \
        f"latency: {sorted(set(o - i for i, o in zip(ins, outs)))}, documented {b.latency}"
    assert ins == list(range(ins[0], ins[0] + len(hoods))), "an input refused without back-pressure"
    assert outs == list(range(outs[0], outs[0] + len(hoods))), "a gap in the outputs at full rate"
    dut._log.info(f"latency {b.latency} cycles, {len(hoods)} beats one per clock")


@cocotb.test()
async def full_pipeline(dut):
    rng = _rng(dut)
    await start(dut)
    b = Bench(dut, rng)
    hoods = random_neighbourhoods(rng, 60, b.p, b.h, b.e_max)
    b.snk.set_pause(iter([True] * 40 + [False] * 1000))         # not ready for 40 cycles
    b.src.extend(payload(w) for w in hoods)
    await ClockCycles(dut.clk, 30)
    assert len(b.src.beats) == b.latency, f"{len(b.src.beats)} inputs taken while stalled, {b.latency} stages"
    assert int(dut.o_stream__valid.value) == 1 and int(dut.i_stream__ready.value) == 0
    got = await b.snk.take(len(hoods), timeout_cycles=500)
    assert got == expected(hoods, b.p, b.h, b.e_max)
    ins = {c for c, _ in b.src.beats}
    outs = [c for c, _ in b.snk.beats]
    assert outs == list(range(outs[0], outs[0] + len(hoods))), "released: not one output a clock"
    # while inputs were waiting, each output cycle took an input too
    both = [c for c in outs[:len(hoods) - b.latency] if c in ins]
    assert len(both) == len(hoods) - b.latency, "a full pipeline did not take an input as it delivered one"
    assert b.snk.stalls >= 40 - b.latency - 2        # valid and not ready from the first output on


@cocotb.test()
async def random_stalls(dut):
    rng = _rng(dut)
    await start(dut)
    b = Bench(dut, rng, in_pause=0.3, out_pause=0.3)
    hoods = random_neighbourhoods(rng, RANDOM_WORDS, b.p, b.h, b.e_max)
    if b.field:
        hoods += field_neighbourhoods(b.e_max)
    want = expected(hoods, b.p, b.h, b.e_max)
    got = await b.run(hoods)
    bad = [(i, hoods[i], got[i], want[i]) for i in range(len(hoods)) if got[i] != want[i]]
    assert not bad, f"{len(bad)} of {len(hoods)} differ; first (index, neighbours, rtl, model): {bad[:3]}"
    await ClockCycles(dut.clk, 2 * b.latency)
    assert len(b.snk.beats) == len(hoods), "more outputs than inputs"
    seen = {k: 0 for k in sorted(KINDS)}
    for w, out in zip(hoods, want):
        for k in kinds(w, out, b.p, b.h, b.e_max):
            seen[k] += 1
    field = f" ({len(hoods) - RANDOM_WORDS} of the crop's field)" if b.field else ""
    dut._log.info(f"{len(hoods)} updates bit-exact{field}; "
                  f"kinds {seen}; input idle {b.src.idle}, input stalled {b.src.stalls}, "
                  f"output stalled {b.snk.stalls}")
    assert all(seen.values()), f"not exercised: {[k for k, n in seen.items() if not n]}"
    assert b.src.idle and b.src.stalls and b.snk.stalls, "no idle input, no full pipeline or no back-pressure"


@cocotb.test()
async def reset_mid_stream(dut):
    rng = _rng(dut)
    await start(dut)
    b = Bench(dut, rng)
    b.snk.set_pause(iter([True] * 1000))
    b.src.extend(payload(w) for w in random_neighbourhoods(rng, 20, b.p, b.h, b.e_max))
    await ClockCycles(dut.clk, 2 * b.latency)
    assert int(dut.o_stream__valid.value) == 1
    await b.streams.apply_reset()
    for _ in range(3 * b.latency):
        assert int(dut.o_stream__valid.value) == 0, "an output after the reset"
        assert dut.o_stream__payload.value.is_resolvable, f"payload {dut.o_stream__payload.value} after reset"
        assert int(dut.i_stream__ready.value) == 1
        await RisingEdge(dut.clk)
    b.snk.set_pause(pauses(rng, 0.5))
    hoods = random_neighbourhoods(rng, 100, b.p, b.h, b.e_max)
    assert await b.run(hoods) == expected(hoods, b.p, b.h, b.e_max)


# --- pytest ---------------------------------------------------------------------

@pytest.mark.parametrize("sim", SIMULATORS)
@pytest.mark.parametrize("build", SETS)
def test_node_exponents_rtl(sim, build):
    params = SETS[build]()
    run("harmonic_node_exponents", params, sim, "test_node_exponents_rtl",
        env={"NODE_EXP_P": params["p"], "NODE_EXP_E_MAX": params["e_max"], "NODE_EXP_H": params.get("headroom", 2)})


def test_field_e_max():
    assert field_e_max() == 472 == plan_node_exponents(_crop(), GOALS, p=P, max_iter=1).e_max


@pytest.mark.parametrize("kw,message", [
    ({"p": 3, "e_max": 10}, "p = 3: node exponents take 4 <= p <= 48"),
    ({"p": 49, "e_max": 10}, "p = 49"),
    ({"p": 16, "e_max": 0}, "e_max = 0: take 1 <= e_max <= 65535"),
    ({"p": 16, "e_max": 1 << 16}, "e_max = 65536"),
    ({"p": 16, "e_max": 10, "headroom": -1}, "headroom = -1"),
    ({"p": 8, "e_max": 10, "headroom": 7}, "headroom = 7: take 0 <= headroom <= p - 2 = 6"),
    ({"p": 16.0, "e_max": 10}, "p = 16.0"),
])
def test_refuses_bad_parameters(kw, message):
    from navcores.hdl.harmonic.node_exponents import NodeExponentUpdate
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace("+", r"\+")):
        NodeExponentUpdate(**kw)
