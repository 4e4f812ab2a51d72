"""docs/protocol.md's byte-level examples are what the protocol module and
the models give (no simulator).

* Every frame written out whole in the examples (``host`` / ``board``
  lines, wrapped lines included; a frame with ``...`` in it is left out)
  decodes: SLIP, a good CRC, unless its comment says "damaged", whose CRC
  must be wrong.
* Each core's example frames are built here from the board's
  configuration (hdl/board/board_top.py CONFIGS), the cores' layouts and
  the golden models, and must appear in the document byte for byte: the
  DFLC's sample and its result from models.dflc, the planner's commands and
  a STATUS response, the EDT/BFS command, image columns, its last result
  beat and status word from models.edt_bfs.
"""

import re
from pathlib import Path

import numpy as np
import pytest

from navcores.hdl.board import protocol as P
from navcores.hdl.board.board_top import CONFIGS
from navcores.hdl.board.cores import edt_status_layout
from navcores.hdl.dflc.core import result_layout as dflc_result, sample_layout
from navcores.hdl.dflc.top import config_for
from navcores.hdl.edt_bfs.cell import cell_widths
from navcores.hdl.edt_bfs.edt_bfs import command_layout, image_layout, result_layout
from navcores.hdl.harmonic import planner
from navcores.models.dflc import Dflc
from navcores.models.edt_bfs import plan_path
from navcores.sim.rtl.stream import pack

DOC = Path(__file__).resolve().parents[2] / "docs" / "protocol.md"
HEX = re.compile(r"^[0-9A-F]{2}$")

# The EDT/BFS example's 8x8 map (# obstacle, G goal), start (0, 0), dfar 1.
EDT_MAP = ["........", "........", "..##....", "..##....", "........", "......#.", "........", ".......G"]


def doc_frames():
    """[(the frame's bytes, its comment)] of every whole frame in the examples."""
    frames, cur, note = [], None, ""
    for line in DOC.read_text().splitlines():
        words = line.split()
        if words and words[0] in ("host", "board"):
            cur, note, words = [], "", words[1:]
        elif cur is None or not words or not HEX.match(words[0]):
            cur = None
            continue
        k = 0
        while k < len(words) and (HEX.match(words[k]) or words[k] == "..."):
            k += 1
        cur += words[:k]
        note += " " + " ".join(words[k:])
        if cur.count("C0") >= 2:
            if "..." not in cur:
                frames.append((bytes.fromhex("".join(cur)), note.strip()))
            cur = None
    return frames


def doc_hex():
    """The examples' bytes as one spaced hex string (wrapped frames joined)."""
    return " ".join(" ".join(f"{b:02X}" for b in f) for f, _ in doc_frames())


def spaced(data):
    return " ".join(f"{b:02X}" for b in data)


def test_whole_frames_decode():
    frames = doc_frames()
    assert len(frames) >= 15, f"only {len(frames)} whole frames found in {DOC.name}"
    for data, note in frames:
        got = P.Decoder().feed(data)
        assert len(got) == 1, (spaced(data), note)
        want = "crc" if "damaged" in note else None
        assert got[0].error == want, (spaced(data), note, got[0])


def any_core():
    return [P.request(P.Cmd.INFO, 0), P.request(P.Cmd.RESET, 2), P.frame(P.ACK | P.Cmd.RESET, 2),
            P.request(P.Cmd.ECHO, 1, b"\xc0\x01\xdb"), P.frame(P.ACK | P.Cmd.ECHO, 1, b"\xc0\x01\xdb"),
            P.frame(P.NAK, 3, bytes((P.Error.BAD_CRC, P.Cmd.STATUS)))]


def dflc():
    params = CONFIGS["ulx3s-85f", "dflc"]
    assert params == CONFIGS["icebreaker", "dflc"]
    model, config = Dflc.from_fll(), config_for(**params)
    codes = model.encode([30, -45])[0]
    (y,), (zero,) = model.infer(codes[None, :])
    beat = pack(sample_layout(config), [int(c) for c in codes])
    result = pack(dflc_result(config), {"y": int(y), "zero": int(zero)})
    return [P.request(P.WRITE, 4, beat.to_bytes(P.beat_bytes(sample_layout(config).size), "little")),
            P.frame(P.ACK | P.WRITE, 4),
            P.frame(P.DATA, 0, result.to_bytes(P.beat_bytes(dflc_result(config).size), "little"))]


def harmonic():
    c = CONFIGS["ulx3s-85f", "harmonic"]
    cmd = planner.command_layout((c["br"], c["bc"]), c["n"], c["m"], c["p_max"])
    resp = planner.response_layout(c["p_max"])
    # a STATUS response after a run of room-32-32-4.map (models.harmonic.plan; docs/protocol.md)
    status = {"code": planner.Code.OK, "op": planner.Op.STATUS, "converged": 1, "p": 96, "sweeps": 67,
              "block_iterations": 4475, "check_iterations": 108, "clear_passes": 0, "cycles": 356440}

    def write(seq, fields):
        return P.request(P.WRITE, seq, pack(cmd, fields).to_bytes(P.beat_bytes(cmd.size), "little"))
    return [write(5, {"op": planner.Op.STATUS}), P.frame(P.ACK | P.WRITE, 5),
            P.frame(P.DATA, 0, pack(resp, status).to_bytes(P.beat_bytes(resp.size), "little")),
            write(6, {"op": planner.Op.READ, "block": 4, "row": 2, "col": 7})]


def edt():
    c = CONFIGS["ulx3s-85f", "edt_bfs"]
    h, w = c["height"], c["width"]
    assert (len(EDT_MAP), len(EDT_MAP[0])) == (h, w)
    ob = np.array([[ch == "#" for ch in row] for row in EDT_MAP])
    goal = np.array([[ch == "G" for ch in row] for row in EDT_MAP])
    model = plan_path(ob, [tuple(g) for g in np.argwhere(goal)], (0, 0), 1)
    assert model.path_found and len(model.path) == 12
    wd = cell_widths(h, w)

    def beat(layout, fields):
        return pack(layout, fields).to_bytes(P.beat_bytes(layout.size), "little")

    def col(mask, j):
        return sum(int(mask[r, j]) << r for r in range(h))

    frames = [P.request(P.WRITE, 7, beat(command_layout(wd), {"dfar": 1, "start_row": 0, "start_col": 0,
                                                               "path": 1})),
              P.frame(P.ACK | P.WRITE, 7)]
    frames += [P.request(P.WRITE + 1, 8 + k, beat(image_layout(h), {"obst": col(ob, j), "goal": col(goal, j)}))
               for k, j in enumerate(reversed(range(w)))]
    r, cc = h - 1, w - 1
    last = {"cell": 1, "row": r, "col": cc, "done": 1, "di": int(model.distance[r, cc]),
            "dx": int(model.vector[r, cc, 0]), "dy": int(model.vector[r, cc, 1]), "cfr": int(model.cfr[r, cc]),
            "visited": int(model.visited[r, cc]), "parent": int(model.parent[r, cc]), "last": 1}
    n = len(model.path) + h * w
    frames.append(P.frame(P.DATA, (n - 1) & 0xFF, beat(result_layout(wd), last)))
    st = {"busy": 0, "path_found": int(model.path_found), "start_err": 0, "iterations_edt": model.iterations_edt,
          "iterations_bfs": model.iterations_bfs, "cycles": model.cycles}
    frames += [P.request(P.Cmd.STATUS, 16), P.frame(P.ACK | P.Cmd.STATUS, 16, beat(edt_status_layout(h, w), st))]
    return frames


@pytest.mark.parametrize("example", [any_core, dflc, harmonic, edt], ids=lambda f: f.__name__)
def test_core_examples(example):
    text = doc_hex()
    for f in example():
        assert spaced(f) in text, f"{example.__name__}: {spaced(f)} is not in {DOC.name}"


if __name__ == "__main__":          # print the examples' frames (to write the document)
    for ex in (any_core, dflc, harmonic, edt):
        print(ex.__name__)
        for f in ex():
            print("  ", spaced(f))
