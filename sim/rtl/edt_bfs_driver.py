"""Cocotb driver of the EDT/BFS core (hdl/edt_bfs/edt_bfs.py), shared by the tests and ``sim edt``.

:class:`EdtBfsDriver` runs one job cycle by cycle: the command, the image
columns (first beat = column W-1, as the load pipeline shifts right), and the
result stream, with optional random stalls on the image source and the
result sink.  It decodes the results into the arrays of
:class:`models.edt_bfs.EdtBfsResult` and counts the job's cycles from the
command handshake (exclusive) to the last result beat (inclusive).
"""

import numpy as np
from amaranth.hdl import Shape
from cocotb.clock import Clock
from cocotb.triggers import ReadOnly, RisingEdge

from navcores.hdl.edt_bfs.cell import cell_widths
from navcores.hdl.edt_bfs.edt_bfs import command_layout, image_layout, result_layout

from .clock import PERIOD_NS

__all__ = ["EdtBfsDriver", "compare", "pack", "unpack"]


def pack(layout, values):
    """``values`` (a dict of field -> int) packed into an integer of ``layout``."""
    word = 0
    for name, v in values.items():
        f = layout[name]
        word |= (int(v) & ((1 << f.width) - 1)) << f.offset
    return word


def unpack(layout, word):
    """An integer of ``layout`` as a dict of field -> int (signed fields signed)."""
    out = {}
    for name, f in layout:
        v = (word >> f.offset) & ((1 << f.width) - 1)
        if Shape.cast(f.shape).signed and v >> (f.width - 1):
            v -= 1 << f.width
        out[name] = v
    return out


class EdtBfsDriver:
    def __init__(self, dut, height, width):
        self.dut, self.h, self.w = dut, height, width
        wd = cell_widths(height, width)
        self.widths = wd
        self.cmd = command_layout(wd)
        self.img = image_layout(height)
        self.res = result_layout(wd)

    async def start(self):
        Clock(self.dut.clk, PERIOD_NS, unit="ns").start()
        await self.reset()

    async def reset(self, cycles=2):
        d = self.dut
        d.rst.value = 1
        d.c_stream__valid.value = 0
        d.i_stream__valid.value = 0
        d.o_stream__ready.value = 0
        for _ in range(cycles):
            await RisingEdge(d.clk)
        d.rst.value = 0
        await RisingEdge(d.clk)

    async def job(self, img, goals, start, dfar, *, rng=None, p_valid=1.0, p_ready=1.0,
                  max_cycles=None, abort_after=None):
        """Run one job; returns a dict of decoded results (None if aborted).

        ``start`` None sends ``path`` = 0.  ``dfar`` beyond the d_i width is
        clamped (exact: no d_i exceeds the largest width value).
        ``abort_after``: stop driving after that many cycles and return None
        (the caller then resets the core).
        """
        d, h, w = self.dut, self.h, self.w
        img = np.asarray(img, dtype=bool)
        assert img.shape == (h, w), (img.shape, h, w)
        goal = np.zeros_like(img)
        for r, c in goals:
            goal[r, c] = True
        dfar = min(int(dfar), (1 << self.widths["di"]) - 1)
        sr, sc = start if start is not None else (0, 0)
        cmd = pack(self.cmd, {"dfar": dfar, "start_row": sr, "start_col": sc,
                               "path": int(start is not None)})
        cols = []
        for j in range(w):
            c = w - 1 - j
            cols.append(pack(self.img, {
                "obst": sum(int(img[r, c]) << r for r in range(h)),
                "goal": sum(int(goal[r, c]) << r for r in range(h))}))
        if max_cycles is None:
            max_cycles = 20 * (h * w + w + 100) + 4 * h * w
        stall = (lambda p: rng.random() < p) if rng is not None else (lambda p: True)

        sent_cmd, j, cycle, t0 = False, 0, 0, None
        beats = []
        while True:
            if abort_after is not None and cycle >= abort_after:
                d.c_stream__valid.value = 0
                d.i_stream__valid.value = 0
                return None
            cv = int(not sent_cmd)
            d.c_stream__valid.value = cv
            d.c_stream__payload.value = cmd
            iv = int(sent_cmd and j < w and stall(p_valid))
            d.i_stream__valid.value = iv
            d.i_stream__payload.value = cols[j] if j < w else 0
            orr = int(stall(p_ready))
            d.o_stream__ready.value = orr
            await ReadOnly()
            fire_c = cv and int(d.c_stream__ready.value)
            fire_i = iv and int(d.i_stream__ready.value)
            fire_o = orr and int(d.o_stream__valid.value)
            beat = unpack(self.res, int(d.o_stream__payload.value)) if fire_o else None
            await RisingEdge(d.clk)
            cycle += 1
            if fire_c:
                sent_cmd, t0 = True, cycle
            if fire_i:
                j += 1
            if beat is not None:
                beats.append(beat)
                if beat["last"]:
                    break
            assert cycle < max_cycles, f"job did not finish in {max_cycles} cycles"
        d.o_stream__ready.value = 0
        out = self._decode(beats)
        out["cycles"] = cycle - t0
        out["iterations_edt"] = int(d.iterations_edt.value)
        out["iterations_bfs"] = int(d.iterations_bfs.value)
        out["path_found_flag"] = int(d.path_found.value)
        out["start_err"] = int(d.start_err.value)
        return out

    def _decode(self, beats):
        h, w = self.h, self.w
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


def compare(got, model, cycles=True):
    """Assert the RTL's decoded results equal the model's bit for bit; returns #values compared."""
    n = 0
    for name in ("distance", "vector", "nearest", "done", "cfr", "visited", "parent"):
        a, b = np.asarray(got[name]), np.asarray(getattr(model, name))
        if not np.array_equal(a, b):
            bad = np.argwhere(a != b)[:5].tolist()
            raise AssertionError(f"{name} differs at {bad}: rtl {[a[tuple(p)].tolist() for p in bad]} "
                                 f"model {[b[tuple(p)].tolist() for p in bad]}")
        n += a.size
    assert got["path"] == model.path, f"path rtl {got['path']} model {model.path}"
    assert got["path_found"] == model.path_found == bool(got["path_found_flag"])
    assert got["iterations_edt"] == model.iterations_edt, (got["iterations_edt"], model.iterations_edt)
    assert got["iterations_bfs"] == model.iterations_bfs, (got["iterations_bfs"], model.iterations_bfs)
    if cycles:
        assert got["cycles"] == model.cycles, f"cycles rtl {got['cycles']} model {model.cycles}"
    return n + len(model.path)
