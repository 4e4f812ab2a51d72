"""The tree is pyflakes-clean: no unused import or local, no undefined name.

pyflakes (a dev dependency, pyproject's ``dev`` extra) reads every .py file
of the folders below as text, without importing it, in a second or two.  A
failure lists its findings (file:line: message), as ``python -m pyflakes``
prints them.
"""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("navcores", "models", "hdl", "sim", "scripts", "tb", "fusesoc", "examples")


def test_no_pyflakes_findings():
    folders = [f for f in FOLDERS if (ROOT / f).is_dir()]
    files = sorted(p for f in folders for p in (ROOT / f).rglob("*.py"))
    assert len(files) > 100, "too few files: is this the project's tree?"
    r = subprocess.run([sys.executable, "-m", "pyflakes", *folders], cwd=ROOT,
                       capture_output=True, text=True, timeout=300)
    assert "No module named pyflakes" not in r.stderr, "pyflakes is missing: pip install -e '.[dev]'"
    assert r.returncode == 0 and not r.stdout, f"pyflakes findings:\n{r.stdout}{r.stderr}"
