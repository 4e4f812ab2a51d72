"""``litedram_gen --sim`` with the controller's timing of the ECPIX-5's core (ECP5DDRPHY), for the DRAM benches.

    python scripts/litedram_gen_sim.py CONFIG.yml --output-dir DIR ... --sim

litedram_gen's simulation core replaces the PHY by LiteDRAM's DRAM model
(``SDRAMPHYModel``), and with it the rate: the model is a 1:4 PHY for a
DDR3 (DDR3-600 at a 75 MHz system clock), where the ECPIX-5's ECP5DDRPHY is
1:2 (DDR3-300).  The controller's timing in system cycles follows the
rate: at 1:4 it takes a native word every cycle (tCCD, 4 DRAM clocks, is
one system cycle), twice what the ECP5's DDR3 bus carries, and its read
latency is 8 cycles against ECP5DDRPHY's 13.  This runs litedram_gen with
the DRAM module at the ECP5DDRPHY's rate (tCCD, tWTR, tRRD and the
nanosecond timings in its system cycles: a native word every 2 cycles) and
the model's read and write latencies ECP5DDRPHY's (litedram/phy/ecp5ddrphy.py:
``cl_sys_latency + 10``, ``cwl_sys_latency`` at its DRAM clock, twice the
system clock), so every timing counter of the controller is the one
generated for the ECPIX-5 (tb/fpga/test_litedram_sim.py); the model keeps its 4 DFI phases (where a burst's data
cross the DFI in one cycle, as on ECP5DDRPHY's 2 phases of 4 beats).
What it still does not model: the ECP5's I/O (its delays and read
leveling, calibrated at start-up on a board).
"""

import sys

ECP5_PHASES = 2         # ECP5DDRPHY's DFI phases: its rate 1:2
ECP5_READ_EXTRA = 10    # ECP5DDRPHY's read latency past CL, in system cycles (its settings: cl_sys_latency + 10)


def _patch():
    import litex.tools.litex_sim as litex_sim
    from litedram import modules
    from litedram.common import get_default_cl, get_default_cwl, get_sys_latency
    from litedram.phy import model

    model_settings = model.get_sdram_phy_settings

    def ecp5_settings(memtype, data_width, clk_freq):
        settings = model_settings(memtype, data_width, clk_freq)
        tck = 1 / (ECP5_PHASES * clk_freq)          # ECP5DDRPHY's DRAM clock: twice the system clock
        cwl_cycles = get_sys_latency(ECP5_PHASES, get_default_cwl(memtype, tck))
        settings.read_latency = get_sys_latency(ECP5_PHASES, get_default_cl(memtype, tck)) + ECP5_READ_EXTRA
        settings.write_latency = cwl_cycles
        # The controller's bank machines and multiplexer take the write latency as ceil(cwl / phases)
        # system cycles (write to precharge, write to read): the CWL that gives ECP5DDRPHY's at the
        # model's phases (the model itself does not read cwl; start-up in simulation skips the mode registers).
        settings.cwl = cwl_cycles * settings.nphases
        return settings

    model.get_sdram_phy_settings = litex_sim.get_sdram_phy_settings = ecp5_settings
    for name in dir(modules):                       # every DRAM module at ECP5DDRPHY's rate
        cls = getattr(modules, name)
        if isinstance(cls, type) and issubclass(cls, modules.SDRAMModule) and getattr(cls, "memtype", None) == "DDR3":
            setattr(modules, name, type(name, (cls,), {"__init__": _at_ecp5_rate(cls)}))


def _at_ecp5_rate(cls):
    def __init__(self, clk_freq, rate, **kwargs):
        cls.__init__(self, clk_freq, rate=f"1:{ECP5_PHASES}", **kwargs)
    return __init__


def main():
    _patch()
    from litedram.gen import main as litedram_gen
    sys.argv[0] = "litedram_gen"
    litedram_gen()


if __name__ == "__main__":
    main()
