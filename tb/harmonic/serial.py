"""Test helpers shared by the harmonic tests: the RAM addresses of the
Counters (models.harmonic.counters), emulated serial words (a border node's
or a neighbour's storage, one bit per RAM address) and cycle steps.  The
clock and reset: navcores.sim.rtl.clock.start."""

from cocotb.triggers import FallingEdge, ReadOnly

from navcores.models.harmonic import counters, word_bits


def cnt_w(c, p):
    """Port B write address of cycle c (two bit positions behind)."""
    return counters(c, p)[2]


def read_offsets(c, p):
    """(port A, port B) addresses whose data the nodes see in cycle c: the
    ones presented in the previous cycle (synchronous RAM)."""
    cnt_r, r_cnt, _ = counters((c - 1) % (p + 2), p)
    return cnt_r, r_cnt


class SerialWord:
    """A node word stored one bit per address, read with one cycle latency."""

    def __init__(self, value, flag, p):
        self.p = p
        self.bits = word_bits(value, flag, p)

    def value(self):
        v = 0
        for bit in self.bits[1:]:
            v = (v << 1) | bit
        return v

    def flag(self):
        return bool(self.bits[0])


async def settle():
    """Between clock edges: inputs are set, combinational outputs settled."""
    await ReadOnly()


async def next_cycle(dut):
    """Go to the middle of the next cycle (after its rising edge)."""
    await FallingEdge(dut.clk)
