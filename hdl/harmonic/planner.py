"""The harmonic planner top: block, border nodes, Control and Decision
behind one host interface of valid/ready streams (paper 000, section 5)."""

from dataclasses import replace

from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import data, enum, stream, wiring
from amaranth.lib.wiring import In, Out

from ...models.harmonic.ram import READ_LATENCY
from ..arith import divmod_const, times
from ..params import Constraint, Param, check, checked_init
from .block import Block
from .cluster import COLS, ROWS
from .controller import Controller
from .decision import NEIGHBOURHOOD, Decision, neighbourhood_layout
from .limits import MAX_DEPTH

__all__ = ["Planner", "Op", "Code", "command_layout", "response_layout", "direction_latency"]


class Op(enum.Enum, shape=3):
    LOAD = 0        # write one cluster's constant flags and goals of one block
    SET = 1         # dynamic obstacle (flag 0) / goal (flag 1) at (B, X, Y)
    START = 2       # run the planner: p1, step, p_last, iters
    STATUS = 3      # converged, precision, counters
    READ = 4        # a node's stored word: constant flag and value
    DIRECTION = 5   # the Decision module at (B, X, Y)


class Code(enum.Enum, shape=3):
    OK = 0
    BAD_NODE = 1        # block, row or column outside the map
    NO_GOAL = 2         # START with no goal loaded
    BAD_PRECISION = 3   # p1 < 2, p_last > p_max, p1 > p_last, or step 0 with p1 < p_last
    BUSY = 4            # LOAD / START / READ / DIRECTION while a run or a clear pass is on
    BAD_OP = 5          # op 6 or 7
    BAD_ITERS = 6       # START with iters = 0


# Cycles of one value read besides its p+2 addresses and the host port's
# HOST_READ_LATENCY: FETCH (the node or neighbour selected and registered) and
# LOCATE (its cluster, bit and RAM base registered: the table look-ups are
# kept out of FETCH's path, issue 17).
READ_SETUP = 2
# The serial read's bit (the selected cluster's word, then the node's bit of
# it) is registered before it is used: the host port's data come
# HOST_READ_LATENCY cycles after the address, one more than the RAM's (issue
# 17: the cluster and bit multiplexers after the RAMs' output registers were
# the 6x3-block planner's path, 9.6 ns, and with the bank multiplexer the
# 11x6 and 14x6 planners').  Every value read costs a cycle more.
HOST_READ_LATENCY = READ_LATENCY + 1
# DECODE: a command's checks are registered in the cycle that takes it and
# acted on in the next (issue 17), before any response.
DECODE_CYCLES = 1


def direction_latency(p, inside=4):
    """DIRECTION's response latency at precision ``p`` (fixed point), in
    cycles from the clock edge that takes the command to the one that
    raises ``o_stream.valid``: DECODE_CYCLES to act on the registered checks,
    then the node and its ``inside`` neighbours in the map are read serially
    (p+2+READ_SETUP+HOST_READ_LATENCY = p+7 cycles each:
    FETCH registers the node, LOCATE its cluster, bit and RAM base, then the
    flag and p+1 value bits through the host port, whose bit comes
    HOST_READ_LATENCY cycles after the address), a neighbour outside the map
    costs 1 cycle, then 1 cycle starts the Decision, whose 2p+5 cycles (two
    serial passes) end with the response: 7p+42 inside the map, 6p+36 on an
    edge, 5p+30 in a corner.  With block exponents each value read adds its
    conversion: 1 + the shift cycles."""
    return (DECODE_CYCLES + (1 + inside) * (p + 2 + READ_SETUP + HOST_READ_LATENCY) + (4 - inside) + 1
            + (2 * p + 5))


def _pw(p_max):
    return (p_max + 1).bit_length()        # p_max + 1 fits: a too-high precision is sayable


def command_layout(blocks, n, m, p_max):
    BR, BC = blocks
    pw = _pw(p_max)
    return data.StructLayout({
        "op": Op,
        "block": (BR * BC).bit_length(), "row": n.bit_length(), "col": m.bit_length(),
        "flag": 1,              # SET: Sat; LOAD: 1 = first load of a new map (has_goal restarts)
        "flags": 18,            # LOAD: constant nodes (obstacles and goals) of the cluster
        "goals": 18,            # LOAD: goal nodes (value 1.0)
        "p1": pw, "step": pw, "p_last": pw, "iters": 8,
    })


def response_layout(p_max, exponents=False, e_max=255):
    pw = _pw(p_max)
    extra = {"exponent": range(e_max + 1)} if exponents else {}   # READ: the block's e_b
    return data.StructLayout({
        **extra,
        "code": Code, "op": Op, "busy": 1, "converged": 1, "p": pw,
        "const": 1, "value": p_max + 1,
        "triangle": 2, "g_row": signed(p_max + 2), "g_col": signed(p_max + 2),
        "sweeps": 32, "block_iterations": 32, "check_iterations": 32, "clear_passes": 32,
        "cycles": 48,
    })


class Planner(wiring.Component):
    """Harmonic planner: a map of BR x BC blocks of n x m nodes.

    Host interface: one command stream in, one response stream out
    (amaranth.lib.stream, valid/ready).  Every command gets exactly one
    response, in order; a command is accepted only when the previous
    response has been taken.  Response fields not named below are 0, except
    ``busy``, ``converged``, ``p`` and the counters, which every response
    carries (the STATUS fields).

    =========  ===============================================================
    op         fields used / response
    =========  ===============================================================
    LOAD       block, row, col (any node of the cluster), flags, goals, flag:
               writes the cluster's words of that block: constant flags,
               goals' integer bit, every other address 0 (p_max+2 cycles),
               and the border storage.  flag = 1 starts a new map (the goal
               record restarts).  BUSY while a run or clear pass is on.
    SET        block, row, col, flag (Sat): node becomes an obstacle (0) or a
               goal (1); every free node restarts from 0 (a clear pass: see
               :class:`~hdl.harmonic.controller.Controller`).  While idle it
               runs at once; during a run it waits for the end of the pass.
               Only one order waits: a second one is not accepted (no ready)
               until the first is taken.  Response OK when taken.
    START      p1, step, p_last, iters: precisions p1, p1+step, ... <= p_last;
               I = iters.  Response at once; poll STATUS for the end.
    STATUS     busy, converged, p, sweeps, block_iterations,
               check_iterations, clear_passes, cycles.
    READ       block, row, col: ``const`` and ``value`` at the current p.
    DIRECTION  block, row, col: ``triangle`` (0 NE, 1 ES, 2 SW, 3 WN) and the
               gradient (g_row, g_col) of :func:`models.harmonic.decision`
               (block exponents: of :func:`models.harmonic.decision_exponents`,
               in the centre's units; ``exponent`` = its e_b).  Response
               after :func:`direction_latency` cycles (7p+42 inside the map).
    =========  ===============================================================

    Errors (``code``): BAD_NODE (block >= B, row >= n or col >= m), NO_GOAL
    (START before any goal was loaded or set), BAD_PRECISION (p1 < 2,
    p_last > p_max, p1 > p_last, or step = 0 with p1 < p_last), BAD_ITERS
    (iters = 0), BUSY (LOAD, START, READ, DIRECTION during a run or a
    clear pass), BAD_OP.  A refused command changes nothing.

    Parameters
    ----------
    n, m : int
        Block size (multiples of 3 and 6).
    blocks : (BR, BC)
        The map: BR*n rows, BC*m columns (pad it with obstacles).
    p_max : int
        Largest precision.
    depth : int
        Words per cluster RAM; needs BR*BC*(p_max+2) <= depth.
    block_exponents : bool
        Issue 10, beyond the paper (default False: the design above,
        unchanged).  True: one exponent per block
        (:func:`models.harmonic.plan_exponents` with ``rtl=True``, bit for
        bit): exponent registers, the border conversion with its clamp scan,
        the re-pick and the in-place shift visits in the Control module;
        READ's response gains ``exponent`` (the node's block's e_b: the
        value is the mantissa, value / 2**(p + e_b)).  DIRECTION converts
        each neighbour in another block into the centre's units first
        (:func:`models.harmonic.convert_mantissa`, serially: one position
        per cycle, at most p+1 cycles per neighbour) and answers in those
        units, ``exponent`` = the centre's e_b.  SET's clear pass also
        sets every e_b back to 0.  See hdl/harmonic/README.md, "Planner RTL
        option".
    e_max, headroom : int
        With ``block_exponents``: the largest e_b (1 ..) and the re-pick's
        headroom h (0 .. p_max), ``plan_exponents``' ``e_max`` and
        ``headroom`` (defaults 255 and 1, the model's).
    paper_schedule : bool
        False (default): still blocks, :func:`models.harmonic.plan`'s
        default (a sweep visits only the blocks a change can reach, no
        confirmation iteration, no check pass; ``check_iterations`` stays
        0).  True: the paper's schedule, ``plan(..., paper_schedule=True)``.
        Both give the same field (see :mod:`models.harmonic.schedule`).
    """

    # Block's parameters (it checks them), at the planner's defaults, and the
    # block-exponent option (issue 10; default off: the paper's design).
    PARAMS = (*(replace(p, default={"n": 6, "m": 12, "br": 2, "bc": 2}.get(p.name, p.default))
                for p in Block.PARAMS if p.name != "exponents"),
              Param("block_exponents", bool, False, doc="block exponents (issue 10, beyond the paper)",
                    message="block_exponents={value!r}: must be True or False"),
              Param("headroom", int, 1, lo=0, hi=MAX_DEPTH - 2,
                    doc="top mantissa bits a re-pick leaves empty (with block_exponents; headroom <= p_max)",
                    message="headroom={value!r}: must be an integer in 0..{hi} (headroom <= p_max)"),
              Param("paper_schedule", bool, False,
                    doc="the paper's schedule (every block in every sweep, a confirmation iteration, a "
                        "check pass) instead of the default still blocks",
                    message="paper_schedule={value!r}: must be True or False"))
    CONSTRAINTS = (*Block.CONSTRAINTS,
                   Constraint("headroom <= p_max", lambda p: p["headroom"] <= p["p_max"],
                              "headroom={headroom!r}: leaves no mantissa bit at p_max={p_max}"))

    @checked_init
    def __init__(self, n=6, m=12, blocks=(2, 2), p_max=30, depth=1024, block_exponents=False, e_max=255,
                 headroom=1, paper_schedule=False):
        check(self.PARAMS, self.CONSTRAINTS, n=n, m=m, br=blocks[0], bc=blocks[1], p_max=p_max, depth=depth,
              block_exponents=block_exponents, e_max=e_max, headroom=headroom, paper_schedule=paper_schedule)
        self.exponents = bool(block_exponents)
        self.paper = bool(paper_schedule)
        self.e_max, self.headroom = e_max, headroom
        ekw = {"exponents": True, "e_max": e_max} if self.exponents else {}
        self.block = Block(n, m, blocks, p_max, depth, **ekw)
        self.n, self.m, self.BR, self.BC = n, m, *blocks
        self.p_max, self.depth = p_max, depth
        self.cmd_layout = command_layout(blocks, n, m, p_max)
        self.resp_layout = response_layout(p_max, **ekw)
        super().__init__({
            "i_stream": In(stream.Signature(self.cmd_layout)),
            "o_stream": Out(stream.Signature(self.resp_layout)),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest (see Controller's table)."""
        return {"iteration_cycles": "L = p+2 (p >= 4; 6 below; a shift iteration one more: iteration_cycles())",
                "block_visit_cycles": "K*L+7 for K iterations",
                "schedule": "paper's" if self.paper else "still blocks",
                "response": "one o_stream beat per i_stream command, in order",
                "direction_latency": "7p+42 cycles (a node with 4 neighbours in the map; "
                                     "p+6 fewer per neighbour outside it: direction_latency())",
                "run_cycles": "reported by STATUS (cycles field)"}

    def elaborate(self, platform):
        m = Module()
        n, mm, BR, BC, p_max = self.n, self.m, self.BR, self.BC, self.p_max
        S, CC = p_max + 2, mm // COLS
        B = BR * BC
        m.submodules.block = blk = self.block
        X = self.exponents
        xkw = {"exponents": True, "e_max": self.e_max, "headroom": self.headroom} if X else {}
        m.submodules.control = ctl = Controller((BR, BC), n, mm, p_max, paper_schedule=self.paper, **xkw)
        m.submodules.decision = dec = Decision(p_max)
        wiring.connect(m, ctl.block, blk.control)
        host = blk.host             # the LOAD / READ / DIRECTION path to the RAMs

        cmd = self.i_stream.payload
        resp = self.o_stream.payload
        c = Signal(self.cmd_layout)             # the command being executed
        has_goal = Signal()

        # (block, row, col) -> block row/column, cluster, bit.  Arithmetic by
        # constants as continuous assignments (defined from time 0); the
        # products as shifts and adds (times): yosys mapped a constant
        # product here to a MULT18X18D on the ECP5, on the planner's
        # critical path (issue 17).
        def locate(block, row, col, prefix):
            tbr, tbc = Signal(range(max(BR, 2)), name=f"{prefix}_br"), Signal(range(max(BC, 2)), name=f"{prefix}_bc")
            ci = Signal(range(max(CC * (n // ROWS), 2)), name=f"{prefix}_ci")
            bit = Signal(range(18), name=f"{prefix}_bit")
            # row // 3, col // 6 as lookup tables (divmod_const): a divider's
            # carry chains here were the 12x24 planner's critical path (issue 17)
            (r_q, r_r), (c_q, c_r) = divmod_const(row, ROWS), divmod_const(col, COLS)
            # and block // BC by the reciprocal: yosys' divider by a BC that is
            # no power of two was the 6x3-block planner's critical path
            b_q, b_r = divmod_const(block, BC)
            m.d.comb += [
                tbr.eq(b_q), tbc.eq(b_r),
                ci.eq(times(r_q, CC) + c_q),
                bit.eq(times(r_r, COLS) + c_r),
            ]
            return tbr, tbc, ci, bit

        in_map = (cmd.block < B) & (cmd.row < n) & (cmd.col < mm)
        c_br, c_bc, c_ci, c_bit = locate(c.block, c.row, c.col, "c")

        def respond(code, op):
            m.d.sync += [self.o_stream.valid.eq(1), resp.code.eq(code), resp.op.eq(op)]
        with m.If(self.o_stream.valid & self.o_stream.ready):
            m.d.sync += self.o_stream.valid.eq(0)
        # The STATUS fields ride on every response: they follow the Controller
        # while no response waits (nobody reads a payload while valid is low),
        # so they take its values in the cycle a response is raised, whatever
        # the state, and hold them while it waits.  Their ~180 enables are one
        # flip-flop, not the OR of every response's condition (issue 17: that
        # OR was the 6x3-block planner's critical path, 11.9 ns).
        with m.If(~self.o_stream.valid):
            m.d.sync += [
                resp.busy.eq(ctl.busy), resp.converged.eq(ctl.converged), resp.p.eq(ctl.p),
                resp.sweeps.eq(ctl.sweeps), resp.block_iterations.eq(ctl.block_iterations),
                resp.check_iterations.eq(ctl.check_iterations),
                resp.clear_passes.eq(ctl.clear_passes), resp.cycles.eq(ctl.cycles),
            ]

        # Serial read of one node word through the host port (p+2 addresses,
        # the node's bit registered HOST_READ_LATENCY cycles after its
        # address): flag, then value MSB first.
        rd_go, rd_done = Signal(), Signal()
        # The host port's address is this register in every state: set to
        # the block's word base when LOAD or a read is decided, then one up
        # per cycle of LOAD / the read (no adder and no FSM state between a
        # register and the RAMs' address pins: the 6x3-block planner's path
        # after the still blocks' choice, issue 17).
        h_addr = Signal(range(self.depth), name="h_addr")
        m.d.comb += host.addr.eq(h_addr)
        # LOAD's write data, a register too (words 0 and 1: the flags or'ed
        # with the goals, then the goals; 0 after): the FSM state and LOAD's
        # word count -> the data -> every cluster RAM's write-data
        # multiplexer was the 6x3-block planner's path (issue 17).
        wdata = Signal.like(host.wdata, name="h_wdata")
        m.d.comb += host.wdata.eq(wdata)
        rd_ci, rd_bit = Signal.like(c_ci), Signal.like(c_bit)
        rd_j = Signal(range(S + 3))                # up to rd_end = p_max + 1 + HOST_READ_LATENCY
        rd_val, rd_const = Signal(p_max + 1), Signal()
        rd_busy = Signal()
        # p+1 and the read's last count, registered: ctl.p holds while idle
        # (the only time READ / DIRECTION read), so the adders leave the
        # read's path (issue 17).
        p_top = Signal(range(p_max + 2))
        rd_end = Signal(range(S + 3))
        m.d.sync += [p_top.eq(ctl.p + 1), rd_end.eq(ctl.p + 1 + HOST_READ_LATENCY)]
        # The host port's cluster select is the register rd_ci in every state
        # (LOAD and reads set it a cycle ahead; it only selects read data and
        # gates host.we): no FSM state on the RAM's read multiplexer, which
        # was the planner's critical path after DECODE (issue 17).
        m.d.comb += host.cluster.eq(rd_ci)
        # rd_j == rd_end as a register set a count ahead (rd_end >= 3): the
        # read's end drives the enables of the Decision's 257-bit values, and
        # the comparator before them was the 6x3-block planner's path (issue 17)
        rd_last = Signal()
        rd_hit = Signal()
        m.d.comb += rd_hit.eq(rd_j + 1 == rd_end)
        got = Signal(name="rd_got")             # the node's bit of the word read
        with m.If(rd_busy):
            m.d.sync += got.eq(host.rdata.bit_select(rd_bit, 1))
        with m.If(rd_go):
            m.d.sync += [rd_busy.eq(1), rd_j.eq(0), rd_val.eq(0), rd_last.eq(0)]
        with m.Elif(rd_busy):
            m.d.sync += [rd_j.eq(rd_j + 1), h_addr.eq(h_addr + 1), rd_last.eq(rd_hit)]
            with m.If(rd_j == HOST_READ_LATENCY):
                m.d.sync += rd_const.eq(got)
            with m.Elif(rd_j > HOST_READ_LATENCY):
                m.d.sync += rd_val.eq(Cat(got, rd_val[:-1]))
            with m.If(rd_last):
                m.d.sync += rd_busy.eq(0)
                m.d.comb += rd_done.eq(1)

        # the word read: its last bit arrives with rd_done
        word = Signal(p_max + 1, name="rd_word")
        m.d.comb += word.eq(Cat(got, rd_val[:-1]))

        # DIRECTION: the centre, then N, E, S, W (0 outside the map): q
        # indexes NEIGHBOURHOOD, the Decision module's values.
        q = Signal(3)
        vals = Signal(neighbourhood_layout(p_max), name="dir")
        t_blk, t_row, t_col, t_in = Signal.like(c.block), Signal.like(c.row), Signal.like(c.col), Signal()
        m.d.comb += [t_blk.eq(c.block), t_row.eq(c.row), t_col.eq(c.col), t_in.eq(1)]
        # q: (in-block test, the move inside the block, the test for a block
        # beyond, the move into it); neither: outside the map (reads 0).
        moves = {
            1: (c.row != 0, [t_row.eq(c.row - 1)],                             # N
                c_br != 0, [t_blk.eq(c.block - BC), t_row.eq(n - 1)]),
            2: (c.col != mm - 1, [t_col.eq(c.col + 1)],                        # E
                c_bc != BC - 1, [t_blk.eq(c.block + 1), t_col.eq(0)]),
            3: (c.row != n - 1, [t_row.eq(c.row + 1)],                         # S
                c_br != BR - 1, [t_blk.eq(c.block + BC), t_row.eq(0)]),
            4: (c.col != 0, [t_col.eq(c.col - 1)],                             # W
                c_bc != 0, [t_blk.eq(c.block - 1), t_col.eq(mm - 1)]),
        }
        # The tests are registered every cycle (c changes only when a command
        # is taken, and DECODE comes between that and FETCH): c.block ->
        # its block row / column -> the tests -> the enables of the value
        # registers was the 6x3-block planner's critical path (issue 17).
        t_inside, t_beyond = Signal(5), Signal(5)
        m.d.sync += [x.eq(t) for i, (inside, _, beyond, _) in moves.items()
                     for x, t in ((t_inside[i], inside), (t_beyond[i], beyond))]
        with m.Switch(q):
            for i, (_, step, _, jump) in moves.items():
                with m.Case(i):
                    with m.If(t_inside[i]):
                        m.d.comb += step
                    with m.Elif(t_beyond[i]):
                        m.d.comb += jump
                    with m.Else():
                        m.d.comb += t_in.eq(0)
        # FETCH registers the selected node (f_*), LOCATE its address.
        f_blk, f_row, f_col = Signal.like(c.block), Signal.like(c.row), Signal.like(c.col)
        _, _, f_ci, f_bit = locate(f_blk, f_row, f_col, "f")
        m.d.comb += [dec.h.eq(vals), dec.p.eq(ctl.p)]

        load_a = Signal(range(S + 1))
        p_bad = Signal()
        m.d.comb += p_bad.eq((cmd.p1 < 2) | (cmd.p_last > p_max) | (cmd.p1 > cmd.p_last)
                             | ((cmd.step == 0) & (cmd.p1 != cmd.p_last)))

        def next_neighbour(first=m.If):
            with first(q == 4):
                m.next = "DECIDE_GO"
            with m.Else():
                m.d.sync += q.eq(q + 1)
                m.next = "FETCH"

        if X:
            # DIRECTION with block exponents (models.harmonic.decision_exponents):
            # the centre's e_c, then each neighbour converted by s = e_c - e_t.
            E_W = ctl.e_rd.shape().width
            dir_e = Signal(E_W)
            cv = Signal(p_max + 1)
            cv_n = Signal(range(p_max + 2))
            cv_left = Signal()
            cap = Signal(p_max + 1)             # 2**(p+1) - 1: the word's top
            m.d.comb += [cap.eq(Cat(1, *[ctl.p >= i for i in range(1, p_max + 1)])),
                         ctl.e_rd_block.eq(f_blk)]
            s_sh = Signal(signed(E_W + 1))
            s_abs = Signal(E_W)
            m.d.comb += [s_sh.eq(dir_e - ctl.e_rd), s_abs.eq(Mux(s_sh < 0, -s_sh, s_sh))]

        accept = Signal()
        # The checks of a command are registered when it is taken and acted on
        # in DECODE, a cycle later: the payload -> comparators and carry chains
        # -> the response's wide load enable was the fixed-point planner's
        # critical path (10.8 ns, issue 17).  Every response comes one cycle
        # later for it (DECODE_CYCLES in direction_latency).
        k_in_map, k_p_bad, k_iters0, k_goals = Signal(), Signal(), Signal(), Signal()
        with m.FSM() as fsm:
            with m.State("IDLE"):
                with m.If(accept):
                    m.d.sync += [c.eq(cmd), k_in_map.eq(in_map), k_p_bad.eq(p_bad),
                                 k_iters0.eq(cmd.iters == 0), k_goals.eq(cmd.goals != 0)]
                    m.next = "DECODE"
            with m.State("DECODE"):
                m.next = "IDLE"
                with m.Switch(c.op):
                    with m.Case(Op.LOAD):
                        with m.If(~k_in_map):
                            respond(Code.BAD_NODE, c.op)
                        with m.Elif(ctl.busy):
                            respond(Code.BUSY, c.op)
                        with m.Else():
                            # LOAD's RAM base and cluster registered now (as
                            # LOCATE does for a read): the host port's cluster
                            # select is then a flip-flop in every state.
                            m.d.sync += [load_a.eq(0), h_addr.eq(times(c.block, S) if B > 1 else 0),
                                         rd_ci.eq(c_ci), wdata.eq(c.flags | c.goals)]
                            with m.If(c.flag):
                                m.d.sync += has_goal.eq(k_goals)
                            with m.Else():
                                m.d.sync += has_goal.eq(has_goal | k_goals)
                            m.next = "LOAD"
                    with m.Case(Op.SET):
                        with m.If(~k_in_map):
                            respond(Code.BAD_NODE, c.op)
                        with m.Else():
                            m.next = "SET"
                    with m.Case(Op.START):
                        with m.If(ctl.busy):
                            respond(Code.BUSY, c.op)
                        with m.Elif(k_p_bad):
                            respond(Code.BAD_PRECISION, c.op)
                        with m.Elif(k_iters0):
                            respond(Code.BAD_ITERS, c.op)
                        with m.Elif(~has_goal):
                            respond(Code.NO_GOAL, c.op)
                        with m.Else():
                            m.next = "START_GO"
                    with m.Case(Op.STATUS):
                        respond(Code.OK, c.op)
                    with m.Case(Op.READ, Op.DIRECTION):
                        with m.If(~k_in_map):
                            respond(Code.BAD_NODE, c.op)
                        with m.Elif(ctl.busy):
                            respond(Code.BUSY, c.op)
                        with m.Else():
                            m.d.sync += q.eq(0)
                            m.next = "FETCH"
                    with m.Default():
                        respond(Code.BAD_OP, c.op)
            with m.State("START_GO"):       # the Controller starts from the registered command
                m.next = "STARTED"
            with m.State("STARTED"):        # the response shows the run begun
                respond(Code.OK, Op.START)
                m.next = "IDLE"
            with m.State("LOAD"):
                # the next word's data: the goals after the flags, then 0
                m.d.sync += [wdata.eq(Mux(load_a == 0, c.goals, 0)),
                             load_a.eq(load_a + 1), h_addr.eq(h_addr + 1)]
                with m.If(load_a == S - 1):
                    respond(Code.OK, Op.LOAD)
                    m.next = "IDLE"
            with m.State("SET"):
                with m.If(ctl.order.ready):
                    with m.If(c.flag):
                        m.d.sync += has_goal.eq(1)
                    m.next = "SET_RESP"
            with m.State("SET_RESP"):
                respond(Code.OK, Op.SET)
                m.next = "IDLE"
            with m.State("FETCH"):          # READ: q = 0 only; DIRECTION: q = 0 .. 4
                with m.If(t_in):
                    m.d.sync += [f_blk.eq(t_blk), f_row.eq(t_row), f_col.eq(t_col)]
                    m.next = "LOCATE"
                with m.Else():              # outside the map: its value stays 0 (cleared below)
                    m.d.sync += q.eq(q + 1)
                    with m.If(q == 4):
                        m.next = "DECIDE_GO"
            with m.State("LOCATE"):         # the read starts (rd_go)
                m.d.sync += [h_addr.eq(times(f_blk, S) if B > 1 else 0), rd_ci.eq(f_ci), rd_bit.eq(f_bit)]
                if X:
                    with m.If(q == 0):
                        m.d.sync += [dir_e.eq(ctl.e_rd), cv_n.eq(0)]
                    with m.Else():
                        m.d.sync += [cv_left.eq(s_sh > 0),
                                     cv_n.eq(Mux(s_abs > p_top, p_top, s_abs))]
                m.next = "FETCH_WAIT"
            with m.State("FETCH_WAIT"):
                with m.If(rd_done):
                    if X:
                        # A neighbour in another block: into the centre's units first.
                        m.d.sync += cv.eq(word)
                    with m.If(c.op == Op.READ):
                        m.next = "READ_RESP"
                    if X:
                        with m.Else():
                            m.next = "CONVERT"
                    else:
                        next_neighbour(m.Elif)
            if X:
                with m.State("CONVERT"):
                    # convert_mantissa serially, one position per cycle (at most
                    # p+1: by then a left shift has clamped any non-zero value
                    # and a right shift has dropped every bit).  Left: the word's
                    # top bit p set means the next shift would pass 2**(p+1)-1:
                    # clamp there.  q = 0 (the centre) has cv_n = 0.
                    with m.If(cv_n == 0):
                        with m.Switch(q):
                            for i in range(5):
                                with m.Case(i):
                                    m.d.sync += vals[NEIGHBOURHOOD[i]].eq(cv)
                        next_neighbour()
                    with m.Else():
                        m.d.sync += cv_n.eq(cv_n - 1)
                        with m.If(~cv_left):
                            m.d.sync += cv.eq(cv >> 1)
                        with m.Elif(cv.bit_select(ctl.p, 1)):
                            m.d.sync += [cv.eq(cap), cv_n.eq(0)]
                        with m.Else():
                            m.d.sync += cv.eq(cv << 1)
            with m.State("READ_RESP"):
                respond(Code.OK, Op.READ)
                m.d.sync += [resp.value.eq(vals.c), resp.const.eq(rd_const)]
                if X:
                    m.d.sync += resp.exponent.eq(ctl.e_rd)
                m.next = "IDLE"
            with m.State("DECIDE_GO"):
                m.next = "DECIDE"
            with m.State("DECIDE"):
                with m.If(dec.done):
                    respond(Code.OK, Op.DIRECTION)
                    m.d.sync += [resp.value.eq(vals.c), resp.triangle.eq(dec.triangle),
                                 resp.g_row.eq(dec.g_row), resp.g_col.eq(dec.g_col)]
                    if X:
                        m.d.sync += resp.exponent.eq(dir_e)
                    m.next = "IDLE"
        # Strobes and enables as plain expressions of the state (continuous
        # assignments in the Verilog: defined from time 0 on every simulator).
        m.d.comb += [
            self.i_stream.ready.eq(fsm.ongoing("IDLE") & ~self.o_stream.valid),
            accept.eq(fsm.ongoing("IDLE") & self.i_stream.valid & ~self.o_stream.valid),
            # START is checked in DECODE (its checks registered when taken) and
            # run from the registered command a cycle later (START_GO): the
            # checks -> the Controller's 48-bit counters was one path (issue 17)
            ctl.start.eq(fsm.ongoing("START_GO")), ctl.p1.eq(c.p1), ctl.step.eq(c.step),
            ctl.p_last.eq(c.p_last), ctl.iters.eq(c.iters),
            ctl.order.valid.eq(fsm.ongoing("SET")), ctl.order.payload.br.eq(c_br),
            ctl.order.payload.bc.eq(c_bc), ctl.order.payload.row.eq(c.row),
            ctl.order.payload.col.eq(c.col), ctl.order.payload.sat.eq(c.flag),
            host.we.eq(fsm.ongoing("LOAD")),
            dec.start.eq(fsm.ongoing("DECIDE_GO")),
            rd_go.eq(fsm.ongoing("LOCATE")),
        ]
        # The Decision's values (5 x p_max+1 flip-flops) load from enables that
        # are flip-flops: ld[i] is set a cycle ahead of the read's end (rd_busy
        # holds only in FETCH_WAIT, and q holds there), so ld[i] <=> rd_done &
        # q == i; and the first LOCATE (q = 0) clears the neighbours,
        # so one outside the map needs no write.  q and the read's end -> these
        # enables was the 6x3-block planner's path (issue 17).  With block
        # exponents only the centre loads here (the rest after CONVERT).
        ld = Signal(5)
        m.d.sync += ld.eq(Mux(rd_busy & ~rd_last & rd_hit, Cat(q == i for i in range(5)), 0))
        for i in range(1 if X else 5):
            with m.If(ld[i]):
                m.d.sync += vals[NEIGHBOURHOOD[i]].eq(word)
        # The clear in the first LOCATE, from a flip-flop set in FETCH (q = 0 is
        # always in the map): the FSM state into the ~1028 flip-flops'
        # synchronous reset was the next path.  Never with ld: a reset.
        clr_nb = Signal()
        m.d.sync += clr_nb.eq(fsm.ongoing("FETCH") & (q == 0))
        with m.If(clr_nb):
            m.d.sync += [vals[NEIGHBOURHOOD[i]].eq(0) for i in range(1, 5)]
        # Responses without a value: clear the data fields, a cycle after the
        # command is taken (no response is raised sooner, and READ / DIRECTION
        # write them much later), from a register: the accept's logic into
        # the ~780 flip-flops' synchronous clear was the 6x3-block planner's
        # path (issue 17).
        clear_data = Signal()
        m.d.sync += clear_data.eq(self.i_stream.valid & self.i_stream.ready)
        with m.If(clear_data):
            m.d.sync += [resp.value.eq(0), resp.const.eq(0), resp.triangle.eq(0),
                         resp.g_row.eq(0), resp.g_col.eq(0)]
            if X:
                m.d.sync += resp.exponent.eq(0)
        return m
