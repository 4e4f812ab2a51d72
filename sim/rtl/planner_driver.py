"""Drive the harmonic Planner RTL in simulation through its host streams.

Shared by the planner regression (tb/harmonic/test_planner.py), the cocotb
job sim/rtl/planner_job.py and, through :func:`run_planner_rtl`, the
command line (``python -m sim harmonic --engine icarus|verilator``).

* :class:`PlannerDriver`: commands and responses on the planner's streams
  (sim/rtl/stream.py, packed by the planner's struct layouts, with optional
  random idle commands and response back-pressure), one command -> one
  response, map loading, a run to the end, reading every node back.
* :func:`planner_params`: the block / RAM parameters for a map.
* :func:`run_planner_rtl`: a whole map through cocotb (a JSON job file read
  by sim/rtl/planner_job.py), returning the fields of
  :class:`models.harmonic.PlanResult`.
"""

import json
import tempfile
from pathlib import Path

import numpy as np

from navcores.hdl.harmonic.cluster import COLS, ROWS
from navcores.hdl.harmonic.planner import Code, Op, command_layout, response_layout
from navcores.models.harmonic import E_MAX, pad_to_blocks, reachable

from .clock import PERIOD_NS
from .stream import Streams, pauses

__all__ = ["PlannerDriver", "planner_params", "run_planner_rtl", "Op", "Code"]

POLL = 128          # cycles between STATUS polls while a run is on


def response_timeout(p_max):
    """Cycles a command may wait for its response before the driver gives
    up: every response comes within DIRECTION's latency (with block
    exponents' conversions about 12 p_max + 50 cycles) or LOAD's p_max + 2
    writes, plus the random idle and back-pressure cycles; this bound leaves
    a wide margin, so that a planner that hangs fails its test at once."""
    return 64 * (p_max + 64)


class PlannerDriver:
    """The Planner's host streams under cocotb: one command, one response.

    ``n``, ``m``, ``blocks``, ``p_max``, ``exponents``, ``e_max``: the
    Planner's parameters (they fix the command and response layouts).
    ``rng`` with ``idle`` / ``back_pressure``: the probability of an idle
    cycle before each command and of ready low on the response stream each
    cycle (:func:`.stream.pauses`); 0: commands at once, responses always
    taken.  ``cmd`` / ``resp``: the :class:`.stream.StreamSource` /
    :class:`.stream.StreamSink` (``beats``, ``idle``, ``stalls``).  The
    clock must run before the first command (:func:`.clock.start`).
    """

    def __init__(self, dut, n, m, blocks, p_max, exponents=False, e_max=255, rng=None, idle=0.0,
                 back_pressure=0.0):
        self.dut, self.n, self.m = dut, n, m
        self.BR, self.BC = blocks
        self.p_max = p_max
        self.exponents = bool(exponents)
        self.streams = Streams(dut)
        self.cmd = self.streams.source("i_stream", command_layout(blocks, n, m, p_max), pause=pauses(rng, idle))
        resp_layout = response_layout(p_max, exponents=True, e_max=e_max) if exponents else response_layout(p_max)
        self.resp = self.streams.sink("o_stream", resp_layout, pause=pauses(rng, back_pressure))
        self.commands = 0

    async def command(self, op, **fields):
        """Send one command; return its response (a dict of the response
        layout's fields, ``code`` and ``op`` as :class:`Code` / :class:`Op`).
        ``op`` may be a raw integer (an op the planner does not know).
        ``self.latency``: the response's latency, the cycles after the one
        that took the command up to the one that raised the response's valid
        (back-pressure on the response does not count)."""
        self.cmd.put({"op": op, **fields})
        resp = await self.resp.recv(timeout_cycles=response_timeout(self.p_max))
        self.latency = self.resp.starts[-1] - self.cmd.beats[-1][0] - 1
        self.commands += 1
        assert resp["op"] == op, f"response to {op} says {resp['op']}"
        return resp

    def locate(self, r, c):
        """Map cell (r, c) -> (block, row, col)."""
        return (r // self.n) * self.BC + c // self.m, r % self.n, c % self.m

    async def load_map(self, obstacle, goal):
        """LOAD every cluster of every block (padded map: BR*n x BC*m)."""
        first = 1
        for b in range(self.BR * self.BC):
            r0, c0 = (b // self.BC) * self.n, (b % self.BC) * self.m
            for i in range(self.n // ROWS):
                for j in range(self.m // COLS):
                    rs = slice(r0 + ROWS * i, r0 + ROWS * (i + 1))
                    cs = slice(c0 + COLS * j, c0 + COLS * (j + 1))
                    flags = _mask(obstacle[rs, cs] | goal[rs, cs])
                    goals = _mask(goal[rs, cs])
                    resp = await self.command(Op.LOAD, block=b, row=ROWS * i, col=COLS * j,
                                              flags=flags, goals=goals, flag=first)
                    assert resp["code"] == Code.OK, resp["code"]
                    first = 0

    async def start(self, schedule, iters):
        p1, step, p_last = arithmetic(schedule)
        return await self.command(Op.START, p1=p1, step=step, p_last=p_last, iters=iters)

    async def wait_idle(self, poll=POLL, limit=10**8, progress=None):
        """STATUS every ``poll`` cycles until the run is over; its last response."""
        from cocotb.triggers import FallingEdge, Timer
        waited = 0
        while True:
            st = await self.command(Op.STATUS)
            if not st["busy"]:
                return st
            if progress:
                progress(st)
            await Timer(poll * PERIOD_NS, unit="ns")    # one wake-up, not one per cycle
            await FallingEdge(self.dut.clk)
            waited += poll
            assert waited < limit, "the planner did not finish"

    async def read_all(self, shape):
        h = np.zeros(shape, dtype=object)
        const = np.zeros(shape, dtype=bool)
        for r in range(shape[0]):
            for c in range(shape[1]):
                b, x, y = self.locate(r, c)
                resp = await self.command(Op.READ, block=b, row=x, col=y)
                assert resp["code"] == Code.OK, resp["code"]
                h[r, c], const[r, c] = resp["value"], bool(resp["const"])
                if self.exponents:
                    self.block_exponents[b // self.BC, b % self.BC] = resp["exponent"]
        return h, const

    @property
    def block_exponents(self):
        """The e_b READ reported (BR x BC; block-exponent option)."""
        if not hasattr(self, "_exps"):
            self._exps = np.zeros((self.BR, self.BC), dtype=np.int64)
        return self._exps


def _mask(flags):
    return sum(int(bool(v)) << i for i, v in enumerate(np.ravel(flags)))


def arithmetic(schedule):
    """(p1, step, p_last) of an arithmetic schedule; the RTL runs no other."""
    sched = [int(p) for p in schedule]
    step = sched[1] - sched[0] if len(sched) > 1 else 0
    if any(b - a != step for a, b in zip(sched, sched[1:])):
        raise ValueError(f"schedule {tuple(sched)}: the planner RTL runs arithmetic schedules only "
                         "(p1, p1+step, ..., p_last)")
    return sched[0], step, sched[-1]


def planner_params(shape, block=(6, 12), p_max=30, depth=None):
    """Planner parameters for a map of ``shape``: the padded map's block
    grid, the RAM depth (the smallest power of two >= B*(p_max+2), at least
    the paper's 1024 if that suffices)."""
    n, m = block
    BR, BC = -(-shape[0] // n), -(-shape[1] // m)
    need = BR * BC * (p_max + 2)
    if depth is None:
        depth = 1 << max(need - 1, 1).bit_length()
    return {"n": n, "m": m, "br": BR, "bc": BC, "p_max": p_max, "depth": depth}


def run_planner_rtl(obstacle, goals, block=(3, 6), iters=6, schedule=(16, 32), sim="verilator",
                    progress=None, work=None, events=(), block_exponents=False, e_max=E_MAX,
                    paper_schedule=False):
    """Run the Planner RTL on a whole map through cocotb; return a dict with
    the fields of :class:`models.harmonic.PlanResult` (h, const, p,
    converged, sweeps, block_iterations, check_iterations, clear_passes,
    node_updates, cycles, unreachable) and ``params`` (the RTL parameters).

    The RTL is built for the map: ``block`` (n, m) nodes per block (default
    3x6, one cluster: Icarus simulates ~1000 cycles/s of it, ~200 of a 6x12
    block, whose Verilator build takes 10+ minutes), the padded map's block
    grid, p_max = the schedule's last precision and the smallest power-of-two
    RAM depth that holds B*(p_max+2) words (:func:`planner_params`).
    Unreachable free cells are walled off (loaded as obstacles) like the
    model does.  ``events``: ``(s, (r, c), kind)`` as in
    :func:`models.harmonic.plan`; s = 0 is sent while idle before START, s >= 1
    during pass s-1 (the driver watches the pass count).  ``progress(status)``
    is called from the job's STATUS polls (through the job's log, after the
    run, when the simulator runs in a subprocess: it gets the last status).
    ``block_exponents``: the Planner's exponent option (:func:`exponent_params`,
    its largest exponent ``e_max``);
    ``h``/``padded_h`` are then the mantissas and ``exponents``
    (BR x BC) the block exponents (models.harmonic.plan(..., rtl=True)).
    ``paper_schedule``: build ``Planner(paper_schedule=True)``, the paper's
    block schedule (``plan(..., paper_schedule=True)``); default still blocks.
    """
    from .runner import run
    obstacle = np.asarray(obstacle, dtype=bool)
    H, W = obstacle.shape
    p1, step, p_last = arithmetic(schedule)
    params = planner_params(obstacle.shape, block, p_max=p_last)
    if paper_schedule:
        params["paper_schedule"] = 1        # the regression's b3x6_paper build (tb/harmonic/test_planner.py)
    padded = pad_to_blocks(obstacle, block)
    goal = np.zeros(padded.shape, dtype=bool)
    for r, c in goals:
        goal[r, c] = True
    unreachable = ~padded & ~reachable(padded, goal)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(work or tmp)
        job, result = work / "planner_job.json", work / "planner_result.json"
        job.write_text(json.dumps({
            "params": params, "obstacle": (padded | unreachable).tolist(), "goal": goal.tolist(),
            "schedule": [p1, step, p_last], "iters": int(iters),
            "events": [[int(s), [int(r), int(c)], str(k)] for s, (r, c), k in events],
            "exponents": bool(block_exponents), "e_max": int(e_max),
        }))
        run("harmonic_planner", exponent_params(params, e_max) if block_exponents else params, sim,
            "navcores.sim.rtl.planner_job",
            env={"PLANNER_JOB": job, "PLANNER_RESULT": result}, log_file=work / "sim.log")
        out = json.loads(result.read_text())
    h = np.array([[int(v) for v in row] for row in out["h"]], dtype=object)
    res = dict(out["status"])
    res.update(h=h[:H, :W], const=np.array(out["const"], dtype=bool)[:H, :W],
               padded_h=h, unreachable=unreachable[:H, :W], params=params,
               node_updates=res["block_iterations"] * block[0] * block[1])
    if block_exponents:
        res["exponents"] = np.array(out["exponents"], dtype=np.int64)
    if progress:
        progress(out["status"])
    return res


def exponent_params(params, e_max=E_MAX):
    """The emitted Planner's parameters with its block-exponent option on,
    its exponent registers holding 0 .. ``e_max``."""
    return {**params, "block_exponents": 1, **({"e_max": int(e_max)} if e_max != E_MAX else {})}

