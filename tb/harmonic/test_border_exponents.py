"""The Border's block-exponent option against models.harmonic.convert_mantissa.

``Border(..., exponents=True)`` on 3x3 blocks of 3x6 nodes: random words
(random bit lengths, so both the shifts and the clamp occur) written into
the four edge RAMs of every block; then, many times, a block, a precision p
and the four exponent differences s (-(p+3) .. p+3, and 0): the clamp scan
(its length and busy timing), then every offset of the LSB-first stream
(``cntR``) and of the MSB-first stream (``r_cnt``) read back: each border
node's converted value equals ``convert_mantissa(v, s, p)``, its flag is
the stored one, ``clamped`` equals the model's clamp flag of the four sides,
sides outside the map read 0; with ``raw`` the MSB-first port reads
unconverted and ``lead_*`` is each side's smallest offset holding a 1.
Counts what it compared (shifts both ways,
clamps, outside sides) and asserts the counts.

The Border is built as the ``harmonic_border`` top of ``hdl.emit`` with
``exponents=1``.
"""

import os
import random

import cocotb
import pytest
from cocotb.triggers import FallingEdge, ReadOnly

from navcores.models.harmonic import convert_mantissa
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.runner import SIMULATORS, run

P = dict(n=3, m=6, br=3, bc=3, p_max=12)
STRIDE = P["p_max"] + 2
TRIALS = 60
# (side, the RAM it reads, width, source block offset (dbr, dbc))
SIDES = (("N", "bottom", P["m"], (-1, 0)), ("S", "top", P["m"], (1, 0)),
         ("W", "right", P["n"], (0, -1)), ("E", "left", P["n"], (0, 1)))


def _layouts():
    """The per-side layouts of the conversion port (``conversion__s`` in,
    ``conversion__lead`` out): one field per side."""
    from navcores.hdl.harmonic.border import BorderExponentsSignature
    members = BorderExponentsSignature(STRIDE, 255).members
    return members["s"].shape, members["lead"].shape


def _field(word, layout, side):
    f = layout[side]
    return (word >> f.offset) & ((1 << f.width) - 1)


async def _tick(dut):
    await FallingEdge(dut.clk)


def _random_value(rng, p):
    k = rng.randrange(0, p + 2)              # bit length 0 .. p+1
    return rng.getrandbits(k) if k else 0


@cocotb.test()
async def border_exponents_against_model(dut):
    rng = random.Random(cocotb.RANDOM_SEED)
    await start(dut)
    BR, BC, B = P["br"], P["bc"], P["br"] * P["bc"]
    s_layout, lead_layout = _layouts()
    for name in ("conversion__s", "conversion__scan", "cntR", "r_cnt", "p", "conversion__raw", "w_en"):
        getattr(dut, name).value = 0
    # Random words (bits per offset) in every RAM of every block.
    words = {ram: [[0] * STRIDE for _ in range(B)] for _, ram, _, _ in SIDES}
    for b in range(B):
        for off in range(STRIDE):
            for _, ram, width, _ in SIDES:
                words[ram][b][off] = rng.getrandbits(width)
    # Random values of random lengths for a chosen p per block are stored per
    # node at offsets 1..p+1 for every p at once: draw values for p_max and
    # thin their top bits so that smaller p see all lengths too.
    for b in range(B):
        for _, ram, width, _ in SIDES:
            for i in range(width):
                v = _random_value(rng, P["p_max"]) >> rng.randrange(0, P["p_max"])
                for off in range(1, STRIDE):
                    k = P["p_max"] + 1 - off
                    bit = (v >> k) & 1
                    words[ram][b][off] = (words[ram][b][off] & ~(1 << i)) | (bit << i)
    for b in range(B):
        for off in range(STRIDE):
            dut.w_addr.value = b * STRIDE + off
            dut.w_en.value = 1
            for _, ram, width, _ in SIDES:
                getattr(dut, f"w_{ram}").value = words[ram][b][off]
            await _tick(dut)
    dut.w_en.value = 0

    seen = {"right": 0, "left": 0, "zero": 0, "clamp": 0, "outside": 0, "nodes": 0, "scan": 0, "lead": 0}
    for trial in range(TRIALS):
        br, bc = rng.randrange(BR), rng.randrange(BC)
        p = rng.randrange(2, P["p_max"] + 1)
        ss = {side: rng.choice([0, rng.randrange(-(p + 3), p + 4), rng.randrange(-3, 4)])
              for side, _, _, _ in SIDES}
        dut.br.value, dut.bc.value, dut.p.value = br, bc, p
        dut.conversion__s.value = s_layout.const(ss).as_value().value
        # Expected per side: (values, flags) or None outside the map.
        want, clamp_any, scan_len = {}, False, 0
        for side, ram, width, (dbr, dbc) in SIDES:
            nbr, nbc = br + dbr, bc + dbc
            if not (0 <= nbr < BR and 0 <= nbc < BC):
                want[side] = None
                seen["outside"] += 1
                continue
            src = words[ram][nbr * BC + nbc]
            vals, flags = [], []
            for i in range(width):
                v = 0
                for k in range(p + 1):
                    v |= ((src[1 + p - k] >> i) & 1) << k
                out, clamped = convert_mantissa(v, ss[side], p)
                clamp_any |= clamped
                vals.append(out)
                flags.append((src[0] >> i) & 1)
                seen["clamp"] += clamped
            want[side] = (vals, flags)
            scan_len = max(scan_len, min(max(ss[side], 0), p + 1))
            s = ss[side]
            seen["right" if s < 0 else "left" if s > 0 else "zero"] += 1
        # The scan: strobe, busy for exactly scan_len cycles after the strobe.
        dut.conversion__scan.value = 1
        await ReadOnly()
        assert int(dut.conversion__scan_len.value) == scan_len, f"trial {trial}: scan_len {int(dut.conversion__scan_len.value)} != {scan_len}"
        await _tick(dut)
        dut.conversion__scan.value = 0
        busy = 0
        while True:
            await ReadOnly()
            if not int(dut.conversion__scan_busy.value):
                break
            busy += 1
            await _tick(dut)
        assert busy == scan_len, f"trial {trial}: scan busy {busy} cycles, expected {scan_len}"
        seen["scan"] += scan_len > 0
        assert int(dut.conversion__clamped.value) == clamp_any, (
            f"trial {trial} block ({br}, {bc}) p={p} s={ss}: clamped {int(dut.conversion__clamped.value)}, model {clamp_any}")
        await _tick(dut)
        # Every offset through both streams (data one cycle after its address).
        for port, out in (("cntR", "h"), ("r_cnt", "m")):
            got = {side: [0] * width for side, _, width, _ in SIDES}
            flag = {side: 0 for side, _, _, _ in SIDES}
            for off in range(p + 2):
                getattr(dut, port).value = off
                await _tick(dut)
                await ReadOnly()
                for side, _, width, _ in SIDES:
                    word = int(getattr(dut, f"{out}_{side}").value)
                    if off == 0:
                        flag[side] = word
                    else:
                        for i in range(width):
                            got[side][i] |= ((word >> i) & 1) << (1 + p - off)
                await _tick(dut)
            for side, _, width, _ in SIDES:
                if want[side] is None:
                    assert got[side] == [0] * width and flag[side] == 0, f"{side} outside the map reads {got[side]}"
                    continue
                vals, flags = want[side]
                assert got[side] == vals, (
                    f"trial {trial} {out}-stream block ({br}, {bc}) p={p} side {side} s={ss[side]}: "
                    f"RTL {got[side]}, model {vals}")
                assert [(flag[side] >> i) & 1 for i in range(width)] == flags
                seen["nodes"] += width
        # Raw MSB-first reads (update visits): each side's lead is the smallest
        # offset 1..p+1 holding a 1 (the ring's largest value), or the stride.
        dut.conversion__raw.value = 1
        for off in range(p + 2):
            dut.r_cnt.value = off
            await _tick(dut)
        dut.conversion__raw.value = 0
        await _tick(dut)
        await ReadOnly()
        for side, ram, width, (dbr, dbc) in SIDES:
            nbr, nbc = br + dbr, bc + dbc
            lead = STRIDE
            if 0 <= nbr < BR and 0 <= nbc < BC:
                src = words[ram][nbr * BC + nbc]
                lead = next((o for o in range(1, p + 2) if src[o]), STRIDE)
            got_lead = _field(int(dut.conversion__lead.value), lead_layout, side)
            assert got_lead == lead, f"trial {trial} side {side}: lead {got_lead}, expected {lead}"
            seen["lead"] += lead != STRIDE
        await _tick(dut)
    dut._log.info(f"compared: {seen}")
    for key in ("right", "left", "zero", "clamp", "outside", "scan", "lead"):
        assert seen[key] > 0, f"not exercised: {key} ({seen})"
    assert seen["nodes"] >= TRIALS * 18, seen     # a corner block: 2 sides, 9 nodes, 2 streams


@pytest.mark.parametrize("sim", SIMULATORS)
def test_border_exponents(sim):
    # One Verilator build fewer in the regression: the Border's conversion is
    # checked on Verilator inside the planner (test_planner_exponents);
    # HARMONIC_BIG=1 runs this unit test on Verilator too.
    if sim == "verilator" and os.environ.get("HARMONIC_BIG") != "1":
        pytest.skip("Verilator run of the Border unit test: HARMONIC_BIG=1")
    run("harmonic_border", {**P, "exponents": 1}, sim, "test_border_exponents")
