"""Border nodes of a block: storage of the neighbouring blocks' edge values
(paper 000, sections 5.1 and 5.4)."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

__all__ = ["Border"]


class Border(wiring.Component):
    """The border nodes around an n x m block of a map of BR x BC blocks.

    Four RAMs, stored like the clusters' (one bit per address, word of block
    b at base ``b*stride``, flag first then value bits MSB first), keep every
    block's edges: ``top`` (row 0, m bits wide), ``bottom`` (row n-1),
    ``left`` (column 0, n bits) and ``right`` (column m-1).  They are written
    with the clusters' write port while the block that holds those nodes is
    computed (its base and ``cntW``), and by the host port at load.  While
    block b = br*BC + bc is computed, the border nodes stream, with the
    clusters' read addresses and one cycle of RAM latency like them:

    ==========  ==========================================  ===============
    border      the edge it reads                           block address
    ==========  ==========================================  ===============
    N (m bits)  bottom row of block b-BC                    B-k (k = BC)
    S (m bits)  top row of block b+BC                       B+k
    W (n bits)  right column of block b-1                   B-1
    E (n bits)  left column of block b+1                    B+1
    ==========  ==========================================  ===============

    A border outside the map (br = 0 for N, br = BR-1 for S, bc = 0 for W,
    bc = BC-1 for E) generates the constant 0 (an obstacle).  Both read
    streams exist for every side: ``h_*`` at ``base + cntR`` (LSB first, the
    Update) and ``m_*`` at ``base + r_cnt`` (MSB first, the Maximum).

    Parameters
    ----------
    n, m : int
        Block rows and columns.
    blocks : (BR, BC)
        Block rows and columns of the map.
    stride : int
        RAM words per block (p_max + 2).
    segment : (rows, cols)
        The cluster size: each edge is stored as one RAM per cluster segment
        (written whole; ``en_*`` is read once per segment, at its first bit).

    Ports
    -----
    br, bc : In
        Row and column of the block being computed (held during the visit).
    cntR, r_cnt : In
        The clusters' read address offsets (relative to a block base).
    w_addr : In(range(depth)); w_top, w_bottom : In(m); w_left, w_right : In(n)
    en_top, en_bottom : In(m); en_left, en_right : In(n)
        Edge write: absolute address, bits and enables (one per segment,
        given on each of its bits).
    h_N, h_S, m_N, m_S : Out(m); h_W, h_E, m_W, m_E : Out(n)
        The border streams.
    """

    def __init__(self, n, m, blocks, stride, segment=(3, 6)):
        BR, BC = blocks
        self.seg_rows, self.seg_cols = segment
        for name, v in (("n", n), ("m", m), ("BR", BR), ("BC", BC), ("stride", stride)):
            if not isinstance(v, int) or v < 1:
                raise ValueError(f"{name}={v!r}: must be an integer >= 1")
        self.n, self.m, self.BR, self.BC, self.stride = n, m, BR, BC, stride
        self.depth = BR * BC * stride
        super().__init__({
            "br": In(range(max(BR, 2))), "bc": In(range(max(BC, 2))),
            "cntR": In(range(stride)), "r_cnt": In(range(stride)),
            "w_addr": In(range(self.depth)),
            "w_top": In(m), "w_bottom": In(m), "w_left": In(n), "w_right": In(n),
            "en_top": In(m), "en_bottom": In(m), "en_left": In(n), "en_right": In(n),
            "h_N": Out(m), "h_S": Out(m), "h_W": Out(n), "h_E": Out(n),
            "m_N": Out(m), "m_S": Out(m), "m_W": Out(n), "m_E": Out(n),
        })

    def elaborate(self, platform):
        m = Module()
        S, BC = self.stride, self.BC
        b = Signal(range(max(self.BR * BC, 2)))
        m.d.comb += b.eq(self.br * BC + self.bc)
        sides = (
            # (RAM, width, data, enable, out side, source-block offset, valid)
            ("bottom", self.m, self.w_bottom, self.en_bottom, "N", -BC, self.br != 0),
            ("top", self.m, self.w_top, self.en_top, "S", BC, self.br != self.BR - 1),
            ("right", self.n, self.w_right, self.en_right, "W", -1, self.bc != 0),
            ("left", self.n, self.w_left, self.en_left, "E", 1, self.bc != BC - 1),
        )
        for name, width, data, en, side, offset, valid in sides:
            seg = self.seg_cols if name in ("top", "bottom") else self.seg_rows
            src = Signal(range(self.depth), name=f"src_{side}")
            m.d.comb += src.eq(Mux(valid, (b + offset) * S, 0))
            # The validity of the data follows its address by one cycle.
            ok = Signal(name=f"ok_{side}")
            m.d.sync += ok.eq(valid)
            # One RAM per cluster edge segment (6 columns / 3 rows): a cluster
            # writes its whole segment at once (at load the host writes one
            # cluster), so no per-bit write enables, which would split the
            # storage into 1-bit-wide block RAMs.
            for k in range(width // seg):
                sl = slice(k * seg, (k + 1) * seg)
                ram = Memory(shape=seg, depth=self.depth, init=[])
                m.submodules[f"ram_{name}_{k}"] = ram
                wp = ram.write_port()
                lsb, msb = ram.read_port(), ram.read_port()
                m.d.comb += [
                    wp.addr.eq(self.w_addr), wp.data.eq(data[sl]), wp.en.eq(en[k * seg]),
                    lsb.addr.eq(src + self.cntR), msb.addr.eq(src + self.r_cnt),
                    getattr(self, f"h_{side}")[sl].eq(Mux(ok, lsb.data, 0)),
                    getattr(self, f"m_{side}")[sl].eq(Mux(ok, msb.data, 0)),
                ]
        return m
