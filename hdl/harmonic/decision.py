"""Decision module of the harmonic planner (paper 000, section 5.3)."""

from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from ..params import Param, check, checked_init

__all__ = ["Decision", "NEIGHBOURHOOD", "neighbourhood_layout"]

NEIGHBOURHOOD = ("c", "N", "E", "S", "W")     # the node, then its neighbours (DIRECTION's read order)


def neighbourhood_layout(p_max):
    """The values the Decision module reads (5.3): ``c`` the node's h, and
    ``N``, ``E``, ``S``, ``W`` its neighbours' h_N, h_E, h_S, h_W
    (p_max + 1 bits each)."""
    return data.StructLayout({k: p_max + 1 for k in NEIGHBOURHOOD})


class Decision(wiring.Component):
    """The steepest of the four triangles at the robot's node (5.3), bit-serial.

    The paper's rule: among the triangles NE, ES, SW, WN (in this order) of
    the node and two consecutive neighbours, the first one maximizing
    (h - h')^2 + (h - h'')^2; the direction is the gradient of that
    triangle's plane in grid axes (row down, column right): g_col = h_E - h
    or h - h_W, g_row = h_S - h or h - h_N.  Bit-exact with
    :func:`models.harmonic.steepest_triangle` (:func:`models.harmonic.decision`,
    and :func:`models.harmonic.decision_exponents` on converted neighbours).

    **No squares.**  Every triangle pairs one row neighbour (N or S) with
    one column neighbour (E or W), and its score is a sum of a row term and
    a column term, so the maximizing triangles are exactly the pairs of a
    maximizing row neighbour and a maximizing column neighbour: NE, ES,
    SW, WN are (N, E), (S, E), (S, W), (N, W).  The first of them in
    triangle order: with E among the best columns, NE if N is among the
    best rows, else ES; otherwise SW if S is among the best rows, else WN.
    Each of the two choices compares two squares exactly through
    (h - a)^2 - (h - b)^2 = (a - b)(a + b - 2h): a is at least as steep as
    b unless one of a - b and a + b - 2h is negative and the other
    positive.  Both signs come from LSB-first serial
    arithmetic: a - b with a borrow flip-flop, a + b - 2h with a carry in
    {-1, 0, 1} (two flip-flops; 2h is h one bit late), each with a
    "non-zero seen" flip-flop.  Area: these few flip-flops, the bit
    selection of the five held values and the two gradient registers, all
    linear in p_max; no multiplier.

    Pass 1 (bits 0 .. p+1, one per cycle) forms the two choices and the
    borrows of the four gradient candidates (their signs); pass 2 (bits
    0 .. p+1) subtracts the chosen pairs serially into g_row / g_col, which
    were set to their sign at its start (the sign extension above bit p+1).

    ===============  ===================================================
    cycle            what happens
    ===============  ===================================================
    0                ``start`` (``h`` and ``p`` held until ``done``)
    1 .. p+2         pass 1: bit i = 0 .. p+1 of the values
    p+3 .. 2p+4      pass 2: bit i = 0 .. p+1 of the gradients
    2p+5             ``done`` high for one cycle; the outputs hold until
                     the next ``start``
    ===============  ===================================================

    Parameters
    ----------
    p_max : int
        Largest precision (values are p_max+1 bits).

    Ports
    -----
    start : In(1)
    p : In(range(p_max + 1))
        The precision: the values are below 2^(p+1) (the fixed-point field
        is at most 2^p; a block-exponent neighbour clamps at 2^(p+1) - 1).
    h : In(:func:`neighbourhood_layout`)
        ``h.c`` the node's value (the paper's h), ``h.N``, ``h.E``, ``h.S``,
        ``h.W`` its neighbours' (h_N, h_E, h_S, h_W; 0 outside the map).
    done : Out(1); triangle : Out(2) (0 NE, 1 ES, 2 SW, 3 WN)
    g_row, g_col : Out(signed(p_max + 2))
    """

    PARAMS = (Param("p_max", int, lo=2, doc="largest precision",
                    message="precision p_max={value!r} is not supported: p must be at least 2"),)

    @checked_init
    def __init__(self, p_max):
        check(self.PARAMS, p_max=p_max)
        self.p_max = p_max
        w = p_max + 1
        super().__init__({
            "start": In(1), "p": In(range(p_max + 1)), "h": In(neighbourhood_layout(p_max)),
            "done": Out(1), "triangle": Out(2),
            "g_row": Out(signed(w + 1)), "g_col": Out(signed(w + 1)),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"decision_cycles": "done 2p+5 cycles after start (two serial passes of p+2 bits)"}

    def elaborate(self, platform):
        m = Module()
        w = self.p_max + 1
        i = Signal(range(w + 1))            # the bit of the pass: 0 .. p+1
        nxt = Signal(range(w + 1))          # the bit of the next cycle: i + 1, 0 after p+1
        top = Signal(range(w + 1))          # p+1, registered at start (p holds until done)
        last = Signal()
        m.d.comb += last.eq(i == top)
        pass1, pass2 = Signal(), Signal()

        # Bit i of every value (0 above bit p_max: i reaches p_max + 1), in a
        # flip-flop a cycle ahead: the serial arithmetic reads flip-flops
        # (issue 17: i -> selection -> borrows -> g_col was the planner's
        # critical path on the ECP5).  The bits come from a shift register
        # per value holding h >> nxt (nxt: the next cycle's bit), reloaded
        # from h where a pass starts again at bit 0, not from a
        # (p_max+2)-to-1 selection by nxt (at p_max 256 that 258:1 select was
        # the 6x3-block planner's path once the still blocks' choice was
        # prepared during the visit).  h holds from start to done.
        bit = {}
        # wrap == (nxt == top): the next cycle reads bit 0 again.  A register
        # following nxt and top (both 0 at reset): nxt's comparator before the
        # shift registers' reload was the 6x3-block planner's path (issue 17).
        wrap = Signal(init=1)
        for k in ("c", "N", "E", "S", "W"):
            bit[k] = Signal(name=f"bit_{k}")
            sr = Signal(w, name=f"bits_{k}")        # h >> nxt: bit 0 is the next bit
            m.d.sync += bit[k].eq(Mux(self.start, self.h[k][0], sr[0]))
            with m.If(self.start):
                m.d.sync += sr.eq(self.h[k] >> 1)
            with m.Elif(wrap):
                m.d.sync += sr.eq(self.h[k])
            with m.Else():
                m.d.sync += sr.eq(sr >> 1)
        c_prev = Signal()                   # bit i-1 of h: bit i of 2h
        m.d.sync += c_prev.eq(Mux(pass1 & ~last, bit["c"], 0))

        def serial_sub(name, x, y):
            """x - y LSB first: (result bit, borrow-out); the borrow is a
            flip-flop cleared at start."""
            b = Signal(name=f"borrow_{name}")
            t = Signal(2, name=f"diff_{name}")          # x - y - b as (borrow, bit)
            m.d.comb += t.eq(x - y - b)
            with m.If(self.start):
                m.d.sync += b.eq(0)
            with m.Elif(pass1):
                m.d.sync += b.eq(t[1])
            return t[0], b

        # Pass 1, per axis (a, b) = (N, S) and (E, W): the sign of
        # (h - a)^2 - (h - b)^2 = (a - b)(a + b - 2h).
        steeper, flatter = {}, {}
        for a, b in (("N", "S"), ("E", "W")):
            d_bit, d_neg = serial_sub(a + b, bit[a], bit[b])           # a - b
            d_nz = Signal(name=f"nz_{a}{b}")
            k = Signal(signed(2), name=f"carry_{a}{b}2h")               # a + b - 2h
            s = Signal(signed(4), name=f"sum_{a}{b}2h")
            x_nz = Signal(name=f"nz_{a}{b}2h")
            m.d.comb += s.eq(bit[a] + bit[b] - c_prev + k)
            with m.If(self.start):
                m.d.sync += [d_nz.eq(0), k.eq(0), x_nz.eq(0)]
            with m.Elif(pass1):
                m.d.sync += [d_nz.eq(d_nz | d_bit), k.eq(s >> 1), x_nz.eq(x_nz | s[0])]
            # After bit p+1: a - b < 0 iff it borrowed, a + b - 2h < 0 iff
            # k < 0 (a + b - 2h < 2^(p+2), so k is never +1 there).
            x_neg = k[1]
            d_pos, x_pos = ~d_neg & d_nz, ~x_neg & x_nz
            steeper[a] = Signal(name=f"steeper_{a}")    # a's term > b's
            flatter[a] = Signal(name=f"flatter_{a}")    # a's term < b's
            m.d.comb += [steeper[a].eq((d_pos & x_pos) | (d_neg & x_neg)),
                         flatter[a].eq((d_pos & x_neg) | (d_neg & x_pos))]
        # The four gradient candidates' signs (borrows of S - h, h - N, E - h, h - W).
        _, neg_s = serial_sub("Sc", bit["S"], bit["c"])
        _, neg_n = serial_sub("cN", bit["c"], bit["N"])
        _, neg_e = serial_sub("Ec", bit["E"], bit["c"])
        _, neg_w = serial_sub("cW", bit["c"], bit["W"])

        # The triangle: with E among the best columns (E not flatter than
        # W), NE if N is among the best rows, else ES; without E, SW if S
        # is among the best rows (N not steeper), else WN.  Final after
        # pass 1, held through pass 2 (pass 1's flip-flops hold).
        tri = Signal(2)
        m.d.comb += tri.eq(Mux(~flatter["E"], Mux(~flatter["N"], 0, 1), Mux(~steeper["N"], 2, 3)))
        use_s = Signal()                    # g_row = S - h (ES, SW), else h - N
        use_e = Signal()                    # g_col = E - h (NE, ES), else h - W
        m.d.comb += [use_s.eq((tri == 1) | (tri == 2)), use_e.eq(~flatter["E"])]

        # Pass 2: the chosen differences, bit i into position i; at bit 0
        # the bits above are set to the sign (the borrow of pass 1), which
        # the later bits overwrite up to bit p+1.
        pairs = ((self.g_row, use_s, (bit["S"], bit["c"]), (bit["c"], bit["N"]), neg_s, neg_n),
                 (self.g_col, use_e, (bit["E"], bit["c"]), (bit["c"], bit["W"]), neg_e, neg_w))
        for g, use, (x1, y1), (x2, y2), neg1, neg2 in pairs:
            b = Signal(name=f"borrow_{g.name}")
            t = Signal(2, name=f"diff_{g.name}")
            m.d.comb += t.eq(Mux(use, x1, x2) - Mux(use, y1, y2) - Mux(i == 0, 0, b))
            with m.If(pass2):
                m.d.sync += b.eq(t[1])
                with m.If(i == 0):
                    m.d.sync += g.eq(Cat(t[0], Mux(use, neg1, neg2).replicate(w)))
                with m.Else():
                    m.d.sync += g.bit_select(i, 1).eq(t[0])

        m.d.sync += self.done.eq(0)
        with m.If(self.start):
            m.d.sync += [pass1.eq(1), pass2.eq(0), i.eq(0), nxt.eq(1), top.eq(self.p + 1),
                         wrap.eq(self.p == 0)]
        with m.Elif(pass1 | pass2):
            m.d.sync += [i.eq(i + 1), nxt.eq(Mux(wrap, 0, nxt + 1)),
                         wrap.eq(Mux(wrap, top == 0, nxt + 1 == top))]
            with m.If(last):
                m.d.sync += i.eq(0)
                with m.If(pass1):
                    m.d.sync += [pass1.eq(0), pass2.eq(1)]
                with m.Else():
                    m.d.sync += [pass2.eq(0), self.done.eq(1), self.triangle.eq(tri)]
        return m
