"""An n x m block of 3x6 clusters with its border nodes (paper 000, 5.1, 5.4)."""

from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..params import Constraint, Param, check
from .border import Border
from .cluster import COLS, NODES, ROWS, Cluster

__all__ = ["Block"]


class Block(wiring.Component):
    """n x m node modules as (n/3) x (m/6) clusters, time-multiplexed over the
    B = BR x BC blocks of the map, surrounded by :class:`Border` nodes.

    RAM layout: every cluster RAM holds, for every block b, its 18 nodes'
    words at base ``b * (p_max + 2)`` (flag, then value bits MSB first, one
    bit per address: :func:`models.harmonic.ram_image`), so a precision
    increase only appends LSB addresses, which were zeroed at load.  A map
    that does not fit, B * (p_max + 2) > depth, is refused at elaboration.

    All clusters run in lockstep on the same commands (see
    :class:`~hdl.harmonic.cluster.Cluster` for the iteration timing); the
    block ANDs their Stable flags (the Early module of Fig. 8) and ORs their
    Maximum flags (Cvg).  Cluster (i, j) covers rows 3i..3i+2 and columns
    6j..6j+5 of the block; node (row, col) is bit 6*(row%3) + col%6 of its
    cluster's word.

    Parameters
    ----------
    n, m : int
        Block size, n a multiple of 3, m a multiple of 6.
    blocks : (BR, BC)
        Blocks of the map (row-major order, b = br*BC + bc).
    p_max : int
        Largest precision (stride p_max + 2 words per block).
    depth : int
        Words per cluster RAM (1024: the paper's 1Kx18 block RAM).

    Ports
    -----
    run, p, enable, clear, Sat : In
        The clusters' commands (sampled at ``take``; ``p`` at start).
    sel, sel_row, sel_col : In
        Sel of the single node (sel_row, sel_col), when ``sel`` is high.
    br, bc : In
        The block being computed (hold during the visit).
    take, done, checked, busy : Out(1)
        Cluster 0's strobes (all clusters are in lockstep).
    all_stable, any_max : Out(1)
        Early (AND of every node's Stable) and Cvg (OR of the Maximum flags).
    host_addr : In(range(depth)); host_cluster : In; host_wdata : In(18)
    host_we : In(1); host_rdata : Out(18)
        Idle RAM access to cluster ``host_cluster`` (read data one cycle
        later); a write also updates the border storage of the edge nodes.
    """

    # hdl.emit's names: br, bc are ``blocks`` = (BR, BC).
    PARAMS = (
        Param("n", int, lo=ROWS, doc=f"block rows, a multiple of {ROWS}",
              message=f"block rows n={{value!r}}: must be a positive multiple of {ROWS}"),
        Param("m", int, lo=COLS, doc=f"block columns, a multiple of {COLS}",
              message=f"block columns m={{value!r}}: must be a positive multiple of {COLS}"),
        Param("br", int, 1, lo=1, doc="block rows of the map (BR)",
              message="blocks: BR={value!r} must be an integer >= 1"),
        Param("bc", int, 1, lo=1, doc="block columns of the map (BC)",
              message="blocks: BC={value!r} must be an integer >= 1"),
        Param("p_max", int, 30, lo=2, doc="largest precision",
              message="precision p_max={value!r} is not supported: p must be at least 2"),
        Param("depth", int, 1024, lo=1, doc="words per cluster RAM"),
        Param("exponents", bool, False, doc="block exponents (issue 10, beyond the paper)",
              message="exponents={value!r}: must be True or False"),
        Param("e_max", int, 255, lo=1, doc="largest block exponent (with exponents)",
              message="e_max={value!r}: must be an integer >= 1"),
    )
    CONSTRAINTS = (
        Constraint(f"n % {ROWS} == 0", lambda p: p["n"] % ROWS == 0,
                   f"block rows n={{n!r}}: must be a positive multiple of {ROWS}"),
        Constraint(f"m % {COLS} == 0", lambda p: p["m"] % COLS == 0,
                   f"block columns m={{m!r}}: must be a positive multiple of {COLS}"),
        Constraint("br * bc * (p_max + 2) <= depth",
                   lambda p: p["br"] * p["bc"] * (p["p_max"] + 2) <= p["depth"],
                   "a map of {br}x{bc} = {b} blocks at p_max={p_max} needs "
                   "{b} * (p_max+2) = {words} words per cluster RAM, but the RAM depth is {depth}",
                   lambda p: {"b": p["br"] * p["bc"], "words": p["br"] * p["bc"] * (p["p_max"] + 2)}),
    )

    def __init__(self, n, m, blocks=(1, 1), p_max=30, depth=1024, exponents=False, e_max=255):
        BR, BC = blocks
        check(self.PARAMS, self.CONSTRAINTS, n=n, m=m, br=BR, bc=BC, p_max=p_max, depth=depth,
              exponents=exponents, e_max=e_max)
        stride = p_max + 2
        self.n, self.m, self.BR, self.BC = n, m, BR, BC
        self.p_max, self.depth, self.stride = p_max, depth, stride
        self.CR, self.CC = n // ROWS, m // COLS
        self.exponents, self.e_max = bool(exponents), e_max
        extra = {}
        if self.exponents:
            # Block exponents (issue 10; see Border and Cluster): the border
            # conversion and scan, the shift iteration, and what the
            # re-pick needs: ``lead_own`` (the smallest value offset, 1..p+1,
            # written with a 1 since ``scan``; stride = none: the block's
            # largest value, as values only rise within a visit),
            # ``lead_N..E`` (the same for the raw neighbour edges while
            # ``raw``), ``all_const`` (every node constant, from the flags
            # of the visit's first iteration).
            sw = signed(e_max.bit_length() + 1)          # as Border's s_*
            L = range(stride + 1)
            extra = {"shift": In(1), "shift_d": In(signed((p_max + 1).bit_length() + 1)),
                     "s_N": In(sw), "s_S": In(sw), "s_W": In(sw), "s_E": In(sw), "raw": In(1),
                     "scan": In(1), "scan_busy": Out(1), "scan_len": Out(L), "clamped": Out(1),
                     "lead_own": Out(L), "lead_N": Out(L), "lead_S": Out(L), "lead_W": Out(L),
                     "lead_E": Out(L), "all_const": Out(1)}
        super().__init__({
            **extra,
            "run": In(1), "p": In(range(p_max + 1)), "enable": In(1), "clear": In(1),
            "Sat": In(1), "sel": In(1), "sel_row": In(range(n)), "sel_col": In(range(m)),
            "br": In(range(max(BR, 2))), "bc": In(range(max(BC, 2))),
            "take": Out(1), "done": Out(1), "checked": Out(1), "busy": Out(1),
            "all_stable": Out(1), "any_max": Out(1),
            "host_addr": In(range(depth)), "host_cluster": In(range(max(self.CR * self.CC, 2))),
            "host_wdata": In(NODES), "host_we": In(1), "host_rdata": Out(NODES),
        })

    def elaborate(self, platform):
        m = Module()
        n, mm, CR, CC, S = self.n, self.m, self.CR, self.CC, self.stride
        if self.exponents:
            border = Border(n, mm, (self.BR, self.BC), S, exponents=True, e_max=self.e_max)
        else:
            border = Border(n, mm, (self.BR, self.BC), S)
        m.submodules.border = border
        ekw = {"exponents": True} if self.exponents else {}
        cl = [[Cluster(depth=self.depth, p_max=self.p_max, **ekw) for _ in range(CC)] for _ in range(CR)]
        base = Signal(range(self.depth))
        m.d.comb += base.eq((self.br * self.BC + self.bc) * S)

        def bit(r, c):
            return COLS * r + c

        stables, maxes = [], []
        for i in range(CR):
            for j in range(CC):
                c = cl[i][j]
                k = i * CC + j
                m.submodules[f"cluster_{i}_{j}"] = c
                sel = Signal(NODES, name=f"sel_{i}_{j}")
                for r in range(ROWS):
                    for q in range(COLS):
                        m.d.comb += sel[bit(r, q)].eq(
                            self.sel & (self.sel_row == ROWS * i + r) & (self.sel_col == COLS * j + q))
                m.d.comb += [
                    c.run.eq(self.run), c.p.eq(self.p), c.enable.eq(self.enable),
                    c.clear.eq(self.clear), c.Sat.eq(self.Sat), c.Sel.eq(sel), c.base.eq(base),
                    c.host_addr.eq(self.host_addr), c.host_wdata.eq(self.host_wdata),
                    c.host_we.eq(self.host_we & (self.host_cluster == k)),
                ]
                with m.If(self.host_cluster == k):
                    m.d.comb += self.host_rdata.eq(c.host_rdata)
                stables.append(c.all_stable)
                maxes.append(c.any_max)
                # Neighbours: the adjacent cluster's edge nodes, or the border.
                for stream, src in (("h", "h"), ("m", "hm")):
                    north = (Cat(getattr(cl[i - 1][j], src)[bit(ROWS - 1, q)] for q in range(COLS)) if i
                             else getattr(border, f"{stream}_N")[COLS * j:COLS * (j + 1)])
                    south = (Cat(getattr(cl[i + 1][j], src)[bit(0, q)] for q in range(COLS)) if i < CR - 1
                             else getattr(border, f"{stream}_S")[COLS * j:COLS * (j + 1)])
                    west = (Cat(getattr(cl[i][j - 1], src)[bit(r, COLS - 1)] for r in range(ROWS)) if j
                            else getattr(border, f"{stream}_W")[ROWS * i:ROWS * (i + 1)])
                    east = (Cat(getattr(cl[i][j + 1], src)[bit(r, 0)] for r in range(ROWS)) if j < CC - 1
                            else getattr(border, f"{stream}_E")[ROWS * i:ROWS * (i + 1)])
                    m.d.comb += [
                        getattr(c, f"{stream}_N_in").eq(north), getattr(c, f"{stream}_S_in").eq(south),
                        getattr(c, f"{stream}_W_in").eq(west), getattr(c, f"{stream}_E_in").eq(east),
                    ]

        c0 = cl[0][0]
        m.d.comb += [
            self.take.eq(c0.take), self.done.eq(c0.done), self.checked.eq(c0.checked),
            self.busy.eq(c0.busy),
            self.all_stable.eq(Cat(*stables).all()), self.any_max.eq(Cat(*maxes).any()),
            border.br.eq(self.br), border.bc.eq(self.bc),
            border.cntR.eq(c0.cntR), border.r_cnt.eq(c0.r_cnt),
        ]

        # Border storage writes: the edge nodes' bits of the clusters' write
        # port while iterating (all clusters write the same address), or of
        # the host word for the one cluster the host writes.
        host = ~c0.busy
        m.d.comb += border.w_addr.eq(c0.w_addr)
        with m.If(host):
            m.d.comb += border.w_addr.eq(self.host_addr)
        # The border RAMs' segments: each cluster edge that faces another
        # block, with the word bits of its nodes (top/bottom rows, left/right
        # columns of the block).
        segments = []
        for j in range(CC):
            cols = slice(COLS * j, COLS * (j + 1))
            segments += [("top", 0, j, cols, [bit(0, q) for q in range(COLS)]),
                         ("bottom", CR - 1, j, cols, [bit(ROWS - 1, q) for q in range(COLS)])]
        for i in range(CR):
            rows = slice(ROWS * i, ROWS * (i + 1))
            segments += [("left", i, 0, rows, [bit(r, 0) for r in range(ROWS)]),
                         ("right", i, CC - 1, rows, [bit(r, COLS - 1) for r in range(ROWS)])]
        for side, i, j, sl, bits in segments:
            c = cl[i][j]
            en = getattr(border, f"en_{side}")[sl]
            d = getattr(border, f"w_{side}")[sl]
            with m.If(host):
                m.d.comb += [d.eq(Cat(self.host_wdata[b] for b in bits)),
                             en.eq(Cat([self.host_we & (self.host_cluster == i * CC + j)] * len(bits)))]
            with m.Else():
                m.d.comb += [d.eq(Cat(c.w_data[b] for b in bits)), en.eq(Cat([c.w_en] * len(bits)))]
        if self.exponents:
            self._exponents(m, border, [c for row in cl for c in row], base)
        return m

    def _exponents(self, m, border, clusters, base):
        """Block exponents: pass the border's conversion ports, drive the
        clusters' shift, track the block's largest value (``lead_own``) and
        whether every node is constant (``all_const``)."""
        for name in ("s_N", "s_S", "s_W", "s_E", "raw", "scan"):
            m.d.comb += getattr(border, name).eq(getattr(self, name))
        m.d.comb += border.p.eq(self.p)
        for name in ("scan_busy", "scan_len", "clamped", "lead_N", "lead_S", "lead_W", "lead_E"):
            m.d.comb += getattr(self, name).eq(getattr(border, name))
        for c in clusters:
            m.d.comb += [c.shift.eq(self.shift), c.shift_d.eq(self.shift_d)]
        c0 = clusters[0]
        off = Signal(range(self.depth), name="w_off")
        m.d.comb += off.eq(c0.w_addr - base)
        written = Cat(*[c.w_data.any() for c in clusters]).any()
        with m.If(self.scan):
            m.d.sync += self.lead_own.eq(self.stride)
        with m.Elif(c0.busy & c0.w_en & written & (off >= 1) & (off < self.lead_own)):
            m.d.sync += self.lead_own.eq(off)
        # The flags stream at cycle 0; the next cycle is the take.
        flags_all = Signal()
        m.d.sync += flags_all.eq(Cat(*[c.h.all() for c in clusters]).all())
        with m.If(c0.take):
            m.d.sync += self.all_const.eq(flags_all)
