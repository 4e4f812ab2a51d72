"""``--engine serial:PORT[@BAUD]``: a command's job on a board, over its USB serial port.

The board runs the command's core behind the UART bridge (``make
bitstream``, docs/boards.md).  The host speaks the bridge's protocol
(navcores.hdl.board.protocol) through pyserial and runs the same per-core
jobs as the board tests (navcores.sim.rtl.board_jobs).  Before a job it
reads INFO and refuses a board that runs another core or a configuration
the job does not fit; after it, the results are compared with the golden
model, as for the simulator engines (``rtl_matches_model``; a mismatch
exits 1).

    serial:/dev/ttyUSB0            115200 Bd (the bitstreams' default)
    serial:/dev/ttyUSB1@1000000    a bitstream built with BAUD=1000000

Every fault of the port or the link is one line and exit status 2 (a port
that does not exist or cannot be opened, a board that does not answer or
runs another core or configuration).
"""

import os

import numpy as np

from .cli import SERIAL, CliError

__all__ = ["PREFIX", "DEFAULT_BAUD", "is_serial", "parse", "check", "SerialTransport", "session", "loopback",
           "run_dflc", "run_edt", "run_harmonic"]

PREFIX = SERIAL
DEFAULT_BAUD = 115200
BAUD_RANGE = (300, 12_000_000)
FIRST_TIMEOUT = 2.0         # seconds for INFO's reply; then from the board's accept timeout


def is_serial(engine):
    return isinstance(engine, str) and engine.startswith(PREFIX)


def parse(engine):
    """``serial:PORT[@BAUD]`` -> (port, baud); CliError for a bad one."""
    body = engine[len(PREFIX):]
    port, at, baud = body.rpartition("@") if "@" in body else (body, "", "")
    if not port:
        raise CliError(f"{engine}: give the board's serial port, e.g. serial:/dev/ttyUSB0[@115200]")
    if at:
        if not baud.isdigit() or not BAUD_RANGE[0] <= int(baud) <= BAUD_RANGE[1]:
            raise CliError(f"{engine}: baud {baud!r} must be an integer in "
                           f"{BAUD_RANGE[0]}..{BAUD_RANGE[1]} (the bitstream's, default {DEFAULT_BAUD})")
        return port, int(baud)
    return port, DEFAULT_BAUD


def check(engine):
    """Refuse, before any work, an engine spec whose port does not exist."""
    port, baud = parse(engine)
    if port.startswith("/") and not os.path.exists(port):
        raise CliError(f"{engine}: no serial port {port} (is the board plugged in? "
                       "ls /dev/ttyUSB* /dev/ttyACM*)")
    return port, baud


class SerialTransport:
    """A pyserial port as the protocol's transport: ``write``, and ``read``
    (what came; waits up to ``timeout`` s for a first byte)."""

    def __init__(self, port, baud, timeout=FIRST_TIMEOUT):
        try:
            import serial
        except ImportError:
            raise CliError("pyserial is not installed (pip install pyserial; make venv installs it)") from None
        if not hasattr(serial, "serial_for_url"):
            raise CliError(f"the module 'serial' found first ({serial.__file__}) is not pyserial: "
                           "take its folder off PYTHONPATH")
        self.timeout = timeout
        try:
            self.port = serial.serial_for_url(port, baudrate=baud, timeout=timeout, write_timeout=10)
            self.port.reset_input_buffer()
        except (serial.SerialException, OSError, ValueError) as e:
            raise CliError(f"serial port {port}: cannot open it ({e})") from None
        self.name, self.baud, self.faults = port, baud, (serial.SerialException, OSError)

    def write(self, data):
        try:
            self.port.write(data)
        except self.faults as e:         # unplugged in the middle of a job, a write that never drains
            raise CliError(f"serial port {self.name}: {e}") from None

    def read(self):
        try:
            self.port.timeout = self.timeout
            first = self.port.read(1)
            return first + self.port.read(self.port.in_waiting) if first else b""
        except self.faults as e:
            raise CliError(f"serial port {self.name}: {e}") from None

    def close(self):
        self.port.close()


def session(engine, core, job, check_info=None):
    """Open the port, INFO and RESET (the board must run ``core``; then
    ``check_info(info)`` may refuse it with a CliError), run
    ``job(link, info)`` (a board_jobs coroutine) and return its result.
    Link faults become one-line CliErrors."""
    from .rtl.board_jobs import open_core

    async def whole(link, transport, baud):
        info = await open_core(link, core)
        if check_info:
            check_info(info)
        transport.timeout = _timeout(info, baud)
        return await job(link, info)

    return _on_port(engine, whole, f"the {core} bitstream")


def loopback(engine):
    """The bring-up checks (board_jobs.bridge_checks) on any board: (info, checks)."""
    from .rtl.board_jobs import bridge_checks

    async def whole(link, transport, baud):
        return await bridge_checks(link)

    return _on_port(engine, whole, "a navcores bitstream")


def _timeout(info, baud):
    """The bridge may hold a beat for its accept timeout: wait longer than that."""
    return max(FIRST_TIMEOUT, 2 * info["accept"] / baud + 0.5)


def _on_port(engine, whole, what):
    from navcores.hdl.board.protocol import Link, LinkTimeout, ProtocolError, run_blocking

    port, baud = check(engine)
    transport = SerialTransport(port, baud)
    try:
        return run_blocking(whole(Link(), transport, baud), transport)
    except LinkTimeout:
        raise CliError(f"{engine}: no answer from the board (is {what} loaded, built for "
                       f"{baud} Bd? make bitstream ... BAUD={baud}; docs/boards.md)") from None
    except ProtocolError as e:
        raise CliError(f"{engine}: {e}") from None
    finally:
        transport.close()


def _needs(info, what, **want):
    """CliError unless INFO's keys equal ``want``."""
    bad = {k: (info.get(k), v) for k, v in want.items() if info.get(k) != v}
    if bad:
        have = ", ".join(f"{k}={b}" for k, (b, _) in bad.items())
        need = ", ".join(f"{k}={v}" for k, (_, v) in bad.items())
        raise CliError(f"the board's core has {have}; {what} needs {need}")


# --- the commands' jobs ---------------------------------------------------------------

def run_dflc(engine, fll_path, config, parallel, codes):
    """The samples through the board's DFLC; (y, zero)."""
    from navcores.hdl.board.cores import fll_digest
    from .rtl.board_jobs import dflc

    def fits(info):
        _needs(info, f"--fll {fll_path}", sha=fll_digest(fll_path))
        _needs(info, "this run", divider=config.div_type, par=int(bool(parallel)), ip_sz=config.ip_sz,
               op_sz=config.op_sz)

    out = session(engine, "dflc", lambda link, info: dflc(link, codes.tolist(), config), fits)
    return [y for y, _ in out], [z for _, z in out]


def run_edt(engine, grid, goals, start, dfar):
    """One EDT/BFS job on the board's array (the map must be its size): the
    RTL engine's result dict."""
    from .rtl.board_jobs import edt

    def fits(info):
        if grid.shape != (info["height"], info["width"]):
            raise CliError(f"the board's EDT/BFS array is {info['height']}x{info['width']}; the map is "
                           f"{grid.shape[0]}x{grid.shape[1]} (the array takes a map of its own size)")

    res = session(engine, "edt_bfs", lambda link, info: edt(link, grid, goals, start, dfar), fits)
    res["path"] = [list(p) for p in res["path"]]
    return res


def run_harmonic(engine, obstacle, goals, block, iters, schedule, block_exponents=False):
    """Plan on the board's planner: the map padded with obstacles to the
    board's whole grid of blocks; the model planned on the same grid and
    compared.  Returns the RTL engine's dict plus ``grid`` (the padded
    map), ``rtl_matches_model`` and ``differences``."""
    from navcores.models.harmonic import pad_to_blocks, plan, reachable
    from .rtl.board_jobs import harmonic, harmonic_differences
    from .rtl.planner_driver import arithmetic

    if block_exponents:
        raise CliError(f"--engine {engine}: the board's planner is built without block exponents")
    try:
        p1, step, p_last = arithmetic(schedule)
    except ValueError as e:
        raise CliError(f"--engine {engine}: {e}") from None
    H, W = obstacle.shape
    board = {}

    def fits(info):
        if tuple(block) != (info["n"], info["m"]):
            raise CliError(f"--block {block[0]}x{block[1]}: the board's planner has {info['n']}x{info['m']} blocks "
                           f"(give --block {info['n']}x{info['m']})")
        rows, cols = info["br"] * info["n"], info["bc"] * info["m"]
        if H > rows or W > cols:
            raise CliError(f"the map is {H}x{W}; the board's planner holds {rows}x{cols} nodes "
                           f"({info['br']}x{info['bc']} blocks of {info['n']}x{info['m']})")
        if p_last > info["p_max"]:
            raise CliError(f"--schedule: precision {p_last} is beyond the board's p_max {info['p_max']}")
        board["shape"] = (rows, cols)

    async def job(link, info):
        grid = np.ones(board["shape"], dtype=bool)
        grid[:H, :W] = pad_to_blocks(obstacle, block)[:H, :W]
        goal = np.zeros(grid.shape, dtype=bool)
        for g in goals:
            goal[g] = True
        walled = grid | (~grid & ~reachable(grid, goal))
        status, h, const = await harmonic(link, walled, goal, (p1, step, p_last), iters)
        return grid, status, h, const

    grid, status, h, const = session(engine, "harmonic", job, fits)
    model = plan(grid, goals, block=block, iters=iters, schedule=tuple(schedule))
    diff = harmonic_differences(status, h, const, model)
    res = {k: int(status[k]) for k in ("p", "converged", "sweeps", "block_iterations", "check_iterations",
                                       "clear_passes", "cycles")}
    res.update(h=h[:H, :W], const=const[:H, :W], padded_h=h, grid=grid, unreachable=model.unreachable[:H, :W],
               node_updates=res["block_iterations"] * block[0] * block[1], levels=[],
               rtl_matches_model=not diff, differences=diff)
    return res
