"""The layers import one way, without cycles, and install under one name.

Every .py file of the project is parsed (``ast``; imports inside functions
count) into a graph of project modules, named as they are imported:
models/, hdl/ and sim/ are ``navcores.models``, ``navcores.hdl`` and
``navcores.sim`` (pyproject.toml maps them), the rest by their path
(``tb.dflc.multi``, ``scripts.bench``).  The rules (README "Layout"):

* models/ imports nothing of the project; hdl/ imports models/ (and itself);
  sim/rtl/ (the RTL engines: runner, drivers, jobs) imports hdl/ and models/;
  the other sim/ modules (the commands) import sim/rtl/, hdl/, models/;
  fusesoc/ and examples/ import the installed layers; tb/ and scripts/
  import anything, and nothing else imports them.
* No module imports a layer by its folder name (``hdl.emit``): each module
  has one name, so it is loaded once and its classes are one class.
* The graph has no cycle (a module importing itself, as hdl/emit.py does to
  hand ``python -m hdl.emit`` over to ``navcores.hdl.emit``, is no cycle).

A failure names the file and line of each offending import.
"""

import ast
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("navcores", "models", "hdl", "sim", "scripts", "tb", "fusesoc", "examples")
# The installed layers: folder -> package name (pyproject.toml's package-dir).
LAYERS = {"models": "navcores.models", "hdl": "navcores.hdl", "sim": "navcores.sim"}
ANY = None
# Importer (module name prefix) -> the prefixes it may import; the longest prefix applies.
ALLOWED = {
    "navcores": (),
    "navcores.models": ("navcores.models",),
    "navcores.hdl": ("navcores.hdl", "navcores.models"),
    "navcores.sim.rtl": ("navcores.sim.rtl", "navcores.hdl", "navcores.models"),
    "navcores.sim": ("navcores.sim", "navcores.hdl", "navcores.models"),
    "fusesoc": ("fusesoc", "navcores"),
    "examples": ("examples", "navcores"),
    "tb": ANY,
    "scripts": ANY,
}
# Folders whose own directory is on sys.path when their files run (the
# scripts insert it, pytest's pythonpath lists tb/<core>/, FuseSoC runs the
# generators there): a bare ``import name`` there may name a sibling file.
SIBLINGS = ("scripts", "fusesoc", "tb")
# The project's importable top-level packages (the other folders hold scripts,
# named here by their paths; ``import fusesoc`` is FuseSoC's package).
PACKAGES = ("navcores", "tb")


def _under(name, prefix):
    return name == prefix or name.startswith(prefix + ".")


def module_name(rel):
    """The import name of the file at ``rel`` (a path relative to the root)."""
    parts = list(rel.with_suffix("").parts)
    if parts[0] in LAYERS:
        parts[:1] = LAYERS[parts[0]].split(".")
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def scan(root, folders=FOLDERS):
    """({module: relative path}, [(importer, imported name, level, path, line)]) of every .py file."""
    modules, raw = {}, []
    for folder in folders:
        for path in sorted((root / folder).rglob("*.py")):
            rel = path.relative_to(root)
            if any(p.startswith(".") or p == "__pycache__" for p in rel.parts):
                continue
            name = module_name(rel)
            modules[name] = rel
            for node in ast.walk(ast.parse(path.read_text(), str(rel))):
                if isinstance(node, ast.Import):
                    raw += [(name, a.name, 0, None, rel, node.lineno) for a in node.names]
                elif isinstance(node, ast.ImportFrom):
                    raw.append((name, node.module or "", node.level, [a.name for a in node.names],
                                rel, node.lineno))
    return modules, raw


def resolve(root, modules, raw):
    """The project-internal edges [(importer, imported module, path, line)] and
    the imports that name the project wrongly [(path, line, message)]."""
    edges, bad = [], []
    for src, mod, level, names, rel, line in raw:
        is_pkg = rel.name == "__init__.py"
        if level:
            base = src.split(".")
            base = base[:len(base) - level + (1 if is_pkg else 0)]
            mod = ".".join(base + ([mod] if mod else []))
        else:
            first = mod.split(".")[0]
            sibling = rel.parent / f"{first}.py"
            if rel.parts[0] in SIBLINGS and first not in PACKAGES and (root / sibling).exists():
                mod = module_name(sibling.with_suffix("")) + mod[len(first):]
            elif first in LAYERS:
                bad.append((rel, line, f"imports {mod!r} by its folder name: import {LAYERS[first]}"
                                       f"{mod[len(first):]} (one name per module)"))
                continue
            elif first not in PACKAGES:
                continue                            # not the project's
        # ``from package import module`` imports the module; other names come from ``mod``
        targets = [f"{mod}.{n}" for n in names or () if f"{mod}.{n}" in modules]
        if not targets:
            if mod not in modules:
                bad.append((rel, line, f"imports {mod!r}: no such module in the project"))
                continue
            targets = [mod]
        edges += [(src, t, rel, line) for t in targets if t != src]
    return edges, bad


def violations(edges):
    """'path:line: message' of every import the layer rules forbid."""
    out = []
    for src, dst, rel, line in edges:
        rule = max((p for p in ALLOWED if _under(src, p)), key=len, default=None)
        if rule is None:
            out.append(f"{rel}:{line}: {src} is in no layer (tb/test_layers.py ALLOWED)")
            continue
        allowed = ALLOWED[rule]
        if allowed is ANY:
            continue
        if not any(_under(dst, p) for p in allowed):
            out.append(f"{rel}:{line}: {src} imports {dst}: {rule} may import only "
                       f"{', '.join(allowed) or 'nothing of the project'}")
    return out


def cycles(edges):
    """Each import cycle as 'a -> b (path:line) -> ... -> a' (Tarjan's strongly connected components)."""
    graph = {}
    where = {}
    for src, dst, rel, line in edges:
        graph.setdefault(src, set()).add(dst)
        graph.setdefault(dst, set())
        where.setdefault((src, dst), f"{rel}:{line}")
    index, low, stack, on, comps, counter = {}, {}, [], set(), [], [0]

    def strong(v):
        work = [(v, iter(sorted(graph[v])))]
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        while work:
            node, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    break
                if w in on:
                    low[node] = min(low[node], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == node:
                            break
                    if len(comp) > 1:
                        comps.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            strong(v)
    out = []
    for comp in comps:
        # one cycle through the component, edge by edge, with where each import is
        members, path, node = set(comp), [comp[0]], comp[0]
        seen = {node}
        while True:
            nxt = sorted(w for w in graph[node] if w in members)
            step = next((w for w in nxt if w not in seen), nxt[0])
            path.append(f"{step} ({where[(node, step)]})")
            if step in seen:
                break
            seen.add(step)
            node = step
        out.append(" -> ".join(path))
    return out


def check(root):
    """(modules, edges, rule violations, cycles) of the tree at ``root``."""
    modules, raw = scan(root)
    edges, bad = resolve(root, modules, raw)
    return modules, edges, [f"{rel}:{line}: {msg}" for rel, line, msg in bad] + violations(edges), cycles(edges)


def test_imports_run_one_way():
    modules, edges, bad, _ = check(ROOT)
    assert not bad, "\n".join(bad)
    # the scan sees the layers and their imports (a vacuous graph passes nothing)
    assert {"navcores.hdl.emit", "navcores.sim.rtl.runner", "navcores.models.dflc", "tb.dflc.multi"} <= set(modules)
    assert ("navcores.sim.rtl.runner", "navcores.hdl.emit") in {(s, d) for s, d, *_ in edges}
    assert len(edges) > 200, len(edges)


def test_no_import_cycles():
    _, _, _, found = check(ROOT)
    assert not found, "import cycles:\n" + "\n".join(found)


def test_the_checks_fail_on_a_bad_tree(tmp_path):
    """A synthetic tree with one forbidden import per rule and a cycle: each is
    reported with its file and line."""
    files = {
        "models/a.py": "import numpy\nfrom navcores.hdl import x\n",           # models -> hdl
        "hdl/x.py": "def f():\n    from navcores.sim import y\n",               # hdl -> sim (in a function)
        "sim/y.py": "",
        "hdl/p.py": "from . import q\n",                                        # p -> q -> p
        "hdl/q.py": "\n\ndef g():\n    from .p import g\n",
        "hdl/emit.py": "from hdl import x\n",                                   # a folder name
        "sim/rtl/r.py": "from ..c import main\n",                               # engine -> command
        "sim/c.py": "from tb.helpers import h\n",                               # command -> tb
        "sim/__init__.py": "", "sim/rtl/__init__.py": "", "hdl/__init__.py": "",
        "tb/helpers.py": "from navcores.sim.c import main\nimport navcores.hdl.x\n",   # allowed
        "scripts/s.py": "import t\nfrom navcores.nope import z\n",                     # a sibling; no such module
        "scripts/t.py": "import numpy\nfrom tb import helpers\n",                      # allowed
    }
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    _, _, bad, found = check(tmp_path)
    text = "\n".join(bad)
    for where, what in [("models/a.py:2:", "navcores.models may import only navcores.models"),
                        ("hdl/x.py:2:", "imports navcores.sim.y: navcores.hdl may import only"),
                        ("hdl/emit.py:1:", "by its folder name: import navcores.hdl"),
                        ("sim/rtl/r.py:1:", "navcores.sim.rtl may import only"),
                        ("sim/c.py:1:", "imports tb.helpers"),
                        ("scripts/s.py:2:", "'navcores.nope': no such module")]:
        assert any(line.startswith(where) and what in line for line in bad), (where, what, text)
    assert not any(line.startswith("tb/helpers.py") for line in bad), text
    assert found == ["navcores.hdl.p -> navcores.hdl.q (hdl/p.py:1) -> navcores.hdl.p (hdl/q.py:4)",
                     "navcores.sim.c -> tb.helpers (sim/c.py:1) -> navcores.sim.c (tb/helpers.py:1)"], found


def test_pyproject_installs_the_layers_and_nothing_else():
    """Every package folder of models/, hdl/ and sim/ is in pyproject's package
    list, under navcores, and nothing else is (tb/ and scripts/ are not installed)."""
    tool = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    want = {"navcores"} | {module_name(p.relative_to(ROOT)) for layer in LAYERS
                           for p in (ROOT / layer).rglob("__init__.py") if "__pycache__" not in p.parts}
    assert set(tool["packages"]) == want, sorted(set(tool["packages"]) ^ want)
    assert tool["package-dir"] == {pkg: folder for folder, pkg in LAYERS.items()}


def test_module_names_in_strings_exist():
    """Modules named in strings (the cocotb jobs the runner starts, the
    console script) exist: a move that forgets one fails here, not in a run."""
    modules, _ = scan(ROOT)
    named = []
    for path in [p for d in ("sim", "scripts", "tb") for p in (ROOT / d).rglob("*.py")]:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and re.fullmatch(r"(navcores|tb)(\.\w+)+", node.value):
                named.append((path.relative_to(ROOT), node.lineno, node.value))
    script = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]["navcores-emit"]
    named.append(("pyproject.toml", 0, script.split(":")[0]))
    assert len(named) >= 5, named
    missing = [f"{rel}:{line}: {name}" for rel, line, name in named if name not in modules]
    assert not missing, missing


def _python(*args, cwd):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run([sys.executable, *args], cwd=cwd, env={**env, "AMARANTH_USE_YOSYS": "builtin"},
                          capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("args", [("-m", "navcores.sim", "--help"), ("-m", "navcores.hdl.emit", "--list")])
def test_commands_run_from_any_directory(args, tmp_path):
    """The installed package (``make venv``: editable) runs outside the tree."""
    r = _python(*args, cwd=tmp_path)
    assert r.returncode == 0 and r.stdout, r.stderr
    emit = Path(sys.executable).with_name("navcores-emit")
    if args[1] == "navcores.hdl.emit" and emit.exists():
        r2 = subprocess.run([str(emit), "--list"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
        assert r2.returncode == 0 and r2.stdout == r.stdout, r2.stderr


@pytest.mark.parametrize("module,args,top", [("hdl.emit", ["--list"], "hdl"), ("sim", ["--help"], "sim"),
                                             ("sim.demo", ["--help"], "sim")])
def test_folder_names_load_each_module_once(module, args, top):
    """``python -m hdl.emit`` / ``sim`` / ``sim.demo`` from the root: besides the
    (empty) top-level package runpy imports, every module is loaded as
    navcores.*, once; nothing of hdl/, sim/ or models/ under a second name."""
    code = ("import runpy, sys\n"
            f"sys.argv = [{module!r}, *{args!r}]\n"
            "try:\n"
            f"    runpy.run_module({module!r}, run_name='__main__', alter_sys=True)\n"
            "except SystemExit as e:\n"
            "    assert not e.code, e.code\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('hdl', 'sim', 'models')))\n"
            "print(sum(m.startswith('navcores.') for m in sys.modules))\n")
    r = _python("-c", code, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    *_, twice, navcores = r.stdout.splitlines()
    assert twice == repr([top]), twice
    assert int(navcores) >= 3, r.stdout
