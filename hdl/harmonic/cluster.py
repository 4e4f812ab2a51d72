"""3x6 cluster of nodes sharing one dual-port RAM (paper 000, sections 5.1, 5.2, 5.4)."""

from amaranth.hdl import Cat, Module, Mux, Signal, signed, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..block_ram import BlockRam
from ..params import Constraint, Param, check, checked_init
from .counters import Counters, le_const
from .limits import DEPTH_WHY, MAX_DEPTH
from .node import Node

__all__ = ["Cluster", "ROWS", "COLS"]

ROWS, COLS = 3, 6
NODES = ROWS * COLS


class Cluster(wiring.Component):
    """18 node modules (3 rows x 6 columns), one 18-bit RAM, one Counters unit.

    RAM word ``a`` holds bit ``a`` of the stored words of all 18 nodes, node
    (row r, column c) in bit ``6*r + c``; a node's word is p+2 bits, flag first
    then value bits p..0 (:func:`models.harmonic.ram_image`).  The read port
    reads it LSB first for the Update and the Maximum (LSB-first compare);
    the write port writes the results two bit positions behind, so the RAM
    is one simple dual-port block RAM (a deeper one:
    :class:`~hdl.block_ram.BlockRam`, the word in lanes of blocks that each
    hold the whole depth).  Its read data is registered (read latency 2: the
    block RAM's output register, ``REGMODE OUTREG`` on an ECP5 DP16KD, which
    scripts/ecp5_pack.py maps for yosys) and each node's write bit is a
    register.  One iteration takes L = p+2 cycles (p >= 4;
    :func:`models.harmonic.iteration_cycles`: 6 for p = 2, 3; a shift
    iteration of block exponents one more).  A read and a write never meet
    on one address in one cycle (the memories carry yosys' ``no_rw_check``).

    Operation: load the words through the host port while idle, raise ``run``
    with a precision ``p``.  After a two-cycle lead-in the cluster iterates.
    At every ``take`` cycle (cycle 0 of an iteration) it samples ``run``,
    ``enable``, ``clear``, ``Sel`` and ``Sat`` for that iteration, whose
    bits enter the adders from cycle S+1 and whose write window starts at
    cycle S+2; in cycle 2 of the following iteration ``done`` shows the
    ``stable`` / ``local_max`` flags of the iteration.  ``run`` low at a
    ``take`` stops the cluster once the previous iteration's writes are
    over, after its ``done`` (the iteration whose command was "stop" only
    read).  Iteration k's flags come (k+1)L + 5 cycles after the cycle in
    which an idle cluster saw ``run``.  ``abort`` with a ``done`` stops the
    cluster at once (busy low from the next cycle): the iteration whose
    flags ``done`` shows has then written its last bit (cycle 2) and the
    iteration in progress nothing yet (its window starts at cycle S+2, its
    first bit is written at S+3), so the RAM holds exactly what the
    iteration of the flags wrote (the Control module's early stop after a
    stable iteration, without a confirmation iteration).

    =========================  ======================================
    Parameters
    ----------
    depth : int
        RAM depth in words (default 1024, the 1Kx18 block RAM of the paper).
    p_max : int
        Largest precision (default ``depth - 2``); needs ``p_max + 2 <= depth``
        and ``p_max >= 2``.

    Ports
    -----
    run : In(1)
        Start (while idle) / keep iterating (sampled at ``take``).
    p : In(bits of p_max)
        Precision, sampled when the cluster starts.  A value outside
        ``2 .. p_max`` does not start it and raises ``p_err``.
    enable : In(1)
        Update iteration (1) or check iteration (0, nothing written,
        ``local_max`` computed).  Sampled at ``take``.
    Sel : In(18), Sat : In(1)
        Saturation orders (paper's Sel/Sat), one Sel bit per node, honoured in
        update iterations.  Sampled at ``take``.
    clear : In(1)
        Clear iteration (with ``enable``): the nodes' adders see 0 from the
        iteration's bit 0 on (the nodes' ``zero`` held over the whole
        iteration), so every free node writes 0, constants keep their words
        and Sel/Sat still apply.  Sampled at ``take``.  The block's Control
        module restarts the free nodes from 0 this way after a dynamic order.
    base : In(range(depth))
        Word base of the block being computed (block b at b*(p_max+2)): added
        to the address counters while iterating.  Hold it while busy.
    w_addr : Out(range(depth)); w_data : Out(18); w_en : Out(1)
        The RAM write port's address, the nodes' ``w`` bits (what the port
        writes while iterating; meaningful with ``w_en``) and the enable of
        the iterations' writes (not the host's), for the border storage that
        mirrors the block's edge nodes.
    abort : In(1)
        With ``done``: stop now (see above).
    h_N_in, h_S_in : In(6); h_E_in, h_W_in : In(3)
        Neighbours' words outside the cluster, LSB first (same timing as
        ``h``: bit of address ``cntR`` two cycles later).
    h : Out(18)
        The RAM's registered read data: every node's serial stream, for the
        neighbouring clusters and the decision module.
    cntR, r_cnt : Out(address width)
        The LSB-first read address and the MSB-first (reverse) counter, for
        the border nodes (block exponents read their MSB first).
    r_addr : Out(range(depth))
        The absolute read address while busy, ``base + cntR`` (a register).
    take, done, checked : Out(1)
        Command sampling strobe; flags-valid strobe; ``done`` after a check
        iteration (``local_max`` meaningful).
    ph2 : Out(1)
        Cycle S+2 of an iteration while busy: ``h`` carried the words'
        constant flags two cycles earlier (cycle S).
    stable, local_max : Out(18); all_stable, any_max : Out(1)
        Per-node flags and their AND (Early) / OR (Cvg), valid with ``done``.
    busy : Out(1)
        Iterating (the host port is ignored); low from the cycle of the
        stop's ``done`` on (the last write happens in that cycle, the host
        port is served from the next one).
    p_err : Out(1)
        The last start request had an unsupported precision.
    host_addr : In(range(depth)); host_wdata : In(18); host_we : In(1)
    host_rdata : Out(18)
        RAM access while idle (read data two cycles after the address; a
        word written in cycle t reads back from t+1 on).
    """

    PARAMS = (
        Param("depth", int, 1024, lo=4, hi=MAX_DEPTH, doc=f"RAM depth in words (at most 2**20: {DEPTH_WHY})",
              message=f"RAM depth must be an integer in 4..{MAX_DEPTH}, not {{value!r}} ({DEPTH_WHY})"),
        Param("p_max", int, None, lo=2, hi=MAX_DEPTH - 2, doc="largest precision (default depth - 2; "
              "p_max + 2 <= depth)",
              message="precision p_max={value!r} is not supported: p must be in 2..{hi} (p_max + 2 <= depth)"),
        Param("exponents", bool, False, doc="shift iterations for block exponents (issue 10)",
              message="exponents={value!r}: must be True or False"),
    )
    CONSTRAINTS = (
        Constraint("p_max + 2 <= depth", lambda p: p["p_max"] + 2 <= p["depth"],
                   "precision p_max={p_max} needs words of p_max+2={w} bits, "
                   "one per RAM address, but the RAM depth is {depth}",
                   lambda p: {"w": p["p_max"] + 2}),
    )

    @checked_init
    def __init__(self, depth=1024, p_max=None, exponents=False):
        check(self.PARAMS, depth=depth)
        if p_max is None:
            p_max = depth - 2
        check(self.PARAMS, self.CONSTRAINTS, depth=depth, p_max=p_max, exponents=exponents)
        self.depth = depth
        self.p_max = p_max
        self.exponents = bool(exponents)
        addr = unsigned((p_max + 1).bit_length())
        extra = {}
        if self.exponents:
            # Block exponents (issue 10): a shift iteration (``shift`` sampled
            # at ``take`` with ``run``; ``enable`` low) writes every word back
            # rotated by ``shift_d`` value positions (left > 0, right < 0):
            # the value bits at offsets 1..p+1 move to 1 + ((a - 1 - d) mod
            # (p+1)), the flag stays.  A left shift of a value whose top d
            # bits are 0 (or a right shift of one whose low -d bits are 0) is
            # this rotation.  Hold ``shift_d`` (|d| <= p) while busy.
            extra = {"shift": In(1), "shift_d": In(signed((p_max + 1).bit_length() + 1))}
        super().__init__({
            **extra,
            "run": In(1),
            "p": In(range(p_max + 1)),
            "enable": In(1),
            "Sel": In(NODES),
            "Sat": In(1),
            "clear": In(1),
            "abort": In(1),
            "base": In(range(depth)),
            "w_addr": Out(range(depth)),
            "w_data": Out(NODES),
            "w_en": Out(1),
            "h_N_in": In(COLS), "h_S_in": In(COLS),
            "h_E_in": In(ROWS), "h_W_in": In(ROWS),
            "h": Out(NODES),
            "cntR": Out(addr),
            "r_addr": Out(range(depth)),
            "r_cnt": Out(addr),
            "take": Out(1),
            "ph2": Out(1),
            "done": Out(1),
            "checked": Out(1),
            "stable": Out(NODES),
            "local_max": Out(NODES),
            "all_stable": Out(1),
            "any_max": Out(1),
            "busy": Out(1),
            "p_err": Out(1),
            "host_addr": In(range(depth)),
            "host_wdata": In(NODES),
            "host_we": In(1),
            "host_rdata": Out(NODES),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"iteration_cycles": "p+2 (p >= 4; max(p, 4)+2 below)",
                "flags_latency": "iteration k's flags (done) (k+1)L+5 cycles after run seen idle (L: iteration_cycles)",
                "host_read_latency": "2 cycles"}

    def elaborate(self, platform):
        m = Module()
        m.submodules.counters = cnt = Counters(self.p_max, self.depth)
        # A read and a write never meet on one address in one cycle (the
        # pipeline's order: models/harmonic/ram.py), so yosys need not
        # emulate any collision behaviour (no logic after the RAM's output).
        # Its read data are registered: the block RAM's output register (read
        # latency 2; hdl/block_ram.py lays a deep RAM out so that no address
        # multiplexer sits before that register).
        m.submodules.ram = ram = BlockRam(NODES, self.depth, attrs={"no_rw_check": 1})
        data = ram.r_data

        running = Signal()
        stopping = Signal()     # the stop command was taken: run until its done
        p_r = Signal.like(self.p)
        # Iteration commands: (a) sampled at take (cycle 0), for the adders'
        # clear mask from bit 0 on; (b) moved at ph1 (cycle 1), for the
        # write window (cycles S+2 .. 1 of the next iteration); (c) the
        # previous iteration's (b), for its flags at cycle 2.
        win_a, upd_a, clr_a, shf_a = Signal(), Signal(), Signal(), Signal()
        sel_a, sat_a = Signal(NODES), Signal()
        win_b, upd_b, shf_b = Signal(), Signal(), Signal()
        sel_b, sat_b = Signal(NODES), Signal()
        last_win, last_upd = Signal(), Signal()

        # p in 2 .. p_max, as plain gates (issue 17: yosys maps ``>=`` /
        # ``<=`` to carry chains, slower here than a LUT tree)
        p_ok = self.p[1:].any()
        if (1 << len(self.p)) - 1 > self.p_max:     # p's port can exceed p_max
            p_ok &= le_const(self.p, self.p_max)
        # A start request loads the counters and the command registers
        # whether or not p is supported (harmless while idle): only
        # ``running`` waits for the range check, so the wide loads do not
        # hang behind p's comparators.
        load = ~running & self.run
        start = load & p_ok
        with m.If(load):
            m.d.sync += [self.p_err.eq(~p_ok), stopping.eq(0), p_r.eq(self.p)]
        with m.If(start):
            m.d.sync += running.eq(1)

        m.d.comb += [
            cnt.p.eq(self.p),                       # read at start
            cnt.base.eq(self.base),
            cnt.start.eq(load),
            cnt.advance.eq(running),
            self.take.eq(running & cnt.z & ~stopping),
            self.ph2.eq(running & cnt.ph2),
            self.busy.eq(running & ~(stopping & cnt.fl)),
            self.cntR.eq(cnt.cntR),
            self.r_addr.eq(cnt.addrR),
            self.r_cnt.eq(cnt.r_cnt),
        ]
        if self.exponents:
            m.d.comb += cnt.shift.eq(self.shift)    # a shift visit's iterations have a pad cycle
        with m.If(load):
            m.d.sync += [win_a.eq(0), upd_a.eq(0), clr_a.eq(0), shf_a.eq(0),
                         win_b.eq(0), upd_b.eq(0), shf_b.eq(0), last_win.eq(0), last_upd.eq(0)]
        with m.Elif(self.take):
            m.d.sync += [
                win_a.eq(self.run), upd_a.eq(self.run & self.enable),
                clr_a.eq(self.run & self.enable & self.clear),
                sel_a.eq(self.Sel), sat_a.eq(self.Sat),
            ]
            if self.exponents:
                m.d.sync += shf_a.eq(self.run & self.shift)
            with m.If(~self.run):
                m.d.sync += stopping.eq(1)
        with m.If(running & cnt.ph1):
            m.d.sync += [win_b.eq(win_a), upd_b.eq(upd_a), shf_b.eq(shf_a), sel_b.eq(sel_a), sat_b.eq(sat_a),
                         last_win.eq(win_b), last_upd.eq(upd_b)]
        with m.If(running & stopping & cnt.fl):
            m.d.sync += running.eq(0)
        with m.If(self.abort & self.done):
            m.d.sync += running.eq(0)

        # The write port writes the nodes' registered bits: the bit computed
        # in cycle u (a writing cycle of a writing iteration) one cycle later,
        # at cntW (the offset five cycles behind the read; a shift iteration
        # rotates it).
        write = Signal()
        m.d.sync += write.eq(running & cnt.wcyc & win_b & (upd_b | shf_b))
        w_addr = Signal.like(cnt.addrW)
        m.d.comb += w_addr.eq(cnt.addrW)
        if self.exponents:
            # The rotation of the bit on the write port: shift_d of its iteration.
            shd_b, shd_w = Signal.like(self.shift_d), Signal.like(self.shift_d)
            with m.If(running & cnt.ph1):
                m.d.sync += shd_b.eq(self.shift_d)
            m.d.sync += shd_w.eq(shd_b)
            shf_w = Signal()
            m.d.sync += shf_w.eq(shf_b)
            tt = Signal(signed(len(cnt.cntW) + 3))
            p1 = p_r + 1
            m.d.comb += tt.eq(cnt.cntW - 1 - shd_w)
            with m.If(shf_w & (cnt.cntW != 0)):
                m.d.comb += w_addr.eq(self.base + Mux(tt < 0, tt + p1, Mux(tt >= p1, tt - p1, tt)) + 1)

        # RAM ports: counters while iterating, host port while idle.
        m.d.comb += [
            ram.r_addr.eq(Mux(running, cnt.addrR, self.host_addr)),
            ram.w_addr.eq(Mux(running, w_addr, self.host_addr)),
            ram.w_data.eq(self.host_wdata),
            ram.w_en.eq(Mux(running, write, self.host_we)),
            self.h.eq(data),
            self.host_rdata.eq(data),
        ]
        m.d.comb += [self.w_addr.eq(ram.w_addr), self.w_en.eq(running & write)]

        # The nodes' adder mask, a register (one LUT level less before the
        # nodes' sum): mask | clr_a of the next cycle.
        zero = Signal()
        clr_next = Mux(self.take, self.run & self.enable & self.clear, clr_a)
        m.d.sync += zero.eq(Mux(load, 0, cnt.mask_next | clr_next))

        # The nodes' strobes: clr_a masks the adders over the bits of a
        # clear iteration (cycles 1 .. L-1 and 0 of the next: cycle 0 and the
        # pads are masked anyway); enable low in the non-writing cycles of a
        # padded iteration.  ``enable`` = upd_b & wcyc, a register (issue 17:
        # no LUT between the strobes and the nodes' selection logic), loaded
        # from the next values of both.
        enable = Signal()
        upd_b_next = Mux(load, 0, Mux(running & cnt.ph1, upd_a, upd_b))
        m.d.sync += enable.eq(upd_b_next & cnt.wcyc_next)

        # The 3x6 node grid: each node streams its word from the RAM and
        # passes it on to its neighbours; edge nodes take the edge inputs.
        nodes = [[Node() for _ in range(COLS)] for _ in range(ROWS)]
        for r in range(ROWS):
            for c in range(COLS):
                i = r * COLS + c
                node = nodes[r][c]
                m.submodules[f"node_{r}_{c}"] = node
                m.d.comb += [
                    node.h.eq(data[i]),
                    node.mask.eq(cnt.mask),
                    node.zero.eq(zero),
                    node.z.eq(cnt.z),
                    node.ph1.eq(cnt.ph1),
                    node.ph2.eq(cnt.ph2),
                    node.enable.eq(enable),
                    node.Sel.eq(sel_b[i]),
                    node.Sat.eq(sat_b),
                    self.stable[i].eq(node.stable),
                    self.local_max[i].eq(node.local_max),
                ]
                for name, dr, dc, h_edge, k in (
                        ("N", -1, 0, self.h_N_in, c),
                        ("S", 1, 0, self.h_S_in, c),
                        ("E", 0, 1, self.h_E_in, r),
                        ("W", 0, -1, self.h_W_in, r)):
                    rr, cc = r + dr, c + dc
                    inside = 0 <= rr < ROWS and 0 <= cc < COLS
                    m.d.comb += getattr(node, f"h_{name}").eq(nodes[rr][cc].to if inside else h_edge[k])
        w_bits = [nodes[r][c].w for r in range(ROWS) for c in range(COLS)]
        with m.If(running):
            m.d.comb += ram.w_data.eq(Cat(*w_bits))
        # The nodes' bits themselves, not the host multiplexer's output: the
        # border storage writes them with w_en (issue 17: one LUT less
        # between the nodes' registers and the border RAMs' data pins).
        m.d.comb += self.w_data.eq(Cat(*w_bits))

        m.d.comb += [
            self.done.eq(running & cnt.fl & last_win),
            self.checked.eq(running & cnt.fl & last_win & ~last_upd),
            self.all_stable.eq(self.stable.all()),
            self.any_max.eq(self.local_max.any()),
        ]
        return m
