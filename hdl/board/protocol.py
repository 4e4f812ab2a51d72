"""The board bridge's serial protocol, in one place: the RTL takes its
constants from here, the host (``--engine serial:PORT``) and the tests its
frames, its decoder and its client.  docs/protocol.md describes it byte by
byte with an example per core.

Framing: SLIP (RFC 1055).  A frame on the line is ``END``, the body and its
CRC with every ``END`` / ``ESC`` byte escaped, ``END``::

    END  body = [type, seq, payload ...]  crc_hi crc_lo  END      (0xC0 ... 0xC0)

An ``END`` always ends a frame, so a receiver resynchronizes at the next
``END`` after any garbage; the leading ``END`` flushes what noise left on
the line.  ``END END`` (an empty frame) is ignored.

CRC: CRC-16/CCITT-FALSE (polynomial 0x1021, initial 0xFFFF, no reflection,
no final XOR; ``crc16(b"123456789") == 0x29B1``) over the unescaped body,
appended most significant byte first, so the CRC over body and CRC is 0.

Requests (host -> board), ``type`` = the command:

=============  ======================  ======================================
command        payload                 reply
=============  ======================  ======================================
INFO    0x01   none                    ACK, payload the INFO text (ASCII
                                       ``key=value`` words: core, parameters,
                                       streams, FIFO depth, timeouts)
ECHO    0x02   0..``echo`` bytes       ACK, payload the same bytes
STATUS  0x03   none                    ACK, payload the core's status word
                                       (little-endian; may be empty)
RESET   0x04   none                    ACK; the core is reset, and so are the
                                       DATA sequence numbers
WRITE   0x10+k the beat for sink k     ACK once the core took the beat
               (exactly its bytes,
               little-endian)
=============  ======================  ======================================

Replies and data (board -> host):

* ACK ``0x80 | command``, ``seq`` = the request's;
* NAK ``0xFF``, ``seq`` = the request's (as received), payload ``[error,
  command as received]``;
* DATA ``0x40 + k``: one beat of the core's source stream k, ``seq`` counting
  that stream's DATA frames (mod 256, from 0 after RESET).

Every request frame gets exactly one ACK or NAK, in order; DATA frames come
in between whenever the core has a beat and the line is free (an ACK or NAK
goes first).  Errors (the NAK's first payload byte): :class:`Error`.

The host may send up to ``fifo`` bytes (INFO) of request frames before it has
their replies: the bridge's receive FIFO holds them.

The client (:class:`Link`) is written without I/O: its coroutines await
:class:`Send` and :class:`Receive` operations, which a runner performs on a
transport: :func:`run_blocking` on a serial port (sim/serial_engine.py),
``navcores.sim.rtl.board_driver`` on the simulated UART in cocotb.  So the
host and the tests run the very same protocol code.
"""

import enum
from collections import deque

__all__ = ["END", "ESC", "ESC_END", "ESC_ESC", "Cmd", "ACK", "NAK", "DATA", "WRITE", "Error", "MIN_BODY",
           "crc16", "crc16_update", "crc16_shift8", "frame", "request", "Decoder", "Frame", "info_text", "parse_info",
           "format_info",
           "BridgeError", "LinkTimeout", "ProtocolError", "Send", "Receive", "Link", "run_blocking",
           "beat_bytes", "PROTOCOL_VERSION"]

PROTOCOL_VERSION = 1

END, ESC, ESC_END, ESC_ESC = 0xC0, 0xDB, 0xDC, 0xDD
CRC_POLY, CRC_INIT = 0x1021, 0xFFFF


class Cmd(enum.IntEnum):
    INFO = 0x01
    ECHO = 0x02
    STATUS = 0x03
    RESET = 0x04


WRITE = 0x10            # WRITE + k: a beat for the core's sink stream k (k < MAX_STREAMS)
ACK = 0x80              # ACK | command
NAK = 0xFF
DATA = 0x40             # DATA + k: a beat of the core's source stream k
MAX_STREAMS = 16
MIN_BODY = 4            # type, seq, CRC (2): a shorter frame is truncated


class Error(enum.IntEnum):
    """The NAK's error code (its first payload byte)."""
    BAD_CRC = 1         # the CRC over body and CRC is not 0 (noise, garbage between frames)
    TRUNCATED = 2       # the frame stopped: a gap longer than the timeout inside it, or < 4 bytes
    UNKNOWN_CMD = 3     # no such command (or no such sink stream)
    BAD_LENGTH = 4      # the payload's length is not the command's (or longer than the buffer)
    CORE_TIMEOUT = 5    # core error: the core did not take the beat within the accept timeout
    LINE = 6            # UART framing error or receive overrun inside the frame: bytes were lost


def crc16_shift8(reg):
    """Eight steps of the CRC register with no input: linear over GF(2), so
    the RTL computes it as XORs (``crc16_shift8(1 << i)`` is column i)."""
    for _ in range(8):
        reg = ((reg << 1) ^ CRC_POLY if reg & 0x8000 else reg << 1) & 0xFFFF
    return reg


def crc16_update(crc, byte):
    """One byte into CRC-16/CCITT-FALSE (MSB first)."""
    return crc16_shift8(crc ^ (byte << 8))


def crc16(data, crc=CRC_INIT):
    for b in data:
        crc = crc16_update(crc, b)
    return crc


def beat_bytes(width):
    """Bytes of a beat of ``width`` bits on the line."""
    return (width + 7) // 8


def _escape(data):
    out = bytearray()
    for b in data:
        out += bytes((ESC, ESC_END)) if b == END else bytes((ESC, ESC_ESC)) if b == ESC else bytes((b,))
    return bytes(out)


def frame(kind, seq, payload=b"", damage=False):
    """The line bytes of one frame: END, escaped body + CRC, END
    (``damage``: one bit of the CRC flipped, for the refusal checks)."""
    body = bytes((kind & 0xFF, seq & 0xFF)) + bytes(payload)
    crc = crc16(body) ^ int(bool(damage))
    return bytes((END,)) + _escape(body + bytes((crc >> 8, crc & 0xFF))) + bytes((END,))


def request(cmd, seq, payload=b"", damage=False):
    """A request frame (host -> board)."""
    return frame(cmd, seq, payload, damage)


class Frame:
    """A received frame: ``kind`` (type byte), ``seq``, ``payload`` (bytes);
    ``error`` is None for a good frame, else why it was dropped."""

    __slots__ = ("kind", "seq", "payload", "error")

    def __init__(self, kind, seq, payload, error=None):
        self.kind, self.seq, self.payload, self.error = kind, seq, payload, error

    def __repr__(self):
        what = f" error={self.error}" if self.error else ""
        return f"Frame(0x{self.kind:02x}, seq={self.seq}, {self.payload.hex() or '-'}{what})"


class Decoder:
    """SLIP + CRC decoder: ``feed(bytes)`` returns the frames completed by
    them (bad ones with ``error`` set: "crc" or "short")."""

    def __init__(self):
        self.body, self.esc = bytearray(), False

    def feed(self, data):
        out = []
        for b in data:
            if b == END:
                if self.body:
                    out.append(self._finish(bytes(self.body)))
                self.body, self.esc = bytearray(), False
            elif b == ESC:
                self.esc = True
            else:
                if self.esc:
                    b = {ESC_END: END, ESC_ESC: ESC}.get(b, b)
                    self.esc = False
                self.body.append(b)
        return out

    @staticmethod
    def _finish(body):
        if len(body) < MIN_BODY:
            return Frame(body[0], body[1] if len(body) > 1 else 0, b"", "short")
        if crc16(body):
            return Frame(body[0], body[1], body[2:-2], "crc")
        return Frame(body[0], body[1], body[2:-2])


# --- INFO --------------------------------------------------------------------------

def info_text(core, params, sinks, sources, status, fifo, echo, gap_bits, accept_bits, divisor, clock_hz=0):
    """The INFO reply's text: ``navcores/<version> core=<name> k=v ...``.

    ``params``: the core's parameters; ``sinks`` / ``sources``: the streams'
    payload widths in bits; ``status``: the status word's width; ``fifo``:
    the receive FIFO's bytes (the host's window); ``echo``: the largest ECHO
    payload; ``gap_bits`` / ``accept_bits``: the truncation and accept
    timeouts in bit times; ``divisor``: clocks per bit; ``clock_hz``: the
    board's clock (0: not known, a simulation)."""
    words = [f"navcores/{PROTOCOL_VERSION}", f"core={core}"]
    words += [f"{k}={v}" for k, v in params.items()]
    words += [f"sinks={','.join(map(str, sinks))}", f"sources={','.join(map(str, sources))}",
              f"status={status}", f"fifo={fifo}", f"echo={echo}", f"gap={gap_bits}", f"accept={accept_bits}",
              f"div={divisor}"]
    if clock_hz:
        words += [f"clk={clock_hz}", f"baud={round(clock_hz / divisor)}"]
    text = " ".join(words)
    if any(c in text for c in "\r\n") or not text.isascii():
        raise ValueError(f"INFO text must be one ASCII line: {text!r}")
    return text.encode()


TEXT_KEYS = ("core", "fll", "sha", "divider")      # INFO values that stay text (a digest may be all digits)


def parse_info(payload):
    """INFO payload -> dict (``version``, ``core`` and every key, numbers as
    int but :data:`TEXT_KEYS`, stream widths as tuples); ProtocolError if it
    is not navcores'."""
    try:
        words = payload.decode("ascii").split()
    except UnicodeDecodeError:
        raise ProtocolError(f"INFO is not ASCII: {payload[:40]!r}") from None
    if not words or not words[0].startswith("navcores/"):
        raise ProtocolError(f"not a navcores bridge (INFO {payload[:40]!r})")
    out = {"version": int(words[0].split("/", 1)[1])}
    for w in words[1:]:
        key, _, value = w.partition("=")
        if key in ("sinks", "sources"):
            out[key] = tuple(int(v) for v in value.split(",") if v)
        elif key in TEXT_KEYS:
            out[key] = value
        else:
            try:
                out[key] = int(value)
            except ValueError:
                out[key] = value
    return out


def format_info(info, skip=("version",)):
    """A parsed INFO dict as ``key=value`` words again (stream widths comma-separated)."""
    return " ".join(f"{k}={','.join(map(str, v)) if isinstance(v, tuple) else v}" for k, v in info.items()
                    if k not in skip)


# --- the client ----------------------------------------------------------------------

class ProtocolError(Exception):
    """The board said something the protocol does not allow."""


class LinkTimeout(ProtocolError):
    """Nothing came from the board for the transport's timeout."""


class BridgeError(ProtocolError):
    """A NAK: the bridge refused a request (``code``: :class:`Error`)."""

    def __init__(self, code, cmd, seq):
        self.code, self.cmd, self.seq = code, cmd, seq
        name = Error(code).name if code in Error._value2member_map_ else f"error {code}"
        super().__init__(f"the board refused request 0x{cmd:02x} (seq {seq}): {name}")


class _Op:
    def __await__(self):
        return (yield self)


class Send(_Op):
    """I/O operation: write ``data`` to the line."""

    def __init__(self, data):
        self.data = bytes(data)


class Receive(_Op):
    """I/O operation: the bytes that came (at least one, waiting up to the
    transport's inactivity timeout; ``b""`` when none came)."""


class Link:
    """The host end of the protocol, without I/O (see the module's doc).

    ``window``: request bytes in flight at most (the bridge's FIFO, from
    INFO; until INFO is read, one request at a time).  DATA frames are kept
    per stream (:meth:`read`); ``bad_frames`` counts frames from the board
    that failed their CRC; ``log`` (a list, or None) records every frame
    sent and received.
    """

    def __init__(self, window=None, log=None):
        self.decoder = Decoder()
        self.window = window
        self.seq = 0
        self.pending = deque()              # (seq, cmd, bytes on the line) in flight, in order
        self.replies = {}                   # seq -> Frame (ACK or NAK) not yet claimed
        self.data = {}                      # stream -> deque of (seq, payload)
        self.data_seq = {}                  # stream -> next expected DATA seq (after RESET)
        self.bad_frames = 0
        self.log = log
        self.info = None

    # -- frames

    def _take(self, frames):
        for f in frames:
            if self.log is not None:
                self.log.append(("in", f))
            if f.error:
                self.bad_frames += 1
            elif DATA <= f.kind < DATA + MAX_STREAMS:
                k = f.kind - DATA
                want = self.data_seq.get(k)
                if want is not None and f.seq != want:
                    raise ProtocolError(f"DATA of stream {k}: frame {f.seq} came, {want} was due "
                                        "(a frame was lost on the line)")
                self.data_seq[k] = (f.seq + 1) & 0xFF
                self.data.setdefault(k, deque()).append(f.payload)
            elif f.kind == NAK or f.kind & ACK:
                if self.pending and self.pending[0][0] == f.seq:
                    self.pending.popleft()
                    self.replies[f.seq] = f
                elif f.kind == NAK:
                    # a NAK of no request of ours: garbage on the line (or a
                    # frame it cut in two) that the bridge refused.
                    self.replies.setdefault(("stray", f.seq), f)
                else:
                    raise ProtocolError(f"unexpected reply {f!r} (waiting for "
                                        f"{[s for s, _, _ in self.pending]})")
            else:
                raise ProtocolError(f"unknown frame type {f!r}")

    async def _pump(self):
        data = await Receive()
        if not data:
            raise LinkTimeout("no reply from the board (line silent for the transport's timeout)")
        self._take(self.decoder.feed(data))

    def _in_flight(self):
        return sum(n for _, _, n in self.pending)

    async def send(self, cmd, payload=b"", damage=False):
        """Send one request as soon as the window allows; returns its seq
        (``damage``: with a wrong CRC, which the bridge must refuse)."""
        seq = self.seq
        self.seq = (self.seq + 1) & 0xFF
        line = request(cmd, seq, payload, damage)
        limit = self.window or 0
        while self.pending and self._in_flight() + len(line) > limit:
            await self._pump()
        self.pending.append((seq, cmd, len(line)))
        if self.log is not None:
            self.log.append(("out", Frame(cmd, seq, bytes(payload))))
        await Send(line)
        return seq

    async def reply(self, seq):
        """The ACK of request ``seq`` (its Frame); BridgeError on a NAK."""
        while seq not in self.replies:
            await self._pump()
        f = self.replies.pop(seq)
        if f.kind == NAK:
            code, cmd = (f.payload + b"\0\0")[:2]
            raise BridgeError(code, cmd, seq)
        return f

    async def call(self, cmd, payload=b""):
        """One request, its ACK's payload."""
        return (await self.reply(await self.send(cmd, payload))).payload

    def stray(self):
        """NAKs of frames the host did not send (garbage), taken out."""
        keys = [k for k in self.replies if isinstance(k, tuple)]
        return [self.replies.pop(k) for k in keys]

    # -- commands

    async def read_info(self):
        info = parse_info(await self.call(Cmd.INFO))
        if info["version"] != PROTOCOL_VERSION:
            raise ProtocolError(f"the board speaks protocol {info['version']}, this host {PROTOCOL_VERSION}")
        self.info, self.window = info, info["fifo"]
        return info

    async def reset(self):
        """Reset the core; DATA frames before the ACK are stale and dropped."""
        await self.call(Cmd.RESET)
        self.data.clear()
        self.data_seq = {k: 0 for k in range(len(self.info["sources"]))} if self.info else {}

    async def status(self):
        return int.from_bytes(await self.call(Cmd.STATUS), "little")

    async def echo(self, data):
        return await self.call(Cmd.ECHO, data)

    def beat(self, k, value):
        """The payload of a WRITE to sink k (INFO's widths)."""
        return int(value).to_bytes(beat_bytes(self.info["sinks"][k]), "little")

    async def write(self, k, value, wait=True):
        """A beat into sink stream k; ``wait``: until its ACK (else returns the seq)."""
        seq = await self.send(WRITE + k, self.beat(k, value))
        if wait:
            await self.reply(seq)
        return seq

    async def read(self, k):
        """The next beat of source stream k (an int)."""
        while not self.data.get(k):
            await self._pump()
        return int.from_bytes(self.data[k].popleft(), "little")


def run_blocking(job, transport):
    """Run the coroutine ``job`` (awaiting :class:`Send` / :class:`Receive`)
    on ``transport``: ``write(bytes)`` and ``read() -> bytes`` (b"" after its
    inactivity timeout).  Returns the job's result."""
    value = None
    while True:
        try:
            op = job.send(value)
        except StopIteration as done:
            return done.value
        if isinstance(op, Send):
            transport.write(op.data)
            value = None
        elif isinstance(op, Receive):
            value = transport.read()
        else:
            raise TypeError(f"a job awaited {op!r}: only Send and Receive are performed")
