"""Emit Verilog for the project's top modules, one file per parameter set.

Amaranth emits no Verilog parameters, so every parameter set is its own
module: the file and module names carry the parameters
(``harmonic_cluster_depth1024_pmax1022.v``).

    python -m hdl.emit [OUT_DIR]     # every top at its listed parameter sets
"""

import os
import sys
from pathlib import Path

os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")

from amaranth.back import verilog  # noqa: E402

from .dflc.core import DflcCore  # noqa: E402
from .dflc.multi import DflcMulti  # noqa: E402
from .dflc.top import DflcStream, config_for  # noqa: E402
from .edt_bfs.array import EdtArray  # noqa: E402
from .edt_bfs.cell import EdtCell  # noqa: E402
from .edt_bfs.edt_bfs import EdtBfs  # noqa: E402
from .harmonic.cluster import Cluster  # noqa: E402
from .harmonic.counters import Counters  # noqa: E402
from .harmonic.node import Node  # noqa: E402
from .harmonic.planner import Planner  # noqa: E402
from .harmonic.block import Block  # noqa: E402

__all__ = ["TOPS", "DEFAULT_SETS", "top_name", "emit"]

# Component factory of every top module, by the name its Verilog carries.
TOPS = {
    "harmonic_node": Node,
    "harmonic_counters": Counters,
    "harmonic_cluster": Cluster,
    "harmonic_block": lambda n, m, br=1, bc=1, p_max=30, depth=1024: Block(n, m, (br, bc), p_max, depth),
    "harmonic_planner": lambda n, m, br, bc, p_max, depth: Planner(n, m, (br, bc), p_max, depth),
    # DFLC: fll = a .fll stem (models/dflc_<fll>.fll or tb/dflc/fll/<fll>.fll),
    # widths ip_sz, dy_ip, mf_op_sz, op_sz, div (lut/array), op (sel_op), par (1 = parallel),
    # psr1_no .. psr4_no, cpr1_no .. cpr9_no (Table 2 pipeline registers)
    "dflc_stream": DflcStream,
    "dflc_core": lambda **kw: DflcCore.from_params(**kw),
    "dflc_multi": DflcMulti,     # test top: the regression's configurations in one build
    "edt_cell": EdtCell,
    "edt_array": EdtArray,
    "edt_bfs": EdtBfs,
}

# Parameter sets `make verilog` emits (the tests emit their own on demand).
DEFAULT_SETS = [
    ("harmonic_node", {}),
    ("harmonic_counters", {"p_max": 1022}),
    ("harmonic_cluster", {"depth": 1024}),
    ("harmonic_cluster", {"depth": 1024, "p_max": 255}),
    ("harmonic_block", {"n": 6, "m": 12, "br": 2, "bc": 2, "p_max": 254, "depth": 1024}),
    ("harmonic_planner", {"n": 6, "m": 12, "br": 2, "bc": 2, "p_max": 62, "depth": 256}),
    ("dflc_stream", {"fll": "table1"}),
    ("dflc_core", {"fll": "table1"}),
    ("dflc_core", {"fll": "table1", "par": 1}),
    ("edt_cell", {"height": 32, "width": 32}),
    ("edt_bfs", {"height": 16, "width": 16}),
    ("edt_bfs", {"height": 32, "width": 32}),
]

_SHORT = {"p_max": "pmax", "fll": ""}


def top_name(name, params):
    """Module (and file) name of ``name`` at ``params``."""
    tail = "".join(f"_{_SHORT.get(k, k)}{v}" for k, v in sorted(params.items()))
    return name + tail


def emit(name, params, out_dir):
    """Write ``out_dir/<top_name>.v`` (only if its text changed); returns its path."""
    module = top_name(name, params)
    text = verilog.convert(TOPS[name](**params), name=module, emit_src=False)
    path = Path(out_dir) / f"{module}.v"
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text() != text:
        path.write_text(text)
    return path


def main(argv):
    out_dir = argv[1] if len(argv) > 1 else "build/verilog"
    for name, params in DEFAULT_SETS:
        print(emit(name, params, out_dir))


if __name__ == "__main__":
    main(sys.argv)
