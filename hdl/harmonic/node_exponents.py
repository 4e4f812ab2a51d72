"""Node exponents (issue 22): the node update of models.harmonic.node_exponents as a pipeline."""

from amaranth.hdl import Cat, Const, Module, Mux, Signal, signed
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from navcores.models.harmonic.node_exponents import GUARD, P_LIMIT

from ..params import Constraint, Param, check, checked_init

__all__ = ["NodeExponentUpdate", "word_layout", "neighbours_layout", "NEIGHBOURS", "E_MAX_LIMIT"]

NEIGHBOURS = ("N", "E", "W", "S")       # eq. 2's four, in the model's order (node_update's columns)
E_MAX_LIMIT = (1 << 16) - 1             # 16-bit exponents: 6x the whole 512x512 maze's 10,288


def word_layout(p, e_max):
    """One node's word: mantissa ``v`` (p+1 bits, low) and exponent ``e``
    (``e_max.bit_length()`` bits, above it); the value is v / 2**(p+e)."""
    return data.StructLayout({"v": p + 1, "e": e_max.bit_length()})


def neighbours_layout(p, e_max):
    """The four neighbours' words, N at the low bits, then E, W, S."""
    w = word_layout(p, e_max)
    return data.StructLayout({k: w for k in NEIGHBOURS})


def _leading_one(x):
    """(any, pos): ``x`` non-zero, and the index of its highest set bit
    (bit_length - 1; 0 when x is 0) as a balanced tree of 2:1 multiplexers
    (log2 levels, where a priority chain would be one level per bit)."""
    n = 1 << max(1, (len(x) - 1).bit_length())
    bits = [x[i] if i < len(x) else Const(0, 1) for i in range(n)]
    # the first level by hand: a pair's position is its high bit (no zero-width multiplexer)
    nodes = [(lo | hi, hi) for lo, hi in zip(bits[0::2], bits[1::2])]
    while len(nodes) > 1:
        nodes = [(a_lo | a_hi, Cat(Mux(a_hi, p_hi, p_lo), a_hi))
                 for (a_lo, p_lo), (a_hi, p_hi) in zip(nodes[0::2], nodes[1::2])]
    return nodes[0]


class NodeExponentUpdate(wiring.Component):
    """The node update of node exponents (issue 22), one per clock.

    Eq. 2 of paper 000 (the harmonic planner): a free node's new
    value is the mean of its four neighbours, x = (x_N + x_E + x_W + x_S) / 4,
    here on words of the node-exponent format, bit-exact with
    :func:`models.harmonic.node_exponents.node_update`.

    Number format: a word is a mantissa v (p+1 bits) and an exponent e
    (0 .. e_max, ``e_max.bit_length()`` bits), value v / 2**(p+e); zero
    is v = 0 (the model writes e = e_max).  A normalized word has its top
    h = ``headroom`` bits empty, 2**(p-h) <= v < 2**(p+1-h); at e = e_max a
    smaller v is a denormal; at e = 0 a value of 2**-h or more (next to a
    goal, 1.0 = 2**p at e = 0) uses the headroom bits.

    The update: r = the smallest exponent of the non-zero neighbours; each
    mantissa aligned to r with GUARD = 2 guard bits, floor((v << 2) >> (e -
    r)); the four summed exactly (S, p+5 bits); S normalized to p+1-h
    significant bits by one flooring shift and the exponent set to match,
    clamped to [0, e_max] (at e_max the shift goes further right: a
    denormal, or zero; at 0 the mantissa keeps its headroom bits).  A zero
    result is (0, e_max).  With b = bit_length(S) and rc = r + 4 + p+1-h:
    e = clamp(rc - b) and the shift of S << (p-h) to the right is rc - 1 -
    e, i.e. b - 1 unclamped.

    Pipeline: every stage moves on together, on each clock unless the
    output beat is stalled (``o_stream.valid`` high, ``o_stream.ready``
    low); so a stalled output holds every stage's data (bubbles included),
    ``i_stream.ready`` is low exactly while it is stalled, and a full
    pipeline takes an input in the cycle it delivers an output: one result
    per clock without stalls.  ``o_stream.valid`` is a register.

    =======  ============================================================
    stage    registers at its end (the work before them)
    =======  ============================================================
    1        the four words; min(N, E) and min(W, S) of the keys
             (e, zero): a zero word sorts after every non-zero one
    2        r = min of the two (the smallest non-zero exponent)
    3        the four alignment shifts e_j - r (saturated); from r alone:
             rc - 1 and the clamps' thresholds (clipped to a few bits)
    4        the aligned mantissas, (v_j << 2) >> shift (barrel shifters)
    5        N + E and W + S
    6        S, the exact four-operand sum (p+5 bits)
    7        the leading one of S (pos = b - 1, a tree), S
    8        e (clamped, e_max for zero), the normalizing shift, S
    9        v = ((S << (p-h)) >> shift)[p:0] (barrel shifter), e: the
             output payload, ``o_stream.valid``
    =======  ============================================================

    ``LATENCY`` = 9: without back-pressure, an output handshake exactly 9
    cycles after its input's; initiation interval 1.  No stage has two
    carry chains in a row (a first version, 8 stages with the sum in one,
    the thresholds as adders in a row and a per-stage ready chain, closed
    at 81 MHz on the LFE5U-85F; this one at 156.5, hdl/harmonic/README.md).

    Parameters
    ----------
    p : int
        Word precision, 4 .. 48 (the model's P_LIMIT): p+1 mantissa bits.
    e_max : int
        Largest exponent, 1 .. 65535; exponents are ``e_max.bit_length()``
        bits (14 for the whole 512x512 maze's 10,288).
    headroom : int
        h, the empty top bits of a normalized word, 0 .. p-2 (default 2).

    Ports
    -----
    i_stream : In(stream.Signature(:func:`neighbours_layout`))
        The four neighbours' words ``N``, ``E``, ``W``, ``S``, each
        ``{v, e}``; a word with e > e_max is outside the format.
    o_stream : Out(stream.Signature(:func:`word_layout`))
        The new word ``{v, e}``, one per input, in order.

    Synchronous reset (``rst``) empties the pipeline: every valid and every
    data register to 0.
    """

    LATENCY = 9

    PARAMS = (
        Param("p", int, lo=4, hi=P_LIMIT, doc="word precision: p+1 mantissa bits (the model's P_LIMIT)",
              message="p = {value!r}: node exponents take 4 <= p <= {hi} (the model's P_LIMIT)"),
        Param("e_max", int, lo=1, hi=E_MAX_LIMIT,
              doc="largest exponent (e_max.bit_length() exponent bits; 10288 on the whole 512x512 maze)",
              message="e_max = {value!r}: take 1 <= e_max <= {hi} (exponents of at most 16 bits)"),
        Param("headroom", int, 2, lo=0, hi=P_LIMIT - 2, doc="empty top mantissa bits of a normalized word",
              message="headroom = {value!r}: take 0 <= headroom <= p - 2"),
    )
    CONSTRAINTS = (
        Constraint("headroom <= p - 2", lambda v: v["headroom"] <= v["p"] - 2,
                   "headroom = {headroom}: take 0 <= headroom <= p - 2 = {p_2} (a normalized word keeps "
                   "at least 3 significant bits)", extra=lambda v: {"p_2": v["p"] - 2}),
    )

    @checked_init
    def __init__(self, p, e_max, headroom=2):
        check(self.PARAMS, self.CONSTRAINTS, p=p, e_max=e_max, headroom=headroom)
        self.p, self.e_max, self.headroom = p, e_max, headroom
        self.exponent_bits = e_max.bit_length()
        super().__init__({
            "i_stream": In(stream.Signature(neighbours_layout(p, e_max))),
            "o_stream": Out(stream.Signature(word_layout(p, e_max))),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"latency_cycles": self.LATENCY, "initiation_interval_cycles": 1,
                "latency": "i_stream handshake to o_stream handshake, no back-pressure"}

    def elaborate(self, platform):
        m = Module()
        p, h, e_max, ew = self.p, self.headroom, self.e_max, self.exponent_bits
        aw = p + 1 + GUARD              # an aligned mantissa: (v << G) < 2**(p+1+G)
        sw = aw + 2                     # S: four of them
        sig = p + 1 - h                 # significant bits of a normalized mantissa
        smax = sw + sig - 1             # width of S << (p-h): a shift this far leaves nothing
        n_stages = self.LATENCY

        # Handshake: one enable for every stage, ``go``: the pipeline moves
        # on unless its output beat is stalled (valid and not ready).  Not a
        # per-stage "take when empty or moving" chain, which would close up
        # bubbles behind a stall but puts one LUT a stage between
        # o_stream.ready and the first stage's clock enables (that chain was
        # the critical path, 7.1 ns, on the LFE5U-85F).  i_stream.ready is
        # ``go``: ready may follow ready, valid never does.
        valid = [Signal(name=f"valid{k}") for k in range(1, n_stages + 1)]
        go = Signal(name="go")
        m.d.comb += go.eq(~valid[-1] | self.o_stream.ready)
        with m.If(go):
            m.d.sync += [valid[k].eq(valid[k - 1] if k else self.i_stream.valid) for k in range(n_stages)]
        m.d.comb += [self.i_stream.ready.eq(go), self.o_stream.valid.eq(valid[-1])]

        def stage(k, name, value, shape=None):
            """A register of stage k (1-based, for its name) loaded with ``value`` when the pipeline moves."""
            reg = Signal(shape if shape is not None else value.shape(), name=f"s{k}_{name}")
            with m.If(go):
                m.d.sync += reg.eq(value)
            return reg

        def carry(k, regs):
            return {name: stage(k, name, reg) for name, reg in regs.items()}

        nb = self.i_stream.payload

        def smaller(a, b, name):
            """(e, zero) of the smaller of two (e, zero) keys: a zero word's
            key is above every non-zero one's, so the smallest key is the
            smallest non-zero exponent whenever there is one (and S = 0, the
            result zero, whatever r is when there is none).  The exponents'
            comparator runs beside the zero flags, not after them."""
            (ea, za), (eb, zb) = a, b
            lt = Signal(name=f"lt_{name}")
            m.d.comb += lt.eq(eb < ea)
            pick_b = za | (~zb & lt)
            return Mux(pick_b, eb, ea), Mux(pick_b, zb, za)

        # Stage 1: the min of pairs (N, E) and (W, S).
        pair = {}
        for a, b in (("N", "E"), ("W", "S")):
            e, z = smaller((nb[a].e, nb[a].v == 0), (nb[b].e, nb[b].v == 0), a + b)
            pair[a + b] = (stage(1, f"min{a}{b}_e", e), stage(1, f"min{a}{b}_z", z))
        v1 = {k: stage(1, f"v{k}", nb[k].v) for k in NEIGHBOURS}
        e1 = {k: stage(1, f"e{k}", nb[k].e) for k in NEIGHBOURS}

        # Stage 2: r.
        r2 = stage(2, "r", smaller(pair["NE"], pair["WS"], "r")[0])
        v2, e2 = carry(2, {f"v{k}": v1[k] for k in NEIGHBOURS}), carry(2, {f"e{k}": e1[k] for k in NEIGHBOURS})

        # Stage 3: the alignment shifts: e_j - r, saturated where it has
        # bits above the shift amount's kb = bit_length(p+3) (a zero word's
        # shift does not matter, its v is 0).  No compare with p+3 after
        # the subtractor (a second carry chain, the critical path at 149
        # MHz): a shift of p+3 .. 2**kb - 1 leaves nothing of the p+3-bit
        # (v << 2) either.
        sh3 = {}
        kb = aw.bit_length()
        for k in NEIGHBOURS:
            d = Signal(signed(ew + 1), name=f"gap{k}")
            m.d.comb += d.eq(e2[f"e{k}"] - r2)
            sat = d[-1] | (d[kb:ew].any() if ew > kb else Const(0, 1))
            sh3[k] = stage(3, f"sh{k}", Mux(sat, (1 << kb) - 1, d[:kb]), kb)
        v3 = carry(3, v2)
        # ... and what stage 8 needs from r, off its path.  With
        # rc = r + G + 2 + (p+1-h) (e unclamped = rc - b, b = pos + 1):
        #   udf: e < 0       <=> b > rc           <=> pos >= rc
        #   ovf: e > e_max   <=> b < rc - e_max   <=> pos < rc - e_max - 1
        #   shift of S << (p-h) to the right: rc - 1 - e: pos, rc - 1 (udf), rc - 1 - e_max (ovf)
        # pos < sw always, so each threshold is clipped to [0, sw] (stage 8
        # compares pos with a few bits only).  Each is r + c clipped: r
        # compared with two constants beside a short adder of r's low bits
        # (the clipped value's bits), never adders in a row.
        c_rc = GUARD + 2 + sig

        def affine(c, hi, name):
            """clamp(r + c, 0, hi) for a constant c."""
            k = hi.bit_length()
            out = Signal(range(hi + 1), name=name)
            low = Signal(k, name=f"{name}_low")
            m.d.comb += low.eq(r2[:k] + (c % (1 << k)))     # r + c mod 2**k: exact when 0 <= r + c <= hi
            m.d.comb += out.eq(Mux(r2 < -c, 0, Mux(r2 > hi - c, hi, low)) if -c > 0 else
                               Mux(r2 > hi - c, hi, low))
            return stage(3, name, out)

        ex3 = {"rcm1": stage(3, "rcm1", r2 + (c_rc - 1), range((1 << ew) + c_rc)),
               "udf_at": affine(c_rc, sw, "udf_at"), "ovf_at": affine(c_rc - e_max - 1, sw, "ovf_at"),
               "s_udf": affine(c_rc - 1, smax, "s_udf"),
               "s_ovf": affine(c_rc - e_max - 1, smax, "s_ovf")}

        # Stage 4: the aligned mantissas (floor: the bits shifted out are dropped).
        a4 = {k: stage(4, f"a{k}", (Cat(Const(0, GUARD), v3[f"v{k}"]) >> sh3[k])[:aw], aw) for k in NEIGHBOURS}
        ex4 = carry(4, ex3)

        # Stages 5 and 6: the exact sum, two adders then one (a carry chain a stage).
        s5 = {"NE": stage(5, "NE", a4["N"] + a4["E"], aw + 1), "WS": stage(5, "WS", a4["W"] + a4["S"], aw + 1)}
        ex5 = carry(5, ex4)
        s6 = stage(6, "S", s5["NE"] + s5["WS"], sw)
        ex6 = carry(6, ex5)

        # Stage 7: the leading one.
        nz, pos = _leading_one(s6)
        nz7 = stage(7, "nz", nz)
        pos7 = stage(7, "pos", pos)
        s7 = stage(7, "S", s6)
        ex7 = carry(7, ex6)

        # Stage 8: the clamps, the exponent and the shift.
        udf, ovf = Signal(name="udf"), Signal(name="ovf")
        m.d.comb += [udf.eq(pos7 >= ex7["udf_at"]), ovf.eq(pos7 < ex7["ovf_at"])]
        # A zero result has e = e_max: S = 0, or at e_max (ovf) a sum below
        # the smallest denormal, which the shift below makes v = 0 by itself.
        e_norm = Signal(ew, name="e_norm")
        m.d.comb += e_norm.eq(ex7["rcm1"] - pos7)
        e8 = stage(8, "e", Mux(~nz7 | ovf, e_max, Mux(udf, 0, e_norm)), ew)
        sh8 = stage(8, "shift", Mux(udf, ex7["s_udf"], Mux(ovf, ex7["s_ovf"], pos7)), range(smax + 1))
        s8 = stage(8, "S", s7)

        # Stage 9: the normalizing shift (one floor), into the output registers.
        v9 = stage(9, "v", (Cat(Const(0, p - h), s8) >> sh8)[:p + 1], p + 1)
        e9 = stage(9, "e", e8)
        m.d.comb += [self.o_stream.payload.v.eq(v9), self.o_stream.payload.e.eq(e9)]
        return m
