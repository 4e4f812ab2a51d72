"""Check the link to a board (the bring-up test, docs/boards.md): INFO, loopback, refusals.

    python -m sim board serial:PORT[@BAUD] [--json OUT]

Talks to a board running any of the project's bitstreams (make bitstream)
over its USB serial port, through the bridge's protocol
(docs/protocol.md): prints the board's INFO (core, parameters, streams,
clock, baud), then one line per check: ECHO of every byte value (the
escaped ones included) through the bridge and back, STATUS, RESET of the
core, and the bridge's refusals of a damaged frame (NAK BAD_CRC), an
unknown command and a sink the core does not have (NAK UNKNOWN_CMD), and a
wrong length (NAK BAD_LENGTH).  --json writes the INFO and the checks.

Exit status: 0 every check passed; 1 the board answered, but not as the
protocol says; 2 bad input (one line on stderr: no such port, a port that
cannot be opened, no answer, not a navcores bridge).
"""

import json

from navcores.hdl.board.protocol import format_info

from . import serial_engine
from .cli import CliError, add_outputs, write_text


def add_arguments(p):
    p.add_argument("engine", metavar="serial:PORT[@BAUD]",
                   help="the board's serial port, e.g. serial:/dev/ttyUSB0 (115200 Bd) or serial:/dev/ttyUSB1@1000000")
    add_outputs(p, plot=False)


def run(args):
    if not serial_engine.is_serial(args.engine):
        raise CliError(f"{args.engine!r}: give the board's port as serial:PORT[@BAUD]")
    info, checks = serial_engine.loopback(args.engine)
    print(f"{args.engine}: {info['core']} board, {format_info(info, skip=('version', 'core'))}")
    for what, ok, came in checks[1:]:
        print(f"  {'ok  ' if ok else 'FAIL'} {what}: {came}")
    passed = all(ok for _, ok, _ in checks)
    print(f"{sum(ok for _, ok, _ in checks)} of {len(checks)} checks passed" + ("" if passed else ": the board "
                                                                               "does not answer as the protocol says"))
    if args.json:
        write_text(args.json, json.dumps({"engine": args.engine, "info": info,
                                          "checks": [{"check": w, "passed": ok, "got": c} for w, ok, c in checks]}))
    return 0 if passed else 1
