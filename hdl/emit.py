"""Emit Verilog and a port/parameter manifest for the project's top modules.

Amaranth emits no Verilog parameters, so every parameter set is its own
module: the file and module names carry the parameters
(``harmonic_cluster_depth1024_pmax1022.v``).

    python -m hdl.emit --list [--json]                  # tops, parameters, types, defaults, ranges
    python -m hdl.emit TOP [name=value ...] [-o DIR]    # DIR/<module>.v + DIR/<module>.json
    python -m hdl.emit [OUT_DIR]                        # every top at its listed sets (make verilog)
    python -m hdl.emit --manifests docs/manifests       # only their manifests (the committed copies)

The parameters' types, defaults and ranges are the components' own
declarations (``PARAMS`` / ``CONSTRAINTS`` beside each ``__init__``,
:mod:`hdl.params`), which their ``__init__`` checks.  The manifest
(``<module>.json``) is built from the Amaranth signature: every port with
its direction and width, the stream it belongs to and its role (valid,
ready, payload with the payload's fields and bit ranges), clock and reset,
and the cycle figures of the component's ``timing()``; emitting checks it
against the port list of the Verilog it wrote.  Bad parameters print the
component's one-line message and exit with status 2.
"""

import argparse
import inspect
import json
import os
import re
import sys
from pathlib import Path

os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")

from amaranth.back import verilog  # noqa: E402
from amaranth.hdl import Shape  # noqa: E402
from amaranth.lib import data, stream, wiring  # noqa: E402

from .dflc.core import DflcCore  # noqa: E402
from .dflc.multi import DflcMulti  # noqa: E402
from .dflc.top import DflcStream, config_for  # noqa: E402
from .edt_bfs.array import EdtArray  # noqa: E402
from .edt_bfs.cell import EdtCell  # noqa: E402
from .edt_bfs.edt_bfs import EdtBfs  # noqa: E402
from .edt_bfs.tile_engine import TileEngine  # noqa: E402
from .harmonic.cluster import Cluster  # noqa: E402
from .harmonic.counters import Counters  # noqa: E402
from .harmonic.node import Node  # noqa: E402
from .harmonic.planner import Planner  # noqa: E402
from .harmonic.block import Block  # noqa: E402
from .params import REQUIRED, Param, check, parse  # noqa: E402

__all__ = ["TOPS", "DEFAULT_SETS", "SPECS", "top_name", "emit", "manifest", "params_of", "main"]

# Component factory of every top module, by the name its Verilog carries.
TOPS = {
    "harmonic_node": Node,
    "harmonic_counters": Counters,
    "harmonic_cluster": Cluster,
    "harmonic_block": lambda n, m, br=1, bc=1, p_max=30, depth=1024, exponents=0, e_max=255: Block(
        n, m, (br, bc), p_max, depth, bool(exponents), e_max),
    "harmonic_planner": lambda n=6, m=12, br=2, bc=2, p_max=30, depth=1024, block_exponents=0, e_max=255,
    headroom=1: Planner(n, m, (br, bc), p_max, depth, bool(block_exponents), e_max, headroom),
    # DFLC: fll = a .fll stem (models/dflc_<fll>.fll or tb/dflc/fll/<fll>.fll),
    # widths ip_sz, dy_ip, mf_op_sz, op_sz, div (lut/array), op (sel_op), par (1 = parallel),
    # psr1_no .. psr4_no, cpr1_no .. cpr9_no (Table 2 pipeline registers)
    "dflc_stream": DflcStream,
    "dflc_core": lambda **kw: DflcCore.from_params(**kw),
    "dflc_multi": DflcMulti,     # test top: the regression's configurations in one build
    "edt_cell": EdtCell,
    "edt_array": EdtArray,
    "edt_bfs": EdtBfs,
    "edt_tile_engine": TileEngine,
}

# The class whose PARAMS / CONSTRAINTS a factory above takes (when it is not a class).
SPECS = {
    "harmonic_block": Block,
    "harmonic_planner": Planner,
    "dflc_core": DflcStream,
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
    ("edt_tile_engine", {"t_r": 8, "t_c": 8, "max_h": 64, "max_w": 64}),
]

_SHORT = {"p_max": "pmax", "fll": ""}

# Amaranth's default ``sync`` domain: the clock and reset every top uses.
CLOCK = {"name": "clk", "edge": "rising", "domain": "sync"}
RESET = {"name": "rst", "polarity": "active high", "synchronous": True,
         "effect": "every register to its init value (defined, no X)"}


def _text(key, value):
    s = str(value)
    if key == "fll" and ("/" in s or s.endswith(".fll")):
        s = Path(s).stem                # a path names the module by its stem
    return re.sub(r"[^A-Za-z0-9_]", "_", s)


def top_name(name, params):
    """Module (and file) name of ``name`` at ``params``."""
    tail = "".join(f"_{_SHORT.get(k, k)}{_text(k, v)}" for k, v in sorted(params.items()))
    return name + tail


def params_of(name):
    """(PARAMS, CONSTRAINTS) of top ``name``: the component's declarations."""
    cls = SPECS.get(name, TOPS[name])
    params = getattr(cls, "PARAMS", None)
    if params is None:      # a top without declarations: its signature, no ranges
        sig = inspect.signature(cls)
        params = tuple(
            Param(p.name, type(p.default) if p.default not in (p.empty, None) else int,
                  REQUIRED if p.default is p.empty else p.default, doc="(no declared range)")
            for p in sig.parameters.values() if p.kind is p.POSITIONAL_OR_KEYWORD and p.name != "path")
    return params, getattr(cls, "CONSTRAINTS", ())


def build(name, params):
    """The component of ``name`` at ``params`` (checked by the component itself)."""
    if name not in TOPS:
        raise ValueError(f"unknown top {name!r}; tops: {', '.join(TOPS)}")
    decl, _ = params_of(name)
    missing = [p.name for p in decl if p.default is REQUIRED and p.name not in params]
    if missing:
        raise ValueError(f"{name}: missing parameter{'s' * (len(missing) > 1)} {', '.join(missing)} "
                         f"(see python -m hdl.emit --list)")
    # Types and single ranges of the declared parameters; the component checks
    # the rest (a parameter a top takes but does not declare passes through).
    names = {p.name for p in decl}
    check(decl, **{k: v for k, v in params.items() if k in names})
    return TOPS[name](**params)


# -- manifest

def _fields(shape, offset=0, prefix=""):
    """Payload fields of a layout: name, lsb, msb, width (recursively)."""
    if isinstance(shape, data.Layout):
        out = []
        for key, field in shape:
            sub = f"{prefix}[{key}]" if isinstance(key, int) else (f"{prefix}.{key}" if prefix else key)
            out += _fields(field.shape, offset + field.offset, sub)
        return out
    s = Shape.cast(shape)
    entry = {"name": prefix, "lsb": offset, "msb": offset + s.width - 1, "width": s.width}
    if s.signed:
        entry["signed"] = True
    if isinstance(shape, type) and hasattr(shape, "__members__"):
        entry["enum"] = {m.name: m.value for m in shape}
    return [entry]


def ports_of(component):
    """The component's ports from its signature, in signature order."""
    sig = component.signature
    ports = []
    for path, member_, value in sig.flatten(component):
        shape = value.shape()
        s = Shape.cast(shape)
        port = {"name": "__".join(str(p) for p in path),
                "direction": "input" if member_.flow == wiring.Flow.In else "output",
                "width": s.width}
        if s.signed:
            port["signed"] = True
        member = sig.members[path[0]]
        if member.is_signature and isinstance(member.signature, stream.Signature):
            port["stream"] = path[0]
            port["role"] = path[1]
        if isinstance(shape, data.Layout) or "stream" in port and port["role"] == "payload":
            port["fields"] = _fields(shape)
        ports.append(port)
    return ports


def streams_of(component, ports):
    out = {}
    for name, member in component.signature.members.items():
        if member.is_signature and isinstance(member.signature, stream.Signature):
            s = member.signature
            out[name] = {
                "direction": "sink (into the core)" if member.flow == wiring.Flow.In else "source (out of the core)",
                "valid": f"{name}__valid", "ready": f"{name}__ready", "payload": f"{name}__payload",
                "payload_width": Shape.cast(s.members["payload"].shape).width,
                "always_valid": s.always_valid, "always_ready": s.always_ready,
                "protocol": "a beat moves on a rising clk edge with valid and ready both high; "
                            "valid never depends on ready",
            }
    return out


def _value(component, p, params):
    """The value of parameter ``p``: given, else the default (a derived default,
    None, as the component resolved it, e.g. the cluster's p_max)."""
    if p.name in params:
        return params[p.name]
    if p.default is None and isinstance(getattr(component, p.name, None), (int, str)):
        return getattr(component, p.name)
    return None if p.default is REQUIRED else p.default


def manifest(name, params, component=None):
    """The manifest of ``name`` at ``params`` (a dict; JSON-ready)."""
    if component is None:
        component = build(name, params)
        _silence(component)         # only its signature is read
    decl, constraints = params_of(name)
    timing = component.timing() if hasattr(component, "timing") else {}
    ports = ports_of(component)
    return {
        "module": top_name(name, params),
        "top": name,
        "generator": "python -m hdl.emit " + " ".join([name] + [f"{k}={v}" for k, v in sorted(params.items())]),
        "parameters": {p.name: _value(component, p, params) for p in decl},
        "parameter_spec": [p.describe() for p in decl],
        "constraints": [c.text for c in constraints],
        "clock": CLOCK,
        "reset": RESET,
        "ports": ports,
        "streams": streams_of(component, ports),
        "timing": timing,
        "doc": inspect.getdoc(type(component)).split("\n\n")[0],
    }


def _silence(component):
    """No "created but never used" warning for a component (and the parts its
    constructor built) that is only described, not elaborated."""
    for obj in (component, *vars(component).values()):
        if hasattr(obj, "elaborate"):
            obj._MustUse__silence = True


_PORT = re.compile(r"^\s*(input|output)\s+(?:signed\s+)?(?:\[(\d+):(\d+)\]\s*)?(\S+)\s*;", re.M)


def verilog_ports(text, module):
    """{port: (direction, width)} of ``module`` in emitted Verilog text."""
    start = text.index(f"module {module}(")
    body = text[start:text.index("endmodule", start)]
    return {m[4]: (m[1], int(m[2]) - int(m[3]) + 1 if m[2] else 1) for m in _PORT.finditer(body)}


def emit(name, params, out_dir, with_manifest=True):
    """Write ``out_dir/<top_name>.v`` and ``.json`` (only if their text changed);
    returns the Verilog file's path."""
    module = top_name(name, params)
    component = build(name, params)
    man = manifest(name, params, component) if with_manifest else None
    text = verilog.convert(component, name=module, emit_src=False)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{module}.v"
    _write(path, text)
    if man is not None:
        # The manifest describes what was emitted: same ports, same widths.
        # (Amaranth emits no zero-width port: such a member is absent from the module.)
        want = {p["name"]: (p["direction"], p["width"]) for p in man["ports"] if p["width"]}
        got = verilog_ports(text, module)
        clocking = {k: got.pop(k) for k in (CLOCK["name"], RESET["name"]) if k in got}
        if got != want:
            raise RuntimeError(f"{module}: the manifest's ports differ from the Verilog's: "
                               f"{sorted(set(got.items()) ^ set(want.items()))}")
        if CLOCK["name"] not in clocking:
            man["clock"] = man["reset"] = None
        _write(out / f"{module}.json", json.dumps(man, indent=1) + "\n")
    return path


def manifest_text(name, params):
    """The manifest's JSON text, without emitting (the clock and reset assumed:
    every top has synchronous logic; ``emit`` checks the ports against the Verilog)."""
    return json.dumps(manifest(name, params), indent=1) + "\n"


def _write(path, text):
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


# -- command line

def listing():
    """Every top with its parameters (the components' declarations)."""
    out = {}
    for name in TOPS:
        decl, constraints = params_of(name)
        cls = {"dflc_core": DflcCore}.get(name, SPECS.get(name, TOPS[name]))
        doc = (inspect.getdoc(cls) or "").split("\n")[0]
        out[name] = {"doc": doc, "parameters": [p.describe() for p in decl],
                     "constraints": [c.text for c in constraints]}
    return out


def _print_listing(tops):
    for name, t in tops.items():
        print(f"{name}: {t['doc']}")
        if not t["parameters"]:
            print("    (no parameters)")
        for p in t["parameters"]:
            default = "required" if p["required"] else f"default {p['default']}"
            print(f"    {p['name']}: {p['type']}, {p['allowed']}, {default}"
                  + (f"  -- {p['doc']}" if p["doc"] else ""))
        for c in t["constraints"]:
            print(f"    constraint: {c}")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    # Legacy form (make verilog): no arguments, or one output directory.
    if not argv or (len(argv) == 1 and not argv[0].startswith("-") and argv[0] not in TOPS
                    and "=" not in argv[0]):
        out_dir = argv[0] if argv else "build/verilog"
        for name, params in DEFAULT_SETS:
            print(emit(name, params, out_dir))
        return 0
    ap = argparse.ArgumentParser(
        prog="python -m hdl.emit",
        description="Verilog and a JSON manifest of one top at one parameter set "
                    "(no TOP: every top at its default sets into build/verilog).")
    ap.add_argument("top", nargs="?", help="top name (see --list)")
    ap.add_argument("params", nargs="*", metavar="name=value", help="parameters")
    ap.add_argument("-o", "--out", default=".", help="output directory (default: .)")
    ap.add_argument("--list", action="store_true", help="list the tops and their parameters")
    ap.add_argument("--json", action="store_true", help="with --list: JSON")
    ap.add_argument("--no-manifest", action="store_true", help="Verilog only")
    ap.add_argument("--manifests", metavar="DIR",
                    help="only the manifests of every default set into DIR (docs/manifests)")
    ap.error = lambda msg: _fail(msg)
    args = ap.parse_args(argv)
    if args.list:
        tops = listing()
        if args.json:
            print(json.dumps(tops, indent=1))
        else:
            _print_listing(tops)
        return 0
    if args.manifests:
        for name, params in DEFAULT_SETS:
            path = Path(args.manifests) / f"{top_name(name, params)}.json"
            path.parent.mkdir(parents=True, exist_ok=True)
            _write(path, manifest_text(name, params))
            print(path)
        return 0
    if args.top is None:
        _fail("give a TOP (or --list)")
    try:
        if args.top not in TOPS:
            raise ValueError(f"unknown top {args.top!r}; tops: {', '.join(TOPS)}")
        params = parse(params_of(args.top)[0], args.params)
        path = emit(args.top, params, args.out, with_manifest=not args.no_manifest)
    except (ValueError, TypeError) as e:
        _fail(str(e).splitlines()[0] if str(e) else type(e).__name__)
    print(path)
    if not args.no_manifest:
        print(path.with_suffix(".json"))
    return 0


def _fail(msg):
    print(f"python -m hdl.emit: error: {msg}", file=sys.stderr)
    sys.exit(2)


if __name__ == "__main__":
    sys.exit(main())
