"""An n x m block of 3x6 clusters with its border nodes (paper 000, 5.1, 5.4)."""

from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from ...models.harmonic.ram import READ_LATENCY
from ..params import Constraint, Param, check, checked_init
from .border import SIDES, Border, BorderExponentsSignature
from .cluster import COLS, NODES, ROWS, Cluster
from .limits import (BLOCKS_WHY, CLUSTERS_WHY, DEPTH_WHY, E_WHY, MAX_BLOCKS_SIDE, MAX_CLUSTERS, MAX_DEPTH, MAX_E,
                     MAX_WORDS, WORDS_WHY)

__all__ = ["Block", "BlockControlSignature", "BlockHostSignature"]


class BlockControlSignature(wiring.Signature):
    """The link from the Control module to the :class:`Block` (paper 000,
    5.1 and Fig. 8), seen from the Control module
    (:class:`~hdl.harmonic.controller.Controller` ``block``); the Block
    takes the flipped form (``control``).  Out: Control -> Block; In: Block
    -> Control.  The clusters sample the commands at ``take`` (``p`` when
    they start); see :class:`~hdl.harmonic.cluster.Cluster` for the timing.

    Parameters
    ----------
    n, m : int
        Block size.
    blocks : (BR, BC)
        Blocks of the map.
    p_max : int
        Largest precision.
    exponents : bool
        Block exponents (issue 10, beyond the paper): the members marked
        below exist only then.
    e_max : int
        Largest block exponent (with ``exponents``).

    Members
    -------
    run : Out(1)
        Start the clusters (while idle) / keep iterating (at ``take``).
    p : Out(range(p_max + 1))
        The precision (value bits p..0 of every node word).
    enable : Out(1)
        Update iteration (1) or check iteration (0: Maximum only).
    clear : Out(1)
        Clear iteration (with ``enable``): every free node writes 0.
    Sat, sel : Out(1); sel_row : Out(range(n)); sel_col : Out(range(m))
        The paper's Sel/Sat of one node: with ``sel``, node (sel_row,
        sel_col) of the block becomes constant Sat (0 obstacle, 1 goal).
    br, bc : Out
        The block being visited, b = br*BC + bc (held during the visit).
    base : Out(range(BR*BC*(p_max + 2)))
        Its word base b*(p_max + 2) in the cluster RAMs (section 5.1's
        memory map), set with br and bc: a register of the Control module,
        so no multiplier lies between br, bc and the clusters' address
        counters (issue 17: with BC or p_max + 2 not a power of two, the two
        products were the planner's critical path).
    abort : Out(1)
        With ``done``: stop the clusters now (the early stop after a stable
        iteration, :class:`~hdl.harmonic.cluster.Cluster`).
    take, done, checked, busy : In(1)
        The clusters' strobes (all in lockstep): command sampled; flags
        valid; ``done`` of a check iteration; iterating (RAMs in use).
    all_stable, any_max : In(1)
        With ``done``: the Early module (AND of every node's Stable) and Cvg
        (OR of the Maximum flags; update iterations have them too).
    edge_changed : In(StructLayout N, S, W, E of 1)
        With ``done``: a node of the block's top row (N), bottom row (S),
        left column (W), right column (E) changed its word in that
        iteration (not Stable): the edge the neighbour block on that side
        reads as its border.
    shift : Out(1); shift_d : Out(signed) (exponents)
        A shift iteration (with ``run``, ``enable`` low) rotating every word
        by ``shift_d`` value positions.
    border : Out(:class:`~hdl.harmonic.border.BorderExponentsSignature`) (exponents)
        The border conversion: exponent differences, clamp scan, leads.
    lead_own : In(range(p_max + 3)); all_const : In(1) (exponents)
        The smallest value offset written with a 1 since ``border.scan``
        (p_max + 2: none); every node constant (the visit's first flags).
    """

    def __init__(self, n, m, blocks, p_max, exponents=False, e_max=255):
        BR, BC = blocks
        self.n, self.m, self.blocks, self.p_max = n, m, tuple(blocks), p_max
        self.exponents, self.e_max = bool(exponents), e_max
        members = {
            "run": Out(1), "p": Out(range(p_max + 1)), "enable": Out(1), "clear": Out(1),
            "Sat": Out(1), "sel": Out(1), "sel_row": Out(range(n)), "sel_col": Out(range(m)),
            "br": Out(range(max(BR, 2))), "bc": Out(range(max(BC, 2))),
            "base": Out(range(max(BR * BC * (p_max + 2), 2))), "abort": Out(1),
            "take": In(1), "done": In(1), "checked": In(1), "busy": In(1),
            "all_stable": In(1), "any_max": In(1),
            "edge_changed": In(data.StructLayout({side: 1 for side in SIDES})),
        }
        if self.exponents:
            stride = p_max + 2
            members.update({
                "shift": Out(1), "shift_d": Out(signed((p_max + 1).bit_length() + 1)),
                "border": Out(BorderExponentsSignature(stride, e_max)),
                "lead_own": In(range(stride + 1)), "all_const": In(1),
            })
        super().__init__(members)

    def __eq__(self, other):
        return type(other) is type(self) and (
            (self.n, self.m, self.blocks, self.p_max, self.exponents, self.e_max)
            == (other.n, other.m, other.blocks, other.p_max, other.exponents, other.e_max))


class BlockHostSignature(wiring.Signature):
    """The Block's host port (RAM access while the clusters are idle), seen
    from the host (the planner's LOAD, READ and DIRECTION); the
    :class:`Block` takes the flipped form (``host``).

    Members
    -------
    addr : Out(range(depth)); cluster : Out(range(clusters))
        Word address and cluster (k = i*CC + j for cluster (i, j)).
    wdata : Out(18); we : Out(1)
        Write the cluster's word (18 nodes' bits); a write also updates the
        border storage of the block's edge nodes, two cycles later (keep the
        clusters from writing in those cycles: a run writes from its first
        iteration's cycle S+3 on, at least six cycles after it saw ``run``).
    rdata : In(18)
        The addressed cluster's word, two cycles after the address (the
        registered RAM read).
    """

    def __init__(self, depth, clusters):
        self.depth, self.clusters = depth, clusters
        super().__init__({
            "addr": Out(range(depth)), "cluster": Out(range(max(clusters, 2))),
            "wdata": Out(NODES), "we": Out(1), "rdata": In(NODES),
        })

    def __eq__(self, other):
        return type(other) is type(self) and (self.depth, self.clusters) == (other.depth, other.clusters)


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
    control : In(:class:`BlockControlSignature`)
        The Control module's commands (run, p, enable, clear, Sel/Sat, the
        block br, bc, abort) and the clusters' strobes and flags (take,
        done, checked, busy: cluster 0's, all clusters are in lockstep;
        all_stable, any_max: Early and Cvg; edge_changed: the Stable flags
        of each edge); with ``exponents`` also the shift iteration, the
        border conversion and the re-pick's inputs.
    host : In(:class:`BlockHostSignature`)
        Idle RAM access to cluster ``host.cluster`` (read data two cycles
        later); a write also updates the border storage of the edge nodes.
    """

    # hdl.emit's names: br, bc are ``blocks`` = (BR, BC).
    PARAMS = (
        Param("n", int, lo=ROWS, hi=ROWS * MAX_CLUSTERS,
              doc=f"block rows, a multiple of {ROWS} (at most {MAX_CLUSTERS} clusters in all, see the constraint)",
              message=f"block rows n={{value!r}}: must be a positive multiple of {ROWS}, at most {{hi}} "
                      f"({CLUSTERS_WHY})"),
        Param("m", int, lo=COLS, hi=COLS * MAX_CLUSTERS,
              doc=f"block columns, a multiple of {COLS} (at most {MAX_CLUSTERS} clusters in all)",
              message=f"block columns m={{value!r}}: must be a positive multiple of {COLS}, at most {{hi}} "
                      f"({CLUSTERS_WHY})"),
        Param("br", int, 1, lo=1, hi=MAX_BLOCKS_SIDE, doc=f"block rows of the map (BR; {BLOCKS_WHY})",
              message=f"blocks: BR={{value!r}} must be an integer in 1..{{hi}} ({BLOCKS_WHY})"),
        Param("bc", int, 1, lo=1, hi=MAX_BLOCKS_SIDE, doc=f"block columns of the map (BC; {BLOCKS_WHY})",
              message=f"blocks: BC={{value!r}} must be an integer in 1..{{hi}} ({BLOCKS_WHY})"),
        Param("p_max", int, 30, lo=2, hi=MAX_DEPTH - 2, doc="largest precision (p_max + 2 <= depth)",
              message="precision p_max={value!r} is not supported: p must be in 2..{hi} (p_max + 2 <= depth)"),
        Param("depth", int, 1024, lo=1, hi=MAX_DEPTH, doc=f"words per cluster RAM (at most 2**20: {DEPTH_WHY})",
              message=f"depth={{value!r}}: must be an integer in 1..{{hi}} ({DEPTH_WHY})"),
        Param("exponents", bool, False, doc="block exponents (issue 10, beyond the paper)",
              message="exponents={value!r}: must be True or False"),
        Param("e_max", int, 255, lo=1, hi=MAX_E, doc=f"largest block exponent (with exponents; {E_WHY})",
              message=f"e_max={{value!r}}: must be an integer in 1..{{hi}} ({E_WHY})"),
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
        Constraint(f"(n / {ROWS}) * (m / {COLS}) <= {MAX_CLUSTERS}",
                   lambda p: (p["n"] // ROWS) * (p["m"] // COLS) <= MAX_CLUSTERS,
                   "a {n}x{m} block is {c} clusters; at most " f"{MAX_CLUSTERS} ({CLUSTERS_WHY})",
                   lambda p: {"c": (p["n"] // ROWS) * (p["m"] // COLS)}, why=CLUSTERS_WHY),
        Constraint("clusters * depth <= 2**22", lambda p: (p["n"] // ROWS) * (p["m"] // COLS) * p["depth"] <= MAX_WORDS,
                   "{c} clusters of {depth} words are {w} RAM words; at most " f"{MAX_WORDS} ({WORDS_WHY})",
                   lambda p: {"c": (p["n"] // ROWS) * (p["m"] // COLS),
                              "w": (p["n"] // ROWS) * (p["m"] // COLS) * p["depth"]}, why=WORDS_WHY),
    )

    @checked_init
    def __init__(self, n, m, blocks=(1, 1), p_max=30, depth=1024, exponents=False, e_max=255):
        BR, BC = blocks
        check(self.PARAMS, self.CONSTRAINTS, n=n, m=m, br=BR, bc=BC, p_max=p_max, depth=depth,
              exponents=exponents, e_max=e_max)
        stride = p_max + 2
        self.n, self.m, self.BR, self.BC = n, m, BR, BC
        self.p_max, self.depth, self.stride = p_max, depth, stride
        self.CR, self.CC = n // ROWS, m // COLS
        self.exponents, self.e_max = bool(exponents), e_max
        # Block exponents (issue 10; see Border and Cluster): ``control``
        # gains the border conversion and scan, the shift iteration, and
        # what the re-pick needs: ``lead_own`` (the smallest value offset,
        # 1..p+1, written with a 1 since the scan; stride = none: the
        # block's largest value, as values only rise within a visit),
        # ``border.lead`` (the same for the raw neighbour edges while
        # ``border.raw``), ``all_const`` (every node constant, from the flags
        # of the visit's first iteration).
        super().__init__({
            "control": In(BlockControlSignature(n, m, blocks, p_max, self.exponents, e_max)),
            "host": In(BlockHostSignature(depth, self.CR * self.CC)),
        })

    def elaborate(self, platform):
        m = Module()
        n, mm, CR, CC = self.n, self.m, self.CR, self.CC
        ctl, host = self.control, self.host
        if self.exponents:
            border = Border(n, mm, (self.BR, self.BC), self.p_max, exponents=True, e_max=self.e_max)
        else:
            border = Border(n, mm, (self.BR, self.BC), self.p_max)
        m.submodules.border = border
        ekw = {"exponents": True} if self.exponents else {}
        cl = [[Cluster(depth=self.depth, p_max=self.p_max, **ekw) for _ in range(CC)] for _ in range(CR)]
        base = Signal(range(self.depth))
        m.d.comb += base.eq(ctl.base)

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
                            ctl.sel & (ctl.sel_row == ROWS * i + r) & (ctl.sel_col == COLS * j + q))
                m.d.comb += [
                    c.run.eq(ctl.run), c.p.eq(ctl.p), c.enable.eq(ctl.enable),
                    c.clear.eq(ctl.clear), c.Sat.eq(ctl.Sat), c.Sel.eq(sel), c.base.eq(base),
                    c.abort.eq(ctl.abort),
                    c.host_addr.eq(host.addr), c.host_wdata.eq(host.wdata),
                    c.host_we.eq(host.we & (host.cluster == k)),
                ]
                with m.If(host.cluster == k):
                    m.d.comb += host.rdata.eq(c.host_rdata)
                stables.append(c.all_stable)
                maxes.append(c.any_max)
                # Neighbours: the adjacent cluster's edge nodes, or the border.
                north = (Cat(cl[i - 1][j].h[bit(ROWS - 1, q)] for q in range(COLS)) if i
                         else border.h_N[COLS * j:COLS * (j + 1)])
                south = (Cat(cl[i + 1][j].h[bit(0, q)] for q in range(COLS)) if i < CR - 1
                         else border.h_S[COLS * j:COLS * (j + 1)])
                west = (Cat(cl[i][j - 1].h[bit(r, COLS - 1)] for r in range(ROWS)) if j
                        else border.h_W[ROWS * i:ROWS * (i + 1)])
                east = (Cat(cl[i][j + 1].h[bit(r, 0)] for r in range(ROWS)) if j < CC - 1
                        else border.h_E[ROWS * i:ROWS * (i + 1)])
                m.d.comb += [c.h_N_in.eq(north), c.h_S_in.eq(south), c.h_W_in.eq(west), c.h_E_in.eq(east)]

        c0 = cl[0][0]
        # Each edge's Stable flags (the still-block schedule's dirty bits).
        edges = {"N": [(cl[0][j], [bit(0, q) for q in range(COLS)]) for j in range(CC)],
                 "S": [(cl[CR - 1][j], [bit(ROWS - 1, q) for q in range(COLS)]) for j in range(CC)],
                 "W": [(cl[i][0], [bit(r, 0) for r in range(ROWS)]) for i in range(CR)],
                 "E": [(cl[i][CC - 1], [bit(r, COLS - 1) for r in range(ROWS)]) for i in range(CR)]}
        for side, parts in edges.items():
            m.d.comb += ctl.edge_changed[side].eq(~Cat(c.stable[b] for c, bits in parts for b in bits).all())
        m.d.comb += [
            ctl.take.eq(c0.take), ctl.done.eq(c0.done), ctl.checked.eq(c0.checked),
            ctl.busy.eq(c0.busy),
            ctl.all_stable.eq(Cat(*stables).all()), ctl.any_max.eq(Cat(*maxes).any()),
            border.br.eq(ctl.br), border.bc.eq(ctl.bc),
            border.cntR.eq(c0.cntR), border.addr.eq(c0.r_addr),
        ]

        # Border storage writes, whole edge words (every lane of the four
        # edges): while iterating, the edge nodes' bits of the clusters'
        # write port (all clusters write the same address); after a host
        # write, READ_LATENCY cycles later, the edge words at its address:
        # every cluster's read port read that address in the write's cycle
        # (the host port's read while idle), the written cluster's word is
        # the host's.
        # So LOAD, one cluster at a time, keeps the lane words whole.
        # The clusters' read data come READ_LATENCY cycles after the address:
        # the host write's address, cluster and data wait as long.
        fills = [(Signal(name=f"fill_{i}"), Signal.like(host.addr, name=f"fill_addr_{i}"),
                  Signal.like(host.cluster, name=f"fill_k_{i}"), Signal.like(host.wdata, name=f"fill_data_{i}"))
                 for i in range(READ_LATENCY)]
        m.d.sync += [fills[0][0].eq(~c0.busy & host.we), fills[0][1].eq(host.addr),
                     fills[0][2].eq(host.cluster), fills[0][3].eq(host.wdata)]
        for a, b in zip(fills, fills[1:]):
            m.d.sync += [y.eq(x) for x, y in zip(a, b)]
        fill, fill_addr, _, fill_data = fills[-1]
        # which cluster's word the last stage holds, one-hot, registered
        # beside it (issue 17: no comparator between a cluster RAM's read
        # and the border RAMs' data pins)
        fill_hit = Signal(CR * CC, name="fill_hit")
        m.d.sync += fill_hit.eq(Cat(*(fills[-2][2] == k for k in range(CR * CC))))
        m.d.comb += [border.w_addr.eq(Mux(fill, fill_addr, c0.w_addr)),
                     border.w_en.eq(fill | c0.w_en)]
        # The border nodes by cluster edge segment: each cluster edge that
        # faces another block, with the word bits of its nodes (top/bottom
        # rows, left/right columns of the block).
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
            word = Mux(fill_hit[i * CC + j], fill_data, c.host_rdata)
            m.d.comb += getattr(border, f"w_{side}")[sl].eq(
                Mux(fill, Cat(word[b] for b in bits), Cat(c.w_data[b] for b in bits)))
        if self.exponents:
            self._exponents(m, border, [c for row in cl for c in row], base)
        return m

    def _exponents(self, m, border, clusters, base):
        """Block exponents: pass the border conversion through, drive the
        clusters' shift, track the block's largest value (``lead_own``) and
        whether every node is constant (``all_const``)."""
        ctl = self.control
        wiring.connect(m, wiring.flipped(ctl.border), border.conversion)
        m.d.comb += [border.p.eq(ctl.p), border.r_cnt.eq(clusters[0].r_cnt)]
        for c in clusters:
            m.d.comb += [c.shift.eq(ctl.shift), c.shift_d.eq(ctl.shift_d)]
        c0 = clusters[0]
        off = Signal(range(self.depth), name="w_off")
        m.d.comb += off.eq(c0.w_addr - base)
        written = Cat(*[c.w_data.any() for c in clusters]).any()
        with m.If(ctl.border.scan):
            m.d.sync += ctl.lead_own.eq(self.stride)
        with m.Elif(c0.w_en & written & (off >= 1) & (off < ctl.lead_own)):
            m.d.sync += ctl.lead_own.eq(off)
        # The flags stream at cycle S (h); two registers later is ph2.
        flags_all, flags_all_r = Signal(), Signal()
        m.d.sync += [flags_all.eq(Cat(*[c.h.all() for c in clusters]).all()), flags_all_r.eq(flags_all)]
        with m.If(c0.ph2):
            m.d.sync += ctl.all_const.eq(flags_all_r)
