"""DFLC fuzzy controller (paper 003): evaluate a .fll controller on a CSV of inputs.

    python -m sim dflc [--fll FILE] --input IN.csv [--engine model|icarus|verilator|serial:PORT[@BAUD]]
                       [--parallel] [--div lut|array] [--json OUT] [--plot OUT.png]

IN.csv has a header naming the .fll's input variables (any order) and one
sample per row in the variables' own units.  An input whose range is
-180..180 (an angle in degrees, as the Table 1 controller's φ1, φ2) takes
a value outside it wrapped by whole turns (400 is 40, -190 is 170); any
other input saturates at its range.  NaN and infinite values are refused;
at most 1,000,000 samples (64 MiB) are read.  The model engine is
models/dflc.py (bit-exact with the RTL); the icarus / verilator engines emit
the stream top for the .fll (``dflc_stream_<stem>_<hash>``;
``dflc_stream_table1``, the module ``make verilog`` emits, for the shipped
default) and run the samples through it in cocotb
(build/sim/<engine>/<module>/, reused while the .fll is unchanged); the
serial:PORT[@BAUD] engine runs them on a board with the DFLC bitstream
(make bitstream CORE=dflc, built for the same .fll; docs/boards.md) and
compares every output with the model.

Output: without --json the samples and outputs as CSV on stdout; --json
writes outputs (floats, output units), codes (output codes), zero_strength
(booleans: no rule fired, the output is the .fll's default),
cycles_per_sample, latency (clock cycles; the simulator engines report what
they measured, the model and serial engines the design's figures),
rtl_matches_model (serial engine).  --plot plots the control surface of a
2-input controller (model).

Exit status: 0 done; 1 the board's outputs differ from the model's; 2 bad
input (one line on stderr; for the serial engine also a port or a board
that does not answer or runs another controller).
"""

import csv
import hashlib
import json
import math
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np

from navcores.models.tracker import wrap_degrees

from . import serial_engine
from .cli import CliError, add_engine, add_outputs, read_lines, save_figure, write_text
from .progress import Ticker

ROOT = Path(__file__).resolve().parents[1]
MAX_SAMPLES = 1_000_000
MAX_CSV_BYTES = 64 << 20


def add_arguments(p):
    p.add_argument("--fll", default=str(ROOT / "models" / "dflc_table1.fll"),
                   help="controller in fuzzylite's FLL (default: models/dflc_table1.fll, paper Table 1)")
    p.add_argument("--input", required=True, metavar="IN.csv", help="samples: header = input variable names")
    add_engine(p, "the DFLC stream top's RTL in that simulator", serial=True)
    p.add_argument("--parallel", action="store_true", help="RTL: the parallel option (one sample per clock)")
    p.add_argument("--div", choices=("lut", "array"), default="lut", help="divider (Table 2 div_type)")
    add_outputs(p, plot_help="plot the control surface (2-input controllers)")


def load_config(path, div):
    from navcores.models.dflc import FllError, load_fll
    try:
        return load_fll(path, div_type=div)
    except FllError as e:
        raise CliError(str(e)) from None


def read_csv(path, names):
    """(N, n) float array ordered as ``names``; CliError naming the place of any fault."""
    lines = read_lines(path, MAX_CSV_BYTES, "CSV file")
    try:
        rows = list(csv.reader(lines))
    except csv.Error as e:
        raise CliError(f"{path}: not CSV ({e})") from None
    rows = [r for r in rows if any(cell.strip() for cell in r)]
    if not rows:
        raise CliError(f"{path}: empty file; expected a header naming {', '.join(names)}")
    header = [h.strip() for h in rows[0]]
    unknown = [h for h in header if h not in names]
    if unknown:
        raise CliError(f"{path}: unknown variable {unknown[0][:40]!r} in the header "
                       f"(the controller's inputs: {', '.join(names)})")
    missing = [v for v in names if v not in header]
    if missing:
        raise CliError(f"{path}: the header lacks input variable(s) {', '.join(missing)}")
    dup = [h for h in header if header.count(h) > 1]
    if dup:
        raise CliError(f"{path}: variable {dup[0]!r} appears twice in the header")
    if len(rows) < 2:
        raise CliError(f"{path}: no samples after the header")
    if len(rows) - 1 > MAX_SAMPLES:
        raise CliError(f"{path}: {len(rows) - 1} samples; at most {MAX_SAMPLES} are run at once")
    out = np.zeros((len(rows) - 1, len(names)))
    col = {h: k for k, h in enumerate(header)}
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise CliError(f"{path} line {i}: {len(row)} cells, the header has {len(header)}")
        for j, name in enumerate(names):
            cell = row[col[name]].strip()
            try:
                v = float(cell)
            except ValueError:
                raise CliError(f"{path} line {i}, column {name}: {cell[:40]!r} is not a number") from None
            if not math.isfinite(v):
                raise CliError(f"{path} line {i}, column {name}: {cell[:40]} is not a sample (finite numbers only)")
            out[i - 2, j] = v
    return out


def wrap_angles(values, inputs):
    """Inputs whose range is -180..180 are angles in degrees: a value outside
    the range is wrapped by whole turns (the others saturate in the model)."""
    out = np.array(values, dtype=float)
    for j, spec in enumerate(inputs):
        if (spec.lo, spec.hi) == (-180.0, 180.0):
            v = out[:, j]
            out[:, j] = np.where((v < -180) | (v > 180), wrap_degrees(v), v)
    return out


def rtl_params(fll_path, config, div, parallel):
    """The emitted top's parameters.  A controller shipped in models/
    (``dflc_<stem>.fll``, byte for byte) is the module ``make verilog`` emits,
    ``dflc_stream_<stem>`` (one build, shared); any other .fll is copied under
    build/dflc_fll/ as <stem>_<hash>.fll, given by that path: its stem names
    the emitted module and changes with the file's content."""
    data = Path(fll_path).read_bytes()
    tag = None
    for shipped in sorted((ROOT / "models").glob("dflc_*.fll")):
        if shipped.read_bytes() == data:
            tag = shipped.stem[len("dflc_"):]
            break
    if tag is None:
        stem = re.sub(r"[^A-Za-z0-9_]", "_", Path(fll_path).stem) or "fll"
        copy = ROOT / "build" / "dflc_fll" / f"{stem}_{hashlib.sha1(data).hexdigest()[:8]}.fll"
        copy.parent.mkdir(parents=True, exist_ok=True)
        copy.write_bytes(data)
        tag = str(copy)
    params = {"fll": tag}
    if div != "lut":
        params["div"] = div
    if parallel:
        params["par"] = 1
    return params


def run_rtl(params, codes, sim):
    from .rtl.runner import run
    with tempfile.TemporaryDirectory() as tmp:
        job, result = Path(tmp) / "job.json", Path(tmp) / "result.json"
        job.write_text(json.dumps({"params": params, "codes": codes.tolist()}))
        log = ROOT / "build" / "dflc_fll" / f"sim_{sim}.log"
        log.parent.mkdir(parents=True, exist_ok=True)
        run("dflc_stream", params, sim, "navcores.sim.rtl.dflc_job",
            env={"DFLC_JOB": job, "DFLC_RESULT": result}, log_file=log)
        return json.loads(result.read_text())


def plot_surface(model, out):
    c = model.config
    if c.n != 2:
        raise CliError(f"--plot needs a 2-input controller (a control surface); {c.name} has {c.n}")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    a, b = c.inputs
    xs = np.linspace(a.lo, a.hi, 129)
    ys = np.linspace(b.lo, b.hi, 129)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    val, _, zero = model.evaluate(np.stack([X.ravel(), Y.ravel()], axis=1))
    Z = np.where(zero, np.nan, val).reshape(X.shape)
    fig, ax = plt.subplots(figsize=(6, 5))
    im = ax.pcolormesh(ys, xs, Z, shading="auto", cmap="coolwarm")
    fig.colorbar(im, ax=ax, label=c.output_name)
    ax.set_xlabel(b.name)
    ax.set_ylabel(a.name)
    ax.set_title(f"{c.name}: control surface (bit-exact model, {c.sel_op}, {c.div_type})")
    save_figure(fig, out, dpi=100, bbox_inches="tight")
    plt.close(fig)


def run(args):
    from navcores.hdl.dflc.top import stream_latency
    from navcores.models.dflc import Dflc
    serial = serial_engine.is_serial(args.engine)
    if serial:
        serial_engine.check(args.engine)        # the port exists, before any work
    if not Path(args.fll).is_file():
        raise CliError(f"{args.fll}: no such .fll file" if not Path(args.fll).exists() else f"{args.fll}: not a file")
    config = load_config(args.fll, args.div)
    model = Dflc(config)
    if args.plot and config.n != 2:           # before any work
        raise CliError(f"--plot needs a 2-input controller (a control surface); {config.name} has {config.n}")
    values = wrap_angles(read_csv(args.input, model.input_names), config.inputs)
    codes = model.encode(values)
    if args.engine == "model" or serial:
        y, zero = model.infer(codes)
        y, zero = [int(v) for v in y], [bool(v) for v in zero]
        cps = 1 if args.parallel else 1 << config.n
        lat = stream_latency(config, args.parallel)
    if serial:
        with Ticker(f"DFLC on the board ({args.engine})"):
            board_y, board_zero = serial_engine.run_dflc(args.engine, args.fll, config, args.parallel, codes)
        matches = (board_y, board_zero) == (y, zero)
        y, zero = board_y, board_zero
    elif args.engine != "model":
        if shutil.which("iverilog") is None and args.engine == "icarus":
            raise CliError("iverilog not found (Debian: apt-get install iverilog)")
        params = rtl_params(args.fll, config, args.div, args.parallel)
        with Ticker(f"DFLC RTL on {args.engine}"):
            res = run_rtl(params, codes, args.engine)
        y, zero = res["y"], res["zero"]
        ins, outs = res["in_cycles"], res["out_cycles"]
        diffs = sorted(set(np.diff(ins).tolist())) if len(ins) > 1 else []
        cps = diffs[0] if len(diffs) == 1 else (1 if args.parallel else 1 << config.n)
        lat = outs[0] - ins[0]
    outputs = [float(v) for v in model.decode(y)]
    result = {"fll": str(args.fll), "engine": args.engine, "inputs": list(model.input_names),
              "output": model.output_name, "outputs": outputs, "codes": y, "zero_strength": zero,
              "cycles_per_sample": cps, "latency": lat}
    if serial:
        result["rtl_matches_model"] = matches
    if args.json:
        write_text(args.json, json.dumps(result, indent=1))
    else:
        check = f", {'bit-exact against' if matches else 'DIFFERENT from'} the model" if serial else ""
        print(f"{config.name} ({args.engine}): {len(y)} samples, {cps} cycles/sample, latency {lat}{check}")
        print(",".join(model.input_names) + f",{model.output_name},code,zero")
        for row, v, code, z in zip(values, outputs, y, zero):
            print(",".join(f"{x:g}" for x in row) + f",{v:.6g},{code},{int(z)}")
    if args.plot:
        plot_surface(model, args.plot)
    return 0 if not serial or matches else 1
