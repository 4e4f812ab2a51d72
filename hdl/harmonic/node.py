"""Node module of the harmonic planner (paper 000, section 5.2, Fig. 8)."""

from amaranth.hdl import Cat, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

__all__ = ["Node"]


def _maj(a, b, c):
    """Carry of a full adder."""
    return (a & b) | (a & c) | (b & c)


class Node(wiring.Component):
    """One grid node: Update, Stable, Maximum, Saturation and Mem of Fig. 8.

    All data ports are 1 bit wide and serial.  The node has no storage of its
    own value: it lives in the cluster's RAM, one bit per address, as described
    in :mod:`models.harmonic.ram` (constant flag, then bits p..0).  The shared
    Counters unit walks the RAM so that the node sees, in an iteration of p+2
    cycles numbered c = 0 .. p+1:

    =========  =========================================================
    cycle c    what the node sees / does
    =========  =========================================================
    0 (ph0)    ``h`` carries the constant flag; the adder sees 0 (its
               inputs are masked) and flushes the last sum bit (bit p-1 of
               the previous iteration's result is written).
    1 (ph1)    ``h`` carries bit 0; the carry's low bit (result bit p)
               is written; the adder starts afresh.
    2 (ph2)    ``h`` carries bit 1; the constant flag of the new word is
               written; the Stable and Maximum results of the previous
               iteration are valid on ``stable`` / ``local_max``.
    k+1        ``h`` carries bit k; result bit k-2 is written (k >= 2).
    =========  =========================================================

    So the sum of the four neighbours is formed LSB first by one serial
    four-operand adder with a two-bit carry (eq. 2), and dropping its two
    low bits, i.e. writing each sum bit two bit
    positions late, divides it by four.  The write window of one iteration
    runs from its cycle 2 to cycle 1 of the next one.

    In an iteration with ``enable`` low ("check" iteration) nothing changes:
    ``w`` is the stored bit.

    The Maximum compares the node's value with each neighbour's on the very
    LSB-first streams the adder reads (bit k at cycle k+1): per neighbour one
    flip-flop holds "mine >= its so far", and a higher bit that differs
    overrides it, so after bit p it is the comparison of the whole values.
    (The paper reads a second, MSB-first stream through the RAM's other port
    for this, 3.2.1; port B writes in update iterations, so that comparison
    exists only in check iterations.  LSB first it comes with every update
    iteration, which folds the check pass into the visits: see
    :mod:`models.harmonic.schedule`.)

    Ports
    -----
    h : In(1)
        Own stored word, from RAM port A (LSB first, flag first).
    h_N, h_E, h_W, h_S : In(1)
        The four neighbours' words, same timing as ``h``.
    ph0, ph1, ph2 : In(1)
        Cycle strobes from the Counters unit (c = 0, 1, 2).
    enable : In(1)
        Update iteration (1) or check iteration (0).  Held over the write
        window (c = 2 .. c = 1 of the next iteration).
    Sel, Sat : In(1)
        Saturation order: in an update iteration with ``Sel`` high the node
        becomes constant with value ``Sat`` (0 obstacle, 1 goal).  Held over
        the write window.
    to : Out(1)
        The node's value, LSB first, for its four neighbours (the paper's
        to_N, to_E, to_W, to_S are this one signal) and the decision module.
    w : Out(1)
        Bit to write to RAM port B (Mem multiplexer): the update, the stored
        bit (constant node or check iteration) or the saturation constant.
    stable : Out(1)
        The word written in the previous iteration equals the stored one.
        Valid when ``ph2`` is high.
    local_max : Out(1)
        Free node whose value is >= its four neighbours' (the values the
        previous iteration read, update or check).  Valid when ``ph2`` is
        high.
    """

    h: In(1)
    h_N: In(1)
    h_E: In(1)
    h_W: In(1)
    h_S: In(1)
    ph0: In(1)
    ph1: In(1)
    ph2: In(1)
    enable: In(1)
    Sel: In(1)
    Sat: In(1)
    to: Out(1)
    w: Out(1)
    stable: Out(1)
    local_max: Out(1)

    PARAMS = ()         # no parameters (hdl.emit --list)

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"iteration_cycles": "p+2", "flags_valid": "stable/local_max at ph2 (cycle 2) of the next iteration"}

    def elaborate(self, platform):
        m = Module()
        # Mem: the stored word is the node's value as its neighbours see it.
        m.d.comb += self.to.eq(self.h)

        # Update: one serial adder of the four neighbours, (N + S + E + W)
        # LSB first, whose carry k (0 .. 3: at most (4 + 3) // 2) takes two
        # flip-flops where three chained full adders take three.  At ph0 the
        # inputs carry the flags and are masked, which flushes the carry:
        # sum bit p+1 is written at ph0 (result bit p-1), sum bit p+2 is
        # k[0] at ph1 (result bit p), and the adder starts afresh at ph1.
        live = ~self.ph0
        a, b = self.h_N & live, self.h_S & live
        c, d = self.h_E & live, self.h_W & live
        k = Signal(2)
        kin = k[0] & ~self.ph1          # k[0] holds result bit p at ph1; k[1] is 0 there
        # a + b + c + d + kin + 2*k[1] as two full adders of weight 1 and
        # one of weight 2 (plain gates: no carry chain for a 3-bit sum).
        s1, g1 = a ^ b ^ c, _maj(a, b, c)
        total, g2 = s1 ^ d ^ kin, _maj(s1, d, kin)
        m.d.sync += k.eq(Cat(g1 ^ g2 ^ k[1], _maj(g1, g2, k[1])))

        # Mem: the stored stream delayed by two flip-flops lines up with the
        # write address, so it is both the write-back value and the Stable
        # reference.  At ph2 it holds the stored constant flag.
        d1, old = Signal(), Signal()
        m.d.sync += [d1.eq(self.h), old.eq(d1)]

        # Saturation: the constant flag of the word being written.
        saturate = self.enable & self.Sel
        flag = old | saturate
        const = Signal()
        with m.If(self.ph2):
            m.d.sync += const.eq(flag)

        with m.If(self.ph2):
            m.d.comb += self.w.eq(flag)
        with m.Elif(saturate):
            m.d.comb += self.w.eq(self.ph1 & self.Sat)   # only bit p may be 1
        with m.Elif(~self.enable | const):
            m.d.comb += self.w.eq(old)
        with m.Elif(self.ph1):
            m.d.comb += self.w.eq(k[0])
        with m.Else():
            m.d.comb += self.w.eq(total)

        # Stable: serial compare of the written word with the stored one.
        diff = Signal()
        changed = self.w ^ old
        m.d.sync += diff.eq(changed | (diff & ~self.ph2))
        m.d.comb += self.stable.eq(~diff)

        # Maximum: LSB-first compare against each neighbour.  ge[n] says
        # "mine >= neighbour n" over the bits seen so far: bit 0 (ph1)
        # starts it, a higher bit that differs decides anew, the flag slot
        # (ph0) holds it.  So during ph1 it holds the previous iteration's
        # comparison of whole values: latched then, shown at ph2.
        mx = Signal()
        ge_all = 1
        for nb in (self.h_N, self.h_E, self.h_W, self.h_S):
            ge = Signal()
            ge_all = ge_all & ge
            first = self.h | ~nb
            with m.If(self.ph1):
                m.d.sync += ge.eq(first)
            with m.Elif(~self.ph0):
                m.d.sync += ge.eq((self.h & ~nb) | (~(self.h ^ nb) & ge))
        with m.If(self.ph1):
            m.d.sync += mx.eq(ge_all)
        m.d.comb += self.local_max.eq(mx & ~const)

        return m
