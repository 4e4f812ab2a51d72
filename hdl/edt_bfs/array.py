"""The n x m cellular array of the EDT/BFS core (paper 004, section IV)."""

from dataclasses import replace

from amaranth.hdl import Cat, ClockSignal, Const, Instance, Module, Mux, ResetSignal, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from navcores.models.edt_bfs import OFFSETS

from ..params import check, checked_init
from .cell import EdtCell, cell_widths, result_layout, state_layout

__all__ = ["EdtArray", "default_cell_module"]


def _mux_tree(items, sel):
    """``items[sel]`` as a tree of 2:1 multiplexers on the bits of ``sel``; 0 past the end."""
    width = len(items[0])
    level = list(items)
    for bit in range(len(sel)):
        if len(level) % 2:
            level.append(Const(0, width))
        level = [Mux(sel[bit], level[j + 1], level[j]) for j in range(0, len(level), 2)]
    return level[0]


def default_cell_module(height, width):
    """The cell module's name when the caller gives none: fixed by the size."""
    return f"edt_cell_{height}x{width}"


class EdtArray(wiring.Component):
    """``height`` x ``width`` cells (:class:`EdtCell`'s logic), each wired to its 8 neighbours.

    Load pipeline (section IV): each row enters at its leftmost cell and
    shifts right, one column per ``shift`` cycle; the column shifted in first
    ends in column ``width - 1`` after ``width`` shifts.  Cells outside the
    array read as not done / not visited.

    Every cell is a Verilog instance of the module ``cell_module`` (default
    :func:`default_cell_module`; hdl.emit names it ``<top module>_cell``):
    :class:`EdtCell` at this size, converted once under that name.  A design
    holding the array must define that module beside its own:
    :meth:`instance_modules` names it, and hdl.emit appends it to the top's
    Verilog (see ``elaborate``).  Both sides must be >= 3.

    Ports
    -----
    shift, step_edt, step_cfr, step_bfs, k, dfar : In
        Broadcast to every cell (see :class:`EdtCell`).
    in_obst, in_goal : In(height)
        The column entering the leftmost cells, bit r = row r.
    changed : Out(1)
        OR of the cells' ``changed``: some cell sets done / visited this cycle.
    rd_row, rd_col : In
        Read-out address (combinational multiplexer, no latency).
    rd_done, rd_di, rd_dx, rd_dy, rd_cfr, rd_visited, rd_parent : Out
        The registers of cell (rd_row, rd_col), combinational.  An address
        outside the array reads 0.
    """

    # Both sides >= 3: the smallest array built and verified (every cell kind:
    # corners, edges, interior).
    PARAMS = tuple(replace(p, lo=3, message="array {name} {value!r}: must be an integer in {lo}..{hi}")
                   for p in EdtCell.PARAMS)

    @checked_init
    def __init__(self, height, width, cell_module=None):
        self.height, self.width = height, width
        check(self.PARAMS, height=height, width=width)
        self.cell_module = cell_module or default_cell_module(height, width)
        w = self.w = cell_widths(height, width)
        super().__init__({
            "shift": In(1), "step_edt": In(1), "step_cfr": In(1), "step_bfs": In(1),
            "k": In(w["k"]), "dfar": In(w["di"]),
            "in_obst": In(height), "in_goal": In(height),
            "changed": Out(1),
            "rd_row": In(w["row"]), "rd_col": In(w["col"]),
            "rd_done": Out(1), "rd_di": Out(w["di"]), "rd_dx": Out(signed(w["dx"])),
            "rd_dy": Out(signed(w["dy"])), "rd_cfr": Out(1), "rd_visited": Out(1),
            "rd_parent": Out(4),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"load_cycles": self.width, "step_cycles": 1, "readout_latency_cycles": 0}

    def instance_modules(self):
        """{Verilog module name: component} of the modules this design
        instantiates by name: the cell, which the emitter converts under
        ``cell_module`` into the same file."""
        return {self.cell_module: EdtCell(self.height, self.width)}

    def elaborate(self, platform):
        m = Module()
        h, wd = self.height, self.width
        # Every cell is an Instance of one module, ``self.cell_module`` (the
        # EdtCell converted on its own, with all its ports: instance_modules).
        # Amaranth 0.5 elaborates every submodule anew and emits no shared
        # module definitions: 1024 elaborated cells take minutes and a million
        # Verilog lines; one definition and 1024 instances take seconds.
        w = self.w
        cells = [[{"state": Signal(state_layout(w), name=f"c{r}_{c}_state"),
                   "result": Signal(result_layout(w), name=f"c{r}_{c}_result"),
                   "changed": Signal(name=f"c{r}_{c}_changed")}
                  for c in range(wd)] for r in range(h)]
        none = Const(0, state_layout(w).size)          # outside the array: not done, not visited
        for r in range(h):
            for c in range(wd):
                me = cells[r][c]
                ins = {
                    "shift": self.shift, "step_edt": self.step_edt, "step_cfr": self.step_cfr,
                    "step_bfs": self.step_bfs, "k": self.k, "dfar": self.dfar,
                }
                for i, (dr, dc) in OFFSETS.items():
                    inside = 0 <= r + dr < h and 0 <= c + dc < wd
                    ins[f"n{i}"] = cells[r + dr][c + dc]["state"].as_value() if inside else none
                if c == 0:
                    # load pipeline: each row enters at its leftmost cell, whose
                    # west neighbour p_3 is the input column while shifting
                    # (and absent, 0, otherwise)
                    west = Signal(state_layout(w), name=f"c{r}_west")
                    m.d.comb += [west.done.eq(self.in_obst[r] & self.shift),
                                 west.visited.eq(self.in_goal[r] & self.shift)]
                    ins["n3"] = west.as_value()
                ports = {f"i_{n}": v for n, v in ins.items()}
                ports.update({f"o_{f}": (v.as_value() if f != "changed" else v) for f, v in me.items()})
                m.submodules[f"cell_{r}_{c}"] = Instance(
                    self.cell_module, i_clk=ClockSignal(), i_rst=ResetSignal(), **ports)
        m.d.comb += self.changed.eq(Cat(*[cell["changed"] for row in cells for cell in row]).any())

        # Read-out multiplexer: one word per cell; a binary tree of 2:1
        # multiplexers on the row bits (one tree per column), then on the
        # column bits (a 1024-way case statement takes Icarus minutes to
        # compile).  Rows first: the read-out walks along a row, so only the
        # last tree (W - 1 multiplexers) changes from one beat to the next,
        # not all H * (W - 1) column multiplexers, which an event-driven
        # simulator re-evaluates.  Addresses outside the array read 0.
        def word(cell):
            st, res = cell["state"], cell["result"]
            return Cat(st.done, res.di, st.dx, st.dy, res.cfr, st.visited, res.parent)
        columns = [_mux_tree([word(cells[r][c]) for r in range(h)], self.rd_row) for c in range(wd)]
        word = _mux_tree(columns, self.rd_col)
        m.d.comb += Cat(self.rd_done, self.rd_di, self.rd_dx, self.rd_dy, self.rd_cfr,
                        self.rd_visited, self.rd_parent).eq(word)
        return m
