"""Node module of the harmonic planner (paper 000, section 5.2, Fig. 8)."""

from itertools import combinations

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

__all__ = ["Node"]


def _at_least(bits, t):
    """At least t of the bits are set, as AND / OR gates (no adder, no carry chain)."""
    return Cat(*(Cat(*c).all() for c in combinations(bits, t))).any()


class Node(wiring.Component):
    """One grid node: Update, Stable, Maximum, Saturation and Mem of Fig. 8.

    All data ports are 1 bit wide and serial.  The node has no storage of its
    own value: it lives in the cluster's RAM, one bit per address, as described
    in :mod:`models.harmonic.ram` (constant flag, then bits p..0).  The shared
    Counters unit walks the RAM so that the node sees, in an iteration of
    L = p+2+S cycles numbered u = 0 .. L-1 (S pad cycles, 0 for p >= 4:
    :func:`models.harmonic.pads`), its own word and its four neighbours'
    LSB first:

    =========  =========================================================
    cycle u    what the node sees / does
    =========  =========================================================
    0          ``z``: the Maximum result of the previous iteration is
               latched; ``w`` = result bit p-1 of the previous iteration
               (the carry flushing: the adder's inputs are masked)
    1          ``ph1``: ``w`` = result bit p (the flushed carry's high
               bit, held in ``hi``); the adder restarts (the mask cleared
               its carry at u = 0)
    < S        pads (``mask``): nothing read, the adder's inputs masked
    S          the constant flag (``mask``: the adder sees 0)
    S+1+k      value bit k; ``w`` = result bit k-2 (k >= 2)
    S+2        ``ph2``: ``w`` = the constant flag of the new word
    =========  =========================================================

    So the sum of the four neighbours is formed LSB first by one serial
    four-operand adder with a two-bit carry (eq. 2), and dropping its two
    low bits, i.e. writing each sum bit two bit positions late, divides it
    by four.  The write window of one iteration runs from its cycle S+2 to
    cycle 1 of the next one (the cycles 2 .. S+1 of a padded iteration
    write nothing: the cluster holds ``enable`` low there).  ``w`` comes
    from registers (one LUT after them, none from the inputs): the bit
    computed in cycle u is on ``w`` in cycle u+1, when
    the cluster writes it.

    In an iteration with ``enable`` low ("check" iteration) nothing changes:
    ``w`` is the stored bit.

    The Maximum compares the node's value with each neighbour's on the very
    LSB-first streams the adder reads (value bit k at cycle S+1+k): per
    neighbour one flip-flop holds "mine >= its so far", and a higher bit that
    differs overrides it, so after bit p it is the comparison of the whole
    values.  (The paper reads a second, MSB-first stream through the RAM's
    other port for this, 3.2.1; port B writes in update iterations, so that
    comparison exists only in check iterations.  LSB first it needs no
    second read port and comes with every iteration, update, check or clear,
    which folds the check pass into the visits: see
    :mod:`models.harmonic.schedule`.)

    Flags: ``stable`` and ``local_max`` of an iteration are registers valid
    in cycle 2 of the next one (``local_max`` loaded at cycle 0, until the
    next cycle 0; ``stable``, loaded at cycle 1 with the last written bit's
    comparison, until the next cycle 1).

    Ports
    -----
    h : In(1)
        Own stored word, from the RAM's read port (LSB first, flag first).
    h_N, h_E, h_W, h_S : In(1)
        The four neighbours' words, same timing as ``h``.
    mask : In(1)
        Pad and flag cycles (u <= S): the Maximum restarts.
    zero : In(1)
        The adder's inputs are masked (0): ``mask``, and the bits of a
        clear iteration (the Maximum still compares the values read).  One
        input, so that the sum's parity and its mask take one LUT level.
    z, ph1, ph2 : In(1)
        Cycle strobes from the Counters unit (u = 0, u = 1, u = S+2).
    enable : In(1)
        Update iteration (1) or check iteration (0), held over the write
        window; low in the non-writing cycles of a padded iteration.
    Sel, Sat : In(1)
        Saturation order: in an update iteration with ``Sel`` high the node
        becomes constant with value ``Sat`` (0 obstacle, 1 goal).  Held over
        the write window.
    to : Out(1)
        The node's value, LSB first, for its four neighbours (the paper's
        to_N, to_E, to_W, to_S are this one signal) and the decision module.
    w : Out(1)
        Bit to write to the RAM (Mem multiplexer; from registers: a LUT after three flip-flops): the update,
        the stored bit (constant node or check iteration) or the saturation
        constant.
    stable : Out(1)
        The word written in the previous iteration equals the stored one
        (a register: valid from cycle 2 of the next iteration to its next
        cycle 1).
    local_max : Out(1)
        Free node whose value is >= its four neighbours' (the values the
        previous iteration read, update, check or clear).
    """

    h: In(1)
    h_N: In(1)
    h_E: In(1)
    h_W: In(1)
    h_S: In(1)
    mask: In(1)
    zero: In(1)
    z: In(1)
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
        return {"iteration_cycles": "p+2 (p >= 4; max(p, 4)+2 below)",
                "w_latency": "the bit of cycle u is on w in cycle u+1",
                "flags_valid": "stable/local_max in cycle 2 of the next iteration"}

    def elaborate(self, platform):
        m = Module()
        # Mem: the stored word is the node's value as its neighbours see it.
        m.d.comb += self.to.eq(self.h)

        # Update: one serial adder of the four neighbours, (N + S + E + W)
        # LSB first, whose carry k (0 .. 3: at most (4 + 3) // 2) takes two
        # flip-flops where three chained full adders take three.  While
        # masked (``zero``) the adder's inputs are 0 and the carry flushes:
        # sum bit p+1 (result bit p-1) is k[0], the sum bit at u = 0, and
        # sum bit p+2 (result bit p) is k[1] then, which ``hi`` holds for
        # u = 1.  A masked cycle clears k (a synchronous reset, so ``zero``
        # stays out of the carry's LUTs); the adder thus starts afresh at
        # u = 1 with no carry to gate, and k stays 0 through pads and clear
        # iterations (the masked sum is the carry alone: 0).
        h4 = Cat(self.h_N, self.h_S, self.h_E, self.h_W)
        k, hi = Signal(2), Signal()
        # k' = (n + k[0] + 2 k[1]) >> 1 with n the count of the four bits:
        # with c = n + k[0] (0 .. 5), k'[1] = c >= (2 if k[1] else 4) and
        # k'[0] = (bit 1 of c) ^ k[1], bit 1 of c = c >= 2 and not c >= 4.
        # The thresholds of c are nets of their own, kept through synthesis
        # (issue 17): each is one LUT (of five inputs) after the RAM's output
        # register, then one LUT with k[1], so that synthesis neither merges
        # them with the neighbours' (a shared sub-expression costs a LUT
        # level and a route on the RAM's read path) nor chains them.
        n0, ge2, ge4 = (Signal(name=name, attrs={"keep": 1}) for name in ("n0", "ge2", "ge4"))
        bits = [*h4, k[0]]
        m.d.comb += [
            n0.eq(h4.xor()),                  # the sum bit's parity
            ge2.eq(_at_least(bits, 2)),
            ge4.eq(_at_least(bits, 4)),
        ]
        with m.If(self.zero):
            m.d.sync += k.eq(0)
        with m.Else():
            m.d.sync += k.eq(Cat((ge2 & ~ge4) ^ k[1], Mux(k[1], ge2, ge4)))
        m.d.sync += hi.eq(k[1])

        # Mem: the stored stream delayed by two flip-flops lines up with the
        # bit being computed, so it is both the write-back value and, one
        # flip-flop later (old_r), the Stable reference of w (one cycle later).
        d1, old, old_r = Signal(), Signal(), Signal()
        m.d.sync += [d1.eq(self.h), old.eq(d1), old_r.eq(old)]

        # Saturation: the constant flag of the word being written.
        saturate = self.enable & self.Sel
        flag = old | saturate
        const = Signal()
        with m.If(self.ph2):
            m.d.sync += const.eq(flag)

        # The bit of cycle u, on w in cycle u+1 (Mem multiplexer):
        #   ph2: the flag; saturate: bit p = Sat (at ph1), the rest 0;
        #   check iteration or constant node: the stored bit; ph1: the
        #   carry's high bit (hi); else the sum bit.
        # Timing (issue 17): the neighbour bits come from flip-flops (the
        # RAM's output register), and each register they reach is two LUT4s
        # away (the count of the four bits, then one LUT with the carry).
        # So the selection is decided beside the sum, from the strobes, into
        # registers that hold the bit XOR the stored bit (``x_sum``, ``x_alt``:
        # the Stable comparison comes with it), and ``w`` is the selected one
        # XOR the stored bit (old_r) after the clock edge: the same bit in
        # the same cycle as one ``w`` register behind the multiplexer.
        x_sum, x_alt, s_sum = Signal(), Signal(), Signal()
        # x_alt's two halves (saturating or not) are kept nets: one LUT4 each
        # from flip-flops, then one LUT4 with enable and Sel
        alt_sat, alt_free = Signal(attrs={"keep": 1}), Signal(attrs={"keep": 1})
        x_alt_next = Signal()
        m.d.comb += [alt_sat.eq((self.ph2 | (self.ph1 & self.Sat)) ^ old),
                     alt_free.eq(~(self.ph2 | const) & (hi ^ old)),
                     # the stored bit (check iteration, constant node, the
                     # flag of a constant) XOR itself is 0; the rest as above
                     x_alt_next.eq(self.enable & Mux(self.Sel, alt_sat, alt_free))]
        m.d.sync += [
            x_sum.eq((n0 & ~self.zero) ^ k[0] ^ old),
            x_alt.eq(x_alt_next),
            s_sum.eq(~self.ph2 & self.enable & ~self.Sel & ~const & ~self.ph1),
        ]
        changed = Signal()      # the bit on w differs from the stored one
        m.d.comb += [changed.eq(Mux(s_sum, x_sum, x_alt)), self.w.eq(changed ^ old_r)]

        # Stable: serial compare of the written word with the stored one;
        # the window starts with the flag's write (ph2 one cycle earlier
        # clears the record).  Its last bit (bit p, on w in cycle 2 of the
        # next iteration) is computed at u = 1 (ph1), where the sum is never
        # selected (s_sum is low then), so its comparison is x_alt's next
        # value: the flag is a register loaded at u = 1, valid from cycle 2
        # to the next cycle 1 (issue 17: the block's AND of all Stable flags,
        # Early, starts at flip-flops).
        diff = Signal()
        m.d.sync += diff.eq(~self.ph2 & (diff | changed))
        stable = Signal()
        with m.If(self.ph1):
            m.d.sync += stable.eq(~(diff | changed | x_alt_next))
        m.d.comb += self.stable.eq(stable)

        # Maximum, LSB first: ge[n] says h >= neighbour n on the bits seen so
        # far (the highest differing bit decides); masked cycles (pads, the
        # flag) restart it.  Its result is latched at u = 0, after bit p.
        ges = []
        for nb in (self.h_N, self.h_E, self.h_W, self.h_S):
            ge = Signal(init=1)
            m.d.sync += ge.eq(self.mask | ((self.h ^ nb) & self.h) | (~(self.h ^ nb) & ge))
            ges.append(ge)
        # (a free node: const changes at ph2 only, after cycle 2, so the
        # flag is one register, loaded at u = 0: issue 17, the block's OR of
        # all Maximum flags, Cvg, starts at flip-flops)
        lm = Signal()
        with m.If(self.z):
            m.d.sync += lm.eq(Cat(*ges).all() & ~const)
        m.d.comb += self.local_max.eq(lm)

        return m
