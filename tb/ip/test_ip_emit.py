"""python -m hdl.emit: --list, manifests against the signature and the Verilog, bad parameters, lint.

The listed ranges are the components' own: every declared bound is checked
against the component class itself (it must refuse the value just outside).
"""

import json
import os
import re
import subprocess
import sys

import pytest
from amaranth.hdl import Const, Shape
from amaranth.lib import wiring

from navcores.hdl import emit
from navcores.hdl.dflc.core import latency
from navcores.hdl.dflc.top import config_for, stream_latency
from navcores.hdl.params import REQUIRED, unelaborated
from navcores.models.dflc import WIDTH_LIMITS
from navcores.sim.rtl.runner import ROOT, VERILATOR_WAIVERS, tool_env

# A small valid parameter set of every top (the required parameters and some).
BASE = {
    "harmonic_node": {},
    "harmonic_counters": {"p_max": 6},
    "harmonic_cluster": {"depth": 64},
    "harmonic_decision": {"p_max": 6},
    "harmonic_node_exponents": {"p": 8, "e_max": 20},
    "harmonic_node_exponent_engine": {"max_h": 6, "max_w": 8, "p": 8, "e_max": 20},
    "harmonic_border": {"n": 3, "m": 6, "br": 2, "bc": 2, "p_max": 6},
    "harmonic_block": {"n": 3, "m": 6, "p_max": 14, "depth": 64},
    "harmonic_planner": {"n": 3, "m": 6, "br": 1, "bc": 2, "p_max": 14, "depth": 64},
    "dflc_stream": {"fll": "table1"},
    "dflc_core": {"fll": "table1"},
    "edt_cell": {"height": 5, "width": 7},
    "edt_dram_stores": {"t_r": 2, "t_c": 4, "max_h": 9, "max_w": 13, "dram_ports": 4},
    "edt_array": {"height": 5, "width": 7},
    "edt_bfs": {"height": 5, "width": 7},
    "edt_tile_engine": {"t_r": 2, "t_c": 3, "max_h": 5, "max_w": 7},
}


def cli(*args, cwd=None):
    env = {**os.environ, "AMARANTH_USE_YOSYS": "builtin"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    return subprocess.run([sys.executable, "-m", "hdl.emit", *args], capture_output=True, text=True,
                          cwd=cwd or ROOT, env=env, timeout=300)


def test_list_shows_every_top_and_parameter():
    r = cli("--list", "--json")
    assert r.returncode == 0, r.stderr
    tops = json.loads(r.stdout)
    assert set(tops) == set(emit.TOPS) == set(BASE)
    for name, t in tops.items():
        decl, _ = emit.params_of(name)
        assert [p["name"] for p in t["parameters"]] == [p.name for p in decl], name
        for p in t["parameters"]:
            assert {"type", "default", "required", "allowed"} <= set(p), (name, p)
    # the DFLC widths' limits are load_fll's; the harmonic p_max bound the counters'
    ip = {p["name"]: p for p in tops["dflc_stream"]["parameters"]}
    for k, (lo, hi) in WIDTH_LIMITS.items():
        assert (ip[k]["min"], ip[k]["max"]) == (lo, hi)
    assert ip["div"]["choices"] == ["array", "lut"] and ip["par"]["allowed"] == "0 or 1"
    assert tops["harmonic_cluster"]["constraints"] == ["p_max + 2 <= depth"]
    assert {p["name"]: p["min"] for p in tops["edt_bfs"]["parameters"]} == {"height": 3, "width": 3}
    text = cli("--list").stdout
    assert all(f"{name}:" in text for name in emit.TOPS)
    assert "p_max: int, 2..1048574, required" in text


def test_list_is_whole_and_plain():
    """--list: every top's description is its docstring's whole first
    paragraph, without Sphinx markup; every int parameter of the harmonic
    cores has an upper bound, and the bounds' reasons are printed."""
    tops = emit.listing()
    for name, t in tops.items():
        for text in [t["doc"]] + [p["doc"] for p in t["parameters"]]:
            assert not re.search(r"``|:[a-z]+:`|`", text), (name, text)
        assert t["doc"].rstrip().endswith((".", ")")), (name, t["doc"])     # a whole sentence
    for name in ("harmonic_counters", "harmonic_cluster", "harmonic_block", "harmonic_planner"):
        for p in tops[name]["parameters"]:
            assert p["type"] != "int" or "max" in p, (name, p["name"])
    text = emit.main.__module__ and cli("--list").stdout
    for reason in ("18 Mbit, more block RAM than a whole Artix-7 200T", "at most 2**18 blocks",
                   "the paper's largest block (48x96, Table 3)", "about 0.8 KB each, measured"):
        assert reason in " ".join(text.split()), reason


def test_every_parameter_is_declared():
    """Each top's factory takes exactly its declared parameters (a new
    constructor argument needs its Param beside the constructor)."""
    import inspect
    for name, factory in emit.TOPS.items():
        assert hasattr(emit.SPECS.get(name, factory), "PARAMS"), f"{name}: no PARAMS declaration"
        sig = inspect.signature(factory)
        if any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values()) and name != "dflc_core":
            continue                    # DflcStream(**kw): checked by its own PARAMS
        takes = {p.name for p in sig.parameters.values()
                 if p.kind is p.POSITIONAL_OR_KEYWORD and p.name not in ("path", "config", "parallel", "cpr", "signature")}
        declared = {p.name for p in emit.params_of(name)[0]}
        if name == "dflc_core":         # par, cpr_* named, the config's widths through **kw
            assert takes <= declared, (name, takes - declared)
        else:
            assert takes == declared, (name, takes ^ declared)


def test_declared_bounds_are_the_components_checks():
    """Every declared bound: the value just outside it is refused by the
    component class itself (not by hdl.emit), with the parameter named."""
    checked = 0
    for name, base in BASE.items():
        decl, _ = emit.params_of(name)
        for p in decl:
            if p.type is not int:
                continue
            for bad in ([p.lo - 1] if p.lo is not None else []) + ([p.hi + 1] if p.hi is not None else []):
                params = {**base, p.name: bad}
                with pytest.raises(ValueError, match=re.escape(str(bad))):
                    emit.TOPS[name](**params)        # the component, not the command line
                checked += 1
    assert checked >= 25, checked


BAD = [
    (["nope"], "unknown top 'nope'"),
    (["dflc_stream", "foo=1"], "unknown parameter 'foo'"),
    (["dflc_stream", "ip_sz=x"], "ip_sz=x: expected an integer"),
    (["dflc_stream", "ip_sz=17"], "ip_sz = 17: must be an integer in 2..16"),
    (["dflc_stream", "op_sz=8"], "op_sz = 8 < MF_op_sz = 12"),
    (["dflc_stream", "div=fast"], "div_type = 'fast': expected one of"),
    (["dflc_stream", "fll=nosuch"], "fll = 'nosuch': no such .fll"),
    (["dflc_stream", "fll=my_rules.fll"], "fll = 'my_rules.fll': no such file"),      # not my_rules.fll.fll
    (["harmonic_cluster", "depth=64", "p_max=63"], "p_max=63 needs words of p_max+2=65 bits"),
    (["harmonic_block", "n=4", "m=6"], "block rows n=4: must be a positive multiple of 3"),
    (["harmonic_block", "m=6"], "missing parameter n"),
    (["harmonic_planner", "br=3", "bc=3", "p_max=200"], "9 * (p_max+2) = 1818 words per cluster RAM"),
    (["edt_bfs", "height=2", "width=8"], "array height 2: must be an integer in 3..256"),
    (["edt_cell", "height=300", "width=8"], "array height 300: must be an integer in 1..256"),
    (["harmonic_counters", "p_max"], "parameters are name=value"),
    # issue 20's probes: unbounded parameters get bounds with their reasons
    (["harmonic_block", "n=3", "m=6", "depth=1000000000"], "depth=1000000000: must be an integer in 1..1048576 "
                                                         "(a cluster RAM of 2**20 words x 18 bits is 18 Mbit"),
    (["harmonic_planner", "br=1000", "bc=1000", "depth=1048576", "p_max=2"],
     "a map of 1000x1000 = 1000000 blocks at p_max=2 needs"),
    (["harmonic_planner", "br=300000"], "BR=300000 must be an integer in 1..262144"),
    (["harmonic_block", "n=96", "m=192"], "a 96x192 block is 1024 clusters; at most 256 (elaborating takes about 10 MB"),
    (["harmonic_block", "n=48", "m=96", "depth=32768"], "256 clusters of 32768 words are 8388608 RAM words"),
    (["harmonic_counters", "p_max=2000000"], "p_max must be an integer in 2..1048574"),
    (["harmonic_planner", "e_max=70000", "block_exponents=1"], "e_max=70000: must be an integer in 1..65535"),
    (["harmonic_cluster", "depth=2000000"], "RAM depth must be an integer in 4..1048576"),
    # the DRAM stores' on-chip bits with skip_clean (the load's obstacle bits): 2048x2048 is 8.5 Mbit
    (["edt_dram_stores", "t_r=8", "t_c=8", "max_h=2048", "max_w=2048", "dram_ports=4", "skip_clean=1"],
     "largest map 2048x2048 with skip_clean: the DRAM stores' obstacle and written bits are 8704 Kbit, at most 2048"),
    # the edge pixels' BFS groups in the B words need the DRAM stores' cfr and on-chip written bits
    (["edt_dram_stores", "t_r=3", "t_c=8", "max_h=64", "max_w=64", "bfs_slots=1"],
     "bfs_slots needs store=dram and skip_clean 1"),
    (["edt_tile_engine", "t_r=3", "t_c=8", "max_h=64", "max_w=64", "store=external", "skip_clean=1", "bfs_slots=1"],
     "bfs_slots needs store=dram and skip_clean 1"),
    (["nosuch_top"], "unknown top 'nosuch_top'"),
]


@pytest.mark.parametrize("args,message", BAD[:3], ids=lambda a: "_".join(a) if isinstance(a, list) else None)
def test_bad_parameters_subprocess(args, message):
    r = cli(*args, "-o", "build/ip_bad")
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "Traceback" not in r.stderr, r.stderr
    assert r.stdout == ""


def test_bad_parameters(capsys, tmp_path):
    n = 0
    for args, message in BAD:
        code = emit.main([*args, "-o", str(tmp_path / "out")])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and message in err[0], (args, err)
        n += 1
    assert n == len(BAD) and not any(tmp_path.iterdir())      # nothing written, no folder made


def test_output_folder_probes(capsys, tmp_path):
    """issue 20: -o an existing file, -o and --manifests where nothing can be
    written, a lone unknown word (once taken as the output folder): one line,
    exit status 2, nothing written, before any work."""
    (tmp_path / "file").write_text("keep")
    for args, message in [
        (["harmonic_node", "-o", str(tmp_path / "file")], "is a file, not a folder"),
        (["harmonic_node", "-o", "/proc/x"], "-o /proc/x: cannot write there"),
        (["harmonic_node", "-o", str(tmp_path / "file" / "sub")], "cannot write there"),
        (["--manifests", "/proc/x"], "--manifests /proc/x: cannot write there"),
        (["--manifests", str(tmp_path / "file")], "is a file, not a folder"),
        (["nosuch_top"], "unknown top 'nosuch_top'; tops: harmonic_node"),
        (["harmonic_node", "--frobnicate"], "unrecognized arguments: --frobnicate"),
    ]:
        assert emit.main(args) == 2, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0] and err[0].startswith("python -m hdl.emit: error:"), (args, err)
    assert (tmp_path / "file").read_text() == "keep" and sorted(p.name for p in tmp_path.iterdir()) == ["file"]
    assert not (ROOT / "nosuch_top").exists()
    # a folder is still taken as the legacy form's output folder, created if missing (make verilog)
    assert emit._is_folder("build/verilog") and emit._is_folder(str(tmp_path)) and not emit._is_folder("nosuch")


N3_PROD = ROOT / "tb" / "dflc" / "fll" / "n3_prod.fll"     # a test fixture: hdl takes it by path

# Non-default parameter sets: manifest against the signature and the Verilog, then lint.
SETS = [
    ("dflc_stream", {"ip_sz": 10, "op_sz": 14, "div": "array", "par": 1, "cpr9_no": 3}),
    ("dflc_core", {"fll": str(N3_PROD), "div": "array"}),  # an always_ready stream (no ready port)
    ("harmonic_cluster", {"depth": 64, "p_max": 30}),
    ("edt_bfs", {"height": 5, "width": 7}),
]


@pytest.mark.parametrize("name,params", SETS, ids=[s[0] for s in SETS])
def test_manifest_and_lint(name, params, tmp_path):
    r = cli(name, *[f"{k}={v}" for k, v in params.items()], "-o", str(tmp_path))
    assert r.returncode == 0, r.stderr
    module = emit.top_name(name, params)
    vfile, jfile = tmp_path / f"{module}.v", tmp_path / f"{module}.json"
    assert r.stdout.split() == [str(vfile), str(jfile)]
    man = json.loads(jfile.read_text())
    assert man["module"] == module and man["top"] == name
    assert all(man["parameters"][k] == v for k, v in params.items())

    # every port of the signature, with its direction and width (a constant
    # member, an always_ready stream's ready, is no port)
    comp = unelaborated(emit.TOPS[name](**params))
    sig_ports = {"__".join(map(str, path)): ("input" if member.flow == wiring.Flow.In else "output",
                                             Shape.cast(value.shape()).width)
                 for path, member, value in comp.signature.flatten(comp) if not isinstance(value, Const)}
    man_ports = {p["name"]: (p["direction"], p["width"]) for p in man["ports"]}
    assert man_ports == sig_ports
    # ... which are the Verilog module's ports, besides the clock and the reset
    vports = emit.verilog_ports(vfile.read_text(), module)
    assert vports.pop("clk") == ("input", 1) and vports.pop("rst") == ("input", 1)
    assert vports == man_ports
    assert man["clock"]["name"] == "clk" and man["reset"] == {**man["reset"], "name": "rst", "synchronous": True}

    # streams: valid / ready / payload roles; the payload fields tile the payload
    streams = {p["stream"] for p in man["ports"] if "stream" in p}
    assert streams == set(man["streams"]) and bool(streams) == (name != "harmonic_cluster")
    for s in streams:
        roles = {p["role"]: p for p in man["ports"] if p.get("stream") == s}
        always_ready = man["streams"][s]["always_ready"]
        assert set(roles) == {"valid", "payload"} | ({"ready"} if not always_ready else set())
        assert man["streams"][s]["ready"] == (None if always_ready else roles["ready"]["name"])
        if not always_ready:
            assert roles["valid"]["direction"] != roles["ready"]["direction"]
        assert roles["payload"]["direction"] == roles["valid"]["direction"]
        bits = sorted((f["lsb"], f["msb"]) for f in roles["payload"]["fields"])
        assert bits[0][0] == 0 and bits[-1][1] == roles["payload"]["width"] - 1
        assert all(b[0] == a[1] + 1 for a, b in zip(bits, bits[1:])), bits

    # the guaranteed figures
    t = man["timing"]
    if name == "dflc_stream":
        assert t["initiation_interval_cycles"] == 1           # par=1
        c = config_for(ip_sz=10, op_sz=14, div="array")
        # one clock of rules (par), then PIPE_DEFAULTS with cpr9_no=3: psr1 1, cpr3 1, the cpr5 / cpr2+psr2
        # join 2, the psr4 / cpr6 join 3, cpr9 3; the core's 2 output stages and the stream's 1
        assert t["latency_cycles"] == stream_latency(c, True, cpr9_no=3) == 1 + (1 + 1 + 2 + 3 + 3) + 2 + 1
        payload = next(p for p in man["ports"] if p["name"] == "i_stream__payload")
        assert [(f["lsb"], f["msb"]) for f in payload["fields"]] == [(0, 9), (10, 19)]
    elif name == "harmonic_cluster":
        assert t["iteration_cycles"] == "p+2 (p >= 4; max(p, 4)+2 below)"  # models.harmonic.iteration_cycles
    elif name == "dflc_core":             # n = 3: 8 cycles per sample; no back-pressure on o_stream
        assert t["initiation_interval_cycles"] == 8
        assert t["latency_cycles"] == latency(config_for(fll=str(N3_PROD), div="array"))
        assert man["streams"]["o_stream"]["always_ready"] and not man["streams"]["i_stream"]["always_ready"]
    else:
        assert t["load_cycles"] == 7 and t["readout_cycles"] == 35

    # lint clean, as make lint
    tool_env()
    lint = subprocess.run(["verilator", "--lint-only", "-Wall", str(VERILATOR_WAIVERS), str(vfile)],
                          capture_output=True, text=True, timeout=300)
    assert lint.returncode == 0, lint.stderr[-3000:]


def test_default_sets_command(tmp_path, monkeypatch, capsys):
    """``python -m hdl.emit OUT_DIR`` (make verilog) writes every default set, manifests too."""
    monkeypatch.setattr(emit, "DEFAULT_SETS", [("harmonic_counters", {"p_max": 1022}), ("harmonic_node", {})])
    assert emit.main([str(tmp_path)]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["harmonic_counters_pmax1022.json", "harmonic_counters_pmax1022.v",
                     "harmonic_node.json", "harmonic_node.v"]
    assert capsys.readouterr().out.split() == [str(tmp_path / "harmonic_counters_pmax1022.v"),
                                               str(tmp_path / "harmonic_node.v")]
    # the emitted manifest is the one --manifests writes without emitting
    assert ((tmp_path / "harmonic_counters_pmax1022.json").read_text()
            == emit.manifest_text("harmonic_counters", {"p_max": 1022}))


def test_committed_manifests_are_current():
    """docs/manifests/ (linked from the docs) holds every default set's manifest, as generated today."""
    docs = ROOT / "docs" / "manifests"
    want = {f"{emit.top_name(n, p)}.json": (n, p) for n, p in emit.DEFAULT_SETS}
    assert sorted(f.name for f in docs.glob("*.json")) == sorted(want)
    stale = [f for f, (n, p) in want.items() if (docs / f).read_text() != emit.manifest_text(n, p)]
    assert not stale, f"stale manifests {stale}: python -m hdl.emit --manifests docs/manifests"


def test_every_default_set_is_valid():
    for name, params in emit.DEFAULT_SETS:
        decl, constraints = emit.params_of(name)
        given = {p.name: params.get(p.name, p.default) for p in decl}
        assert all(v is not REQUIRED for v in given.values()), (name, params)
        emit.manifest(name, params)         # builds the component: its checks pass


def test_undefined_memory_has_no_initial_block():
    """A memory from hdl.ram_init.undefined_memory is emitted without its word-by-word zero init
    (the tile engine's state store: yosys' Verilog front end stalls on it); a plain Memory keeps
    its init; a marked memory with a non-zero init is refused, never dropped."""
    from amaranth.hdl import Module, Signal
    from amaranth.lib.memory import Memory
    from navcores.hdl.ram_init import UNDEFINED_INIT, strip_undefined_init, undefined_memory

    def verilog(mem_kind):
        m = Module()
        m.submodules.plain = plain = Memory(shape=8, depth=4, init=[])
        m.submodules.undef = undef = mem_kind()
        a, d, q1, q2 = Signal(2), Signal(8), Signal(8), Signal(8)
        for mem, q in ((plain, q1), (undef, q2)):
            rp, wp = mem.read_port(), mem.write_port()
            m.d.comb += [rp.addr.eq(a), wp.addr.eq(a), wp.data.eq(d), wp.en.eq(1), q.eq(rp.data)]
        return emit.verilog.convert(m, ports=[a, d, q1, q2], emit_src=False)

    raw = verilog(lambda: undefined_memory(shape=8, depth=4))
    text = strip_undefined_init(raw)
    assert raw.count("initial begin") == 2 and text.count("initial begin") == 1
    assert re.search(r"reg \[7:0\] plain \[3:0\];\n\s*initial begin", text)
    assert "undef[0] =" not in text and "undef[0] =" in raw
    assert "always @(posedge clk)" in text.split("reg [7:0] undef [3:0];")[1]   # the rest stays
    bad = verilog(lambda: Memory(shape=8, depth=4, init=[0, 5], attrs={UNDEFINED_INIT: 1}))
    with pytest.raises(ValueError, match="initial value"):
        strip_undefined_init(bad)


def test_zero_init_dropped_for_synthesis_only():
    """hdl.ram_init.strip_zero_init (the fit flow's synthesis input): the all-zero
    init of a memory of at least min_words words goes, a smaller one's and a
    non-zero one's stay, and everything else is kept as it was."""
    from amaranth.hdl import Module, Signal
    from amaranth.lib.memory import Memory
    from navcores.hdl.ram_init import strip_zero_init

    m = Module()
    mems = {"big": Memory(shape=8, depth=16, init=[]), "few": Memory(shape=8, depth=8, init=[]),
            "rom": Memory(shape=8, depth=16, init=[0, 0, 7])}
    a, d = Signal(4), Signal(8)
    outs = []
    for name, mem in mems.items():
        m.submodules[name] = mem
        rp, wp = mem.read_port(), mem.write_port()
        q = Signal(8, name=f"q_{name}")
        m.d.comb += [rp.addr.eq(a), wp.addr.eq(a), wp.data.eq(d), wp.en.eq(1), q.eq(rp.data)]
        outs.append(q)
    raw = emit.verilog.convert(m, ports=[a, d, *outs], emit_src=False)
    text = strip_zero_init(raw, min_words=16)
    assert raw.count("initial begin") == 3 and text.count("initial begin") == 2
    assert "big[0] =" in raw and "big[0] =" not in text and re.search(r"reg \[7:0\] big \[15:0\];\n", text)
    assert "few[0] =" in text and "rom[2] = 8'h07;" in text
    assert len(raw) - len(text) == len("  initial begin\n") + sum(len(f"    big[{i}] = 8'h00;\n") for i in range(16)) \
        + len("  end\n")
