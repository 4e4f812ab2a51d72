"""The cores behind the board bridge: one job per core over
:class:`navcores.hdl.board.protocol.Link`, written once and run by the host
on a serial port (``--engine serial:PORT``, sim/serial_engine.py) and by
the board tests on the simulated UART (:mod:`.board_driver`).

Each job is a coroutine awaiting only the protocol's I/O operations:

* :func:`open_core`: INFO (the board runs the expected core; its
  parameters), then RESET (a clean core, DATA numbering from 0).
* :func:`harmonic`: load a map, START, poll STATUS until idle, READ every
  node: (status, h, const) as the planner RTL engine's job returns them.
* :func:`dflc`: samples through the DFLC, up to the bridge's window in
  flight: [(y, zero)].
* :func:`edt`: one EDT/BFS job: the decoded results of
  :func:`.edt_bfs_driver.decode`, with the iterations and the job's
  cycles from the status word.

A core's own error (the planner's ``code``, the EDT/BFS ``start_err``) is a
:class:`CoreError`; the bridge's refusals are ``protocol.BridgeError``.
"""

import numpy as np

from navcores.hdl.board.cores import edt_status_layout
from navcores.hdl.board.protocol import WRITE, BridgeError, Cmd, Error, ProtocolError, format_info
from navcores.hdl.dflc.core import sample_layout
from navcores.hdl.edt_bfs.cell import cell_widths
from navcores.hdl.edt_bfs.edt_bfs import command_layout, image_layout, result_layout
from navcores.hdl.harmonic import planner

from .edt_bfs_driver import decode
from .planner_driver import Code, Op, PlannerDriver
from .stream import pack, unpack

__all__ = ["CoreError", "open_core", "bridge_checks", "RemotePlanner", "harmonic", "harmonic_differences", "dflc",
           "edt"]

MAX_POLLS = 1_000_000       # STATUS polls of one planner run (a run that never ends is a fault)


class CoreError(ProtocolError):
    """The core answered with an error of its own."""


async def open_core(link, core):
    """INFO and RESET; the INFO dict.  ProtocolError if the board runs another core."""
    info = await link.read_info()
    if info.get("core") != core:
        raise ProtocolError(f"the board runs {info.get('core')!r}, not {core!r} (load the {core} bitstream)")
    await link.reset()
    return info


async def bridge_checks(link):
    """The bring-up checks of any board top (``python -m sim board``):
    INFO, ECHO of every byte value, STATUS, RESET, and the refusals of a
    damaged frame, an unknown command, a missing sink and a wrong length.
    Returns (info, [(check, passed, what came)]); the core is left reset."""
    info = await link.read_info()
    checks = [("INFO", True, format_info(info))]
    values, echo = bytes(range(256)), info["echo"]
    got = b"".join([await link.echo(values[i:i + echo]) for i in range(0, 256, echo)])
    checks.append((f"ECHO of the 256 byte values in {-(-256 // echo)} frames", got == values,
                   "all equal" if got == values else f"first difference at byte {_first_difference(got, values)}"))
    status = await link.call(Cmd.STATUS)
    checks.append(("STATUS", len(status) == -(-info["status"] // 8), f"{len(status)} bytes: {status.hex() or '-'}"))
    await link.reset()
    checks.append(("RESET", True, "acknowledged"))
    refusals = (("a damaged frame (CRC)", Cmd.STATUS, b"", True, Error.BAD_CRC),
                ("an unknown command 0x0F", 0x0F, b"", False, Error.UNKNOWN_CMD),
                (f"a WRITE to sink {len(info['sinks'])} (none)", WRITE + len(info["sinks"]), b"\0", False,
                 Error.UNKNOWN_CMD),
                ("INFO with a payload", Cmd.INFO, b"x", False, Error.BAD_LENGTH))
    for what, cmd, payload, damage, want in refusals:
        try:
            await link.reply(await link.send(cmd, payload, damage=damage))
            checks.append((f"{what}: NAK {want.name}", False, "acknowledged"))
        except BridgeError as e:
            came = Error(e.code).name if e.code in Error._value2member_map_ else str(e.code)
            checks.append((f"{what}: NAK {want.name}", e.code == want, f"NAK {came}"))
    return info, checks


def _first_difference(a, b):
    return next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))


# --- harmonic planner ------------------------------------------------------------------

class RemotePlanner(PlannerDriver):
    """:class:`.planner_driver.PlannerDriver` over the link: its map loading
    (``load_map``, ``locate``) on the same command and response layouts;
    each command is a WRITE of sink 0 and its response the next DATA beat of
    source 0.  No simulator streams: ``PlannerDriver.__init__`` (which
    opens them on a DUT) is not called.  ``check``: a response whose code
    is not OK raises :class:`CoreError`."""

    def __init__(self, link, check=True):       # not super().__init__: it would open streams on a DUT
        i = link.info
        self.n, self.m, self.BR, self.BC, self.p_max = i["n"], i["m"], i["br"], i["bc"], i["p_max"]
        self.exponents, self.commands = False, 0
        self.cmd_layout = planner.command_layout((self.BR, self.BC), self.n, self.m, self.p_max)
        self.resp_layout = planner.response_layout(self.p_max)
        self.link, self.check = link, check

    async def command(self, op, **fields):
        await self.link.write(0, pack(self.cmd_layout, {"op": op, **fields}))
        resp = unpack(self.resp_layout, await self.link.read(0))
        self.commands += 1
        if resp["op"] != op:
            raise ProtocolError(f"the planner answered {resp['op'].name} to {op.name}")
        if self.check and resp["code"] != Code.OK:
            raise CoreError(f"the planner refused {op.name} {fields}: {resp['code'].name}")
        return resp

    async def read_all(self, shape):
        """Every node's value and flag, the READs pipelined: as many in
        flight as the bridge's window holds (the planner takes the next one
        as soon as the bridge has its response)."""
        cells = [(r, c) for r in range(shape[0]) for c in range(shape[1])]
        seqs = []
        for r, c in cells:
            b, x, y = self.locate(r, c)
            seqs.append(await self.link.write(0, pack(self.cmd_layout, {"op": Op.READ, "block": b, "row": x,
                                                                         "col": y}), wait=False))
        for s in seqs:
            await self.link.reply(s)
        h = np.zeros(shape, dtype=object)
        const = np.zeros(shape, dtype=bool)
        for r, c in cells:
            resp = unpack(self.resp_layout, await self.link.read(0))
            if (resp["op"], resp["code"]) != (Op.READ, Code.OK):
                raise CoreError(f"READ ({r}, {c}): the planner answered {resp['op'].name} {resp['code'].name}")
            h[r, c], const[r, c] = resp["value"], bool(resp["const"])
        self.commands += len(cells)
        return h, const

    async def wait_idle(self, poll=None, limit=MAX_POLLS, progress=None):
        for _ in range(limit):
            st = await self.command(Op.STATUS)
            if not st["busy"]:
                return st
            if progress:
                progress(st)
        raise CoreError(f"the planner is still busy after {limit} STATUS polls")


async def harmonic(link, obstacle, goal, schedule, iters, progress=None):
    """Plan on the board: ``obstacle`` / ``goal`` of the board's whole map
    (BR*n x BC*m), ``schedule`` = (p1, step, p_last).  Returns (status, h,
    const) as sim/rtl/planner_job.py's run_map."""
    drv = RemotePlanner(link)
    await drv.load_map(np.asarray(obstacle, dtype=bool), np.asarray(goal, dtype=bool))
    p1, step, p_last = schedule
    await drv.command(Op.START, p1=p1, step=step, p_last=p_last, iters=iters)
    status = await drv.wait_idle(progress=progress)
    h, const = await drv.read_all(np.shape(obstacle))
    return status, h, const


STATUS_KEYS = ("p", "converged", "sweeps", "block_iterations", "check_iterations", "clear_passes", "cycles")


def harmonic_differences(status, h, const, model):
    """How the board's plan (:func:`harmonic`) differs from ``model``, the
    PlanResult of models.harmonic.plan on the same padded map: [] when bit
    for bit equal (every node's value and flag, the counters, the cycles)."""
    out = [f"{k}: board {int(status[k])}, model {int(getattr(model, k))}"
           for k in STATUS_KEYS if int(status[k]) != int(getattr(model, k))]
    bad = np.argwhere((np.asarray(h, dtype=object) != model.padded_h) | (np.asarray(const) != model.padded_const))
    if len(bad):
        r, c = bad[0]
        out.append(f"{len(bad)} nodes differ, first ({r}, {c}): board {h[r, c]}, model {model.padded_h[r, c]}")
    return out


# --- DFLC ----------------------------------------------------------------------------

async def dflc(link, rows, config):
    """``rows`` of input codes through the DFLC (``config``: its
    models.dflc.DflcConfig); [(y, zero)] in order.  The samples go out as
    fast as the bridge's window allows; their ACKs and the results are
    collected as they come."""
    layout, op_sz = sample_layout(config), config.op_sz
    seqs = [await link.write(0, pack(layout, [int(c) for c in r]), wait=False) for r in rows]
    for s in seqs:
        await link.reply(s)
    out = []
    for _ in rows:
        v = await link.read(0)
        out.append((v & ((1 << op_sz) - 1), bool(v >> op_sz)))
    return out


# --- EDT/BFS ---------------------------------------------------------------------------

async def edt(link, img, goals, start, dfar):
    """One EDT/BFS job on the board's array (the image its size): the
    decoded results (:func:`.edt_bfs_driver.decode`), ``cycles`` from the
    status word.  ``start`` None: no path."""
    h, w = link.info["height"], link.info["width"]
    img = np.asarray(img, dtype=bool)
    if img.shape != (h, w):
        raise ValueError(f"the board's array is {h}x{w}; the image is {img.shape[0]}x{img.shape[1]}")
    widths = cell_widths(h, w)
    dfar = min(int(dfar), (1 << widths["di"]) - 1)
    sr, sc = start if start is not None else (0, 0)
    await link.write(0, pack(command_layout(widths), {"dfar": dfar, "start_row": sr, "start_col": sc,
                                                      "path": int(start is not None)}))
    goal = np.zeros((h, w), dtype=bool)
    for r, c in goals:
        goal[r, c] = True
    # the first column to go in is the rightmost (the load pipeline shifts right)
    seqs = [await link.write(1, pack(image_layout(h), {"obst": _column(img, c), "goal": _column(goal, c)}),
                             wait=False) for c in reversed(range(w))]
    for s in seqs:
        await link.reply(s)
    layout = result_layout(widths)
    beats = []
    while not beats or not beats[-1]["last"]:
        beats.append(unpack(layout, await link.read(0)))
    try:
        out = decode(beats, h, w)
    except AssertionError as e:         # the board's beats break the core's read-out order
        raise ProtocolError(f"the EDT/BFS results: {e}") from None
    st = unpack(edt_status_layout(h, w), await link.status())
    if st["start_err"]:
        raise CoreError(f"start {start} is outside the board's {h}x{w} array")
    # the status word's cycles leave out the clocks the UART stalled the core: none to add
    out.update(cycles=st["cycles"], starved=0, stalls=0, iterations_edt=st["iterations_edt"],
               iterations_bfs=st["iterations_bfs"], path_found_flag=st["path_found"], start_err=st["start_err"])
    return out


def _column(mask, c):
    return sum(int(mask[r, c]) << r for r in range(mask.shape[0]))
