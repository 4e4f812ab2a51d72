"""DFLC benchmark: the model against pyfuzzylite over the full input plane.

Every one of the 4096 x 4096 code pairs of the default controller
(models/dflc_table1.fll, Table 2 widths), in chunks: the bit-exact model's
output against pyfuzzylite's evaluation of the same .fll at the decoded codes,
checked against the per-sample bound of models/dflc.py; reports the maximum
error, where it occurs, the bound, and the zero-strength count.  Too long for
the regression (tb/dflc/test_dflc_model.py sweeps ~75k samples).

    .venv/bin/python scripts/dflc_plane.py [--fll FILE] [--rows-per-chunk 64] [--out build/bench/dflc_plane.md]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

from navcores.models.dflc import DEFAULT_FLL, Dflc  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fll", default=str(DEFAULT_FLL))
    ap.add_argument("--rows-per-chunk", type=int, default=64)
    ap.add_argument("--out", default="build/bench/dflc_plane.md")
    args = ap.parse_args()
    import fuzzylite as fl
    m = Dflc.from_fll(args.fll)
    c = m.config
    if c.n != 2:
        sys.exit("error: the plane benchmark takes a 2-input controller")
    engine = fl.FllImporter().from_file(args.fll)
    size = 1 << c.ip_sz
    t0 = time.monotonic()
    worst = (0.0, None, None, None)
    over = zeros = total = 0
    col = np.arange(size)
    for r0 in range(0, size, args.rows_per_chunk):
        rows = np.arange(r0, min(size, r0 + args.rows_per_chunk))
        codes = np.stack(np.meshgrid(rows, col, indexing="ij"), axis=-1).reshape(-1, 2)
        vals = m.decode_inputs(codes)
        engine.input_variables[0].value = vals[:, 0]
        engine.input_variables[1].value = vals[:, 1]
        engine.process()
        ref = np.asarray(engine.output_variables[0].value, dtype=float)
        y, zero = m.infer(codes)
        err = np.abs(m.decode(y) - ref)
        bound = m.error_bound(codes)
        live = ~zero
        over += int((live & ~(err <= bound)).sum())
        zeros += int(zero.sum())
        total += len(codes)
        e = np.where(live, err, -1)
        i = int(np.argmax(e))
        if e[i] > worst[0]:
            worst = (float(e[i]), codes[i].tolist(), float(bound[i]), float(ref[i]))
    elapsed = time.monotonic() - t0
    text = (f"# DFLC model vs pyfuzzylite, full plane\n\n{c.name}: {total} samples "
            f"({size} x {size} codes), {elapsed:.0f} s\n\n"
            f"- max |model - pyfuzzylite| = {worst[0]:.6g} at codes {worst[1]} "
            f"(pyfuzzylite {worst[3]:.6g}, per-sample bound {worst[2]:.6g})\n"
            f"- samples over their bound: {over}\n- zero-strength samples: {zeros}\n"
            f"- output step: {m.output_step:.6g}\n")
    print(text, end="")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
