"""A fit JSON is read only for the Verilog it was placed from.

scripts/fit.py records ``verilog_sha256``, the SHA-256 of the top's emitted
Verilog; scripts/bench_edt_tiled.py's ``fit_result`` reads a JSON only when
that hash is the one of the top's Verilog emitted now, and otherwise returns
None with one line on stderr naming the command that places it again (a
JSON without the hash, written before it was recorded, is stale too).

The tools are stand-ins (Python) that write the files the flow reads; the
tops are small (an engine of 2x2 cells for a 16x16 map): the Verilog and
its hash are real, no yosys or nextpnr runs here, and nothing is written
under the checkout's build/ (the flow's root is the test's folder).
"""

import hashlib
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))

import bench_edt_tiled  # noqa: E402
import fit  # noqa: E402
import fmax  # noqa: E402
import tile_engine_size  # noqa: E402
import toolchain  # noqa: E402

# yosys writes the core's cell counts and a netlist, nextpnr a timing report: what the flow parses
STAND_IN = r"""
import json, sys
tool, args = sys.argv[1], sys.argv[2:]
if tool == "yosys":
    module = args[args.index("-p") + 1].split("keep_hierarchy 1 ")[1].split(";")[0]
    json.dump({"modules": {"\\" + module: {"num_cells_by_type": {"SB_LUT4": 10, "SB_DFF": 5}}}},
              open("stat.json", "w"))
    open("netlist.json", "w").write("{}")
else:
    json.dump({"fmax": {"clk": {"achieved": 50.0}}, "critical_paths": []}, open("report.json", "w"))
    open("nextpnr.log", "w").write("")
"""

PART = "iCE40-UP5K"         # no block-RAM register packing: the stand-in netlist is empty
ARRAY, RAM = (2, 2), (16, 16)
MODULE = "edt_tile_engine_max_h16_max_w16_t_c2_t_r2"
COMMAND = f"python scripts/fit.py edt_tile_engine max_h=16 max_w=16 t_c=2 t_r=2 --part {PART} --seeds 1"


@pytest.fixture
def flow(tmp_path, monkeypatch):
    """The fit flow and the bench rooted in ``tmp_path``, with stand-in tools."""
    for module in (fmax, bench_edt_tiled, tile_engine_size):
        monkeypatch.setattr(module, "ROOT", tmp_path)
    monkeypatch.setattr(toolchain, "RESULTS", tmp_path / "cache")
    monkeypatch.setattr(toolchain, "prepare", lambda tool, progress=None: f"{tool} stand-in")
    monkeypatch.setattr(toolchain, "argv", lambda tool, args=(): [sys.executable, "-c", STAND_IN, tool, *args])
    monkeypatch.setattr(bench_edt_tiled, "_WARNED", set())
    bench_edt_tiled.verilog_sha256.cache_clear()
    yield tmp_path
    bench_edt_tiled.verilog_sha256.cache_clear()


def sha256_of_emitted(tmp_path, top, params):
    """The hash of the top's Verilog, emitted apart from the flow's folder."""
    if top == "edt_tile_cell":
        path = tile_engine_size.cell_verilog(params, fmax.part(PART))
    else:
        path = fmax.emit(top, params, tmp_path / "apart", with_manifest=False)
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_fit_records_the_hash_and_bench_reads_only_a_matching_json(flow, capsys):
    assert fit.main(["edt_tile_engine", "t_r=2", "t_c=2", "max_h=16", "max_w=16", "--part", PART,
                     "--seeds", "1"]) == 0
    path = flow / "build" / "fit" / f"{MODULE}--{PART}.json"
    written = json.loads(path.read_text())
    assert written["fmax_mhz"] == 50.0 and written["generator"] == COMMAND
    want = sha256_of_emitted(flow, "edt_tile_engine", {"t_r": 2, "t_c": 2, "max_h": 16, "max_w": 16})
    assert written["verilog_sha256"] == want
    capsys.readouterr()

    # the Verilog now is the one placed: read, nothing said
    assert bench_edt_tiled.fit_result(ARRAY, RAM, part=PART) == written
    assert capsys.readouterr().err == ""

    # another Verilog's hash: refused, one line naming the JSON and the command placing it again
    path.write_text(json.dumps({**written, "verilog_sha256": "0" * 64}))
    assert bench_edt_tiled.fit_result(ARRAY, RAM, part=PART) is None
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"bench_edt_tiled: stale fit build/fit/{MODULE}--{PART}.json ")
    assert "not that of edt_tile_engine's Verilog now" in err[0] and err[0].endswith(f"re-run `{COMMAND}`")
    assert bench_edt_tiled.fit_result(ARRAY, RAM, part=PART) is None      # said once a run
    assert capsys.readouterr().err == ""

    # no hash (a JSON from before it was recorded): stale too
    path.write_text(json.dumps({k: v for k, v in written.items() if k != "verilog_sha256"}))
    assert bench_edt_tiled.fit_result(ARRAY, RAM, part=PART) is None
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "records no verilog_sha256" in err[0] and err[0].endswith(f"re-run `{COMMAND}`")

    path.write_text(json.dumps(written))           # and the matching one is read again
    assert bench_edt_tiled.fit_result(ARRAY, RAM, part=PART) == written


def test_cell_alone_checked_against_its_own_verilog(flow, capsys):
    """The cell alone (scripts/tile_engine_size.py --cell-fit) is checked against the cell's Verilog,
    not the engine's; a JSON without a generator names the command that places the cell."""
    params = {"t_r": 2, "t_c": 2, "max_h": 16, "max_w": 16}
    path = flow / "build" / "fit" / f"edt_tile_cell_max_h16_max_w16_t_c2_t_r2--{PART}.json"
    path.parent.mkdir(parents=True)
    cell = {"module": "edt_tile_cell_max_h16_max_w16_t_c2_t_r2", "fmax_mhz": 40.0,
            "verilog_sha256": sha256_of_emitted(flow, "edt_tile_cell", params),
            "generator": "python scripts/tile_engine_size.py --cell-fit 2x2:16x16"}
    path.write_text(json.dumps(cell))
    assert bench_edt_tiled.fit_result(ARRAY, RAM, part=PART, top="edt_tile_cell") == cell
    assert capsys.readouterr().err == ""
    engine = sha256_of_emitted(flow, "edt_tile_engine", params)
    path.write_text(json.dumps({**cell, "verilog_sha256": engine, "generator": None}))
    assert bench_edt_tiled.fit_result(ARRAY, RAM, part=PART, top="edt_tile_cell") is None
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].endswith(
        "re-run `python scripts/tile_engine_size.py --cell-fit 2x2:16x16`"), err
