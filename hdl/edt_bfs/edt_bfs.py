"""The EDT/BFS path-planning core: controller and streams around the array (paper 004)."""

from amaranth.hdl import Module, Mux, Signal, signed
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from navcores.models.edt_bfs import OFFSETS

from ..params import check, checked_init
from .array import EdtArray, default_cell_module
from .cell import EdtCell, cell_widths

STATES = ("IDLE", "LOAD", "EDT", "CFR", "BFS", "PATH", "DUMP")

__all__ = ["EdtBfs", "image_layout", "command_layout", "result_layout"]


def image_layout(height):
    """One image column: bit r of ``obst`` / ``goal`` is row r."""
    return data.StructLayout({"obst": height, "goal": height})


def command_layout(w):
    return data.StructLayout({
        "dfar": w["di"], "start_row": w["row"], "start_col": w["col"], "path": 1,
    })


def result_layout(w):
    return data.StructLayout({
        "cell": 1,                       # 0: a path pixel, 1: a cell of the read-out
        "row": w["row"], "col": w["col"],
        "done": 1, "di": w["di"], "dx": signed(w["dx"]), "dy": signed(w["dy"]),
        "cfr": 1, "visited": 1, "parent": 4,
        "last": 1,                       # the job's last beat
    })


class EdtBfs(wiring.Component):
    """Parallel_Path_Plan on a ``height`` x ``width`` array: EDT, cfr, BFS, path.

    One job: a command, then the image, then the results.  The controller
    holds the k counter and runs the paper's three modes (section IV) one
    iteration per clock, each until an iteration changes nothing.

    Ports
    -----
    c_stream : In(stream of command_layout)
        ``dfar`` (d_far), ``start_row`` / ``start_col`` (p_s) and ``path`` (1:
        stream the path).  Accepted in the idle state only.
    i_stream : In(stream of image_layout(height))
        ``width`` beats after the command, one image column each; bit r of
        ``obst`` is an obstacle, of ``goal`` a goal mark (p_g), in row r.  The
        columns enter the leftmost cells and shift right (section IV), so the
        first beat is column ``width - 1`` and the last column 0.
    o_stream : Out(stream of result_layout)
        If ``path`` and the start is reached by the BFS: the path, one beat
        per pixel (``cell`` = 0, ``row`` / ``col``) from p_s to the goal,
        following ``parent`` (Step 5).  Then every cell (``cell`` = 1) in
        row-major order: ``done`` (0 only without obstacles), ``di``, the
        vector ``dx`` / ``dy`` (p - nearest obstacle), ``cfr``, ``visited``,
        ``parent``.  ``last`` marks the final beat.  Honours back-pressure;
        valid never waits for ready.
    busy : Out(1)
        A job is in progress (from the command to the last result beat).
    iterations_edt, iterations_bfs : Out
        Iteration counts of the last job (EDT, BFS), including the final
        iteration that changed nothing.
    path_found : Out(1)
        The last job's start was reached (valid from the path read-out on).
    start_err : Out(1)
        The last command's start lies outside the array: no path is read
        out (the defined error response; impossible at power-of-two sizes).

    Timing (source always valid, sink always ready), cycles after the
    command's handshake: ``width`` load cycles, ``iterations_edt`` EDT
    cycles, 1 cfr cycle, ``iterations_bfs`` BFS cycles, one cycle per path
    pixel, ``height * width`` read-out cycles
    (:func:`models.edt_bfs.job_cycles`).  The cfr and path decisions cost no
    extra cycle: the start's visited flag is read in the last BFS cycle,
    which changes nothing.  A synchronous reset at any point returns to idle;
    the next load clears every cell.

    ``cell_module`` names the Verilog module of the array's cells (see
    :class:`EdtArray`): a design holding this core defines it beside its own
    (:meth:`instance_modules`; hdl.emit does).
    """

    PARAMS = EdtArray.PARAMS        # the array's (it is elaborated inside)

    @checked_init
    def __init__(self, height, width, cell_module=None):
        self.height, self.width = height, width
        check(self.PARAMS, height=height, width=width)
        w = self.w = cell_widths(height, width)
        self.cell_module = cell_module or default_cell_module(height, width)
        self._bfs_bits = max(1, w["bfs_max"].bit_length())
        super().__init__({
            "c_stream": In(stream.Signature(command_layout(w))),
            "i_stream": In(stream.Signature(image_layout(height))),
            "o_stream": Out(stream.Signature(result_layout(w))),
            "busy": Out(1),
            "iterations_edt": Out(w["k"]),
            "iterations_bfs": Out(self._bfs_bits),
            "path_found": Out(1),
            "start_err": Out(1),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest (models.edt_bfs.job_cycles)."""
        h, w = self.height, self.width
        return {"job_cycles": f"{w} + iterations_edt + 1 + iterations_bfs + path_len + {h * w}",
                "load_cycles": w, "iteration_cycles": 1, "readout_cycles": h * w,
                "note": "source always valid, sink always ready; back-pressure adds cycles"}

    def instance_modules(self):
        """The modules the array instantiates by name (:meth:`EdtArray.instance_modules`)."""
        return {self.cell_module: EdtCell(self.height, self.width)}

    def elaborate(self, platform):
        m = Module()
        h, wd, w = self.height, self.width, self.w
        m.submodules.array = arr = EdtArray(h, wd, cell_module=self.cell_module)

        dfar = Signal(w["di"])
        start_row = Signal(w["row"])
        start_col = Signal(w["col"])
        want_path = Signal()
        k = Signal(w["k"])
        kb = Signal(self._bfs_bits)
        count = Signal(range(wd + 1))
        row = Signal(w["row"])
        col = Signal(w["col"])

        m.d.comb += [arr.k.eq(k), arr.dfar.eq(dfar)]
        it_edt = Signal(w["k"])
        it_bfs = Signal(self._bfs_bits)
        m.d.comb += [self.iterations_edt.eq(it_edt), self.iterations_bfs.eq(it_bfs)]

        # Result beat: the addressed cell's registers.
        payload = self.o_stream.payload
        m.d.comb += [
            arr.rd_row.eq(row), arr.rd_col.eq(col),
            payload.row.eq(row), payload.col.eq(col),
            payload.done.eq(arr.rd_done), payload.di.eq(arr.rd_di),
            payload.dx.eq(arr.rd_dx), payload.dy.eq(arr.rd_dy),
            payload.cfr.eq(arr.rd_cfr), payload.visited.eq(arr.rd_visited),
            payload.parent.eq(arr.rd_parent),
        ]
        last_cell = (row == h - 1) & (col == wd - 1)

        # The step along parent(p): p <- p_parent (Fig. 1 offsets).  Muxes
        # and plain assignments only (no comb switch): Icarus does not run an
        # `always @*` block at time 0, so a comb output of a process whose
        # inputs never change would stay X after reset.
        next_row, next_col = row, col
        for i, (dr, dc) in OFFSETS.items():
            hit = arr.rd_parent == i
            next_row = Mux(hit, row + dr, next_row) if dr else next_row
            next_col = Mux(hit, col + dc, next_col) if dc else next_col

        # The state register: if/elif on its value rather than m.FSM, whose
        # case statement without default Verilator -Wall rejects.
        state = Signal(range(len(STATES)))
        ongoing = {name: state == n for n, name in enumerate(STATES)}
        with m.If(ongoing["IDLE"]):
            with m.If(self.c_stream.valid):
                cmd = self.c_stream.payload
                m.d.sync += [
                    dfar.eq(cmd.dfar), start_row.eq(cmd.start_row),
                    start_col.eq(cmd.start_col), want_path.eq(cmd.path),
                    self.start_err.eq((cmd.start_row >= h) | (cmd.start_col >= wd)),
                    self.path_found.eq(0), count.eq(0), it_edt.eq(0), it_bfs.eq(0),
                ]
                m.d.sync += state.eq(STATES.index("LOAD"))
        with m.Elif(ongoing["LOAD"]):
            # Row-wise load pipeline: one column per accepted beat.
            with m.If(self.i_stream.valid):
                m.d.sync += count.eq(count + 1)
                with m.If(count == wd - 1):
                    m.d.sync += k.eq(1)
                    m.d.sync += state.eq(STATES.index("EDT"))
        with m.Elif(ongoing["EDT"]):
            # Mode 1 (step 2): iteration k, until one sets no done flag.
            m.d.sync += it_edt.eq(k)
            with m.If(arr.changed):
                m.d.sync += k.eq(k + 1)
            with m.Else():
                m.d.sync += state.eq(STATES.index("CFR"))
        with m.Elif(ongoing["CFR"]):
            # Mode 2 (step 3): one cycle.
            m.d.sync += [kb.eq(1), row.eq(start_row), col.eq(start_col)]
            m.d.sync += state.eq(STATES.index("BFS"))
        with m.Elif(ongoing["BFS"]):
            # Mode 3 (step 4), until one iteration visits nothing.  The
            # read-out address holds the start: its visited flag decides
            # the path read-out in the last iteration.
            m.d.sync += it_bfs.eq(kb)
            with m.If(arr.changed):
                m.d.sync += kb.eq(kb + 1)
            with m.Elif(want_path & ~self.start_err & arr.rd_visited):
                m.d.sync += self.path_found.eq(1)
                m.d.sync += state.eq(STATES.index("PATH"))
            with m.Else():
                m.d.sync += [row.eq(0), col.eq(0)]
                m.d.sync += state.eq(STATES.index("DUMP"))
        with m.Elif(ongoing["PATH"]):
            # Step 5: the parent chain from the start, one pixel per beat.
            with m.If(self.o_stream.ready):
                with m.If(arr.rd_parent == 0):
                    m.d.sync += [row.eq(0), col.eq(0)]
                    m.d.sync += state.eq(STATES.index("DUMP"))
                with m.Else():
                    m.d.sync += [row.eq(next_row), col.eq(next_col)]
        with m.Elif(ongoing["DUMP"]):
            with m.If(self.o_stream.ready):
                with m.If(last_cell):
                    m.d.sync += state.eq(STATES.index("IDLE"))
                with m.Elif(col == wd - 1):
                    m.d.sync += [row.eq(row + 1), col.eq(0)]
                with m.Else():
                    m.d.sync += col.eq(col + 1)

        idle, load = ongoing["IDLE"], ongoing["LOAD"]
        path, dump = ongoing["PATH"], ongoing["DUMP"]
        m.d.comb += [
            self.c_stream.ready.eq(idle),
            self.busy.eq(~idle),
            self.i_stream.ready.eq(load),
            arr.shift.eq(load & self.i_stream.valid),
            arr.in_obst.eq(self.i_stream.payload.obst),
            arr.in_goal.eq(self.i_stream.payload.goal),
            arr.step_edt.eq(ongoing["EDT"]),
            arr.step_cfr.eq(ongoing["CFR"]),
            arr.step_bfs.eq(ongoing["BFS"]),
            self.o_stream.valid.eq(path | dump),
            payload.cell.eq(dump),
            payload.last.eq(dump & last_cell),
        ]
        return m
