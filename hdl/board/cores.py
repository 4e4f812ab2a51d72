"""The cores a board top holds, as the bridge sees them: which streams go in
(WRITE 0x10+k) and out (DATA 0x40+k), the status word, and the parameters
INFO names (what the host checks before it runs a job).

========  ============  ==========================  ===============  =========================
core      hdl.emit top  sinks (WRITE 0x10+k)        sources (DATA)   status word (STATUS)
========  ============  ==========================  ===============  =========================
harmonic  harmonic_     0: ``i_stream`` (commands)  0: responses     none (the planner's own
          planner                                                    STATUS command)
dflc      dflc_stream   0: ``i_stream`` (samples)   0: results       none
edt_bfs   edt_bfs       0: ``c_stream`` (command),  0: results       :func:`edt_status_layout`
                        1: ``i_stream`` (columns)
========  ============  ==========================  ===============  =========================
"""

import hashlib
from dataclasses import dataclass

from amaranth.hdl import Signal
from amaranth.lib import data

from ..dflc.top import resolve_fll
from ..edt_bfs.cell import cell_widths
from ..emit import TOPS

__all__ = ["CoreSpec", "CORES", "edt_status_layout", "fll_digest"]


def fll_digest(path):
    """The first 8 hex digits of the SHA-1 of a .fll file: INFO's ``sha``, which the host compares."""
    with open(path, "rb") as fh:
        return hashlib.sha1(fh.read()).hexdigest()[:8]


@dataclass(frozen=True)
class CoreSpec:
    """How a core sits behind the bridge.

    ``build(**params)``: the component; ``sinks`` / ``sources``: its stream
    members, in WRITE / DATA order; ``status_layout(core)``: the status
    word's layout, or None; ``status(m, core, word)``: drives it (in the
    core's clock domain, ``m.d.core``);
    ``info(core, params)``: the parameters INFO names.  The components
    are hdl.emit's tops (the same parameters and defaults).
    """

    name: str
    build: object
    sinks: tuple
    sources: tuple
    status_layout: object
    status: object
    info: object


def edt_status_layout(height, width):
    """The EDT/BFS status word: the core's outputs after a job, and
    ``cycles``: the job's clocks from the command's handshake to the last
    result beat, without the clocks the streams stalled it (an image column
    not there yet, a result not taken): what a source always valid and a
    sink always ready would take, :func:`models.edt_bfs.job_cycles`."""
    w = cell_widths(height, width)
    return data.StructLayout({
        "busy": 1, "path_found": 1, "start_err": 1,
        "iterations_edt": w["k"], "iterations_bfs": max(1, w["bfs_max"].bit_length()),   # EdtBfs's ports
        "cycles": 32,
    })


def _edt_status(m, core, st):
    assert (len(st.iterations_edt), len(st.iterations_bfs)) == (len(core.iterations_edt), len(core.iterations_bfs))
    active = Signal()
    c_fire = core.c_stream.valid & core.c_stream.ready
    stalled = ((core.i_stream.ready & ~core.i_stream.valid) | (core.o_stream.valid & ~core.o_stream.ready))
    with m.If(c_fire):
        m.d.core += [st.cycles.eq(0), active.eq(1)]
    with m.Elif(active & ~stalled):
        m.d.core += st.cycles.eq(st.cycles + 1)
        with m.If(core.o_stream.valid & core.o_stream.payload.last):
            m.d.core += active.eq(0)
    m.d.comb += [st.busy.eq(core.busy), st.path_found.eq(core.path_found), st.start_err.eq(core.start_err),
                 st.iterations_edt.eq(core.iterations_edt), st.iterations_bfs.eq(core.iterations_bfs)]


def _dflc_info(core, params):
    fll = resolve_fll(params.get("fll", "table1"))
    c = core.config
    return {"fll": fll.stem.removeprefix("dflc_"), "sha": fll_digest(fll), "inputs": c.n, "ip_sz": c.ip_sz,
            "op_sz": c.op_sz, "divider": c.div_type, "par": int(core.parallel)}


CORES = {
    "harmonic": CoreSpec(
        "harmonic", TOPS["harmonic_planner"], ("i_stream",), ("o_stream",), None, None,
        lambda core, p: {"n": core.n, "m": core.m, "br": core.BR, "bc": core.BC, "p_max": core.p_max,
                         "depth": core.depth}),
    "dflc": CoreSpec("dflc", TOPS["dflc_stream"], ("i_stream",), ("o_stream",), None, None, _dflc_info),
    "edt_bfs": CoreSpec(
        "edt_bfs", TOPS["edt_bfs"], ("c_stream", "i_stream"), ("o_stream",),
        lambda core: edt_status_layout(core.height, core.width), _edt_status,
        lambda core, p: {"height": core.height, "width": core.width}),
}
