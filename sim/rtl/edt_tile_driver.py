"""Cocotb driver of the EDT/BFS tile engine (hdl/edt_bfs/tile_engine.py), shared by the tests and ``sim edt --array``.

:class:`TileEngineDriver` runs one job on the engine's four streams
(sim/rtl/stream.py): the command, the map words, the goals (queued with the
map; the engine takes them after the EDT) and the results, optionally with
random idle cycles on the sources and random back-pressure on the result
sink (:meth:`TileEngineDriver.set_stalls`).  It records the visit monitor
(the model's ``trace``; one wake-up per change of the ``visit`` port, not
one per cycle), counts the job's cycles (from the command's handshake,
exclusive, to the last cycle ``busy`` is high: the model's cycle count with
the sources always valid and the sink always ready; with stalls, that plus
every cycle the engine lost to them: ``starved``, the cycles the engine was
ready for a map word or goal that was held back, and ``stalls``, the result
beats held back, since it waits exactly those cycles and no other) and
decodes the results into the fields of
:class:`models.edt_bfs_tiled.EdtBfsTiledResult`.

:meth:`TileEngineDriver.plan` is the whole job for a caller: a map, goals,
start and d_far in; the model's result object out.
"""

import random

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import (ClockCycles, FallingEdge, First, ReadOnly, RisingEdge, Timer,
                              current_gpi_trigger)

from navcores.hdl.edt_bfs.dram_store import dram_layout
from navcores.hdl.edt_bfs.tile_engine import (DRAM_WIDTH, command_layout, goal_layout, map_layout, result_layout,
                                              visit_layout)
from navcores.hdl.edt_bfs.tile_layouts import tile_widths
from navcores.models.edt_bfs_tiled import EdtBfsTiledResult

from .clock import PERIOD_NS
from .edt_bfs_driver import compare_fields
from .native_dram import NativeDram, native_ports
from .state_store import StateStore
from .stream import Streams, pauses, unpack

__all__ = ["TileEngineDriver", "compare", "FIELDS", "DRAM_PERIOD_NS"]

DRAM_PERIOD_NS = 3.4        # store="dram": the controller's clock, about 3x the engine's (75 against 22 MHz)

FIELDS = ("distance", "nearest", "vector", "sqdist", "done", "cfr", "visited", "parent", "hop")
FLAGS = ("cmd_err", "start_err", "goal_err", "path_found", "levels", "tile_visits")


async def _read_only():
    """The read-only phase of this time step (at once if it is the current one)."""
    if not isinstance(current_gpi_trigger(), ReadOnly):
        await ReadOnly()


class TileEngineDriver:
    """A ``TileEngine(t_r, t_c, max_h, max_w)`` top under cocotb.

    ``cmd``, ``map``, ``goal``: the :class:`.stream.StreamSource` on
    ``c_stream`` / ``m_stream`` / ``g_stream``; ``res``: the
    :class:`.stream.StreamSink` on ``o_stream``; ``store``: with an external
    store (``store="external"``), the :class:`.state_store.StateStore` on
    its ``state`` port, with ``store="dram"`` the :class:`.native_dram.NativeDram`
    on its ``dram`` ports (``seed``: its random bits and timing; ``bfs_slots``: the engine's, for
    :func:`~hdl.edt_bfs.dram_store.dram_layout`), else None.  ``on_visit`` (if set) is
    called with the count of visits so far at each visit (progress)."""

    def __init__(self, dut, t_r, t_c, max_h, max_w, seed=0, bfs_slots=False):
        self.dut, self.t_r, self.t_c, self.max_h, self.max_w = dut, t_r, t_c, max_h, max_w
        w = self.widths = tile_widths(t_r, t_c, max_h, max_w)
        self.vis = visit_layout(w)
        self.streams = Streams(dut)
        self.cmd = self.streams.source("c_stream", command_layout(w))
        self.map = self.streams.source("m_stream", map_layout(t_c))
        self.goal = self.streams.source("g_stream", goal_layout(w))
        self.res = self.streams.sink("o_stream", result_layout(w))
        # an engine built with store="external": the store on its state port, StateRam's timing
        self.store = (StateStore(self.streams, w, t_c, random.Random(seed))
                      if hasattr(dut, "state__rd__valid") else None)
        # store="dram": the DRAM on its native port (not reset with the engine); not when the top
        # holds its own controller (hdl/edt_bfs/tile_litedram.py, whose inner wires have those names)
        if native_ports(dut) and not hasattr(dut, "wb_ctrl_cyc"):
            lay = self.dram_layout = dram_layout(w, t_c, max_h, DRAM_WIDTH, bfs_slots)
            self.store = NativeDram(dut, DRAM_WIDTH, lay["addr_width"], random.Random(seed), clock=dut.dram_clk,
                                    ports=native_ports(dut))
        self.on_visit = None

    def set_stalls(self, rng=None, idle=0.0, back_pressure=0.0):
        """Random idle cycles before each command, map word and goal
        (probability ``idle``) and ready low on the results
        (``back_pressure``), from ``rng``; no arguments: none."""
        for s in (self.cmd, self.map, self.goal):
            s.pause = pauses(rng, idle)
        self.res.set_pause(pauses(rng, back_pressure))

    async def start(self):
        cocotb.start_soon(Clock(self.dut.clk, PERIOD_NS, unit="ns").start())
        if isinstance(self.store, NativeDram):
            # the controller's clock: DRAM_PERIOD_NS, not a multiple of the engine's (the
            # crossing sees every phase); its reset once, at power-up
            self.dut.dram_rst.value = 1
            cocotb.start_soon(Clock(self.dut.dram_clk, DRAM_PERIOD_NS, unit="ns").start())
            await ClockCycles(self.dut.dram_clk, 3)
            self.dut.dram_rst.value = 0
        await self.reset()

    async def reset(self, cycles=2):
        """Synchronous reset (:meth:`.stream.Streams.apply_reset`): drops what
        the sources hold and the results not yet read."""
        await self.streams.apply_reset(cycles)
        if self.store is not None:
            self.store.reset()

    def words(self, img):
        """The map stream: row-major, ceil(W / T_c) words a row, bit j = column w T_c + j."""
        h, wd = img.shape
        p = self.t_c
        padded = np.zeros((h, -(-wd // p) * p), dtype=np.int64)
        padded[:, :wd] = img
        bits = (padded.reshape(h, -1, p) << np.arange(p)).sum(axis=2)
        return [{"obst": int(b)} for b in bits.ravel()]

    async def _trace(self, trace):
        d = self.dut
        while True:
            await d.visit.value_change
            await ReadOnly()
            v = unpack(self.vis, int(d.visit.value))
            if v["valid"]:
                trace.append((v, int(d.levels.value)))
                if self.on_visit is not None:
                    self.on_visit(len(trace))

    async def job(self, img, goals, start, dfar, *, readout=True, abort_after=None, max_cycles=None,
                  height=None, width=None):
        """Run one job; returns the raw outcome (a dict), or None if aborted
        ``abort_after`` cycles after the command's handshake (the caller then
        resets the engine: :meth:`reset`).

        No checks: goals and the start go to the engine as given (the engine
        flags what lies outside the map); ``height`` / ``width`` override the
        command's size (a refused command returns at once, its map and goals
        dropped)."""
        d = self.dut
        img = np.asarray(img, dtype=bool)
        h, wd = img.shape
        dfar = min(int(dfar), (1 << self.widths["di"]) - 1)     # exact: no di reaches the cap
        sr, sc = start if start is not None else (0, 0)
        if max_cycles is None:
            max_cycles = 200 * (h * wd + 100) * 4
        before = {s: (len(s.beats), s.starved if s is not self.res else s.stalls)
                  for s in (self.cmd, self.map, self.goal, self.res)}
        trace = []
        tracer = cocotb.start_soon(self._trace(trace))
        self.cmd.put({"height": h if height is None else height, "width": wd if width is None else width,
                      "dfar": dfar, "goals": len(goals), "start_row": sr, "start_col": sc,
                      "path": int(start is not None), "readout": int(readout)})
        self.map.extend(self.words(img))
        self.goal.extend({"row": r, "col": c} for r, c in goals)
        await self.cmd.wait_beats(before[self.cmd][0] + 1, max_cycles)
        c0 = self.cmd.beats[-1][0]
        if abort_after is not None:
            await ClockCycles(d.clk, abort_after)
            tracer.cancel()
            return None
        await _read_only()
        if d.busy.value == 1:               # not refused: until busy falls
            timeout = Timer(max_cycles * PERIOD_NS, unit="ns")
            if await First(FallingEdge(d.busy), timeout) is timeout:
                tracer.cancel()
                raise TimeoutError(f"job did not finish in {max_cycles} cycles")
            cycles = self.streams.cycle - 1 - c0
        else:
            cycles = 0
        await _read_only()
        tracer.cancel()
        flags = {n: int(getattr(d, n).value) for n in FLAGS}
        beats = list(self.res.queue)
        self.res.queue.clear()
        out = {"beats": beats, "trace": trace, "cycles": cycles,
               "words_sent": len(self.map.beats) - before[self.map][0],
               "goals_sent": len(self.goal.beats) - before[self.goal][0],
               "starved": self.map.starved + self.goal.starved - before[self.map][1] - before[self.goal][1],
               "stalls": self.res.stalls - before[self.res][1], **flags}
        await RisingEdge(d.clk)             # out of the read-only phase: the caller may drive
        if self.map.busy or self.goal.busy:     # what a refused job left: dropped
            self.map.clear()
            self.goal.clear()
        return out

    def decode(self, raw, shape, readout=True):
        """The raw outcome of a job on an ``shape`` map as the model's result fields (a dict)."""
        h, wd = shape
        beats = raw["beats"]
        path = [(b["row"], b["col"]) for b in beats if not b["map"]]
        cells = [b for b in beats if b["map"]]
        assert all(not b["map"] for b in beats[:len(path)]), "path beats come first"
        assert sum(b["last"] for b in beats) == (1 if beats else 0) and (not beats or beats[-1]["last"])
        out = {"path": path, "path_found": bool(raw["path_found"]), "levels": raw["levels"],
               "cycles": raw["cycles"], "starved": raw["starved"], "stalls": raw["stalls"],
               "tile_visits": raw["tile_visits"], "iterations_edt": raw["levels"] + 1}
        nc = -(-wd // self.t_c)
        out["trace"] = [("bfs" if v["bfs"] else "edt", 0 if v["bfs"] else k, v["r"] * nc + v["c"],
                         v["iterations"], v["marks"]) for v, k in raw["trace"]]
        if not readout:
            assert not cells
            return out
        assert len(cells) == h * wd, f"{len(cells)} map beats, expected {h * wd}"
        rows, cols = np.array([(b["row"], b["col"]) for b in cells]).T
        assert (rows * wd + cols == np.arange(h * wd)).all(), "the read-out is not row-major"
        a = {f: np.array([b[f] for b in cells], dtype=np.int64).reshape(h, wd)
             for f in ("di", "dx", "dy", "hop", "parent")}
        b = {f: np.array([bt[f] for bt in cells], dtype=bool).reshape(h, wd) for f in ("done", "cfr", "visited")}
        done, visited = b["done"], b["visited"]
        rows, cols = np.indices((h, wd))
        nearest = np.stack([rows - a["dx"], cols - a["dy"]], axis=-1)
        nearest[~done] = -1
        hop = np.where(visited, a["hop"], -1)
        out.update(distance=np.where(done, a["di"], -1), vector=np.stack([a["dx"], a["dy"]], axis=-1),
                   nearest=nearest, sqdist=np.where(done, a["dx"] ** 2 + a["dy"] ** 2, -1), done=done,
                   cfr=b["cfr"], visited=visited, parent=a["parent"], hop=hop,
                   iterations_bfs=int(hop.max()) + 1 if visited.any() else 1)
        return out

    async def plan(self, obstacle, goals, start, dfar, **kw):
        """Parallel_Path_Plan on the engine: :func:`models.edt_bfs_tiled.plan_path_tiled`'s arguments
        (``array`` is the engine's), its result object back (``stats`` holds only what the engine reports)."""
        obstacle = np.asarray(obstacle, dtype=bool)
        h, wd = obstacle.shape
        if obstacle.ndim != 2 or not (1 <= h <= self.max_h and 1 <= wd <= self.max_w):
            raise ValueError(f"map {obstacle.shape} does not fit the engine's RAM ({self.max_h}x{self.max_w})")
        for what, cells in (("goal", goals), ("start", [] if start is None else [start])):
            for r, c in cells:
                if not (0 <= r < h and 0 <= c < wd):
                    raise ValueError(f"{what} ({r}, {c}) is outside the {h}x{wd} map")
        if dfar < 0:
            raise ValueError(f"dfar {dfar} must be >= 0")
        raw = await self.job(obstacle, goals, start, dfar, readout=True, **kw)
        got = self.decode(raw, (h, wd))
        return EdtBfsTiledResult(
            distance=got["distance"], nearest=got["nearest"], vector=got["vector"], sqdist=got["sqdist"],
            done=got["done"], cfr=got["cfr"], visited=got["visited"], parent=got["parent"], path=got["path"],
            path_found=got["path_found"], iterations_edt=got["iterations_edt"],
            iterations_bfs=got["iterations_bfs"], cycles=raw["cycles"], hop=got["hop"],
            array=(self.t_r, self.t_c), tile_visits=got["tile_visits"],
            stats={"levels": got["levels"], "starved": raw["starved"], "stalls": raw["stalls"]},
            trace=got["trace"])


def compare(got, model, cycles=True, readout=True):
    """Assert the engine's decoded results equal the tiled model's; returns the number of values compared.

    Every result field, the path, the iteration counts, the tile visits and
    the visit trace (tile by tile: phase, level, tile, iterations, marks);
    with ``cycles`` the job's cycle count too: the model's plus the cycles
    the stalls cost the engine (``starved`` + ``stalls``, 0 without)."""
    n = compare_fields(got, model, FIELDS) if readout else 0
    if readout:
        assert got["iterations_bfs"] == model.iterations_bfs, (got["iterations_bfs"], model.iterations_bfs)
    assert got["path"] == model.path, f"path rtl {got['path']} model {model.path}"
    assert got["path_found"] == model.path_found
    assert got["iterations_edt"] == model.iterations_edt, (got["iterations_edt"], model.iterations_edt)
    assert got["tile_visits"] == model.tile_visits, (got["tile_visits"], model.tile_visits)
    if got["trace"] != model.trace:
        first = next(i for i, (a, b) in enumerate(zip(got["trace"] + [None], model.trace + [None])) if a != b)
        raise AssertionError(f"visit {first} differs: rtl {got['trace'][first:first + 3]} "
                             f"model {model.trace[first:first + 3]}")
    if cycles:
        want = model.cycles + got["starved"] + got["stalls"]
        assert got["cycles"] == want, (f"cycles rtl {got['cycles']}, model {model.cycles} + "
                                       f"{got['starved']} starved + {got['stalls']} stalled = {want}")
    return n + len(model.path) + len(model.trace)
