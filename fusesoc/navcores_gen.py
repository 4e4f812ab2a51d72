"""FuseSoC generator of the navcores cores: runs ``python -m navcores.hdl.emit``.

FuseSoC calls ``<interpreter> gen_<family>.py <input.yml>`` in an empty
working directory (GAPI 1.0: ``parameters``, ``vlnv``, ``files_root``).
The parameters are ``top`` (a top of this family, see ``python -m hdl.emit
--list``) and that top's parameters; this writes the Verilog, its JSON
manifest and a .core file naming the Verilog, which FuseSoC adds to the
build.  A relative ``fll`` path is taken relative to the calling core.

The Python that runs hdl.emit: $NAVCORES_PYTHON if set, else the
interpreter FuseSoC started (``python3`` on PATH: activate the venv where
navcores is installed, ``pip install -e <clone>``).
"""

import os
import subprocess
import sys
from pathlib import Path

FAMILIES = {"harmonic": "harmonic_", "dflc": "dflc_", "edt_bfs": "edt_"}
DEFAULT_TOP = {"harmonic": "harmonic_planner", "dflc": "dflc_stream", "edt_bfs": "edt_bfs"}


def fail(msg):
    print(f"navcores generator: {msg}", file=sys.stderr)
    sys.exit(1)


def main(family):
    import yaml      # FuseSoC's own dependency

    gapi = yaml.safe_load(Path(sys.argv[1]).read_text())
    params = dict(gapi.get("parameters") or {})
    vlnv = gapi["vlnv"]
    files_root = Path(gapi.get("files_root") or ".")
    top = params.pop("top", DEFAULT_TOP[family])
    if not str(top).startswith(FAMILIES[family]):
        fail(f"top {top!r} is not a {family} top (python -m hdl.emit --list)")
    fll = params.get("fll")
    if fll is not None and str(fll).endswith(".fll") and not Path(str(fll)).is_absolute():
        params["fll"] = str((files_root / str(fll)).resolve())
    # YAML booleans (par: true) are the command line's 1 / 0; null is the default.
    params = {k: int(v) if isinstance(v, bool) else v for k, v in params.items() if v is not None}
    python = os.environ.get("NAVCORES_PYTHON", sys.executable)
    args = [python, "-m", "navcores.hdl.emit", str(top)] + [f"{k}={v}" for k, v in params.items()] + ["-o", "."]
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode:
        err = (r.stderr.strip().splitlines() or ["?"])[-1]
        if "No module named navcores" in r.stderr:
            err = f"{python} cannot import navcores.hdl.emit: pip install <navcores clone> (or set NAVCORES_PYTHON)"
        fail(err)
    verilog = [Path(line).name for line in r.stdout.split() if line.endswith(".v")]
    manifest = [Path(line).name for line in r.stdout.split() if line.endswith(".json")]
    # The generated core: its name is the last-but-one VLNV field (FuseSoC's convention).
    core = vlnv.split(":")[2] + ".core"
    Path(core).write_text(
        "CAPI=2:\n"
        f"name: {vlnv}\n"
        f"description: navcores {top} ({' '.join(args[4:-2]) or 'default parameters'}), "
        f"module {Path(verilog[0]).stem}\n"
        "filesets:\n"
        "  rtl:\n"
        "    files:\n"
        + "".join(f"      - {v}: {{file_type: verilogSource}}\n" for v in verilog)
        + "".join(f"      - {m}: {{file_type: user}}\n" for m in manifest)
        + "targets:\n"
        "  default:\n"
        "    filesets: [rtl]\n")
