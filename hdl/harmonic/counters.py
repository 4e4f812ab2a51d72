"""Counters unit shared by the 18 nodes of a cluster (paper 000, section 5.2)."""

from amaranth.hdl import Cat, Module, Mux, Signal, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ...models.harmonic.ram import P_MIN, READ_LATENCY, WRITE_LATENCY
from ..params import Constraint, Param, check, checked_init
from .limits import DEPTH_WHY, MAX_DEPTH

__all__ = ["Counters", "le_const"]


def le_const(x, c):
    """x <= c for a constant c, as AND / OR gates from the LSB up (no carry chain)."""
    le = 1
    for i in range(len(x)):         # le: x[:i] <= c[:i]
        le = (~x[i] & le) if not (c >> i) & 1 else (~x[i] | le)
    return le if c < 1 << len(x) else 1


class Counters(wiring.Component):
    """RAM address counters and cycle strobes of one iteration.

    An iteration is L = p+2+S cycles u = 0 .. L-1 (S pad cycles: 0 for
    p >= 4, :func:`models.harmonic.pads`); the nodes see the flag at u = S
    and value bit k at u = S+1+k (see :class:`~hdl.harmonic.node.Node`).
    The RAM answers a read two cycles after its address (its output
    register), so the addresses run two cycles ahead of the nodes: in the
    cycle where the nodes are at u, the Counters present the offsets of
    :func:`models.harmonic.counters` (u + 2 mod L), and the strobes of u
    (:func:`models.harmonic.strobes`).  Every output is a register.

    * ``cntR`` (read port, LSB first): a down counter p+1 .. 1, then 0 for
      the pads and the flag (a pad counter of S+1 cycles at 0 reloads it).
    * ``r_cnt`` (MSB first, for the border's MSB-first reads with block
      exponents): 1 .. p+1 in the same slots, 0 in pads and at the flag.
    * ``cntW`` (write port): the same sequence as cntR five cycles later
      (two cycles of read latency, the two bit positions of eq. 2's division
      by four, one cycle of the nodes' write register): the address of the
      result bit the nodes' ``w`` registers hold.
    * strobes ``mask`` (u <= S), ``z`` (u = 0), ``ph1`` (u = 1), ``fl``
      (u = 2), ``ph2`` (u = S+2), ``wcyc`` (not 2 <= u <= S+1): the read
      slots' markers delayed to the nodes' cycle.  They hold their reset
      values in the first two cycles after ``start`` (the lead-in, before
      the first iteration's cycle 0).

    Parameters
    ----------
    p_max : int
        Largest precision; sets the counter widths.
    depth : int
        RAM depth in words (default p_max + 2): the absolute addresses' width.

    Ports
    -----
    p : In(range(p_max+1)); shift : In(1)
        Precision and the shift-visit flag (block exponents: one pad); both
        read at ``start``.
    start : In(1)
        Load the lead-in state: the next cycle presents the first
        iteration's slot u + 2 = 0, the nodes' cycle 0 comes two cycles
        later.
    advance : In(1)
        Step to the next cycle.
    cntR, r_cnt, cntW : Out(address width)
        The three RAM address offsets.
    base : In(range(depth)); addrR, addrW : Out(range(depth))
        The word base of the block (read at ``start``) and the absolute
        read / write addresses ``base + cntR`` and ``base + cntW``, counted
        in registers beside the offsets, so that the block RAM's address
        pins see a flip-flop and no adder (the clock's critical path).
    mask, z, ph1, fl, ph2, wcyc : Out(1)
        The nodes' cycle strobes (held while ``advance`` is low).
    mask_next : Out(1)
        ``mask`` of the next advancing cycle (a register: the cluster
        registers the nodes' adder mask from it).
    wcyc_next : Out(1)
        ``wcyc`` of the next cycle (after this cycle's ``start`` /
        ``advance``; the cluster registers the nodes' ``enable`` from it).
    """

    PARAMS = (Param("p_max", int, lo=2, hi=MAX_DEPTH - 2,
                    doc="largest precision; sets the counter widths (p_max + 2 <= the RAM depth <= 2**20)",
                    message="p_max must be an integer in 2..{hi} (a word of p_max + 2 bits fills at most a "
                            "2**20-word RAM), not {value!r}"),
              Param("depth", int, None, lo=4, hi=MAX_DEPTH,
                    doc="RAM depth in words, the absolute addresses' range (default p_max + 2)",
                    message=f"RAM depth must be an integer in 4..{MAX_DEPTH}, not {{value!r}} ({DEPTH_WHY})"))
    CONSTRAINTS = (
        Constraint("p_max + 2 <= depth", lambda p: p["depth"] is None or p["p_max"] + 2 <= p["depth"],
                   "precision p_max={p_max} needs words of p_max+2 bits, one per RAM address, "
                   "but the RAM depth is {depth}"),
    )

    @checked_init
    def __init__(self, p_max, depth=None):
        check(self.PARAMS, self.CONSTRAINTS, p_max=p_max, depth=depth)
        self.p_max = p_max
        self.depth = depth = p_max + 2 if depth is None else depth
        addr = unsigned((p_max + 1).bit_length())
        super().__init__({
            "base": In(range(depth)),
            "addrR": Out(range(depth)),
            "addrW": Out(range(depth)),
            "p": In(range(p_max + 1)),
            "shift": In(1),
            "start": In(1),
            "advance": In(1),
            "cntR": Out(addr),
            "r_cnt": Out(addr),
            "cntW": Out(addr),
            "mask_next": Out(1), "wcyc_next": Out(1),
            "mask": Out(1), "z": Out(1), "ph1": Out(1), "fl": Out(1), "ph2": Out(1), "wcyc": Out(1, init=1),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"iteration_cycles": "p+2 (p >= 4; max(p, 4)+2 below)",
                "read_lead": "addresses two cycles ahead of the strobes (the RAM's read latency)",
                "strobe_cycles": "z/ph1/fl at u = 0, 1, 2; ph2 at u = S+2; mask at u <= S"}

    def elaborate(self, platform):
        m = Module()
        lag = READ_LATENCY + WRITE_LATENCY + 2          # cntW follows cntR by this many cycles
        S = Signal(2)                                   # pad cycles of the run
        p1 = Signal.like(self.p, name="p_plus_1")       # reload value p + 1
        pad_max = P_MIN - 2                             # S <= 2
        assert pad_max < 4

        base_p1 = Signal.like(self.base, name="base_plus_p_plus_1")    # the absolute reload value

        def phase(value, q, absolute):
            """One read-slot counter: value p+1 .. 1, then 0 for S+1 cycles
            (q counts them), and base + value beside it; returns its flags
            (value == 0, value == 1, q == S).

            Timing (issue 17): the flags are registers, updated from the
            comparisons one slot earlier (value == 2, q + 1 == S), so that
            the multiplexers of the wide counters select on flip-flops and
            no comparator of the counter's width sits before their enables."""
            zero = Signal(name=f"{value.name}_zero", init=1)        # value == 0
            one = Signal(name=f"{value.name}_one")                  # value == 1
            q_end = Signal(name=f"{value.name}_q_end", init=1)      # q == S
            count_pad = zero & ~q_end
            # (value and absolute hold in the pad cycles, a clock enable, and
            # reload when zero and q == S; ``start`` loads them below)
            with m.If(self.advance & ~self.start & ~count_pad):
                m.d.sync += [value.eq(Mux(zero, p1, value - 1)),
                             absolute.eq(Mux(zero, base_p1, absolute - 1))]
            with m.If(self.advance & ~self.start):
                m.d.sync += [q.eq(Mux(count_pad, q + 1, 0)),
                             zero.eq(count_pad | one),          # a reload (p + 1 >= 3) is neither 0 nor 1
                             one.eq(~zero & (value == 2)),
                             q_end.eq(Mux(count_pad, q + 1 == S, S == 0))]
            return zero, one, q_end

        qR, qW = Signal(2), Signal(2)
        zR, oneR, qendR = phase(self.cntR, qR, self.addrR)
        reloadR = zR & qendR
        zW, oneW, qendW = phase(self.cntW, qW, self.addrW)
        with m.If(self.advance & ~self.start):
            m.d.sync += self.r_cnt.eq(Mux(reloadR, 1, Mux(zR | oneR, 0, self.r_cnt + 1)))

        # The read slot's markers, delayed to the nodes' cycle u (slot - 2).
        x0 = zR & (qR == 0)             # slot 0: u = 0 two cycles later
        pad = zR & ~qendR               # slot < S: u = slot + 2 writes nothing, two cycles after that
        chain = {}
        for name, src, n in (("mask", zR, 2), ("zc", x0, 4), ("ph2", reloadR, 4), ("pad", pad, 4)):
            regs = [Signal(name=f"{name}_d{i}") for i in range(1, n + 1)]
            with m.If(self.start):
                m.d.sync += [r.eq(0) for r in regs]
            with m.Elif(self.advance):
                m.d.sync += [regs[0].eq(src), *(b.eq(a) for a, b in zip(regs, regs[1:]))]
            chain[name] = regs
        m.d.comb += [
            self.mask.eq(chain["mask"][1]), self.mask_next.eq(chain["mask"][0]),
            self.z.eq(chain["zc"][1]), self.ph1.eq(chain["zc"][2]), self.fl.eq(chain["zc"][3]),
            self.ph2.eq(chain["ph2"][3]), self.wcyc.eq(~chain["pad"][3]),
            self.wcyc_next.eq(~Mux(self.start, 0, Mux(self.advance, chain["pad"][2], chain["pad"][3]))),
        ]

        # The lead-in: slot 0 next (cntR 0, its pad count 0); cntW five slots
        # behind, slot L-5 (L >= 6): a value slot (offset 5) for p >= 4, else
        # the pad / flag slot p + S - 3 <= S.
        s_new = Signal(2)
        small = Signal()        # p < P_MIN (gates: no carry chain on the start's paths)
        m.d.comb += [small.eq(le_const(self.p, P_MIN - 1)),
                     # P_MIN - p for p < P_MIN, a lookup of p's two low bits (no subtractor)
                     s_new.eq(Mux(small, Cat(*(Cat(*(self.p[:2] == v for v in range(P_MIN) if (P_MIN - v) >> b & 1)).any()
                                               for b in range(2))), self.shift))]
        with m.If(self.start):
            m.d.sync += [S.eq(s_new), p1.eq(self.p + 1), self.cntR.eq(0), qR.eq(0), self.r_cnt.eq(0),
                         base_p1.eq(self.base + self.p + 1), self.addrR.eq(self.base),
                         zR.eq(1), oneR.eq(0), qendR.eq(s_new == 0)]
            with m.If(small):
                m.d.sync += [self.cntW.eq(0), qW.eq(self.p + s_new - 3), self.addrW.eq(self.base),
                             zW.eq(1), oneW.eq(0), qendW.eq(self.p == 3)]    # q = p + S - 3 = 1 == S
            with m.Else():
                m.d.sync += [self.cntW.eq(lag), qW.eq(0), self.addrW.eq(self.base + lag),
                             zW.eq(0), oneW.eq(0), qendW.eq(s_new == 0)]
        return m
