"""The simulated DDR3 controller keeps the ECPIX-5's timing (scripts/litedram_gen_sim.py).

litedram_gen's own ``--sim`` core is a 1:4 PHY: its controller takes a
native word every system cycle and reads in 8, where the ECPIX-5's
(ECP5DDRPHY, 1:2) takes one every 2 and reads in 13, so a DRAM bench on
it is twice too fast where the DDR3's bus bounds the job.  Here the
simulation core's timing counters (every ``*con`` reload value: tCCD, tWTR,
tRRD, tRP, tRCD, tRAS, tRC, write to precharge, ...; the refresh timer) and
its read and write latencies must equal the core generated for the
ECPIX-5's part, and litedram_gen's plain ``--sim`` core must differ (the
comparison can see it).  Needs litedram (``pip install -e .[dram]``): skipped
without it.
"""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))

import litedram_core  # noqa: E402

pytest.importorskip("litedram", reason="litedram not installed (pip install -e .[dram])")

# a counter's load: "[soc_]litedramcore_<name> <= N'dV;", <name> with "count" or "timer" in it
RELOAD = re.compile(r"(?:soc_)?litedramcore_(\w*(?:count|timer)\w*) <= \d+'d(\d+);")


def timings(core):
    """{counter: sorted reload values} of a generated core."""
    found = {}
    for name, value in RELOAD.findall(Path(core).read_text()):
        found.setdefault(name, set()).add(int(value))
    return {k: sorted(v) for k, v in found.items()}


def test_sim_core_has_the_ecpix5_timing(tmp_path):
    sim, _ = litedram_core.generate(sim=True, ports=1)
    real, _ = litedram_core.generate(sim=False, ports=1)
    t_sim, t_real = timings(sim), timings(real)
    assert {"tccdcon_count", "twtrcon_count", "trrdcon_count"} <= set(t_real), sorted(t_real)
    assert len(t_real) > 20, sorted(t_real)
    assert t_sim == t_real, {k: (t_sim.get(k), v) for k, v in t_real.items() if t_sim.get(k) != v}
    # the model's read latency: a pipeline register a cycle (ECP5DDRPHY's cl_sys_latency + 10 = 13 at 75 MHz)
    assert len(set(re.findall(r"_new_banks_read(\d+)\b", Path(sim).read_text()))) == 13

    # litedram_gen's own --sim core (a 1:4 PHY) differs, so the comparison above can fail
    plain = tmp_path / "plain"
    plain.mkdir()
    cfg = plain / "config.yml"
    cfg.write_text(json.dumps(litedram_core.config(1, True)))
    exe, _ = litedram_core._generator()
    subprocess.run([exe, str(cfg), "--output-dir", str(plain), "--no-compile", "--sim"], cwd=plain, check=True,
                   capture_output=True)
    t_plain = timings(plain / "gateware" / "litedram_core.v")
    assert t_plain != t_real and t_plain["tccdcon_count"] == [0], t_plain["tccdcon_count"]
