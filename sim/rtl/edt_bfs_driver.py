"""Cocotb driver of the EDT/BFS core (hdl/edt_bfs/edt_bfs.py), shared by the tests and ``sim edt``.

:class:`EdtBfsDriver` runs one job on the core's three streams
(sim/rtl/stream.py): the command, the image columns (first beat = column
W-1, as the load pipeline shifts right) and the results, optionally with
random idle cycles on the two sources and random back-pressure on the
result sink (:meth:`EdtBfsDriver.set_stalls`).  It decodes the results into
the arrays of :class:`models.edt_bfs.EdtBfsResult` and counts the job's
cycles from the command handshake (exclusive) to the last result beat
(inclusive): ``models.edt_bfs.job_cycles`` with the image always valid and
the results always ready; with stalls, that plus every cycle the core lost
to them (``starved``: load cycles with no column, ``stalls``: result beats
held back), since the core waits exactly those cycles and no other.
"""

import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles

from navcores.hdl.edt_bfs.cell import cell_widths
from navcores.hdl.edt_bfs.edt_bfs import command_layout, image_layout, result_layout

from .clock import PERIOD_NS
from .stream import Streams, pauses

__all__ = ["EdtBfsDriver", "decode", "compare", "compare_fields"]


class EdtBfsDriver:
    """An EDT/BFS core of ``height`` x ``width`` cells under cocotb.

    ``cmd``, ``img``: the :class:`.stream.StreamSource` on ``c_stream`` /
    ``i_stream``; ``res``: the :class:`.stream.StreamSink` on ``o_stream``.
    """

    def __init__(self, dut, height, width):
        self.dut, self.h, self.w = dut, height, width
        wd = cell_widths(height, width)
        self.widths = wd
        self.streams = Streams(dut)
        self.cmd = self.streams.source("c_stream", command_layout(wd))
        self.img = self.streams.source("i_stream", image_layout(height))
        self.res = self.streams.sink("o_stream", result_layout(wd))

    def set_stalls(self, rng=None, idle=0.0, back_pressure=0.0):
        """Random idle cycles before each command and image column (probability
        ``idle``) and ready low on the results (``back_pressure``), from
        ``rng``; no arguments: none."""
        self.cmd.pause = pauses(rng, idle)
        self.img.pause = pauses(rng, idle)
        self.res.set_pause(pauses(rng, back_pressure))

    async def start(self):
        Clock(self.dut.clk, PERIOD_NS, unit="ns").start()
        await self.reset()

    async def reset(self, cycles=2):
        """Synchronous reset (:meth:`.stream.Streams.apply_reset`): drops what
        the sources hold and the results not yet read."""
        await self.streams.apply_reset(cycles)

    async def job(self, img, goals, start, dfar, *, max_cycles=None, abort_after=None):
        """Run one job; returns a dict of decoded results (None if aborted).

        ``start`` None sends ``path`` = 0.  ``dfar`` beyond the d_i width is
        clamped (exact: no d_i exceeds the largest width value).
        ``abort_after``: return None after that many cycles, the streams
        left as they are (the caller then resets the core: :meth:`reset`).  Besides the results: ``cycles``
        (command handshake, exclusive, to the last result beat, inclusive),
        ``starved`` (load cycles the core waited for a column) and
        ``stalls`` (cycles a result beat waited for ready).
        """
        d, h, w = self.dut, self.h, self.w
        img = np.asarray(img, dtype=bool)
        assert img.shape == (h, w), (img.shape, h, w)
        goal = np.zeros_like(img)
        for r, c in goals:
            goal[r, c] = True
        dfar = min(int(dfar), (1 << self.widths["di"]) - 1)
        sr, sc = start if start is not None else (0, 0)
        if max_cycles is None:
            max_cycles = 20 * (h * w + w + 100) + 4 * h * w
        starved, stalls = self.img.starved, self.res.stalls
        self.cmd.put({"dfar": dfar, "start_row": sr, "start_col": sc, "path": int(start is not None)})
        self.img.extend({"obst": sum(int(img[r, c]) << r for r in range(h)),
                         "goal": sum(int(goal[r, c]) << r for r in range(h))} for c in reversed(range(w)))
        if abort_after is not None:         # the streams stay as they are: the caller resets
            await ClockCycles(d.clk, abort_after)
            return None
        deadline = self.streams.cycle + max_cycles
        beats = []
        while not beats or not beats[-1]["last"]:
            beats.append(await self.res.recv(max(1, deadline - self.streams.cycle)))
        out = decode(beats, h, w)
        out["cycles"] = self.res.beats[-1][0] - self.cmd.beats[-1][0]
        out["starved"] = self.img.starved - starved
        out["stalls"] = self.res.stalls - stalls
        out["iterations_edt"] = int(d.iterations_edt.value)
        out["iterations_bfs"] = int(d.iterations_bfs.value)
        out["path_found_flag"] = int(d.path_found.value)
        out["start_err"] = int(d.start_err.value)
        return out


def decode(beats, h, w):
    """The result beats of one job (unpacked ``result_layout`` dicts, the
    path's first, then every cell row by row) as the model's arrays; shared
    with the board's job (sim/rtl/board_jobs.py)."""
    path = [(b["row"], b["col"]) for b in beats if not b["cell"]]
    cells = [b for b in beats if b["cell"]]
    assert all(not b["cell"] for b in beats[:len(path)]), "path beats come first"
    assert len(cells) == h * w, f"{len(cells)} cell beats, expected {h * w}"
    assert sum(b["last"] for b in beats) == 1 and beats[-1]["last"]
    dist = np.full((h, w), -1, dtype=np.int64)
    vec = np.zeros((h, w, 2), dtype=np.int64)
    nearest = np.full((h, w, 2), -1, dtype=np.int64)
    done = np.zeros((h, w), dtype=bool)
    cfr = np.zeros((h, w), dtype=bool)
    visited = np.zeros((h, w), dtype=bool)
    parent = np.zeros((h, w), dtype=np.int64)
    for n, b in enumerate(cells):
        r, c = b["row"], b["col"]
        assert (r, c) == divmod(n, w), f"beat {n} is cell {(r, c)}: not row-major"
        done[r, c] = b["done"]
        if b["done"]:
            dist[r, c] = b["di"]
            vec[r, c] = (b["dx"], b["dy"])
            nearest[r, c] = (r - b["dx"], c - b["dy"])
        else:
            assert (b["di"], b["dx"], b["dy"]) == (0, 0, 0)
        cfr[r, c], visited[r, c], parent[r, c] = b["cfr"], b["visited"], b["parent"]
    return {"path": path, "path_found": bool(path), "distance": dist, "vector": vec,
            "nearest": nearest, "done": done, "cfr": cfr, "visited": visited, "parent": parent}


def compare_fields(got, model, names):
    """Assert the RTL's arrays ``got[name]`` equal the model's ``model.name`` for each of ``names``
    (the first differing pixels in the message); returns the number of values compared."""
    n = 0
    for name in names:
        a, b = np.asarray(got[name]), np.asarray(getattr(model, name))
        if not np.array_equal(a, b):
            bad = np.argwhere(a != b)[:5].tolist()
            raise AssertionError(f"{name} differs at {bad}: rtl {[a[tuple(p)].tolist() for p in bad]} "
                                 f"model {[b[tuple(p)].tolist() for p in bad]}")
        n += a.size
    return n


def compare(got, model, cycles=True):
    """Assert the RTL's decoded results equal the model's bit for bit; returns #values compared."""
    n = compare_fields(got, model, ("distance", "vector", "nearest", "done", "cfr", "visited", "parent"))
    assert got["path"] == model.path, f"path rtl {got['path']} model {model.path}"
    assert got["path_found"] == model.path_found == bool(got["path_found_flag"])
    assert got["iterations_edt"] == model.iterations_edt, (got["iterations_edt"], model.iterations_edt)
    assert got["iterations_bfs"] == model.iterations_bfs, (got["iterations_bfs"], model.iterations_bfs)
    if cycles:      # the model's figure plus the cycles the stalls cost the core, if any
        want = model.cycles + got["starved"] + got["stalls"]
        assert got["cycles"] == want, (f"cycles rtl {got['cycles']}, model {model.cycles} + "
                                       f"{got['starved']} starved + {got['stalls']} stalled = {want}")
    return n + len(model.path)
