"""Fuzzing the readers and the command lines (issue 20): never a traceback.

Seeded (``SEED=<n>`` replays a run, ``SEED=random`` draws one; the seed is
printed), about a minute in all:

* every map reader (.map, .txt, .pgm, .png, .yaml with its image), the CSV
  readers (``sim dflc --input``, ``sim track`` paths) and the FLL reader
  (models.dflc.load_fll) get mutated files: random bytes, bytes flipped,
  inserted and dropped, lines truncated and repeated, huge numbers, NaN and
  inf, UTF-16 and Latin-1 text, NUL bytes, headers announcing huge images.
  A reader returns a result or raises its own error (MapFormatError,
  CliError, FllError), nothing else, within a time bound;
* random argument lists to every ``python -m sim`` command, to
  ``python -m sim.demo`` and to ``python -m hdl.emit``, in-process
  (``main(argv)``, fast), a handful also as subprocesses: the exit status is
  0, 1 or 2, status 2 is exactly one line on stderr, there is never a
  traceback or an "internal error", and every call ends within the bound.

The argument vocabulary keeps the runs that are valid small (tiny maps, short
paths, the model engine: an RTL engine is only ever given with inputs that
are refused first), so the bound is about the frame, not the work.
"""

import contextlib
import io
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from navcores.hdl.params import unelaborated
from navcores.models.dflc import FllError, load_fll
from navcores.models.maps import MapFormatError, load, save_ros
from navcores.sim.cli import CliError
from navcores.sim.rtl.runner import seed_from_env

ROOT = Path(__file__).resolve().parents[2]
SEED = seed_from_env()
CALL_LIMIT = 30            # seconds: any one call
READS = 150                 # mutated files per reader
COMMAND_RUNS = 400         # random argument lists, in-process

MAP_TEXT = "type octile\nheight 4\nwidth 6\nmap\n......\n.@@...\n......\n....@.\n"
TXT_TEXT = "......\n.##...\n......\n....#.\n"
YAML_TEXT = ("image: m.pgm\nmode: trinary\nresolution: 0.1\norigin: [-0.3, -0.2, 0.0]\nnegate: 0\n"
             "occupied_thresh: 0.65\nfree_thresh: 0.25\n")
CSV_TEXT = "phi1,phi2\n0,0\n10,-30\n170,100\n"
PATH_TEXT = "x,y\n0,0\n0.1,0.02\n0.2,0.0\n"
WEIRD = ["1e400", "-1e400", "nan", "inf", "-inf", "99999999999999999999999", "-0", "0x1F", "1_000", "",
         "\u00e9", "\x00", "\xff", "1e-400", "4294967296", "-1", "٣"]


class Timeout(Exception):
    pass


@contextlib.contextmanager
def time_bound(what, seconds=CALL_LIMIT):
    def alarm(signum, frame):
        raise Timeout(f"{what}: more than {seconds} s")
    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def mutate(rng, data: bytes) -> bytes:
    """One to four random edits of ``data``."""
    for _ in range(rng.randint(1, 4)):
        op = rng.randrange(11)
        n = len(data)
        if op == 0 and n:                                  # flip bytes
            b = bytearray(data)
            for _ in range(rng.randint(1, 8)):
                b[rng.randrange(n)] = rng.randrange(256)
            data = bytes(b)
        elif op == 1:                                      # insert random bytes
            k = rng.randint(0, n)
            data = data[:k] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 16))) + data[k:]
        elif op == 2 and n:                                # truncate
            data = data[:rng.randrange(n)]
        elif op == 3:                                      # repeat or drop a line
            lines = data.split(b"\n")
            k = rng.randrange(len(lines))
            lines[k:k + 1] = [lines[k]] * rng.choice([0, 2, 3])
            data = b"\n".join(lines)
        elif op == 4:                                      # a number becomes a weird one
            words = data.split(b" ")
            k = rng.randrange(len(words))
            words[k] = rng.choice(WEIRD).encode("utf-8", "surrogatepass")
            data = b" ".join(words)
        elif op == 5:                                      # a digit run becomes huge
            text = data.decode("latin-1")
            digits = [i for i, ch in enumerate(text) if ch.isdigit()]
            if digits:
                i = rng.choice(digits)
                text = text[:i] + "9" * rng.randint(10, 40) + text[i + 1:]
            data = text.encode("latin-1")
        elif op == 6:                                      # another encoding
            data = data.decode("latin-1").encode(rng.choice(["utf-16", "utf-32", "utf-16-be"]))
        elif op == 7:                                      # Latin-1 text (not UTF-8)
            data = data.replace(b".", b"\xe9", 1) if b"." in data else data + b"\xe9"
        elif op == 8:                                      # NUL bytes
            k = rng.randint(0, n)
            data = data[:k] + b"\x00" * rng.randint(1, 4) + data[k:]
        elif op == 9:                                      # pure noise
            data = bytes(rng.randrange(256) for _ in range(rng.randint(0, 200)))
        else:                                              # NaN / inf in a field
            data = data.replace(b"0", rng.choice([b"nan", b"inf", b"-inf", b"1e999"]), 1)
    return data


def _images():
    """Valid small images and images whose header lies."""
    rng = np.random.default_rng(SEED)
    out = []
    grey = rng.integers(0, 256, (5, 7), dtype=np.uint8)
    for mode in ("L", "LA", "RGB", "RGBA", "P", "1", "I;16"):
        buf = io.BytesIO()
        im = Image.fromarray(grey, "L")
        im = im.convert(mode) if mode != "I;16" else Image.fromarray(grey.astype(np.uint16) * 257)
        im.save(buf, format="PNG")
        out.append(("png", buf.getvalue()))
    out.append(("pgm", b"P5\n7 5\n255\n" + grey.tobytes()))
    out.append(("pgm", b"P5\n100000 100000\n255\n" + grey.tobytes()))        # a header announcing 10**10 pixels
    out.append(("pgm", b"P5\n7 5\n65535\n" + grey.tobytes() * 2))
    out.append(("pgm", b"P2\n3 2\n255\n0 255 128\n1e400 nan -5\n"))
    return out


def check_reader(fn, allowed, what):
    """``fn()`` returns, or raises one of ``allowed``, within the bound."""
    t0 = time.monotonic()
    try:
        with time_bound(what):
            fn()
    except allowed:
        pass
    assert time.monotonic() - t0 < CALL_LIMIT


def test_map_readers(tmp_path):
    """Mutated .map, .txt, .pgm, .png and .yaml (and the YAML's image) files."""
    rng = random.Random(SEED)
    print(f"SEED={SEED}")
    seeds = {".map": MAP_TEXT.encode(), ".txt": TXT_TEXT.encode(), ".yaml": YAML_TEXT.encode()}
    images = _images()
    grid = np.zeros((4, 6), dtype=bool)
    grid[1, 1:3] = True
    save_ros(tmp_path / "base.yaml", grid, 0.1)
    (tmp_path / "m.pgm").write_bytes((tmp_path / "base.pgm").read_bytes())
    n = ok = 0
    for k in range(READS):
        for suffix, data in seeds.items():
            path = tmp_path / f"f{k}{suffix}"
            path.write_bytes(mutate(rng, data))
            check_reader(lambda: load(path), (MapFormatError, FileNotFoundError), str(path))
            n += 1
        kind, data = rng.choice(images)
        path = tmp_path / f"i{k}.{kind}"
        path.write_bytes(mutate(rng, data) if rng.random() < 0.7 else data)
        check_reader(lambda: load(path), (MapFormatError,), str(path))
        # the YAML's image mutated under a valid YAML
        (tmp_path / "m.pgm").write_bytes(mutate(rng, (tmp_path / "base.pgm").read_bytes()))
        yaml = tmp_path / "y.yaml"
        yaml.write_text(YAML_TEXT.replace("image: m.pgm", rng.choice(
            ["image: m.pgm", "image: /dev/zero", "image: .", "image: nothere.pgm", f"image: {tmp_path}/m.pgm"])))
        try:
            with time_bound(str(yaml)):
                g = load(yaml).obstacle
            ok += 1
            assert g.dtype == bool and g.ndim == 2
        except MapFormatError:
            pass
        n += 2
    print(f"{n} mutated map files read, {ok} valid YAML maps among them")
    assert n >= 5 * READS


def test_csv_and_fll_readers(tmp_path):
    """Mutated dflc inputs, track paths and FLL files."""
    from navcores.sim.dflc import read_csv
    from navcores.sim.tracking import read_path_csv
    rng = random.Random(SEED + 1)
    fll = (ROOT / "models" / "dflc_table1.fll").read_bytes()
    n = 0
    for k in range(READS):
        csv = tmp_path / f"c{k}.csv"
        csv.write_bytes(mutate(rng, CSV_TEXT.encode()))
        check_reader(lambda: read_csv(csv, ("phi1", "phi2")), (CliError,), str(csv))
        path = tmp_path / f"p{k}.csv"
        path.write_bytes(mutate(rng, PATH_TEXT.encode()))
        check_reader(lambda: read_path_csv(path), (CliError,), str(path))
        f = tmp_path / f"r{k}.fll"
        f.write_bytes(mutate(rng, fll))
        check_reader(lambda: load_fll(f), (FllError,), str(f))
        n += 3
    assert n == 3 * READS


# --- command lines ------------------------------------------------------------------

@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz_cli")
    (d / "m.map").write_text(MAP_TEXT)
    (d / "m.txt").write_text(TXT_TEXT)
    grid = np.zeros((4, 6), dtype=bool)
    grid[1, 1:3] = True
    save_ros(d / "m.yaml", grid, 0.1, (-0.3, -0.2, 0.0))
    Image.fromarray(np.where(grid, 0, 255).astype(np.uint8)).save(d / "m.png")
    (d / "bad.map").write_bytes(os.urandom(300))
    (d / "p.csv").write_text(PATH_TEXT)
    (d / "in.csv").write_text(CSV_TEXT)
    (d / "bad.csv").write_bytes(b"phi1,phi2\n\xff\xfe,1\n")
    (d / "bad.fll").write_bytes(b"garbage\x00\xff")
    (d / "out").mkdir()
    return d


def _vocabulary(d):
    maps = [str(d / n) for n in ("m.map", "m.txt", "m.yaml", "m.png", "bad.map", "none.map")] + [str(d), "/dev/zero"]
    cells = ["0,0", "3,5", "2,2", "0,5", "-1,2", "9,9", "a,b", "1", "1,2,3", "", "1e9,1", "nan,0"]
    xys = ["0.05,0.15", "-0.25,-0.15", "0.2,0.1", "1e300,0", "nan,1", "inf,inf", "x,y", "-1,-1"]
    numbers = ["0", "1", "0.1", "0.2", "-1", "1e9", "nan", "inf", "-inf", "abc", "", "2", "255", "256",
               "99999999999999999999"]
    # no board here: a missing port, a bad spec, and a file that is no serial port
    serial = ["serial:/dev/nonexistent", "serial:", "serial:/dev/null", "serial:/dev/null@12", "serial:x@"]
    outs = [str(d / "out" / "r.json"), str(d / "out" / "r.png"), str(d / "out" / "r.csv"), str(d / "out" / "p.xyz"),
            "/proc/x/y.json", str(d), str(d / "out" / "deep" / "x.json")]
    return {
        "harmonic": ([maps], {"--goal": cells, "--goal-xy": xys, "--start": cells, "--start-xy": xys,
                              "--block": ["3x6", "6x12", "0x1", "100000x6", "3,6", "x"],
                              "--iters": numbers, "--schedule": ["16:16:64", "8,16", "16,8", "2:1:99999", "x", "8:8"],
                              "--engine": ["model", "fpga"] + serial, "--cell": numbers,
                              "--unknown": ["free", "obstacle", "x"],
                              "--json": outs, "--plot": outs, "--csv": outs, "--block-exponents": None}),
        "edt": ([maps], {"--dfar": numbers + ["3"], "--goal": cells, "--goal-xy": xys, "--start": cells,
                         "--start-xy": xys, "--engine": ["model", "fpga"] + serial, "--cell": numbers,
                         "--json": outs, "--plot": outs, "--csv": outs}),
        "dflc": ([], {"--fll": [str(ROOT / "models" / "dflc_table1.fll"), str(d / "bad.fll"), "none.fll", str(d)],
                      "--input": [str(d / "in.csv"), str(d / "bad.csv"), "none.csv", str(d / "p.csv")],
                      "--engine": ["model", "x"] + serial, "--div": ["lut", "array", "x"], "--parallel": None,
                      "--json": outs, "--plot": outs}),
        # (in.csv as a path is a valid 238 m chain: minutes of driving, not the fuzzer's business)
        "track": ([[str(d / "p.csv"), str(d / "bad.csv"), "none.csv", str(d / "bad.fll"), str(ROOT / "paths" / "line.csv")]],
                  {"--speed": ["0.5", "1", "0.0001", "2", "nan", "-1", "x"], "--lookahead": ["0.03", "0", "5", "nan"],
                   "--slip": ["0", "0.01", "0.6", "-1", "nan"], "--seed": ["0", "-5", "1e3", "x", "7"],
                   "--start": ["0,0,0", "2,1,0", "0,0.01,1e9", "x", "0,0", "nan,0,0"],
                   "--map": maps, "--cell": numbers, "--engine": ["model", "fpga"],
                   "--json": outs, "--plot": outs}),
        "navigate": ([maps], {"--start": cells, "--goal": cells, "--start-xy": xys, "--goal-xy": xys,
                              "--planner": ["harmonic", "edt", "x"], "--cell": ["0.1", "0", "inf", "1e9", "-1", "x"],
                              "--speed": ["0.5", "1", "0.0001", "nan"], "--slip": ["0", "0.01", "0.6"],
                              "--seed": ["0", "-5"], "--dfar": ["0", "1", "-1"], "--block": ["3x6", "6,12", "x"],
                              "--schedule": ["16:16:64", "x"], "--iters": ["6", "0", "300"],
                              "--engine": ["model", "fpga"], "--json": outs, "--plot": outs, "--csv": outs}),
        "board": ([serial + ["x", str(d)]], {"--json": outs}),
    }


def _templates(d):
    """Valid small runs, each of which the fuzzer then edits a little."""
    return [["harmonic", str(d / "m.txt"), "--goal", "0,5", "--start", "3,0", "--schedule", "16:16:64"],
            ["harmonic", str(d / "m.yaml"), "--goal-xy", "0.25,0.15", "--start-xy", "-0.25,-0.15"],
            ["edt", str(d / "m.map"), "--dfar", "0", "--goal", "0,5", "--start", "3,0"],
            ["edt", str(d / "m.png"), "--dfar", "1", "--goal", "0,5", "--start", "3,0"],
            ["edt", str(d / "m.txt"), "--dfar", "0", "--goal", "0,5", "--start", "1,1"],          # no path: 1
            ["navigate", str(d / "m.txt"), "--start", "0,0", "--goal", "3,5", "--speed", "0.5", "--planner", "edt"],
            ["navigate", str(d / "m.yaml"), "--start-xy", "-0.25,0.15", "--goal-xy", "0.25,-0.15", "--speed", "1"],
            ["track", str(d / "p.csv"), "--speed", "0.5"],
            ["dflc", "--input", str(d / "in.csv")]]


def _argv(rng, vocab, templates=()):
    """A random argument list: a valid small run edited a little, or the
    command's positionals (sometimes left out) and random options with random
    values (sometimes without, sometimes twice)."""
    if templates and rng.random() < 0.4:
        argv = list(rng.choice(templates))
        _, options = vocab[argv[0]]
        for _ in range(rng.randint(0, 2)):
            opt = rng.choice(list(options))
            argv.append(opt)
            if options[opt] is not None:
                argv.append(rng.choice(options[opt]))
        return argv
    command = rng.choice(list(vocab) + ["nosuch", "--help", ""])
    if command not in vocab:
        return [command] if command else []
    positionals, options = vocab[command]
    argv = [command] + [rng.choice(p) for p in positionals if rng.random() < 0.9]
    for _ in range(rng.randint(0, 6)):
        opt = rng.choice(list(options) + ["--bogus"])
        values = options.get(opt, ["1"])
        argv.append(opt)
        if values is not None and rng.random() < 0.95:
            argv.append(rng.choice(values))
    if rng.random() < 0.1:
        argv.insert(rng.randint(1, len(argv)), rng.choice(["--", "-", "--=", "\x00", "é"]))
    return argv


def _check_run(call, argv, capfd):
    t0 = time.monotonic()
    with time_bound(" ".join(map(str, argv))):
        status = call(argv)
    out, err = capfd.readouterr()
    assert status in (0, 1, 2), (argv, status, err)
    assert "Traceback" not in err and "internal error" not in err, (argv, err)
    if status == 2:
        assert len(err.strip().splitlines()) == 1, (argv, err)
    return status, time.monotonic() - t0


def test_random_command_lines(files, capfd):
    """Random argument lists to every sim command, the demo's frame and hdl.emit, in-process."""
    from navcores.hdl import emit
    from navcores.sim import demo
    from navcores.sim.cli import main
    rng = random.Random(SEED + 2)
    vocab = _vocabulary(files)
    counts = {0: 0, 1: 0, 2: 0}
    slowest = (0.0, None)
    templates = _templates(files)
    for _ in range(COMMAND_RUNS):
        argv = _argv(rng, vocab, templates)
        status, dt = _check_run(main, argv, capfd)
        counts[status] += 1
        slowest = max(slowest, (dt, argv), key=lambda t: t[0])
    # the demo's options, refused before any work (a valid demo run takes 15 s: make demo runs it)
    for argv in (["--cell", "inf"], ["--seed", "-5"], ["--index", "999"], ["--out", "/proc/x"], ["--map", "none.map"],
                 ["--speed", "0"], ["--slip", "nan"], ["--engine", "fpga"], ["--bogus"]):
        assert _check_run(demo.cli, argv, capfd)[0] == 2, argv
    # hdl.emit: parsing, bounds, the component's checks; the conversion stubbed (a default set takes seconds)
    tops = list(emit.TOPS)
    values = ["1", "3", "6", "12", "64", "0", "-1", "1000000000", "2**20", "x", "", "0x10", "table1", "nosuch.fll"]
    names = ["n", "m", "br", "bc", "p_max", "depth", "e_max", "headroom", "height", "width", "fll", "ip_sz", "div",
             "par", "bogus", ""]

    def fake_emit(name, params, out_dir, with_manifest=True, factory=None, before_work=None):
        unelaborated(emit.build(name, params))      # the component checks; the conversion is stubbed
        if before_work:
            before_work()
        return Path(out_dir) / f"{emit.top_name(name, params)}.v"
    real = emit.emit
    emit.emit = fake_emit
    try:
        for _ in range(COMMAND_RUNS // 2):
            argv = [rng.choice(tops + ["nosuch", "--list", "--bogus"])]
            argv += [f"{rng.choice(names)}={rng.choice(values)}" for _ in range(rng.randint(0, 4))]
            argv += rng.choice([[], ["-o", str(files / "out")], ["-o", "/proc/x"], ["-o", str(files / "p.csv")],
                                ["--no-manifest"], ["--json"]])
            if argv[0] == "--list" or len(argv) > 1 and argv[1] == "--list":
                continue
            status, _ = _check_run(emit.main, argv, capfd)
            counts[status] += 1
    finally:
        emit.emit = real
    print(f"SEED={SEED}: exit statuses {counts}; slowest {slowest[0]:.1f} s: {slowest[1]}")
    assert counts[0] + counts[1] > 0 and counts[2] > 0        # both kinds were exercised


def test_random_command_lines_as_subprocesses(files):
    """A handful of random argument lists as a user runs them (python -m sim, python -m hdl.emit)."""
    rng = random.Random(SEED + 3)
    vocab = _vocabulary(files)
    runs = [["-m", "sim", *_argv(rng, vocab)] for _ in range(4)]
    runs += [["-m", "hdl.emit", "nosuch_top"], ["-m", "hdl.emit", "harmonic_planner", "br=1000", "bc=1000",
                                                "depth=1048576", "p_max=2"]]
    for argv in runs:
        r = subprocess.run([sys.executable, *argv], cwd=files, capture_output=True, text=True, timeout=CALL_LIMIT * 2,
                           env={**os.environ, "PYTHONPATH": str(ROOT)})
        assert r.returncode in (0, 1, 2), (argv, r.returncode, r.stderr[-500:])
        assert "Traceback" not in r.stderr, (argv, r.stderr[-2000:])
        if r.returncode == 2:
            assert len(r.stderr.strip().splitlines()) == 1, (argv, r.stderr)
    assert not (files / "nosuch_top").exists()
