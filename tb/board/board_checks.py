"""The protocol checks every board top passes in simulation (tb/board/test_board_*.py).

:func:`protocol_suite` runs, on the simulated UART of a started board top,
through the same protocol module as the host (navcores.hdl.board.protocol):
INFO, ECHO (every byte value, the escaped ones included, up to the buffer,
and one byte too many), then one bad frame of each kind, each followed by a
good frame that must work: a bad CRC, a truncated frame (the line goes
silent inside it), a frame too short, garbage between two frames, an unknown
command, a WRITE to a sink that does not exist, a wrong length, a byte with
a framing error; then requests sent back to back, whose replies must come
in order.  Each bad frame must get its defined NAK (error code, seq and
command as sent).
"""

import random

from navcores.hdl.board import protocol as P
from navcores.sim.rtl.board_driver import perform


class Wire:
    """Raw frames on the line and the frames that come back (no Link)."""

    def __init__(self, line):
        self.line, self.decoder, self.frames = line, P.Decoder(), []
        self.checked = 0

    async def send(self, data, **kw):
        await self.line.write(data, **kw)

    async def expect(self, n, timeout_bits=None):
        """The next ``n`` frames from the board (DATA frames included)."""
        while len(self.frames) < n:
            data = await self.line.read(timeout_bits)
            assert data, f"{len(self.frames)} of {n} frames came before the line went silent"
            self.frames += self.decoder.feed(data)
        out, self.frames = self.frames[:n], self.frames[n:]
        self.checked += n
        assert all(f.error is None for f in out), f"a bad frame from the board: {out}"
        return out


def assert_nak(f, error, seq, cmd):
    assert f.kind == P.NAK and f.seq == seq and f.payload == bytes((error, cmd)), \
        f"expected NAK {P.Error(error).name} of seq {seq} cmd 0x{cmd:02x}, got {f!r}"


def assert_ack(f, cmd, seq, payload=None):
    assert f.kind == P.ACK | cmd and f.seq == seq, f"expected ACK of 0x{cmd:02x} seq {seq}, got {f!r}"
    if payload is not None:
        assert f.payload == payload, f"ACK payload {f.payload!r}, expected {payload!r}"


async def good(w, seq=0x21):
    """A good request (ECHO) right after a bad one: it must work."""
    await w.send(P.request(P.Cmd.ECHO, seq, b"ok"))
    (f,) = await w.expect(1)
    assert_ack(f, P.Cmd.ECHO, seq, b"ok")


async def protocol_suite(line, info, rng, full=True):
    """The checks above on a board top whose INFO is ``info`` (its core
    idle, no DATA pending); returns how many frames it checked.  Without
    ``full`` (the cores' tops beyond the first: the same bridge) it leaves
    out the ECHO of every byte value, the too-long ECHO, the short frame and
    the framing error."""
    w = Wire(line)
    # INFO, ECHO: every byte value through the escaping, both ways.
    await w.send(P.request(P.Cmd.INFO, 1))
    (f,) = await w.expect(1)
    assert_ack(f, P.Cmd.INFO, 1)
    assert P.parse_info(f.payload) == info, (P.parse_info(f.payload), info)
    echo = info["echo"]
    values = bytes(range(256)) if full else b""
    for k, i in enumerate(range(0, len(values), echo)):
        chunk = values[i:i + echo]
        await w.send(P.request(P.Cmd.ECHO, 2 + k, chunk))
        (f,) = await w.expect(1)
        assert_ack(f, P.Cmd.ECHO, 2 + k, chunk)
    if full:
        await w.send(P.request(P.Cmd.ECHO, 0x30, bytes(echo + 1)))
        assert_nak((await w.expect(1))[0], P.Error.BAD_LENGTH, 0x30, P.Cmd.ECHO)

    # A bad CRC (the last CRC byte flipped; not into END / ESC).
    bad = bytearray(P.request(P.Cmd.STATUS, 0x31))
    bad[-2] ^= 0x01 if bad[-2] not in (0xC1, 0xDA) else 0x04
    await w.send(bad)
    assert_nak((await w.expect(1))[0], P.Error.BAD_CRC, 0x31, P.Cmd.STATUS)
    await good(w)

    # Truncated: half a frame, then silence beyond the gap timeout.
    frame = P.request(P.Cmd.ECHO, 0x32, b"truncated")
    await w.send(frame[:len(frame) // 2])
    await line.idle(info["gap"] + 20)
    assert_nak((await w.expect(1))[0], P.Error.TRUNCATED, 0x32, P.Cmd.ECHO)
    await good(w)
    if full:    # too short: two bytes between ENDs
        await w.send(bytes((P.END, P.Cmd.INFO, 0x33, P.END)))
        assert_nak((await w.expect(1))[0], P.Error.TRUNCATED, 0x33, P.Cmd.INFO)
        await good(w)

    # Garbage between frames: it ends at the next frame's END and is refused
    # (its "seq" and "command" are its own first bytes); the frame works.
    garbage = bytes(rng.choice([b for b in range(256) if b not in (P.END, P.ESC)]) for _ in range(11))
    await w.send(P.request(P.Cmd.ECHO, 0x34, b"a") + garbage + P.request(P.Cmd.ECHO, 0x35, b"b"))
    f1, f2, f3 = await w.expect(3)
    assert_ack(f1, P.Cmd.ECHO, 0x34, b"a")
    assert_nak(f2, P.Error.BAD_CRC, garbage[1], garbage[0])
    assert_ack(f3, P.Cmd.ECHO, 0x35, b"b")

    # Unknown commands: no such command, no such sink.
    for seq, cmd in ((0x36, 0x0F), (0x37, P.WRITE + len(info["sinks"])), (0x38, 0x80)):
        await w.send(P.request(cmd, seq, b"\0"))
        assert_nak((await w.expect(1))[0], P.Error.UNKNOWN_CMD, seq, cmd)
    await good(w)

    # Wrong lengths: a beat one byte short, INFO with a payload.
    width = P.beat_bytes(info["sinks"][0])
    await w.send(P.request(P.WRITE, 0x39, bytes(width - 1)))
    assert_nak((await w.expect(1))[0], P.Error.BAD_LENGTH, 0x39, P.WRITE)
    await w.send(P.request(P.Cmd.INFO, 0x3A, b"x"))
    assert_nak((await w.expect(1))[0], P.Error.BAD_LENGTH, 0x3A, P.Cmd.INFO)
    await good(w)

    if full:    # a framing error inside a frame: bytes were lost, the frame is refused
        frame = P.request(P.Cmd.ECHO, 0x3B, b"line")
        await w.send(frame[:4])
        await w.send(frame[4:5], bad_stop=True)
        await line.idle(2)                  # the receiver waits for the line to go high
        await w.send(frame[5:])
        assert_nak((await w.expect(1))[0], P.Error.LINE, 0x3B, P.Cmd.ECHO)
        await good(w)

    # Back to back: five requests in one burst; five replies in order.
    burst = [(P.Cmd.ECHO, 0x40, b"\xc0\xdb"), (P.Cmd.STATUS, 0x41, b""), (P.Cmd.INFO, 0x42, b""),
             (0x0E, 0x43, b""), (P.Cmd.ECHO, 0x44, b"end")]
    await w.send(b"".join(P.request(c, s, p) for c, s, p in burst))
    replies = await w.expect(len(burst))
    assert_ack(replies[0], P.Cmd.ECHO, 0x40, b"\xc0\xdb")
    assert_ack(replies[1], P.Cmd.STATUS, 0x41)
    assert len(replies[1].payload) == P.beat_bytes(info["status"])
    assert_ack(replies[2], P.Cmd.INFO, 0x42)
    assert_nak(replies[3], P.Error.UNKNOWN_CMD, 0x43, 0x0E)
    assert_ack(replies[4], P.Cmd.ECHO, 0x44, b"end")
    assert not w.frames and line.framing_errors == 0
    return w.checked


async def open_board(dut, params, timeout_bits):
    """Start the board top, put a UART line on it at ``params["divisor"]``
    clocks a bit, open a Link, read INFO and reset the core
    (board_jobs.open_core): (line, link, info)."""
    from navcores.sim.rtl.board_driver import UartLine, start
    from navcores.sim.rtl.board_jobs import open_core
    await start(dut)
    line = UartLine(dut, params["divisor"], timeout_bits=timeout_bits)
    link = P.Link()
    info = await perform(open_core(link, params["core"]), line)
    return line, link, info


def rng_from_env():
    from navcores.sim.rtl.runner import seed_from_env
    seed = seed_from_env()
    print(f"board checks: seed {seed} (replay with SEED={seed})")
    return random.Random(seed)


async def host_command(dut, line, argv, timeout_s=300, option="--engine"):
    """``python -m sim ARGV --engine serial:<pty>`` (``option`` None: the
    port as the last positional argument) against the simulated
    board top: the command opens a pseudo-terminal as its serial port (with
    pyserial, as on a board), and this coroutine carries its bytes to and
    from the UART line.  Returns (exit status, stdout, stderr)."""
    import os
    import subprocess
    import time
    import tty

    import cocotb
    from cocotb.triggers import ClockCycles

    master, slave = os.openpty()
    tty.setraw(slave)
    port = os.ttyname(slave)
    os.set_blocking(master, False)
    # the command as a user runs it: from the tree's root, without the
    # simulator's PYTHONPATH (whose test folders hold a module named serial)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    with open(os.devnull, "rb") as null:
        proc = subprocess.Popen([os.environ["HOST_PYTHON"], "-m", "sim", *argv, *([option] if option else []),
                                 f"serial:{port}"],
                                cwd=os.environ["HOST_ROOT"], env=env, stdin=null, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
    running = True

    async def to_host():
        while running:
            data = await line.read(timeout_bits=50)
            if data:
                os.write(master, data)

    task = cocotb.start_soon(to_host())
    t0 = time.monotonic()
    try:
        while proc.poll() is None:
            try:
                data = os.read(master, 4096)
            except (BlockingIOError, OSError):
                data = b""
            if data:
                await line.write(data)
            else:
                await ClockCycles(dut.clk, 10 * line.div)
            if time.monotonic() - t0 > timeout_s:
                proc.kill()
                raise AssertionError(f"python -m sim {' '.join(argv)} did not end in {timeout_s} s")
    finally:
        running = False
        await task
        os.close(master)
        os.close(slave)
    out, err = proc.communicate()
    return proc.returncode, out, err


async def host_matches_model(dut, line, argv, work, unrecorded=()):
    """``python -m sim ARGV`` on the board (``host_command``) and on the model:
    the same JSON but for ``engine``, ``rtl_matches_model`` (true),
    ``model_differences`` (empty) and the ``unrecorded`` keys (what the
    hardware does not record, empty on the board as on the simulator
    engines); returns the board's JSON."""
    import json
    import os
    import subprocess

    rc, out, err = await host_command(dut, line, [*argv, "--json", str(work / "serial.json")])
    assert rc == 0 and not err, (rc, out, err)
    board = json.loads((work / "serial.json").read_text())
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    model = subprocess.run([os.environ["HOST_PYTHON"], "-m", "sim", *argv, "--json", str(work / "model.json")],
                           cwd=os.environ["HOST_ROOT"], env=env, capture_output=True, text=True)
    assert model.returncode == 0, model.stderr
    model = json.loads((work / "model.json").read_text())
    assert board.pop("rtl_matches_model") is True and not board.pop("model_differences", [])
    assert board.pop("engine").startswith("serial:") and model.pop("engine") == "model"
    for k in unrecorded:
        assert not board.pop(k) and model.pop(k), k
    assert board == model, [k for k in model if board.get(k) != model[k]]
    return board


def host_env(tmp_path):
    """What the host tests need from pytest: the interpreter, the tree, a folder."""
    import sys

    from navcores.sim.rtl.runner import ROOT
    return {"HOST_PYTHON": sys.executable, "HOST_ROOT": ROOT, "HOST_WORK": tmp_path}


HOST_TESTS = ("host_engine",)


def run_board(core, params, sim, tmp_path, tests):
    """Build the board top ``board_<core>`` (SerialTop at ``params``) for
    ``sim`` and run its cocotb ``tests`` (tb/board/test_board_<core>.py);
    on Icarus all but :data:`HOST_TESTS`: the host engine is the same
    Python over the same bridge the other tests drive on both simulators,
    and its jobs (a pseudo-terminal, the ``python -m sim`` subprocesses)
    run once, on Verilator, which simulates them several times faster.
    Asserts that exactly those tests ran."""
    from navcores.hdl.board.serial_top import SerialTop
    from navcores.sim.rtl.runner import run

    want = [t for t in tests if sim == "verilator" or t not in HOST_TESTS]
    env = {**host_env(tmp_path), "COCOTB_TEST_FILTER": rf"\.({'|'.join(want)})$"}
    assert run(f"board_{core}", params, sim, f"test_board_{core}", factory=SerialTop, env=env) == len(want)
