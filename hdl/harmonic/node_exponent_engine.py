"""The node-exponent engine (issue 22): the harmonic field with one exponent
per node on a whole map held in one state RAM, one pipelined node update
(:class:`~hdl.harmonic.node_exponents.NodeExponentUpdate`) streaming over it."""

from amaranth.hdl import Cat, Const, Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from navcores.models.harmonic.node_exponents import (ENGINE_HALF_EXTRA, ENGINE_SLOTS, P_LIMIT, RAM_LATENCY,
                                                     UPDATE_LATENCY)

from ..params import Constraint, Param, check, checked_init
from ..ram_init import UNDEFINED_INIT
from .node_exponents import E_MAX_LIMIT, NEIGHBOURS, NodeExponentUpdate, word_layout

__all__ = ["NodeExponentEngine", "CELL_FREE", "CELL_OBSTACLE", "CELL_GOAL", "MAX_SIDE", "MAX_ITER_BITS"]

CELL_FREE, CELL_OBSTACLE, CELL_GOAL = 0, 1, 2       # the ``cells`` stream's codes
MAX_SIDE = 1024                 # a map side: 1M words of state at most (the LFE5U-85F holds 256 x 256)
MAX_ITER_BITS = 16              # the command's iteration bound


class NodeExponentEngine(wiring.Component):
    """The harmonic potential with node exponents over a map in block RAM.

    models.harmonic.plan_node_exponents(..., order="red-black",
    until_fixed=True) in hardware, bit-exact, cycle-exact with
    :func:`models.harmonic.node_exponents.engine_cycles`: the state RAM
    holds a word per cell (mantissa v, exponent e, a constant bit for goals
    and obstacles); an iteration updates the even cells (row + column), then
    the odd ones from their new values, in place (a half-sweep reads only
    the other colour, so the words it writes are never read in it); the run
    stops at the first iteration that changes no word (the fixed point of
    the rounded update) or after ``max_iter`` iterations.  Outside the map
    reads as zero; a free cell no goal reaches stays zero.

    Parameters
    ----------
    max_h, max_w : int
        The largest map, 1 .. 1024 rows and 2 .. 1024 columns (the RAM:
        max_h x 2**ceil(log2 max_w) words of p + 2 + e bits).
    p, e_max, headroom :
        The node update's number format (:class:`NodeExponentUpdate`).

    Ports
    -----
    cmd : In(stream {height, width, max_iter})
        A job: the map's size (1 <= height <= max_h, 2 <= width <= max_w)
        and the iteration bound (>= 1).  A size out of range sets ``error``
        and is dropped (the engine stays idle).
    cells : In(stream of 2 bits)
        Then height x width cells in reading order: 0 free, 1 obstacle, 2
        goal (3 reads as an obstacle).
    field : Out(stream {v, e})
        After the run, height x width words in reading order, v / 2**(p+e).
    busy, error, fixed, iterations, cycles : Out
        Status: a job is running; the last command was refused; the last run
        ended on a fixed point (else at max_iter); its iterations; its cycles
        from the first half-sweep to the end of the last iteration (the
        load and the read-out are the host's pace).

    ==================  ===============================================
    step                cycles
    ==================  ===============================================
    a cell              ENGINE_SLOTS (5) reads: own, N, W, E, S, each
                        RAM_LATENCY (3) cycles to its data; the update's
                        input a cycle after the last read's data, its word
                        chosen UPDATE_LATENCY (9) later, written the next
                        cycle (WRITE_LATENCY 1)
    a half-sweep        5 x its cells + ENGINE_HALF_EXTRA (14)
    an iteration        5 x height x width + 2 x 14 + 1 (the decision)
    load / read-out     one cell a beat / five cycles a word at most
    ==================  ===============================================

    Synchronous reset: idle, status cleared; the RAM keeps its words.  The
    RAM has no initial value (undefined until written: X in Icarus): a job
    loads every cell of its map before it reads any, and a neighbour outside
    the map is read but replaced by a zero word, so no unwritten word
    reaches the update or the read-out (the Icarus test checks it).
    """

    PARAMS = (
        Param("max_h", int, lo=1, hi=MAX_SIDE, doc="largest map height"),
        Param("max_w", int, lo=2, hi=MAX_SIDE, doc="largest map width"),
        Param("p", int, 16, lo=4, hi=P_LIMIT, doc="word precision: p+1 mantissa bits"),
        Param("e_max", int, lo=1, hi=E_MAX_LIMIT, doc="largest exponent (2 x the longest distance a map needs)"),
        Param("headroom", int, 2, lo=0, hi=P_LIMIT - 2, doc="empty top mantissa bits of a normalized word"),
    )
    CONSTRAINTS = (
        Constraint("headroom <= p - 2", lambda v: v["headroom"] <= v["p"] - 2,
                   "headroom = {headroom}: take 0 <= headroom <= p - 2"),
    )

    @checked_init
    def __init__(self, max_h, max_w, p=16, e_max=255, headroom=2):
        check(self.PARAMS, self.CONSTRAINTS, max_h=max_h, max_w=max_w, p=p, e_max=e_max, headroom=headroom)
        self.max_h, self.max_w, self.p, self.e_max, self.headroom = max_h, max_w, p, e_max, headroom
        self.col_bits = max(1, (max_w - 1).bit_length())
        self.row_bits = max(1, (max_h - 1).bit_length())
        self.word = word_layout(p, e_max)
        super().__init__({
            "cmd": In(stream.Signature(data.StructLayout({
                "height": range(max_h + 1), "width": range(max_w + 1), "max_iter": MAX_ITER_BITS}))),
            "cells": In(stream.Signature(2)),
            "field": Out(stream.Signature(self.word)),
            "busy": Out(1), "error": Out(1), "fixed": Out(1),
            "iterations": Out(MAX_ITER_BITS), "cycles": Out(48),
        })

    def timing(self):
        return {"iteration_cycles": f"{ENGINE_SLOTS} * height * width + 2 * {ENGINE_HALF_EXTRA} + 1",
                "run_cycles": "iterations * iteration_cycles", "update_latency": UPDATE_LATENCY,
                "note": f"load one cell a beat; read-out a word every {RAM_LATENCY + 2} cycles without "
                        "back-pressure; idle input and back-pressure add cycles outside run_cycles"}

    def elaborate(self, platform):
        m = Module()
        p, e_max = self.p, self.e_max
        m.submodules.update = upd = NodeExponentUpdate(p, e_max, self.headroom)
        assert upd.LATENCY == UPDATE_LATENCY, "models.harmonic.node_exponents.UPDATE_LATENCY is the unit's"
        L = UPDATE_LATENCY
        cw, rw = self.col_bits, self.row_bits
        state = data.StructLayout({"v": p + 1, "e": max(1, e_max.bit_length()), "const": 1})
        # No initial value (hdl/ram_init.py: a 64K-word init block stalls yosys' front end): every
        # word a job reads is loaded first; a neighbour outside the map is read but replaced by zero.
        m.submodules.ram = ram = Memory(shape=state, depth=self.max_h << cw, init=[],
                                        attrs={UNDEFINED_INIT: 1, "no_rw_check": 1})
        rd = ram.read_port()
        wr = ram.write_port()

        H, W = Signal(range(self.max_h + 1), name="H"), Signal(range(self.max_w + 1), name="W")
        max_iter = Signal(MAX_ITER_BITS)
        zero = state.const({"v": 0, "e": e_max, "const": 0})

        # --- the command ---------------------------------------------------
        cmd = self.cmd.payload
        bad = Signal()
        m.d.comb += bad.eq((cmd.height < 1) | (cmd.height > self.max_h) | (cmd.width < 2)
                           | (cmd.width > self.max_w) | (cmd.max_iter == 0))

        r, c = Signal(rw, name="r"), Signal(cw, name="c")   # the cell being read (load / sweep / read-out)
        colour = Signal()
        it = Signal(MAX_ITER_BITS)
        changed = Signal()
        slot = Signal(range(ENGINE_SLOTS))
        wait = Signal(range(L + 3))

        # --- the sweep's reads: own, N, W, E, S (slot 0..4) -------------------
        offs = ((0, 0), (-1, 0), (0, -1), (0, 1), (1, 0))
        rr, cc, inside = Signal(rw + 1, name="rr"), Signal(cw + 1, name="cc"), Signal(name="inside")
        with m.Switch(slot):
            for k, (dr, dc) in enumerate(offs):
                with m.Case(k):
                    m.d.comb += [rr.eq(r + dr), cc.eq(c + dc)]
                    m.d.comb += inside.eq(((r != 0) if dr < 0 else (r + 1 < H) if dr > 0 else 1)
                                          & ((c != 0) if dc < 0 else (c + 1 < W) if dc > 0 else 1))
        sweep_addr = Cat(cc[:cw], rr[:rw])
        # A read's slot and whether it was inside the map ride along with it.  The read has latency
        # RAM_LATENCY = 3: the address registered (it fans out to every block of
        # the RAM: 128 at 256 x 256), the block RAM, then a register behind the multiplexer that joins
        # the blocks (each was the critical path in turn).
        addr_q = Signal(len(rd.addr), name="addr_q")
        a_slot, a_in, a_valid = Signal.like(slot, name="a_slot"), Signal(name="a_in"), Signal(name="a_valid")
        issued_slot, issued_in, issued = (Signal.like(slot, name="issued_slot"), Signal(name="issued_in"),
                                          Signal(name="issued"))
        m.d.comb += rd.addr.eq(addr_q)
        m.d.sync += [issued_slot.eq(a_slot), issued_in.eq(a_in), issued.eq(a_valid)]
        got_slot, got_in, got_valid = Signal.like(slot, name="got_slot"), Signal(name="got_in"), Signal(name="got_valid")
        rd_q = Signal(state, name="rd_q")
        m.d.sync += [rd_q.eq(rd.data), got_slot.eq(issued_slot), got_in.eq(issued_in), got_valid.eq(issued)]
        data_in = Signal(state)
        m.d.comb += data_in.eq(Mux(got_in, rd_q, zero))
        nb = {k: Signal(state, name=f"nb_{k}") for k in ("own", "N", "W", "E")}
        push, push_own = Signal(name="push"), Signal(state, name="push_own")
        push_addr = Signal(rw + cw, name="push_addr")
        addr_of = {k: Signal(rw + cw, name=f"addr_{k}") for k in ("cur", "own")}
        payload = Signal.like(upd.i_stream.payload)
        m.d.comb += [upd.i_stream.valid.eq(push), upd.i_stream.payload.eq(payload), upd.o_stream.ready.eq(1)]
        with m.If(got_valid):
            with m.Switch(got_slot):
                with m.Case(0):
                    m.d.sync += [nb["own"].eq(data_in), addr_of["own"].eq(addr_of["cur"])]
                for k, name in ((1, "N"), (2, "W"), (3, "E")):
                    with m.Case(k):
                        m.d.sync += nb[name].eq(data_in)
                with m.Case(4):             # the neighbourhood is complete: the update's input
                    words = {"N": nb["N"], "W": nb["W"], "E": nb["E"], "S": data_in}
                    m.d.sync += [push.eq(1), push_own.eq(nb["own"]), push_addr.eq(addr_of["own"])]
                    m.d.sync += [payload[k].v.eq(words[k].v) for k in NEIGHBOURS]
                    m.d.sync += [payload[k].e.eq(words[k].e) for k in NEIGHBOURS]
        with m.If(push & ~(got_valid & (got_slot == 4))):
            m.d.sync += push.eq(0)

        # The cell's address and old word travel beside the update (it never
        # stalls: its output comes exactly L cycles after its input).
        aux = [(Signal(name=f"aux_valid{k}"), Signal(rw + cw, name=f"aux_addr{k}"), Signal(state, name=f"aux_own{k}"))
               for k in range(L)]
        prev = (push, push_addr, push_own)
        for av, aa, ao in aux:
            m.d.sync += [av.eq(prev[0]), aa.eq(prev[1]), ao.eq(prev[2])]
            prev = (av, aa, ao)
        out_valid, out_addr, out_own = aux[-1][0], aux[-1][1], aux[-1][2]
        new = upd.o_stream.payload
        sweep_write = Signal()
        m.d.comb += sweep_write.eq(out_valid & upd.o_stream.valid & ~out_own.const)
        with m.If(sweep_write & ((new.v != out_own.v) | (new.e != out_own.e))):
            m.d.sync += changed.eq(1)

        # --- the load's writes --------------------------------------------
        cell = self.cells.payload
        load_word = Signal(state)
        m.d.comb += load_word.eq(Mux(cell == CELL_FREE, zero,
                                     Mux(cell == CELL_GOAL, state.const({"v": 1 << p, "e": 0, "const": 1}),
                                         state.const({"v": 0, "e": e_max, "const": 1}))))
        load_write = Signal()

        # --- the read-out ---------------------------------------------------
        out_pending = Signal(range(RAM_LATENCY + 1))    # cycles since the read-out's read was issued
        field_valid = Signal()
        m.d.comb += [self.field.valid.eq(field_valid)]

        last_col, last_row = Signal(name="last_col"), Signal(name="last_row")
        m.d.comb += [last_col.eq(c + 1 >= W), last_row.eq(r + 1 >= H)]

        with m.FSM() as fsm:
            with m.State("IDLE"):
                with m.If(self.cmd.valid):
                    with m.If(bad):
                        m.d.sync += self.error.eq(1)
                    with m.Else():
                        m.d.sync += [H.eq(cmd.height), W.eq(cmd.width), max_iter.eq(cmd.max_iter),
                                     self.error.eq(0), self.busy.eq(1), self.fixed.eq(0),
                                     self.iterations.eq(0), self.cycles.eq(0), r.eq(0), c.eq(0)]
                        m.next = "LOAD"
            with m.State("LOAD"):
                m.d.comb += load_write.eq(self.cells.valid)
                with m.If(self.cells.valid):
                    m.d.sync += c.eq(Mux(last_col, 0, c + 1))
                    with m.If(last_col):
                        m.d.sync += r.eq(r + 1)
                        with m.If(last_row):
                            m.d.sync += [r.eq(0), c.eq(0), colour.eq(0), slot.eq(0), it.eq(0), changed.eq(0)]
                            m.next = "SWEEP"
            with m.State("SWEEP"):
                m.d.sync += self.cycles.eq(self.cycles + 1)
                m.d.sync += [addr_q.eq(sweep_addr), a_valid.eq(1), a_slot.eq(slot), a_in.eq(inside)]
                with m.If(slot == 0):
                    m.d.sync += addr_of["cur"].eq(Cat(c, r))
                m.d.sync += slot.eq(Mux(slot == ENGINE_SLOTS - 1, 0, slot + 1))
                with m.If(slot == ENGINE_SLOTS - 1):
                    # the next cell of this colour in reading order (width >= 2: every row has one)
                    with m.If(c + 2 < W):
                        m.d.sync += c.eq(c + 2)
                    with m.Else():
                        m.d.sync += [r.eq(r + 1), c.eq((r[0] ^ colour) ^ 1)]
                        with m.If(last_row):
                            m.d.sync += [r.eq(0), wait.eq(0)]
                            m.next = "DRAIN"
            with m.State("DRAIN"):              # the half-sweep's last words are written
                m.d.sync += [self.cycles.eq(self.cycles + 1), a_valid.eq(0), wait.eq(wait + 1)]
                with m.If(wait == ENGINE_HALF_EXTRA - 1):
                    with m.If(colour == 0):
                        m.d.sync += [colour.eq(1), r.eq(0), c.eq(1)]
                        m.next = "SWEEP"
                    with m.Else():
                        m.next = "DECIDE"
            with m.State("DECIDE"):
                m.d.sync += [self.cycles.eq(self.cycles + 1), self.iterations.eq(it + 1)]
                with m.If(~changed | (it + 1 == max_iter)):
                    m.d.sync += [self.fixed.eq(~changed), r.eq(0), c.eq(0), out_pending.eq(0)]
                    m.next = "READ"
                with m.Else():
                    m.d.sync += [it.eq(it + 1), changed.eq(0), colour.eq(0), r.eq(0), c.eq(0)]
                    m.next = "SWEEP"
            with m.State("READ"):               # one word: its read, then the output register
                m.d.sync += addr_q.eq(Cat(c, r))
                with m.If(~field_valid & (out_pending < RAM_LATENCY)):
                    m.d.sync += out_pending.eq(out_pending + 1)
                with m.If(out_pending == RAM_LATENCY):
                    m.d.sync += [out_pending.eq(0), field_valid.eq(1),
                                 self.field.payload.v.eq(rd_q.v), self.field.payload.e.eq(rd_q.e)]
                with m.If(field_valid & self.field.ready):
                    m.d.sync += [field_valid.eq(0), c.eq(Mux(last_col, 0, c + 1))]
                    with m.If(last_col):
                        m.d.sync += r.eq(r + 1)
                        with m.If(last_row):
                            m.d.sync += self.busy.eq(0)
                            m.next = "IDLE"

        # The readies as plain functions of the state (Icarus evaluates a case
        # statement on a signal only once it changes: IDLE from time 0 would leave X).
        m.d.comb += [self.cmd.ready.eq(fsm.ongoing("IDLE")), self.cells.ready.eq(fsm.ongoing("LOAD"))]

        # The one write port, registered (its address, data and enable fan out to every block of the
        # RAM; a word lands a cycle after it is chosen, WRITE_LATENCY): the load's cells, else the
        # sweep's new words.
        wa, wd, we = Signal(len(wr.addr), name="wr_addr_q"), Signal(state, name="wr_data_q"), Signal(name="wr_en_q")
        m.d.comb += [wr.addr.eq(wa), wr.data.eq(wd), wr.en.eq(we)]
        with m.If(load_write):
            m.d.sync += [wa.eq(Cat(c, r)), wd.eq(load_word), we.eq(1)]
        with m.Else():
            m.d.sync += [wa.eq(out_addr), wd.eq(Cat(new.v, new.e, Const(0, 1))), we.eq(sweep_write)]
        return m
