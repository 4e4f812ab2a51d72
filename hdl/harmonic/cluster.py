"""3x6 cluster of nodes sharing one dual-port RAM (paper 000, sections 5.1, 5.2, 5.4)."""

from amaranth.hdl import Cat, Module, Mux, Signal, signed, unsigned
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from ..params import Constraint, Param, check, checked_init
from .counters import Counters
from .limits import DEPTH_WHY, MAX_DEPTH
from .node import Node

__all__ = ["Cluster", "ROWS", "COLS"]

ROWS, COLS = 3, 6
NODES = ROWS * COLS


class Cluster(wiring.Component):
    """18 node modules (3 rows x 6 columns), one 18-bit RAM, one Counters unit.

    RAM word ``a`` holds bit ``a`` of the stored words of all 18 nodes, node
    (row r, column c) in bit ``6*r + c``; a node's word is p+2 bits, flag first
    then value bits p..0 (:func:`models.harmonic.ram_image`).  Port A reads it
    LSB first for the Update; port B writes the results two bit positions
    behind in update iterations and reads MSB first for the Maximum in check
    iterations, never both in the same cycle, so A and B map onto the two
    ports of one true dual-port block RAM.  One iteration takes p+2 cycles.

    Operation: load the words through the host port while idle, raise ``run``
    with a precision ``p``.  After a one-cycle lead-in the cluster iterates.
    At every ``take`` cycle (cycle 1 of an iteration) it samples ``run``,
    ``enable``, ``Sel`` and ``Sat`` for that iteration, whose write window
    starts in the next cycle; in the cycle after the next ``take`` (cycle 2
    of the following iteration) ``done`` shows the ``stable`` /
    ``local_max`` flags of the iteration.  ``run`` low at a ``take`` stops
    the cluster once the previous iteration's writes are over (its flags
    still come with ``done``); the iteration whose command was "stop" only
    read.  Iteration k's flags come (k+1)(p+2) + 4 cycles after the cycle
    in which an idle cluster saw ``run``.

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
        iteration's bit 0 on (the ``ph0`` input mask held over the whole
        iteration), so every free node writes 0, constants keep their words
        and Sel/Sat still apply.  Sampled at ``take`` (and used in that very
        cycle, when bit 0 enters the adders).  The block's Control module
        restarts the free nodes from 0 this way after a dynamic order.
    base : In(range(depth))
        Word base of the block being computed (block b at b*(p_max+2)): added
        to the three address counters while iterating.  Hold it while busy.
    w_addr : Out(range(depth)); w_data : Out(18); w_en : Out(1)
        The RAM write port (address, the nodes' ``w`` bits, enable), for the
        border storage that mirrors the block's edge nodes.
    h_N_in, h_S_in : In(6); h_E_in, h_W_in : In(3)
        Neighbours' words outside the cluster, LSB first (same timing as
        ``h``: bit of address ``cntR`` one cycle later).
    m_N_in, m_S_in : In(6); m_E_in, m_W_in : In(3)
        The same neighbours MSB first (bit of address ``r_cnt`` one cycle
        later).
    h, hm : Out(18)
        RAM port A / port B read data: every node's serial streams, for the
        neighbouring clusters and the decision module.
    cntR, r_cnt : Out(address width)
        Port A / port B read addresses, for border nodes.
    take, done, checked : Out(1)
        Command sampling strobe; flags-valid strobe; ``done`` after a check
        iteration (``local_max`` meaningful).
    stable, local_max : Out(18); all_stable, any_max : Out(1)
        Per-node flags and their AND (Early) / OR (Cvg), valid with ``done``.
    busy : Out(1)
        Iterating (the host port is ignored).
    p_err : Out(1)
        The last start request had an unsupported precision.
    host_addr : In(range(depth)); host_wdata : In(18); host_we : In(1)
    host_rdata : Out(18)
        RAM access while idle (read data one cycle after the address).
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
            "base": In(range(depth)),
            "w_addr": Out(range(depth)),
            "w_data": Out(NODES),
            "w_en": Out(1),
            "h_N_in": In(COLS), "h_S_in": In(COLS),
            "h_E_in": In(ROWS), "h_W_in": In(ROWS),
            "m_N_in": In(COLS), "m_S_in": In(COLS),
            "m_E_in": In(ROWS), "m_W_in": In(ROWS),
            "h": Out(NODES),
            "hm": Out(NODES),
            "cntR": Out(addr),
            "r_cnt": Out(addr),
            "take": Out(1),
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
        return {"iteration_cycles": "p+2",
                "flags_latency": "iteration k's flags (done) (k+1)(p+2)+4 cycles after run seen idle"}

    def elaborate(self, platform):
        m = Module()
        m.submodules.counters = cnt = Counters(self.p_max)
        m.submodules.ram = ram = Memory(shape=NODES, depth=self.depth, init=[])
        port_a = ram.read_port()
        port_b = ram.read_port()
        port_w = ram.write_port()

        running = Signal()
        p_r = Signal.like(self.p)
        win = Signal()          # the current write window belongs to an iteration
        upd = Signal()          # ... and it is an update iteration
        last_win = Signal()     # the same for the iteration whose flags come next
        last_upd = Signal()
        sel_r = Signal(NODES)
        sat_r = Signal()
        clr_r = Signal()        # the current write window belongs to a clear iteration
        shf = Signal()          # ... to a shift iteration (exponents only)

        p_ok = self.p >= 2
        if (1 << len(self.p)) - 1 > self.p_max:     # p's port can exceed p_max
            p_ok &= self.p <= self.p_max
        start = ~running & self.run & p_ok
        with m.If(~running & self.run):
            m.d.sync += self.p_err.eq(~p_ok)
        with m.If(start):
            m.d.sync += [running.eq(1), p_r.eq(self.p)]

        m.d.comb += [
            cnt.p.eq(p_r),
            cnt.start.eq(start),
            cnt.advance.eq(running),
            self.take.eq(running & cnt.ph1),
            self.busy.eq(running),
            self.cntR.eq(cnt.cntR),
            self.r_cnt.eq(cnt.r_cnt),
        ]
        with m.If(start):
            m.d.comb += cnt.p.eq(self.p)            # the lead-in state depends on p
            m.d.sync += [win.eq(0), upd.eq(0), clr_r.eq(0)]
        with m.Elif(self.take):
            m.d.sync += [
                win.eq(self.run), upd.eq(self.run & self.enable),
                clr_r.eq(self.run & self.enable & self.clear),
                last_win.eq(win), last_upd.eq(upd),
                sel_r.eq(self.Sel), sat_r.eq(self.Sat),
            ]
            if self.exponents:
                m.d.sync += shf.eq(self.run & self.shift)
            with m.If(~self.run):
                m.d.sync += running.eq(0)

        # RAM ports: counters while iterating, host port while idle.
        write = win & (upd | shf) if self.exponents else win & upd
        m.d.comb += [
            port_a.addr.eq(self.host_addr),
            port_b.addr.eq(self.host_addr),
            port_w.addr.eq(port_b.addr),     # one address: one physical port
            port_w.data.eq(self.host_wdata),
            port_w.en.eq(self.host_we),
            self.h.eq(port_a.data),
            self.hm.eq(port_b.data),
            self.host_rdata.eq(port_a.data),
        ]
        with m.If(running):
            m.d.comb += [
                port_a.addr.eq(self.base + cnt.cntR),
                port_b.addr.eq(self.base + cnt.r_cnt),
                port_w.en.eq(write),
            ]
            with m.If(write):
                m.d.comb += port_b.addr.eq(self.base + cnt.cntW)
                if self.exponents:
                    t = Signal(signed(len(cnt.cntW) + 3))
                    rot = Signal(len(cnt.cntW))
                    p1 = p_r + 1
                    m.d.comb += t.eq(cnt.cntW - 1 - self.shift_d)
                    m.d.comb += rot.eq(Mux(cnt.cntW == 0, 0,
                                           Mux(t < 0, t + p1, Mux(t >= p1, t - p1, t)) + 1))
                    with m.If(shf):
                        m.d.comb += port_b.addr.eq(self.base + rot)
        m.d.comb += [self.w_addr.eq(port_w.addr), self.w_data.eq(port_w.data), self.w_en.eq(port_w.en)]

        # Clear iteration: mask the adders' inputs from bit 0 (cycle 1, the
        # take cycle itself) to the iteration's last bit; cycle 0 is masked
        # anyway.  The previous iteration's top bits (written at cycles 0
        # and 1) come from carries already registered, so they are intact.
        mask = cnt.ph0 | (self.take & self.run & self.enable & self.clear) | (clr_r & ~cnt.ph1)

        # The 3x6 node grid: each node streams its word from the RAM and
        # passes it on to its neighbours; edge nodes take the edge inputs.
        nodes = [[Node() for _ in range(COLS)] for _ in range(ROWS)]
        for r in range(ROWS):
            for c in range(COLS):
                i = r * COLS + c
                node = nodes[r][c]
                m.submodules[f"node_{r}_{c}"] = node
                m.d.comb += [
                    node.h.eq(port_a.data[i]),
                    node.hm.eq(port_b.data[i]),
                    node.ph0.eq(mask),
                    node.ph1.eq(cnt.ph1),
                    node.ph2.eq(cnt.ph2),
                    node.enable.eq(upd),
                    node.Sel.eq(sel_r[i]),
                    node.Sat.eq(sat_r),
                    self.stable[i].eq(node.stable),
                    self.local_max[i].eq(node.local_max),
                ]
                for name, dr, dc, h_edge, m_edge, k in (
                        ("N", -1, 0, self.h_N_in, self.m_N_in, c),
                        ("S", 1, 0, self.h_S_in, self.m_S_in, c),
                        ("E", 0, 1, self.h_E_in, self.m_E_in, r),
                        ("W", 0, -1, self.h_W_in, self.m_W_in, r)):
                    rr, cc = r + dr, c + dc
                    inside = 0 <= rr < ROWS and 0 <= cc < COLS
                    m.d.comb += [
                        getattr(node, f"h_{name}").eq(nodes[rr][cc].to if inside else h_edge[k]),
                        getattr(node, f"m_{name}").eq(nodes[rr][cc].to_m if inside else m_edge[k]),
                    ]
        w_bits = [nodes[r][c].w for r in range(ROWS) for c in range(COLS)]
        with m.If(running):
            m.d.comb += port_w.data.eq(Cat(*w_bits))

        # ph2 stays high while the cluster idles at cycle 2: done is one cycle.
        with m.If(self.done):
            m.d.sync += last_win.eq(0)
        m.d.comb += [
            self.done.eq(cnt.ph2 & last_win),
            self.checked.eq(cnt.ph2 & last_win & ~last_upd),
            self.all_stable.eq(self.stable.all()),
            self.any_max.eq(self.local_max.any()),
        ]
        return m
