"""DFLC stream top (hdl/dflc/top.py) against models.dflc, bit-exact, through sim/rtl/stream.py.

Two builds per simulator: the test top ``dflc_multi_setregress``
(tb/dflc/multi.py) holds one DflcStream per configuration, and the paper's
default runs alone as ``dflc_stream_table1`` (the build the CLI test shares);
each cocotb test below runs on every instance of the build in turn:

* ``sweep``: a dense sweep of the input space (per input: every segment
  boundary / MF breakpoint and its +-1 codes, the extremes, and a grid of 64
  codes (fewer for the fixtures); all their combinations) through the stream
  at full rate, every output compared with ``Dflc.infer`` (y and zero flag).
* ``random_stalls``: random samples with random idle cycles on the input and
  random back-pressure on the output (seeded: SEED=); each output is checked
  against the model's as it is taken, in order, none lost or duplicated, and
  the run must have stalled both ways (idle input cycles the core was ready
  for, output cycles with valid and not ready).
* ``cycles``: at full throughput the input accepts exactly one sample every
  2^n cycles (1 in the parallel option), outputs come equally spaced, and
  the first output is ``stream_latency`` cycles after its input handshake.
* ``reset_mid_stream``: reset while samples are in flight and the output is
  stalled; afterwards the top is ready, emits nothing, and a fresh batch comes
  out exactly.

Configurations: the paper's default (Table 1, min, LUT divider, n = 2, 9
triangles, sequential, default pipeline; ``dflc_stream_table1``) and
(tb/dflc/multi.py SETS["regress"]) n = 3 with
5/3/4 MFs, prod, restoring array and missing rules, every pipeline generic at
its minimum; trapezoids with gaps (zero firing strength), max, LUT, parallel,
the front generics at 4; 5/4 MFs, probor, array, parallel, the singleton route
longer than the weight route; n = 1 with the paper's Table 2 generics; n = 1,
array, every generic at 4 (latency 45); n = 4 (16 rules per sample), the back
generics at 4.  ``cycles`` asserts each instance's latency against
``hdl.dflc.core.latency`` of its generics and its 2^n (or 1) clocks per sample.
"""

import itertools
import os
import random

import cocotb
import numpy as np
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, RisingEdge

from navcores.hdl.dflc.top import config_for, split_params, stream_latency
from navcores.models.dflc import Dflc
from navcores.sim.rtl.clock import PERIOD_NS
from navcores.sim.rtl.dflc_driver import DflcDriver
from navcores.sim.rtl.runner import SIMULATORS, run, seed_from_env
from tb.dflc.multi import SETS, DflcMulti

SET = "regress"
ONLY = os.environ.get("DFLC_ONLY")          # e.g. DFLC_ONLY=n3: one instance only
# The builds under test: the test top with its instances, and the Table 1
# default alone as ``make verilog`` emits it (``dflc_stream_table1``, the build
# ``python -m sim dflc --engine icarus|verilator`` runs on the default .fll and
# test_dflc_cli.py shares; alone, its long sweep does not simulate six idle
# instances every clock).
# name, parameters, the factory of a test top (None: one of hdl.emit's tops)
BUILDS = {"multi": ("dflc_multi", {"set": SET}, DflcMulti), "table1": ("dflc_stream", {"fll": "table1"}, None)}
TOP = os.environ.get("DFLC_TOP", "multi")
# Stream latency of every instance, by hand from hdl/dflc/core.py's formula
# (multi.py's comments); the cycles test asserts both agree with the RTL.
LATENCIES = {"multi": {"n3": 13, "tr": 28, "or": 20, "n1": 20, "n1m": 46, "n4": 37},
             "table1": {"": 13}}
_CONFIGS = {}


def prefix(key):
    return f"{key}_" if key else ""


def instances(dut):
    """(key, config, mode, model) of every instance of the build under test
    (mode: ``parallel`` and the pipeline generics, as ``stream_latency`` takes
    them); all other instances idle (valid low, ready high)."""
    if not _CONFIGS:
        sets = SETS[SET] if TOP == "multi" else {"": BUILDS[TOP][1]}
        for key, params in sets.items():
            p, par, cpr = split_params(params)
            config = config_for(**p)
            _CONFIGS[key] = (config, {"parallel": par, **cpr}, Dflc(config))
    for key in _CONFIGS:
        getattr(dut, f"{prefix(key)}i_stream__valid").value = 0
        getattr(dut, f"{prefix(key)}o_stream__ready").value = 1
    for key, (config, par, model) in _CONFIGS.items():
        if ONLY is None or key in ONLY.split(","):
            yield key, config, par, model


def seed():
    return int(os.environ.get("DFLC_SEED", "1"))


def start_clock(dut):
    cocotb.start_soon(Clock(dut.clk, PERIOD_NS, unit="ns").start())


async def new_driver(dut, key, config, **stalls):
    """A DflcDriver on instance ``key``, reset; ``stalls``: rng, idle, back_pressure."""
    drv = DflcDriver(dut, config, prefix=prefix(key), **stalls)
    await drv.reset()
    return drv


def sweep_axes(model, grid, per_axis_cap=None):
    c = model.config
    top = (1 << c.ip_sz) - 1
    axes = []
    for spec in c.inputs:
        pts = {0, 1, top - 1, top, *range(0, top + 1, (top + 1) // grid)}
        for s in spec.seg_start:
            pts |= {s - 1, s, s + 1}
        for mf in spec.mfs:
            for p in mf.points:
                pts |= {p - 1, p, p + 1}
        pts = sorted(v for v in pts if 0 <= v <= top)
        if per_axis_cap and len(pts) > per_axis_cap:
            keep = set(np.linspace(0, len(pts) - 1, per_axis_cap).round().astype(int))
            pts = [v for i, v in enumerate(pts) if i in keep]
        axes.append(pts)
    return axes


@cocotb.test()
async def sweep(dut):
    start_clock(dut)
    for key, config, par, model in instances(dut):
        drv = await new_driver(dut, key, config)
        await _sweep(dut, drv, config, model)
        drv.stop()


async def _sweep(dut, drv, config, model):
    if config.name == "dflc_table1":
        axes = sweep_axes(model, 64)                 # >= 64 x 64 plus breakpoints +-1
    else:
        axes = sweep_axes(model, 16, per_axis_cap={1: 400, 2: 40, 3: 9, 4: 4}[config.n])
    codes = np.array(list(itertools.product(*axes)), dtype=np.int64)
    y, zero = model.infer(codes)
    got = await drv.run(codes.tolist())
    bad = [(list(codes[i]), got[i], (int(y[i]), bool(zero[i])))
           for i in range(len(codes)) if got[i] != (int(y[i]), bool(zero[i]))]
    assert not bad, f"{len(bad)} of {len(codes)} differ; first (codes, rtl, model): {bad[:3]}"
    assert len(got) == len(codes)
    dut._log.info(f"sweep {config.name}: {len(codes)} samples bit-exact ({int(zero.sum())} zero-strength)")
    if config.name == "dflc_table1":
        assert len(axes[0]) >= 64 and len(codes) >= 64 * 64
    if config.name == "trap_max":
        assert zero.any()


@cocotb.test()
async def random_stalls(dut):
    start_clock(dut)
    done = []
    for key, config, par, model in instances(dut):
        rng = random.Random(seed())
        # output ready on average half as often as the core delivers: the
        # output FIFO fills and the input sees back-pressure
        ready_p = 0.5 / (1 if par["parallel"] else 1 << config.n)
        drv = await new_driver(dut, key, config, rng=rng, idle=0.3, back_pressure=1 - ready_p)
        await _random_stalls(dut, drv, config, model, rng, ready_p)
        drv.stop()
        done.append(key)
    assert len(done) == len(list(instances(dut)))


async def _random_stalls(dut, drv, config, model, rng, ready_p):
    n = 200 if config.n <= 2 else 60
    codes = np.array([[rng.randrange(1 << config.ip_sz) for _ in range(config.n)] for _ in range(n)])
    # a few saturated corners too
    codes[:4] = [[0] * config.n, [(1 << config.ip_sz) - 1] * config.n,
                 [0, (1 << config.ip_sz) - 1][: config.n] + [0] * (config.n - 2),
                 [(1 << config.ip_sz) - 1] + [0] * (config.n - 1)]
    y, zero = model.infer(codes)
    expected = [(int(a), bool(b)) for a, b in zip(y, zero)]
    compared, errors = [], []

    def check(cycle, value):        # each output as it is taken (a scoreboard)
        got, want = drv.result(value), expected_q.pop(0) if expected_q else None
        if got != want:
            errors.append(f"output {len(compared)} (cycle {cycle}): rtl {got}, model {want}")
        compared.append(got)

    expected_q = list(expected)
    drv.sink.callback = check
    t0 = drv.streams.cycle
    out = await drv.run(codes.tolist(), timeout_cycles=n * 40 + 500)
    spent = drv.streams.cycle - t0
    src, snk = drv.source, drv.sink
    dut._log.info(f"random_stalls {config.name}: {n} samples in {spent} cycles; input idle {src.idle} "
                  f"and stalled {src.stalls} cycles, output stalled {snk.stalls} cycles")
    assert not errors, errors[:3]
    assert spent > 0.7 * n / ready_p, "the output, not the input, must limit the rate"
    assert out == expected
    await ClockCycles(dut.clk, 40)
    assert len(compared) == n and not expected_q and len(snk.beats) == n, "lost or duplicated"
    assert len(src.beats) == n
    # it stalled every way: idle input cycles, input valid and not ready (the
    # core held back by its output), output valid and not ready
    assert src.idle > 0 and src.stalls > 0 and snk.stalls > 0, (src.idle, src.stalls, snk.stalls)


@cocotb.test()
async def cycles(dut):
    start_clock(dut)
    checked = {}
    for key, config, par, model in instances(dut):
        rng = random.Random(seed() + 1)
        drv = await new_driver(dut, key, config)
        checked[key] = await _cycles(dut, drv, config, par, model, rng)
        drv.stop()
    assert len(checked) == len(list(instances(dut)))
    if ONLY is None:    # the generics really spread the latency (multi.py's comments)
        assert checked == LATENCIES[TOP], checked


async def _cycles(dut, drv, config, par, model, rng):
    p = 1 if par["parallel"] else 1 << config.n
    n = 40
    codes = [[rng.randrange(1 << config.ip_sz) for _ in range(config.n)] for _ in range(n)]
    out = await drv.run(codes)
    y, zero = model.infer(np.array(codes))
    assert out == [(int(a), bool(b)) for a, b in zip(y, zero)]
    ins, outs = drv.in_cycles, drv.out_cycles
    assert len(ins) == n and len(outs) == n
    assert set(np.diff(ins)) == {p}, f"input spacing {sorted(set(np.diff(ins)))}, expected {p}"
    assert set(np.diff(outs)) == {p}, f"output spacing {sorted(set(np.diff(outs)))}, expected {p}"
    lat = outs[0] - ins[0]
    assert lat == stream_latency(config, **par), f"latency {lat}, documented {stream_latency(config, **par)}"
    dut._log.info(f"cycles {config.name} {par}: {p} per sample, latency {lat}")
    return lat


@cocotb.test()
async def reset_mid_stream(dut):
    start_clock(dut)
    for key, config, par, model in instances(dut):
        rng = random.Random(seed() + 2)
        drv = await new_driver(dut, key, config, rng=rng, back_pressure=1.0)   # output stalled
        await _reset_mid_stream(dut, drv, config, par, model, rng)
        drv.stop()


async def _reset_mid_stream(dut, drv, config, par, model, rng):
    codes = [[rng.randrange(1 << config.ip_sz) for _ in range(config.n)] for _ in range(30)]
    drv.source.extend(codes)
    await ClockCycles(dut.clk, rng.randrange(20, 40))
    assert len(drv.source.beats) > 0 and drv.source.busy, "some samples entered before the reset, some not"
    await drv.reset()
    drv.sink.set_pause(None)
    # ready and empty: input ready at once, nothing comes out
    await RisingEdge(dut.clk)
    assert int(drv.source.ready.value) == 1
    for _ in range(3 * stream_latency(config, **par)):
        await RisingEdge(dut.clk)
        assert int(drv.sink.valid.value) == 0, "output after reset without input"
    assert drv.sink.beats == []
    fresh = [[rng.randrange(1 << config.ip_sz) for _ in range(config.n)] for _ in range(12)]
    out = await drv.run(fresh)
    y, zero = model.infer(np.array(fresh))
    assert out == [(int(a), bool(b)) for a, b in zip(y, zero)]
    await ClockCycles(dut.clk, 2 * stream_latency(config, **par))
    assert len(drv.sink.beats) == len(fresh), "nothing from before the reset may appear"


@pytest.mark.parametrize("build", BUILDS)
@pytest.mark.parametrize("sim", SIMULATORS)
def test_dflc_stream(sim, build):
    env = {"DFLC_SEED": seed_from_env(), "DFLC_TOP": build}
    if ONLY:
        env["DFLC_ONLY"] = ONLY
    name, params, factory = BUILDS[build]
    assert run(name, params, sim, "test_dflc_stream", env=env, factory=factory) == 4
