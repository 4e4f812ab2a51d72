"""``python -m sim dflc``: results equal the model, errors are one line, the RTL engines
(Icarus and Verilator, one shared ``dflc_stream_table1`` build each) agree."""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from navcores.hdl.emit import top_name
from navcores.models.dflc import DEFAULT_FLL, Dflc
from navcores.sim.cli import CliError, main
from navcores.sim.rtl.runner import SIMULATORS

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = Path(__file__).resolve().parent / "fll"


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def cli(*args):
    return subprocess.run([sys.executable, "-m", "sim", "dflc", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True)


def test_model_engine_json_and_surface(tmp_path):
    csv = write(tmp_path, "in.csv", "phi2,phi1\n0,0\n10,-30\n170,100\n-180,180\n400,-999\n")
    out, png = tmp_path / "o.json", tmp_path / "s.png"
    assert main(["dflc", "--input", str(csv), "--json", str(out), "--plot", str(png)]) == 0
    res = json.loads(out.read_text())
    m = Dflc.from_fll(DEFAULT_FLL)
    # angles (inputs of range -180..180) outside the range wrap by whole turns: -999 is 81, 400 is 40
    vals = np.array([[0, 0], [-30, 10], [100, 170], [180, -180], [81, 40]], dtype=float)
    y, codes, zero = m.evaluate(vals)
    assert res["codes"] == codes.tolist() and res["outputs"] == y.tolist()
    assert res["zero_strength"] == zero.tolist()
    assert res["cycles_per_sample"] == 4 and res["latency"] == 13
    assert png.stat().st_size > 1000


def test_zero_strength_flag(tmp_path):
    csv = write(tmp_path, "in.csv", "x\n0.7\n0.1\n")
    out = tmp_path / "o.json"
    assert main(["dflc", "--fll", str(FIXTURES / "n1.fll"), "--input", str(csv), "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["zero_strength"] == [True, False] and res["outputs"][0] == pytest.approx(0.0, abs=1e-3)


@pytest.mark.parametrize("text,match", [
    ("phi1,theta\n1,2\n", "unknown variable 'theta'"),
    ("phi1\n1\n", "lacks input variable.*phi2"),
    ("phi1,phi2\n1,abc\n", "line 2, column phi2: 'abc' is not a number"),
    ("phi1,phi2\n1,1e999\n", "line 2, column phi2: 1e999 is not a sample"),
    ("phi1,phi2\n1\n", "line 2: 1 cells"),
    ("", "empty file"),
])
def test_bad_csv(tmp_path, text, match):
    csv = write(tmp_path, "in.csv", text)
    with pytest.raises(CliError, match=match):
        from navcores.sim.dflc import run
        import argparse
        run(argparse.Namespace(fll=str(DEFAULT_FLL), input=str(csv), engine="model", parallel=False,
                               div="lut", json=None, plot=None))


def test_errors_are_one_line(tmp_path, capsys):
    csv = write(tmp_path, "in.csv", "a,b\n1,2\n")
    gauss = write(tmp_path, "g.fll", (FIXTURES / "n1.fll").read_text().replace(
        "term: t1 Triangle 0.125 0.375 0.500", "term: t1 Gaussian 0.375 0.1"))
    junk = write(tmp_path, "junk.fll", "this is not FLL\n")
    cases = [
        (("--input", csv), "unknown variable 'a'"),
        (("--fll", gauss, "--input", csv), "term t1 is Gaussian"),
        (("--fll", junk, "--input", csv), "junk.fll"),
        (("--fll", tmp_path / "none.fll", "--input", csv), "no such .fll"),
        (("--input", tmp_path / "none.csv"), "none.csv: no such CSV file"),
        (("--fll", FIXTURES / "n3_prod.fll", "--input", write(tmp_path, "c.csv", "a,b,c\n1,0,2\n"),
          "--plot", tmp_path / "x.png"), "2-input"),
        (("--fll", write(tmp_path, "bin.fll", "x"), "--input", csv), "bin.fll"),
        (("--input", write(tmp_path, "inf.csv", "phi1,phi2\n1,inf\n")), "line 2, column phi2: inf is not a sample"),
        (("--input", write(tmp_path, "nan.csv", "phi1,phi2\nnan,1\n")), "line 2, column phi1: nan is not a sample"),
    ]
    (tmp_path / "bin.fll").write_bytes(b"garbage\x00\xff\x80 not FLL")
    (tmp_path / "bin.csv").write_bytes(b"phi1,phi2\n\xff\xfe,1\n")
    cases.append((("--input", tmp_path / "bin.csv"), r"bin.csv:2: byte 0xff: binary data or not UTF-8"))
    for k, (args, match) in enumerate(cases):
        if k < 2:      # as a user runs it: a subprocess
            r = cli(*args)
            code, err = r.returncode, r.stderr
        else:
            code = main(["dflc", *map(str, args)])
            err = capsys.readouterr().err
        assert code == 2, (args, err)
        assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
        assert __import__("re").search(match, err), (match, err)


def test_rtl_params_share_the_shipped_build(tmp_path):
    """The shipped controller is the module ``make verilog`` emits (one build for
    every run, the regression's too); any other .fll gets a copy named by its content."""
    from navcores.sim.dflc import rtl_params
    copy = write(tmp_path, "mine.fll", DEFAULT_FLL.read_text())
    assert rtl_params(copy, None, "lut", False) == {"fll": "table1"}
    assert rtl_params(DEFAULT_FLL, None, "array", True) == {"fll": "table1", "div": "array", "par": 1}
    changed = write(tmp_path, "mine2.fll", DEFAULT_FLL.read_text() + "\n")
    p = rtl_params(changed, None, "lut", False)
    copy = Path(p["fll"])
    assert copy.parent == ROOT / "build" / "dflc_fll" and re.fullmatch(r"mine2_[0-9a-f]{8}", copy.stem)
    assert copy.read_text() == changed.read_text()
    assert top_name("dflc_stream", p) == f"dflc_stream_{copy.stem}"     # the module carries the stem


@pytest.mark.parametrize("sim", SIMULATORS)
def test_rtl_engine_matches_model(tmp_path, sim):
    """``--engine icarus|verilator`` as a user runs it (a subprocess) on the default
    .fll: the codes, flags, clocks per sample and latency the RTL shows are the
    model's and the design's (dflc_stream_table1: one build per simulator)."""
    rng = np.random.default_rng(5)
    vals = rng.uniform(-200, 200, (24, 2))
    vals[:2] = [[180, -180], [0, 0]]
    csv = write(tmp_path, "in.csv", "phi1,phi2\n" + "\n".join(f"{a},{b}" for a, b in vals) + "\n")
    out = tmp_path / "o.json"
    r = cli("--input", csv, "--engine", sim, "--json", out)
    assert r.returncode == 0, r.stderr[-2000:]
    res = json.loads(out.read_text())
    assert res["engine"] == sim and len(res["codes"]) == len(vals)
    m = Dflc.from_fll(DEFAULT_FLL)
    # the angles beyond +-180 degrees wrap by whole turns (sim dflc's rule): the model on the wrapped values
    wrapped = (vals + 180.0) % 360.0 - 180.0
    wrapped = np.where(np.abs(vals) > 180, wrapped, vals)
    assert (np.abs(vals) > 180).any() and not np.array_equal(wrapped, vals)
    y, codes, zero = m.evaluate(wrapped)
    assert res["codes"] == codes.tolist() and res["zero_strength"] == zero.tolist()
    assert res["outputs"] == y.tolist()
    assert res["cycles_per_sample"] == 4 and res["latency"] == 13
