"""Regenerate golden.hex, the expected outputs of the DFLC example, from the golden model.

    python examples/dflc_stream/make_golden.py

Reads the generator parameters of dflc_stream_example.core (one place for
them), draws the samples with a fixed seed (plus the corners), and runs
``models.dflc.Dflc.infer``, bit-exact with the RTL.  One line per sample,
35 bits: [9:0] input 0 code, [19:10] input 1 code, [33:20] y, [34] zero.
"""

import sys
from pathlib import Path

import numpy as np
import yaml

from navcores.hdl.dflc.top import config_for, split_params
from navcores.models.dflc import Dflc

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))   # examples/golden_files.py
from golden_files import run, write_or_check  # noqa: E402

N = 24
SEED = 2024


def main(check=False):
    """Write the files (``check``: only compare them with the stored ones; True if equal)."""
    files = {}
    core = yaml.safe_load((HERE / "dflc_stream_example.core").read_text())
    params = dict(core["generate"]["flc"]["parameters"])
    assert params.pop("top") == "dflc_stream"
    widths, _, _ = split_params(params)   # parallel / pipeline registers do not change the values
    config = config_for(**widths)
    assert config.n == 2 and config.ip_sz == 10 and config.op_sz == 14, "tb_dflc_stream.v assumes these"
    full = (1 << config.ip_sz) - 1
    rng = np.random.default_rng(SEED)
    codes = np.concatenate([[[0, 0], [full, full], [0, full], [full // 2, full // 2]],
                            rng.integers(0, full + 1, size=(N - 4, 2))])
    y, zero = Dflc(config).infer(codes)
    lines = [
        "// golden values of examples/dflc_stream: python examples/dflc_stream/make_golden.py",
        f"// {params}; seed {SEED}",
        "// [9:0] input 0, [19:10] input 1, [33:20] y, [34] zero",
    ]
    for (c0, c1), yy, zz in zip(codes, y, zero):
        word = int(c0) | int(c1) << 10 | int(yy) << 20 | int(zz) << 34
        lines.append(f"{word:09x}")
    files["golden.hex"] = ("\n".join(lines) + "\n")
    print(f"golden.hex: {len(codes)} samples, {int(zero.sum())} with zero strength")
    return write_or_check(HERE, files, check)


if __name__ == "__main__":
    run(main)
