"""The cores through FuseSoC, as a user outside this repository gets them.

A copy of the repository's tracked files (what a fresh clone holds) is the
FuseSoC library; FuseSoC runs the generators (python -m hdl.emit) and the
plain-Verilog examples on Icarus, lints a generated core with Verilator, and
reports a bad generator parameter with the core's one-line message.
"""

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from navcores.sim.rtl.runner import ROOT, tool_env

if importlib.util.find_spec("fusesoc") is None:         # pragma: no cover - the Makefile installs the ip extra
    raise ImportError("tb/ip needs FuseSoC: pip install -e '.[ip]' (make test installs it)")

FUSESOC = Path(sys.executable).with_name("fusesoc")


@pytest.fixture(scope="module")
def clone(tmp_path_factory):
    """The repository's tracked (and new, not ignored) files, copied: a fresh clone."""
    try:
        files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=ROOT,
                               capture_output=True, text=True, check=True).stdout.split("\0")
    except (OSError, subprocess.CalledProcessError):     # not a git checkout: what the cores need
        files = [str(p.relative_to(ROOT)) for d in ("fusesoc", "examples", "hdl", "models", "lint", "tb")
                 for p in (ROOT / d).rglob("*")
                 if (p.is_file() or p.is_symlink()) and "__pycache__" not in p.parts]
    dst = tmp_path_factory.mktemp("clone")
    for f in filter(None, files):
        src = ROOT / f
        if not src.exists() and not src.is_symlink():
            continue            # deleted in the work tree
        (dst / f).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dst / f, follow_symlinks=False)
    assert (dst / "fusesoc" / "waivers.vlt").resolve().is_file()
    return dst


def fusesoc(clone, work, *args):
    """Run FuseSoC in ``work`` with the clone's cores; the generators' python3
    is this interpreter, which imports the clone's hdl.emit."""
    tool_env()                  # Verilator on PATH for the lint target
    env = {**os.environ, "AMARANTH_USE_YOSYS": "builtin",
           "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ["PATH"]]),
           "PYTHONPATH": str(clone), "NAVCORES_PYTHON": sys.executable}
    work.mkdir(parents=True, exist_ok=True)
    cmd = [str(FUSESOC), "--cores-root", str(clone / "fusesoc"), "--cores-root", str(clone / "examples"), *args]
    return subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("example,expect", [
    ("dflc_stream", "PASS: 24 samples matched the golden model"),
    ("edt_bfs", "PASS: 74 beats (a path of 10 pixels) matched the golden model"),
])
def test_ip_example(clone, tmp_path, example, expect):
    # the stored golden values are the model's today
    chk = subprocess.run([sys.executable, str(clone / "examples" / example / "make_golden.py"), "--check"],
                         env={**os.environ, "PYTHONPATH": str(clone)}, capture_output=True, text=True)
    assert chk.returncode == 0, chk.stdout + chk.stderr
    r = fusesoc(clone, tmp_path, "run", "--target=sim", f"navcores:examples:{example}")
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    assert expect in r.stdout, r.stdout[-3000:]
    assert "FAIL" not in r.stdout and "MISMATCH" not in r.stdout
    # the generated core holds the Verilog and its manifest
    gen = list(tmp_path.glob("build/*/sim-icarus/generator_cache/*/*.json"))
    assert len(gen) == 1, gen


def test_ip_example_fails_on_a_wrong_value(clone, tmp_path):
    """The example can fail: one golden output changed -> $fatal, FuseSoC exits non-zero."""
    ex = tmp_path / "examples"
    shutil.copytree(clone / "examples", ex)
    golden = ex / "dflc_stream" / "golden.hex"
    lines = golden.read_text().splitlines()
    i = next(k for k, line in enumerate(lines) if not line.startswith("//")) + 5
    lines[i] = f"{int(lines[i], 16) ^ (1 << 20):09x}"        # y's LSB of sample 5
    golden.write_text("\n".join(lines) + "\n")
    r = subprocess.run(
        [str(FUSESOC), "--cores-root", str(clone / "fusesoc"), "--cores-root", str(ex / "dflc_stream"),
         "run", "--target=sim", "navcores:examples:dflc_stream"],
        cwd=tmp_path, env={**os.environ, "PATH": os.pathsep.join([str(Path(sys.executable).parent),
                                                                 os.environ["PATH"]]),
                           "PYTHONPATH": str(clone), "AMARANTH_USE_YOSYS": "builtin"},
        capture_output=True, text=True, timeout=600)
    assert r.returncode != 0
    assert "MISMATCH sample 5" in r.stdout and "FAIL: 1 of 24 samples differ" in r.stdout + r.stderr


@pytest.mark.parametrize("family,module", [
    ("harmonic", "harmonic_planner_bc2_br1_depth64_m6_n3_pmax14"),
    ("dflc", "dflc_stream_table1"),
    ("edt_bfs", "edt_bfs_height8_width8"),
])
def test_ip_lint_target(clone, tmp_path, family, module):
    """Each family's lint target: Verilator -Wall with the waivers on its generated default top."""
    r = fusesoc(clone, tmp_path, "run", "--target=lint", f"navcores:ip:{family}")
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    vc = next(tmp_path.glob("build/*/lint-verilator/*.vc")).read_text()
    assert "waivers.vlt" in vc and f"{module}.v" in vc and f"--top-module {module}" in vc
    mk = next(tmp_path.glob("build/*/lint-verilator/Makefile")).read_text()
    cfg = next(tmp_path.glob("build/*/lint-verilator/config.mk")).read_text()
    assert "--lint-only" in mk and "-Wall" in cfg


def test_ip_generator_bad_parameter(clone, tmp_path):
    """A user's core asking for a value out of range: the core's one-line message."""
    user = tmp_path / "user"
    user.mkdir()
    (user / "mine.core").write_text(
        "CAPI=2:\nname: me:my:flc:1.0\n"
        "filesets:\n  dep:\n    depend: [navcores:ip:dflc]\n"
        "generate:\n  flc:\n    generator: navcores_dflc\n    parameters: {top: dflc_stream, ip_sz: 99}\n"
        "targets:\n  default:\n    filesets: [dep]\n    generate: [flc]\n    toplevel: x\n"
        "  sim:\n    filesets: [dep]\n    generate: [flc]\n    default_tool: icarus\n    toplevel: x\n")
    r = fusesoc(clone, tmp_path / "work", "--cores-root", str(user), "run", "--target=sim", "me:my:flc")
    assert r.returncode != 0
    out = r.stdout + r.stderr
    assert "navcores generator: python -m hdl.emit: error: ip_sz = 99: must be an integer in 2..16" in out, out[-2000:]
    assert "Traceback" not in out
