"""Emit Verilog and a port/parameter manifest for the project's top modules.

Amaranth emits no Verilog parameters, so every parameter set is its own
module: the file and module names carry the parameters
(``harmonic_cluster_depth1024_pmax1022.v``).

    python -m hdl.emit --list [--json]                  # tops, parameters, types, defaults, ranges
    python -m hdl.emit TOP [name=value ...] [-o DIR]    # DIR/<module>.v + DIR/<module>.json
    python -m hdl.emit [OUT_DIR]                        # every top at its default sets (make verilog)
    python -m hdl.emit --manifests docs/manifests       # only their manifests (the committed copies)

The parameters' types, defaults and ranges are the components' own
declarations (``PARAMS`` / ``CONSTRAINTS`` beside each ``__init__``,
:mod:`hdl.params`), which their ``__init__`` checks.  The manifest
(``<module>.json``) is built from the Amaranth signature: every port with
its direction and width, the stream it belongs to and its role (valid,
ready, payload with the payload's fields and bit ranges), clock and reset,
and the cycle figures of the component's ``timing()``; emitting checks it
against the port list of the Verilog it wrote.  Bad parameters print the
component's one-line message and exit with status 2.  The default sets are
the catalog's (:mod:`hdl.catalog`, with the papers' figures).
"""

if __name__ == "__main__":
    # `python -m navcores.hdl.emit`, or `python -m hdl.emit` in a source tree:
    # run the module under its package name, so that no class is loaded a
    # second time as __main__'s (or as the top-level hdl's).
    import sys
    from navcores.hdl.emit import main
    sys.exit(main())

import argparse
import inspect
import json
import os
import re
import sys
from pathlib import Path

os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")

from amaranth.back import verilog  # noqa: E402
from amaranth.hdl import Const, Shape, ValueCastable  # noqa: E402
from amaranth.lib import data, stream, wiring  # noqa: E402

# The sets `make verilog` emits (the tests emit their own): the catalog's.
from .catalog import DEFAULT_SETS  # noqa: E402
from .dflc.core import DflcCore  # noqa: E402
from .dflc.top import DflcStream, core_from_params  # noqa: E402
from .edt_bfs.array import EdtArray  # noqa: E402
from .edt_bfs.cell import EdtCell  # noqa: E402
from .edt_bfs.edt_bfs import EdtBfs  # noqa: E402
from .edt_bfs.dram_stores import DramStores  # noqa: E402
from .edt_bfs.tile_engine import TileEngine  # noqa: E402
from .harmonic.border import Border  # noqa: E402
from .harmonic.cluster import Cluster  # noqa: E402
from .harmonic.counters import Counters  # noqa: E402
from .harmonic.decision import Decision  # noqa: E402
from .harmonic.node import Node  # noqa: E402
from .harmonic.node_exponents import NodeExponentUpdate  # noqa: E402
from .harmonic.node_exponent_engine import NodeExponentEngine  # noqa: E402
from .harmonic.planner import Planner  # noqa: E402
from .harmonic.block import Block  # noqa: E402
from .ram_init import strip_undefined_init  # noqa: E402
from .params import REQUIRED, Param, check, parse, unelaborated  # noqa: E402

__all__ = ["TOPS", "DEFAULT_SETS", "SPECS", "top_name", "emit", "manifest", "params_of", "main"]

# Component factory of every top module, by the name its Verilog carries.
TOPS = {
    "harmonic_node": Node,
    "harmonic_counters": Counters,
    "harmonic_cluster": Cluster,
    "harmonic_decision": Decision,
    # issue 22: the node update of node exponents, a pipeline between two streams
    "harmonic_node_exponents": NodeExponentUpdate,
    # issue 22: node exponents over a whole map in block RAM (red-black, in place, to a fixed point)
    "harmonic_node_exponent_engine": NodeExponentEngine,
    # the border storage of an n x m block, for its unit test and synthesis
    "harmonic_border": lambda n, m, br=1, bc=1, p_max=30, exponents=0, e_max=255: Border(
        n, m, (br, bc), p_max, bool(exponents), e_max),
    "harmonic_block": lambda n, m, br=1, bc=1, p_max=30, depth=1024, exponents=0, e_max=255: Block(
        n, m, (br, bc), p_max, depth, bool(exponents), e_max),
    "harmonic_planner": lambda n=6, m=12, br=2, bc=2, p_max=30, depth=1024, block_exponents=0, e_max=255,
    headroom=1, paper_schedule=0: Planner(n, m, (br, bc), p_max, depth, bool(block_exponents), e_max, headroom,
                                          bool(paper_schedule)),
    # DFLC: fll = a .fll path or the stem of a shipped one (models/dflc_<fll>.fll),
    # widths ip_sz, dy_ip, mf_op_sz, op_sz, div (lut/array), op (sel_op), par (1 = parallel),
    # psr1_no .. psr4_no, cpr1_no .. cpr9_no (Table 2 pipeline registers)
    "dflc_stream": DflcStream,
    "dflc_core": core_from_params,
    "edt_cell": EdtCell,
    # The array's cells instantiate one module, named after the top (instance_modules).
    "edt_array": lambda height, width: EdtArray(height, width, cell_module=_cell_module("edt_array", height, width)),
    "edt_bfs": lambda height, width: EdtBfs(height, width, cell_module=_cell_module("edt_bfs", height, width)),
    "edt_tile_engine": TileEngine,
    # the tile engine's DRAM side (store="dram"), on the controller's clock: its own top for the fit flow
    "edt_dram_stores": DramStores,
}

# The class whose PARAMS / CONSTRAINTS a factory above takes (when it is not a class).
SPECS = {
    "harmonic_border": Border,
    "harmonic_block": Block,
    "harmonic_planner": Planner,
    "dflc_core": DflcStream,
    "edt_array": EdtArray,
    "edt_bfs": EdtBfs,
}

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


def _cell_module(top, height, width):
    """The EDT/BFS cell's module name in the Verilog of ``top``: ``<top module>_cell``."""
    return top_name(top, {"height": height, "width": width}) + "_cell"


def params_of(name, factory=None):
    """(PARAMS, CONSTRAINTS) of top ``name``: the component's declarations
    (``factory``'s, for a top that is not in TOPS)."""
    cls = factory or SPECS.get(name, TOPS[name])
    params = getattr(cls, "PARAMS", None)
    if params is None:      # a top without declarations: its signature, no ranges
        sig = inspect.signature(cls)
        params = tuple(
            Param(p.name, type(p.default) if p.default not in (p.empty, None) else int,
                  REQUIRED if p.default is p.empty else p.default, doc="(no declared range)")
            for p in sig.parameters.values() if p.kind is p.POSITIONAL_OR_KEYWORD and p.name != "path")
    return params, getattr(cls, "CONSTRAINTS", ())


def build(name, params, factory=None):
    """The component of ``name`` at ``params`` (checked by the component itself).

    ``factory``: the component class (or a function of the parameters) of a
    top that is not in TOPS, e.g. a test's own top; ``name`` then only names
    its module (:func:`top_name`)."""
    if factory is None and name not in TOPS:
        raise ValueError(f"unknown top {name!r}; tops: {', '.join(TOPS)}")
    decl, _ = params_of(name, factory)
    missing = [p.name for p in decl if p.default is REQUIRED and p.name not in params]
    if missing:
        raise ValueError(f"{name}: missing parameter{'s' * (len(missing) > 1)} {', '.join(missing)} "
                         f"(see python -m hdl.emit --list)")
    # Types and single ranges of the declared parameters; the component checks
    # the rest (a parameter a top takes but does not declare passes through).
    names = {p.name for p in decl}
    check(decl, **{k: v for k, v in params.items() if k in names})
    return (factory or TOPS[name])(**params)


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


def _signature_ports(component):
    """(path, member, value) of every port of the component's signature that
    becomes a module port: a constant member (the ``ready`` of an
    ``always_ready`` stream, the ``valid`` of an ``always_valid`` one) is
    none.  Amaranth 0.5 refuses constants as ports
    (amaranth-lang/amaranth#1574), so :func:`emit` passes these explicitly."""
    return [(path, member, value) for path, member, value in component.signature.flatten(component)
            if not isinstance(value, Const)]


def _convert(component, module):
    """The component's Verilog: ``verilog.convert`` with the ports it would
    take from the signature itself, minus the constant members; memories made
    by :func:`~hdl.ram_init.undefined_memory` without their initial blocks."""
    from amaranth.hdl._ir import PortDirection     # what verilog.convert uses for a component's ports
    ports = {}
    for path, member, value in _signature_ports(component):
        value = value.as_value() if isinstance(value, ValueCastable) else value
        ports["__".join(map(str, path))] = (
            value, PortDirection.Input if member.flow == wiring.Flow.In else PortDirection.Output)
    return strip_undefined_init(verilog.convert(component, name=module, emit_src=False, ports=ports))


def ports_of(component):
    """The component's ports from its signature, in signature order."""
    sig = component.signature
    ports = []
    for path, member_, value in _signature_ports(component):
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
                "valid": None if s.always_valid else f"{name}__valid",
                "ready": None if s.always_ready else f"{name}__ready",
                "payload": f"{name}__payload",
                "payload_width": Shape.cast(s.members["payload"].shape).width,
                "always_valid": s.always_valid, "always_ready": s.always_ready,
                "protocol": ("a beat moves on a rising clk edge with valid and ready both high; "
                             "valid never depends on ready") if not s.always_ready else
                            ("always_ready, no ready port (no back-pressure): a beat moves on every "
                             "rising clk edge with valid high; the consumer must take it"),
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


def manifest(name, params, component=None, factory=None):
    """The manifest of ``name`` at ``params`` (a dict; JSON-ready); ``factory`` as in :func:`build`."""
    if component is None:
        component = unelaborated(build(name, params, factory))     # only described
    decl, constraints = params_of(name, factory)
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


_TOP_ATTR = "(* top =  1  *)\n"          # as yosys' write_verilog prints the attribute

_PORT = re.compile(r"^\s*(input|output|inout)\s+(?:signed\s+)?(?:\[(\d+):(\d+)\]\s*)?(\S+)\s*;", re.M)


def verilog_ports(text, module):
    """{port: (direction, width)} of ``module`` in emitted Verilog text."""
    start = text.index(f"module {module}(")
    body = text[start:text.index("endmodule", start)]
    return {m[4]: (m[1], int(m[2]) - int(m[3]) + 1 if m[2] else 1) for m in _PORT.finditer(body)}


def emit(name, params, out_dir, with_manifest=True, factory=None, before_work=None):
    """Write ``out_dir/<top_name>.v`` and ``.json`` (only if their text changed,
    both after the manifest is checked, each replaced in one step); returns
    the Verilog file's path.  ``factory`` as in :func:`build`;
    ``before_work()``: called once the component accepted its parameters,
    before the conversion (the command line checks the output folder there)."""
    module = top_name(name, params)
    component = build(name, params, factory)
    if before_work is not None:
        try:
            before_work()
        except BaseException:
            unelaborated(component)         # refused before any work: never elaborated
            raise
    man = manifest(name, params, component, factory) if with_manifest else None
    text = verilog_text(component, module)
    out = Path(out_dir)
    path = out / f"{module}.v"
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
    out.mkdir(parents=True, exist_ok=True)
    _write(path, text)
    if man is not None:
        _write(out / f"{module}.json", json.dumps(man, indent=1) + "\n")
    return path


def verilog_text(component, module):
    """The Verilog of ``component`` as module ``module``, followed by the
    modules it instantiates by name (``component.instance_modules()``:
    {module name: component}, e.g. the EDT/BFS array's cell), each converted
    under its name: one self-contained file.  Only ``module`` keeps the
    ``top`` attribute, so tools that look for it find the one top."""
    text = _convert(component, module)
    for sub_name, sub in getattr(component, "instance_modules", dict)().items():
        text += _convert(sub, sub_name).replace(_TOP_ATTR, "", 1)
    return text


def manifest_text(name, params):
    """The manifest's JSON text, without emitting (the clock and reset assumed:
    every top has synchronous logic; ``emit`` checks the ports against the Verilog)."""
    return json.dumps(manifest(name, params), indent=1) + "\n"


def _write(path, text):
    """``text`` into ``path`` if it differs, through a temporary file renamed
    over it (no partial file)."""
    if path.exists() and path.read_text() == text:
        return
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


# -- command line

def plain(text):
    """Docstring text as plain words: Sphinx roles and literals unwrapped
    (:class:`~a.B` -> B, ``x`` -> x), lines joined."""
    text = re.sub(r":[a-z]+:`~?([^`<]*?)(?:\s*<[^>]*>)?`", lambda m: m[1].split(".")[-1] if m[0].count("~")
                  else m[1], text)
    text = re.sub(r"``([^`]*)``", r"\1", text)
    text = re.sub(r"`([^`]*)`", r"\1", text)
    return " ".join(text.split())


def _summary(cls):
    """The first paragraph of a class's docstring, whole and plain."""
    doc = inspect.getdoc(cls) or ""
    return plain(doc.split("\n\n")[0])


def listing():
    """Every top with its parameters (the components' declarations)."""
    out = {}
    for name in TOPS:
        decl, constraints = params_of(name)
        cls = {"dflc_core": DflcCore}.get(name, SPECS.get(name, TOPS[name]))
        params = []
        for p in decl:
            d = p.describe()
            d["doc"] = plain(d["doc"])
            params.append(d)
        out[name] = {"doc": _summary(cls), "parameters": params,
                     "constraints": [c.text for c in constraints],
                     "constraint_reasons": {c.text: c.why for c in constraints if getattr(c, "why", "")}}
    return out


def _print_listing(tops, width=100):
    import textwrap
    wrap = lambda text, indent: textwrap.fill(text, width, initial_indent=indent,       # noqa: E731
                                              subsequent_indent=indent + "    ")
    for name, t in tops.items():
        print(wrap(f"{name}: {t['doc']}", ""))
        if not t["parameters"]:
            print("    (no parameters)")
        for p in t["parameters"]:
            default = ("required" if p["required"] else "default derived (see its text)" if p["default"] is None
                       else f"default {int(p['default']) if isinstance(p['default'], bool) else p['default']}")
            print(wrap(f"{p['name']}: {p['type']}, {p['allowed']}, {default}"
                       + (f" -- {p['doc']}" if p["doc"] else ""), "    "))
        for c in t["constraints"]:
            why = t.get("constraint_reasons", {}).get(c)
            print(wrap(f"constraint: {c}" + (f" ({why})" if why else ""), "    "))


EXIT_STATUS = "exit status: 0 done; 2 bad input (one line on stderr, nothing written)"


def _fail(msg, status=2):
    print(f"python -m hdl.emit: error: {msg}", file=sys.stderr)
    raise SystemExit(status)


def _out_dir(path, option):
    """A folder the command can write into: created if missing, checked by
    writing a probe file (before any work)."""
    import tempfile
    p = Path(path)
    if p.exists() and not p.is_dir():
        _fail(f"{option} {path}: is a file, not a folder")
    try:
        p.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=p, prefix=".emit_probe_"):
            pass
    except OSError as e:
        _fail(f"{option} {path}: cannot write there ({e.strerror or e})")
    return p


def _is_folder(arg):
    """The legacy form's lone argument: a folder (a path with a separator, or
    an existing folder), never a word that could be a misspelt top."""
    return "/" in arg or os.sep in arg or Path(arg).is_dir()


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        return _main(argv)
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else 2
    except (ValueError, TypeError) as e:
        return _status(str(e).splitlines()[0] if str(e) else type(e).__name__)
    except OSError as e:
        name = f"{e.filename}: " if getattr(e, "filename", None) else ""
        return _status(f"{name}{e.strerror or e}")
    except MemoryError:
        return _status("out of memory: these parameters need more than this machine has")
    except KeyboardInterrupt:
        print("python -m hdl.emit: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # noqa: BLE001 - one line, never a traceback
        if os.environ.get("EMIT_DEBUG") == "1":
            raise
        return _status(f"internal error: {type(e).__name__}: {e} (EMIT_DEBUG=1 shows the traceback)", 70)


def _status(msg, status=2):
    try:
        _fail(msg, status)
    except SystemExit as e:
        return e.code


def _main(argv):
    # Legacy form (make verilog): no arguments, or one output folder.
    if not argv or (len(argv) == 1 and not argv[0].startswith("-") and argv[0] not in TOPS
                    and "=" not in argv[0] and _is_folder(argv[0])):
        out_dir = _out_dir(argv[0] if argv else "build/verilog", "OUT_DIR")
        for name, params in DEFAULT_SETS:
            print(emit(name, params, out_dir))
        return 0
    ap = argparse.ArgumentParser(
        prog="python -m hdl.emit",
        description="Verilog and a JSON manifest of one top at one parameter set "
                    "(no TOP: every top at its default sets into build/verilog; a lone folder path "
                    "(with a '/') instead of TOP: into that folder).",
        epilog=EXIT_STATUS)
    ap.add_argument("top", nargs="?", help="top name (see --list)")
    ap.add_argument("params", nargs="*", metavar="name=value", help="parameters")
    ap.add_argument("-o", "--out", default=".", help="output folder (default: .; created if missing)")
    ap.add_argument("--list", action="store_true", help="list the tops and their parameters, with their bounds")
    ap.add_argument("--json", action="store_true", help="with --list: JSON")
    ap.add_argument("--no-manifest", action="store_true", help="Verilog only")
    ap.add_argument("--manifests", metavar="DIR",
                    help="only the manifests of every default set into DIR (docs/manifests)")
    ap.error = lambda msg: _fail(f"{msg} (see --help)")
    args = ap.parse_args(argv)
    if args.list:
        tops = listing()
        if args.json:
            print(json.dumps(tops, indent=1))
        else:
            _print_listing(tops)
        return 0
    if args.manifests:
        out = _out_dir(args.manifests, "--manifests")
        texts = [(out / f"{top_name(name, params)}.json", manifest_text(name, params))
                 for name, params in DEFAULT_SETS]
        for path, text in texts:
            _write(path, text)
            print(path)
        return 0
    if args.top is None:
        _fail("give a TOP (or --list)")
    if args.top not in TOPS:
        hint = (f" (a folder for every default set is a path: python -m hdl.emit ./{args.top})"
                if not args.params and "=" not in args.top else "")
        _fail(f"unknown top {args.top!r}; tops: {', '.join(TOPS)}{hint}")
    params = parse(params_of(args.top)[0], args.params)
    # the component's own checks first, then the output folder, then the work
    path = emit(args.top, params, args.out, with_manifest=not args.no_manifest,
                before_work=lambda: _out_dir(args.out, "-o"))
    print(path)
    if not args.no_manifest:
        print(path.with_suffix(".json"))
    return 0
