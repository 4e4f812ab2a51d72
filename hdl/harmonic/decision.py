"""Decision module of the harmonic planner (paper 000, section 5.3)."""

from amaranth.hdl import Module, Mux, Signal, signed
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

__all__ = ["Decision", "NEIGHBOURHOOD", "neighbourhood_layout"]

NEIGHBOURHOOD = ("c", "N", "E", "S", "W")     # the node, then its neighbours (DIRECTION's read order)


def neighbourhood_layout(p_max):
    """The values the Decision module reads (5.3): ``c`` the node's h, and
    ``N``, ``E``, ``S``, ``W`` its neighbours' h_N, h_E, h_S, h_W
    (p_max + 1 bits each)."""
    return data.StructLayout({k: p_max + 1 for k in NEIGHBOURHOOD})


class Decision(wiring.Component):
    """The steepest of the four triangles at the robot's node (5.3).

    Given the node's value h and its neighbours' h_N, h_E, h_S, h_W (0
    outside the map), it walks the four triangles NE, ES, SW, WN (in this
    order, one per cycle, as a small sequential program) and keeps the first
    one maximizing (h - h')^2 + (h - h'')^2; the direction is the gradient of
    that triangle's plane in grid axes (row down, column right):
    g_col = h_E - h or h - h_W, g_row = h_S - h or h - h_N.  Equal slopes:
    the earlier triangle wins.  Bit-exact with :func:`models.harmonic.decision`.

    ==========  =================================================
    cycle       what happens
    ==========  =================================================
    0           ``start`` (values held until ``done``)
    1 .. 4      triangle t = 0 .. 3 scored and compared
    5           ``done`` high for one cycle, outputs valid until
                the next ``start``
    ==========  =================================================

    Parameters
    ----------
    p_max : int
        Largest precision (values are p_max+1 bits).

    Ports
    -----
    start : In(1); h : In(:func:`neighbourhood_layout`)
        ``h.c`` the node's value (the paper's h), ``h.N``, ``h.E``, ``h.S``,
        ``h.W`` its neighbours' (h_N, h_E, h_S, h_W)
    done : Out(1); triangle : Out(2); g_row, g_col : Out(signed(p_max+2))
    """

    def __init__(self, p_max):
        if not isinstance(p_max, int) or p_max < 2:
            raise ValueError(f"precision p_max={p_max!r} is not supported: p must be at least 2")
        self.p_max = p_max
        w = p_max + 1
        super().__init__({
            "start": In(1), "h": In(neighbourhood_layout(p_max)),
            "done": Out(1), "triangle": Out(2),
            "g_row": Out(signed(w + 1)), "g_col": Out(signed(w + 1)),
        })

    def elaborate(self, platform):
        m = Module()
        w = self.p_max + 1
        t = Signal(3)
        busy = Signal()
        best = Signal(2 * w + 1)
        d = {s: Signal(signed(w + 1), name=f"d_{s}") for s in "NESW"}   # h' - h
        for s in "NESW":
            m.d.comb += d[s].eq(self.h[s] - self.h.c)
        pairs = (("N", "E"), ("E", "S"), ("S", "W"), ("W", "N"))
        da, db = Signal(signed(w + 1)), Signal(signed(w + 1))
        with m.Switch(t):
            for i, (a, b) in enumerate(pairs):
                with m.Case(i):
                    m.d.comb += [da.eq(d[a]), db.eq(d[b])]
        score = Signal(2 * w + 1)
        m.d.comb += score.eq(da * da + db * db)

        m.d.sync += self.done.eq(0)
        with m.If(self.start):
            m.d.sync += [busy.eq(1), t.eq(0), best.eq(0), self.triangle.eq(0)]
        with m.Elif(busy):
            with m.If((t == 0) | (score > best)):
                m.d.sync += [best.eq(score), self.triangle.eq(t)]
            m.d.sync += t.eq(t + 1)
            with m.If(t == 3):
                m.d.sync += [busy.eq(0), self.done.eq(1)]
        tri = self.triangle
        # The plane's gradient: along the column, h_E - h if E is in the pair,
        # else h - h_W; along the row, h_S - h if S is in it, else h - h_N.
        m.d.comb += [
            self.g_col.eq(Mux((tri == 0) | (tri == 1), d["E"], -d["W"])),
            self.g_row.eq(Mux((tri == 1) | (tri == 2), d["S"], -d["N"])),
        ]
        return m
