"""scripts/toolchain.py: a tool run finds its inputs when build/cache is a
link to another clone's cache (how a second clone shares the tools' results).

The tool is a stand-in (Python) that reads its input by the relative path the
run hands it; no yosys or nextpnr runs here."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_inputs_reached_through_a_linked_cache(tmp_path, monkeypatch):
    sys.path.insert(0, str(ROOT / "scripts"))
    import toolchain
    real = tmp_path / "other-clone" / "build" / "cache"
    real.mkdir(parents=True)
    clone = tmp_path / "clone" / "build"
    (clone / "fit").mkdir(parents=True)
    (clone / "cache").symlink_to(real)
    design = clone / "fit" / "design.v"
    design.write_text("module top; endmodule\n")
    monkeypatch.setattr(toolchain, "RESULTS", clone / "cache")
    monkeypatch.setattr(toolchain, "prepare", lambda tool, progress=None: f"{tool} stand-in")
    script = "import sys; open('out.txt', 'w').write(open(sys.argv[1]).read())"
    monkeypatch.setattr(toolchain, "argv", lambda tool, args=(): [sys.executable, "-c", script, *args])
    run = toolchain.run("yosys", ["{design}"], {"design": design})
    assert run.returncode == 0 and not run.cached, run.text("stderr.txt")
    assert run.text("out.txt") == design.read_text()
    assert toolchain.run("yosys", ["{design}"], {"design": design}).cached
