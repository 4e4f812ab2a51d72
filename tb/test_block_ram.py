"""BlockRam (hdl/block_ram.py) against a plain list of words: lanes, banks, read latency 2.

Random writes and reads at random addresses (over every bank and lane, the
last bank partial), random idle cycles on both ports; a read and a write
never meet on one address in one cycle (the callers' rule).  Every read's
data, two cycles after its address, must be the model's word: the last
value written in an earlier cycle.  The layout itself (lanes as wide as a
block holding the depth, banks of 16384 words) is checked without a simulator.
"""

import os
import random

import cocotb
import pytest

from navcores.hdl.block_ram import BlockRam, ram_layout
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.runner import SIMULATORS, run
from tb.harmonic.serial import next_cycle

# (width, depth): 18 bits over two banks (16384 words in 1-bit lanes, 3616 in 4-bit lanes: 23 memories);
# 7 bits at 3000 words (4-bit lanes: 4 + 3)
SHAPES = ((18, 20000), (7, 3000))


@cocotb.test()
async def block_ram_follows_list(dut):
    width, depth = int(os.environ["RAM_WIDTH"]), int(os.environ["RAM_DEPTH"])
    rng = random.Random(cocotb.RANDOM_SEED)
    await start(dut)
    words = [0] * depth
    written = set()
    hot = [rng.randrange(depth) for _ in range(24)] + [0, depth - 1, min(16383, depth - 1), min(16384, depth - 1)]
    pending = [None, None]                  # the reads of the last two cycles (address, word then), oldest first
    checked = 0
    seen = set()
    for _ in range(3000):
        got = pending.pop(0)
        if got is not None:
            a, want = got
            assert int(dut.r_data.value) == want, f"read of {a}: {int(dut.r_data.value):#x}, model {want:#x}"
            checked += 1
            seen.add(a >> 14)
        ra = rng.choice(hot) if rng.random() < 0.7 else rng.randrange(depth)
        read = rng.random() < 0.7 and ra in written
        wa = rng.choice(hot) if rng.random() < 0.7 else rng.randrange(depth)
        write = rng.random() < 0.5 and not (read and wa == ra)
        wd = rng.getrandbits(width)
        dut.r_addr.value = ra if read else rng.randrange(depth)
        dut.w_addr.value, dut.w_data.value, dut.w_en.value = wa, wd, int(write)
        pending.append((ra, words[ra]) if read else None)      # the word as the read sees it
        await next_cycle(dut)
        if write:
            words[wa] = wd
            written.add(wa)
    dut.w_en.value = 0
    banks_seen = len(seen)
    assert checked > 500, f"only {checked} reads of written words"
    assert banks_seen == len(ram_layout(width, depth)), f"reads reached {banks_seen} bank(s)"


def test_layout():
    assert ram_layout(18, 1024) == [(1024, [slice(0, 18)])]
    assert ram_layout(18, 200) == [(200, [slice(0, 18)])]
    assert ram_layout(18, 8192) == [(8192, [slice(k, k + 2) for k in range(0, 18, 2)])]
    assert ram_layout(7, 3000) == [(3000, [slice(0, 4), slice(4, 7)])]
    assert ram_layout(18, 32768) == [(16384, [slice(k, k + 1) for k in range(18)])] * 2
    assert ram_layout(12, 17028) == [(16384, [slice(k, k + 1) for k in range(12)]), (644, [slice(0, 12)])]
    with pytest.raises(ValueError, match=r"BlockRam width 0: must be an integer in 1\.\.1024"):
        BlockRam(0, 8)
    with pytest.raises(ValueError, match=r"BlockRam depth 1: must be an integer in 2\.\.1048576"):
        BlockRam(8, 1)


@pytest.mark.parametrize("shape", SHAPES, ids=[f"{w}x{d}" for w, d in SHAPES])
@pytest.mark.parametrize("sim", SIMULATORS)
def test_block_ram(sim, shape):
    width, depth = shape
    run("block_ram", {"width": width, "depth": depth}, sim, "tb.test_block_ram", factory=BlockRam,
        env={"RAM_WIDTH": width, "RAM_DEPTH": depth})
