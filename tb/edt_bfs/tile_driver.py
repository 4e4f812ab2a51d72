"""Cocotb driver of the EDT/BFS tile engine (hdl/edt_bfs/tile_engine.py), for the tests and ``sim edt --array``.

:class:`TileEngineDriver` runs one job cycle by cycle: the command, the map
words, the goals (offered from the start; the engine takes them after the
EDT) and the result stream, with optional random idle cycles on the sources
and back-pressure on the sink.  It records the visit monitor (the model's
``trace``), counts the job's cycles (the cycles ``busy`` is high after the
command's handshake: the model's cycle count) and decodes the results into
the fields of :class:`models.edt_bfs_tiled.EdtBfsTiledResult`.

:meth:`TileEngineDriver.plan` is the whole job for a caller: a map, goals,
start and d_far in; the model's result object out.
"""

import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ReadOnly, RisingEdge

from edt_bench import pack, unpack
from hdl.edt_bfs.tile_engine import command_layout, goal_layout, map_layout, result_layout, visit_layout
from hdl.edt_bfs.tile_layouts import tile_widths
from models.edt_bfs_tiled import EdtBfsTiledResult

__all__ = ["TileEngineDriver", "compare", "FIELDS"]

FIELDS = ("distance", "nearest", "vector", "sqdist", "done", "cfr", "visited", "parent", "hop")


class TileEngineDriver:
    """Drives a ``TileEngine(t_r, t_c, max_h, max_w)`` top in cocotb."""

    def __init__(self, dut, t_r, t_c, max_h, max_w):
        self.dut, self.t_r, self.t_c, self.max_h, self.max_w = dut, t_r, t_c, max_h, max_w
        w = self.widths = tile_widths(t_r, t_c, max_h, max_w)
        self.cmd, self.map, self.goal = command_layout(w), map_layout(t_c), goal_layout(w)
        self.res, self.vis = result_layout(w), visit_layout(w)

    async def start(self):
        Clock(self.dut.clk, 10, unit="ns").start()
        await self.reset()

    async def reset(self, cycles=2):
        d = self.dut
        d.rst.value = 1
        for s in (d.c_stream__valid, d.m_stream__valid, d.g_stream__valid, d.o_stream__ready):
            s.value = 0
        for _ in range(cycles):
            await RisingEdge(d.clk)
        d.rst.value = 0
        await RisingEdge(d.clk)

    def words(self, img):
        """The map stream: row-major, ceil(W / T_c) words a row, bit j = column w T_c + j."""
        h, wd = img.shape
        p = self.t_c
        out = []
        for r in range(h):
            for c0 in range(0, wd, p):
                bits = sum(int(img[r, c]) << (c - c0) for c in range(c0, min(wd, c0 + p)))
                out.append(pack(self.map, {"obst": bits}))
        return out

    async def job(self, img, goals, start, dfar, *, readout=True, rng=None, p_valid=1.0, p_ready=1.0,
                  abort_after=None, max_cycles=None, height=None, width=None):
        """Run one job; returns the raw outcome (a dict), or None if aborted after ``abort_after`` cycles.

        No checks: goals and the start go to the engine as given (the engine
        flags what lies outside the map); ``height`` / ``width`` override the
        command's size (a refused command returns at once).
        """
        d = self.dut
        img = np.asarray(img, dtype=bool)
        h, wd = img.shape
        dfar = min(int(dfar), (1 << self.widths["di"]) - 1)     # exact: no di reaches the cap
        sr, sc = start if start is not None else (0, 0)
        cmd = pack(self.cmd, {"height": h if height is None else height, "width": wd if width is None else width,
                              "dfar": dfar, "goals": len(goals), "start_row": sr, "start_col": sc,
                              "path": int(start is not None), "readout": int(readout)})
        words = self.words(img)
        gbeats = [pack(self.goal, {"row": r, "col": c}) for r, c in goals]
        if max_cycles is None:
            max_cycles = 200 * (h * wd + 100) * (1 + int(p_valid < 1 or p_ready < 1))
        pick = (lambda p: rng.random() < p) if rng is not None else (lambda p: True)

        sent_cmd, nw, ng, cycle, busy_cycles = False, 0, 0, 0, 0
        beats, trace = [], []
        while True:
            if abort_after is not None and cycle >= abort_after:
                for s in (d.c_stream__valid, d.m_stream__valid, d.g_stream__valid):
                    s.value = 0
                return None
            cv = int(not sent_cmd)
            d.c_stream__valid.value = cv
            d.c_stream__payload.value = cmd
            mv = int(sent_cmd and nw < len(words) and pick(p_valid))
            d.m_stream__valid.value = mv
            d.m_stream__payload.value = words[nw] if nw < len(words) else 0
            gv = int(sent_cmd and ng < len(gbeats) and pick(p_valid))
            d.g_stream__valid.value = gv
            d.g_stream__payload.value = gbeats[ng] if ng < len(gbeats) else 0
            orr = int(pick(p_ready))
            d.o_stream__ready.value = orr
            await ReadOnly()
            fire_c = cv and int(d.c_stream__ready.value)
            fire_m = mv and int(d.m_stream__ready.value)
            fire_g = gv and int(d.g_stream__ready.value)
            fire_o = orr and int(d.o_stream__valid.value)
            busy = int(d.busy.value)
            beat = unpack(self.res, int(d.o_stream__payload.value)) if fire_o else None
            v = unpack(self.vis, int(d.visit.value))
            if v["valid"]:
                trace.append((v, int(d.levels.value)))
            if sent_cmd:
                if not busy:
                    break                   # the job's last cycle was the one before (or it was refused)
                busy_cycles += 1
            await RisingEdge(d.clk)
            cycle += 1
            if fire_c:
                sent_cmd = True
            nw += fire_m
            ng += fire_g
            if beat is not None:
                beats.append(beat)
            assert cycle < max_cycles, f"job did not finish in {max_cycles} cycles"
        flags = {n: int(getattr(d, n).value) for n in
                 ("cmd_err", "start_err", "goal_err", "path_found", "levels", "tile_visits")}
        await RisingEdge(d.clk)
        for s in (d.c_stream__valid, d.m_stream__valid, d.g_stream__valid, d.o_stream__ready):
            s.value = 0
        return {"beats": beats, "trace": trace, "cycles": busy_cycles, "words_sent": nw, "goals_sent": ng, **flags}

    def decode(self, raw, shape, readout=True):
        """The raw outcome of a job on an ``shape`` map as the model's result fields (a dict)."""
        h, wd = shape
        beats = raw["beats"]
        path = [(b["row"], b["col"]) for b in beats if not b["map"]]
        cells = [b for b in beats if b["map"]]
        assert all(not b["map"] for b in beats[:len(path)]), "path beats come first"
        assert sum(b["last"] for b in beats) == (1 if beats else 0) and (not beats or beats[-1]["last"])
        out = {"path": path, "path_found": bool(raw["path_found"]), "levels": raw["levels"], "cycles": raw["cycles"],
               "tile_visits": raw["tile_visits"], "iterations_edt": raw["levels"] + 1}
        nc = -(-wd // self.t_c)
        out["trace"] = [("bfs" if v["bfs"] else "edt", 0 if v["bfs"] else k, v["r"] * nc + v["c"],
                         v["iterations"], v["marks"]) for v, k in raw["trace"]]
        if not readout:
            assert not cells
            return out
        assert len(cells) == h * wd, f"{len(cells)} map beats, expected {h * wd}"
        a = {n: np.zeros((h, wd), dtype=np.int64) for n in ("di", "dx", "dy", "hop", "parent")}
        b = {n: np.zeros((h, wd), dtype=bool) for n in ("done", "cfr", "visited")}
        for n, beat in enumerate(cells):
            r, c = beat["row"], beat["col"]
            assert (r, c) == divmod(n, wd), f"beat {n} is pixel {(r, c)}: not row-major"
            for f in a:
                a[f][r, c] = beat[f]
            for f in b:
                b[f][r, c] = beat[f]
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
            stats={"levels": got["levels"]}, trace=got["trace"])


def compare(got, model, cycles=True, readout=True):
    """Assert the engine's decoded results equal the tiled model's; returns the number of values compared.

    Every result field, the path, the iteration counts, the tile visits and
    the visit trace (tile by tile: phase, level, tile, iterations, marks);
    with ``cycles`` the job's cycle count too.
    """
    n = 0
    if readout:
        for name in FIELDS:
            a, b = np.asarray(got[name]), np.asarray(getattr(model, name))
            if not np.array_equal(a, b):
                bad = np.argwhere(a != b)[:5].tolist()
                raise AssertionError(f"{name} differs at {bad}: rtl {[a[tuple(p)].tolist() for p in bad]} "
                                     f"model {[b[tuple(p)].tolist() for p in bad]}")
            n += a.size
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
        assert got["cycles"] == model.cycles, f"cycles rtl {got['cycles']} model {model.cycles}"
    return n + len(model.path) + len(model.trace)
