"""A DFLC controller of a given size for the fit flow: n inputs with m triangular MFs each.

    python scripts/dflc_grid.py N M [--singletons S] [--rules full|diagonal] --out FILE.fll

Each input ranges over [0, m-1] with m triangles peaking at 0, 1, .., m-1
(overlap 2, a partition of unity: the end triangles reach outside the
range).  The output has S singletons (default 7) spread over [0, 1].
``--rules full`` (default) writes every combination of MFs as a rule, the
singleton index being the sum of the MF indices modulo S; ``diagonal`` only
the m rules "all inputs in MF j".  The rule ROM of the core holds m^n words
either way (missing rules read "no rule"), so both give the same hardware
size; ``diagonal`` keeps the .fll small when m^n is large.  Used by
scripts/bench.py for the largest DFLC that fits a part (issue 17).
"""

import argparse
import itertools
import sys
from pathlib import Path


def grid_fll(n, m, singletons=7, rules="full"):
    """The .fll text of an n-input, m-MF controller (see the module docstring)."""
    if not 1 <= n <= 4 or not 2 <= m <= 64 or not 1 <= singletons <= 64:
        raise ValueError(f"n = {n}, m = {m}, singletons = {singletons}: expected 1..4, 2..64, 1..64")
    names = "abcd"[:n]
    out = [f"Engine: grid_{n}x{m}"]
    for v in names:
        out += [f"InputVariable: {v}", "  enabled: true", f"  range: 0.000 {m - 1:.3f}", "  lock-range: false"]
        out += [f"  term: t{j} Triangle {j - 1:.3f} {j:.3f} {j + 1:.3f}" for j in range(m)]
    out += ["OutputVariable: y", "  enabled: true", "  range: 0.000 1.000", "  lock-range: false",
            "  aggregation: none", "  defuzzifier: WeightedAverage TakagiSugeno", "  default: nan",
            "  lock-previous: false"]
    out += [f"  term: s{k} Constant {k / max(singletons - 1, 1):.3f}" for k in range(singletons)]
    out += ["RuleBlock: rules", "  enabled: true", "  conjunction: Minimum", "  disjunction: none",
            "  implication: none", "  activation: General"]
    combos = itertools.product(range(m), repeat=n) if rules == "full" else ((j,) * n for j in range(m))
    for idx in combos:
        ante = " and ".join(f"{v} is t{j}" for v, j in zip(names, idx))
        out.append(f"  rule: if {ante} then y is s{sum(idx) % singletons}")
    return "\n".join(out) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("n", type=int)
    ap.add_argument("m", type=int)
    ap.add_argument("--singletons", type=int, default=7)
    ap.add_argument("--rules", choices=("full", "diagonal"), default="full")
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    try:
        text = grid_fll(args.n, args.m, args.singletons, args.rules)
    except ValueError as e:
        print(f"dflc_grid: error: {e}", file=sys.stderr)
        return 2
    Path(args.out).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
