"""LiteDRAM's controller for the tile engine's DRAM store: generated, cached, with its CSR map.

``python scripts/litedram_core.py [--sim] [--ports N]`` writes
``build/litedram/<key>/gateware/litedram_core.v`` (and ``csr.csv``) with
``litedram_gen`` from PyPI's litedram (``pip install -e .[dram]``): a
16-bit DDR3 of one MT41K256M16 (the ECPIX-5's) on ECP5DDRPHY, no CPU,
``--ports`` 128-bit native user ports, the system clock SYS_CLK_HZ.  ``--sim``
replaces the PHY and the chips by LiteDRAM's SDRAMPHYModel, through
scripts/litedram_gen_sim.py, which keeps the controller's timing the
ECP5DDRPHY's (its 1:2 rate: a native word every 2 system cycles, tRCD, tRP,
refresh in its cycles; its read and write latencies): what
scripts/bench_dram.py simulates (litedram_gen's own --sim is a 1:4 PHY,
twice the bandwidth).  The key hashes the configuration, litedram's
version and litedram_gen_sim.py, so a second run reads the cache.  Exit 2 with one
line when litedram is not installed.
"""

import argparse
import hashlib
import json
import re
import shutil
import subprocess
import sys
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SYS_CLK_HZ = 75e6       # the ECPIX-5's LiteX system clock: DDR3 at 300 MHz (ECP5DDRPHY is 1:2 rate, sys x 4)
# A native word (128 bits: a burst of 8 on the 16-bit DDR3) holds the DDR3's data bus 4 of its 150 MHz clocks:
# 2 cycles of the system clock.  So the controller moves a native word every 2 cycles at most, whichever ports.
BURST_SYS_CYCLES = 2

# litedram_gen's configuration (its YAML: JSON is YAML)
CONFIG = {
    "speedgrade": 8, "cpu": "None", "memtype": "DDR3", "uart": "rs232", "cmd_latency": 0,
    "sdram_module": "MT41K256M16", "sdram_module_nb": 2, "sdram_rank_nb": 1, "sdram_phy": "ECP5DDRPHY",
    "rtt_nom": "60ohm", "rtt_wr": "60ohm", "ron": "34ohm",
    "input_clk_freq": 100e6, "sys_clk_freq": SYS_CLK_HZ, "init_clk_freq": 25e6, "cmd_buffer_depth": 16,
    # The controller's longest run of reads (of writes) while the other kind waits: LiteDRAM's 32 (16)
    # cycles, 4x.  Each switch costs a turnaround (read to write: the read latency, 12 cycles at ECP5DDRPHY's
    # 13); the tile engine's reads (the next visits') and writes (this one's) come mixed.  room-64-64-8
    # through the simulated controller (3x8 at 37.2 MHz): 36,215 engine cycles -> 33,600 (4x); 8x 33,394.
    "read_time": 128, "write_time": 64,
}

# The part the PHY is generated for (without --sim): the ECPIX-5's.
DEVICE = "LFE5UM5G-85F-8BG554I"

# The controller's CSRs the start-up writes (byte addresses from the generated csr.csv).
CSRS = ("sdram_dfii_control", "ddrctrl_init_done")


class NotInstalled(RuntimeError):
    pass


def _generator():
    exe = shutil.which("litedram_gen", path=str(Path(sys.executable).parent)) or shutil.which("litedram_gen")
    try:
        version = metadata.version("litedram")
    except metadata.PackageNotFoundError:
        version = None
    if exe is None or version is None:
        raise NotInstalled("litedram is not installed: pip install -e '.[dram]' (litedram, litex, migen)")
    return exe, version


def config(ports=1, sim=True):
    """litedram_gen's configuration with ``ports`` native user ports (native_0 ...); with the PHY
    (``sim`` false) for :data:`DEVICE`."""
    if CONFIG.get("cmd_buffer_buffered"):
        # room-64-64-8 through it (both simulation cores, 2026-12-06): results unlike the model's, the EDT's
        # distances already; which side breaks the read-after-write order is not known yet
        raise ValueError("cmd_buffer_buffered: the tile engine's results through LiteDRAM's buffered command "
                         "buffers are wrong (BENCHMARKS.md, the DRAM section)")
    cfg = {**CONFIG, "user_ports": {f"native_{i}": {"type": "native"} for i in range(ports)}}
    return cfg if sim else {**cfg, "device": DEVICE}


def generate(sim=True, ports=1):
    """The generated core with ``ports`` native user ports: (path of litedram_core.v, {csr name: byte
    address})."""
    exe, version = _generator()
    cfg = config(ports, sim)
    # the simulation core from litedram_gen_sim.py (ECP5DDRPHY's rate and latencies): its text in the key
    gen_sim = Path(__file__).with_name("litedram_gen_sim.py")
    what = json.dumps({"config": cfg, "sim": sim, "litedram": version,
                       **({"gen_sim": gen_sim.read_text()} if sim else {})}, sort_keys=True)
    out = ROOT / "build" / "litedram" / hashlib.sha256(what.encode()).hexdigest()[:16]
    core, csv = out / "gateware" / "litedram_core.v", out / "csr.csv"
    if not (core.exists() and csv.exists()):
        out.mkdir(parents=True, exist_ok=True)
        (out / "config.yml").write_text(json.dumps(cfg, indent=1) + "\n")
        cmd = [exe, str(out / "config.yml"), "--output-dir", str(out), "--no-compile", "--soc-csv", str(csv)]
        if sim:
            cmd = [sys.executable, str(gen_sim), *cmd[1:], "--sim"]
        done = subprocess.run(cmd, cwd=out, capture_output=True, text=True)
        if done.returncode != 0 or not core.exists():
            (out / "litedram_gen.log").write_text(done.stdout + done.stderr)
            raise RuntimeError(f"litedram_gen failed (exit {done.returncode}): {out / 'litedram_gen.log'}")
        if not sim:
            # migen declares the DQ and DQS pads, which its TRELLIS_IO drive both ways, as inputs
            text = core.read_text()
            for pad in ("ddram_dq", "ddram_dqs_p"):
                text = re.sub(rf"^(\s*)input(\s+wire\s+(?:\[\d+:0\]\s+)?{pad},)$", r"\1inout\2", text, count=1,
                              flags=re.M)
            core.write_text(text)
    csrs = {}
    for line in csv.read_text().splitlines():
        f = line.split(",")
        if len(f) >= 3 and f[0] == "csr_register" and f[1] in CSRS:
            csrs[f[1]] = int(f[2], 16)
    missing = [c for c in CSRS if c not in csrs]
    if missing:
        raise RuntimeError(f"{csv}: no CSR {', '.join(missing)}")
    return core, csrs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sim", action="store_true", help="with LiteDRAM's DRAM model (for simulation)")
    ap.add_argument("--ports", type=int, default=1, choices=(1, 2, 4, 8), help="native user ports (default 1)")
    args = ap.parse_args(argv)
    try:
        core, csrs = generate(args.sim, args.ports)
    except NotInstalled as e:
        print(f"litedram_core: {e}", file=sys.stderr)
        return 2
    print(core)
    print(", ".join(f"{k} at {v:#x}" for k, v in csrs.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
