"""The catalog: the parameter sets the project builds by default, and the papers' figures beside them.

One definition of each, read by ``python -m hdl.emit`` (``make verilog``,
docs/manifests: :data:`DEFAULT_SETS`), scripts/synth.py (``make synth``) and
scripts/bench.py (``make bench``) (the sets with a ``family``: synthesized
and reported beside the paper's figures).

* :class:`Figures`: what a paper reports for the part of its design one of
  our tops corresponds to (its own implementation's resources and clock).
* :data:`PAPER`: those figures, by name; :data:`PAPER_JOBS`: the papers'
  speed figures for the jobs ``make bench`` times.
* :class:`Set` and :data:`SETS`: the named parameter sets of the tops
  (``hdl.emit.TOPS``), each with its uses (emitted by default, synthesized
  for a family) and the figures it is compared with.
* :class:`Goal` and :data:`TIMING_GOALS`: issue 17's timing-closure table,
  the tops ``make bench`` places on the LFE5U-85F against their goals.

Papers (/work/shared/papers/): 000 harmonic planner (Tables 1-3 and
section 5.4), 003 DFLC (section 7), 004 EDT/BFS array (Tables I-II).
"""

from dataclasses import dataclass, field

__all__ = ["Figures", "PAPER", "PAPER_JOBS", "Set", "SETS", "DEFAULT_SETS", "SYNTHESIZED", "get", "Goal",
           "TIMING_GOALS"]


@dataclass(frozen=True)
class Figures:
    """A paper's resource and clock figures for one part of its design.

    ``of`` names that part when it is not what our top is (a larger block);
    ``other`` holds the figures without a column of their own, in the
    paper's words.  None: the paper gives no such figure."""

    paper: str                  # "000", "003", "004"
    where: str                  # the table or section
    device: str = ""            # the paper's FPGA
    of: str = ""
    ff: int | None = None
    lut4: int | None = None
    bram: int | None = None     # block RAMs beside the FF / LUT4 counts
    mhz: float | None = None
    other: tuple = ()

    def text(self):
        """``[of: ]11 FF, 22 LUT4, 361 MHz (device, where)``."""
        items = [f"{self.ff} FF"] if self.ff is not None else []
        if self.lut4 is not None:
            items.append(f"{self.lut4} LUT4" + (f" + {self.bram} BRAM" if self.bram else ""))
        items += [*self.other] + ([f"{self.mhz:g} MHz"] if self.mhz is not None else [])
        source = ", ".join(x for x in (self.device, self.where) if x)
        return (f"{self.of}: " if self.of else "") + ", ".join(items) + f" ({source})"


PAPER = {
    # paper 000 (harmonic planner), section 5.4: ISE 7.1i synthesis, place and route
    "node": Figures("000", "Table 1", "XC2V6000-5", ff=11, lut4=22, mhz=361),
    "cluster": Figures("000", "Table 2", "XC2V6000-5", ff=198, lut4=398, bram=1, mhz=300),
    "block_48x96": Figures("000", "Table 3", "XC4VLX160-12", of="48x96 block", ff=50699, lut4=101396,
                           mhz=150),
    "control_decision": Figures("000", "section 5.4", "XC2V6000",
                                other=("Control 844 slices", "Decision 3p+682 slices")),
    "border_36x66": Figures("000", "section 5.4", "XC2V6000", of="36x66 grid's border nodes",
                            other=("204 border nodes in 12 SRAM blocks",)),
    # paper 003 (DFLC), section 7: the core alone, with the Table 2 parameters
    "dflc_core": Figures("003", "section 7", "XC3S1500-4", of="core alone", lut4=1303, mhz=85,
                         other=("8 MULT18X18", "12 ROM64X1 + 54 ROM256X1")),
    # paper 004 (EDT/BFS array): gates of "BFS and NNT" (Table II), the BFS clock (Table I)
    "edt_cell": Figures("004", "Tables I-II", of="BFS and NNT", mhz=232, other=("1188 gates",)),
}

# The papers' speed figures for the jobs make bench times (in words: each
# mixes a time, a clock and a speed-up the paper states together).
PAPER_JOBS = {
    "harmonic_iteration": "100 us/iteration on a 2 GHz Pentium 4; p+2 cycles at 150 MHz; 'up to 100x'",
    "harmonic_map": "100x to 400x (270x: 9500-node maze, 4 blocks, p = 255)",
    "dflc_sample": "4 clocks/sample (78.3 ns at 51.1 MHz in the SoC), 9 pipeline stages",
    "edt_job": "43.1 us at 232 MHz (Table I, BFS)",
}


@dataclass(frozen=True)
class Set:
    """A named parameter set of top ``top`` and what it is for.

    ``emit``: one of the sets ``make verilog`` emits (and docs/manifests
    holds); ``family``: synthesized by ``make synth`` / ``make bench`` with
    yosys ``synth_xilinx -family`` (the paper's family), ``hierarchical``
    keeping the hierarchy; ``paper``: the figures it is compared with, or
    ``beyond``: what the set adds beyond the paper."""

    name: str
    top: str
    params: dict = field(default_factory=dict)
    emit: bool = False
    family: str | None = None
    hierarchical: bool = False
    paper: Figures | None = None
    beyond: str = ""

    def paper_text(self):
        """The paper column of a report: the figures, what the set adds, or ``-``."""
        if self.paper is not None:
            return self.paper.text()
        return f"(beyond the paper: {self.beyond})" if self.beyond else "-"


# The 6x12 block (4 clusters) of a 2x2-block map at p_max = 254 (16 * 256 = 1024 words).
BLOCK = {"n": 6, "m": 12, "br": 2, "bc": 2, "p_max": 254, "depth": 1024}
# The planner top: that block at p_max = 62 + Control + Decision + host streams.
PLANNER = {"n": 6, "m": 12, "br": 2, "bc": 2, "p_max": 62, "depth": 256}

SETS = (
    Set("node", "harmonic_node", {}, emit=True, family="xc2v", paper=PAPER["node"]),
    Set("counters", "harmonic_counters", {"p_max": 1022}, emit=True),
    Set("cluster", "harmonic_cluster", {"depth": 1024}, emit=True, family="xc2v", paper=PAPER["cluster"]),
    Set("cluster_pmax255", "harmonic_cluster", {"depth": 1024, "p_max": 255}, emit=True),
    Set("block", "harmonic_block", BLOCK, emit=True, family="xc2v", paper=PAPER["block_48x96"]),
    Set("planner", "harmonic_planner", PLANNER, emit=True, family="xc2v", paper=PAPER["control_decision"]),
    # The planner at p_max 126 and 254 (issue 19: the Decision's area grows linearly in p).
    Set("planner_pmax126", "harmonic_planner", {**PLANNER, "p_max": 126, "depth": 512}, family="xc2v",
        paper=PAPER["control_decision"]),
    Set("planner_pmax254", "harmonic_planner", {**PLANNER, "p_max": 254, "depth": 1024}, family="xc2v",
        paper=PAPER["control_decision"]),
    # The border storage alone at the paper's block sizes (issue 19: its block RAMs).
    Set("border_36x66", "harmonic_border", {"n": 36, "m": 66, "br": 2, "bc": 2, "p_max": 254}, family="xc2v",
        paper=PAPER["border_36x66"]),
    Set("border_48x96", "harmonic_border", {"n": 48, "m": 96, "br": 2, "bc": 2, "p_max": 254}, family="xc2v",
        beyond="Table 3's 48x96 block"),
    Set("planner_exp", "harmonic_planner", {**PLANNER, "block_exponents": 1}, family="xc2v",
        beyond="the block-exponent option, issue 10"),
    # Issue 22: the node update of node exponents at the whole 512x512 maze's e_max (14-bit exponents).
    Set("node_exponents", "harmonic_node_exponents", {"p": 16, "e_max": 10288}, emit=True,
        beyond="issue 22: one floating-point node update a clock, one exponent per node"),
    # Issue 22: the engine sized for the 256x256 crop of maze512-1-0 (2 Mbit of state: the LFE5U-85F holds it).
    Set("node_exponent_engine", "harmonic_node_exponent_engine",
        {"max_h": 256, "max_w": 256, "p": 16, "e_max": 10288}, emit=True,
        beyond="issue 22: node exponents over a whole map in block RAM, red-black to a fixed point"),
    Set("dflc_stream", "dflc_stream", {"fll": "table1"}, emit=True),
    Set("dflc", "dflc_core", {"fll": "table1"}, emit=True, family="xc3s", paper=PAPER["dflc_core"]),
    Set("dflc_par", "dflc_core", {"fll": "table1", "par": 1}, emit=True, family="xc3s",
        beyond="the parallel option, 1 clock/sample"),
    Set("edt_cell_32", "edt_cell", {"height": 32, "width": 32}, emit=True),
    Set("edt_cell", "edt_cell", {"height": 16, "width": 16}, family="xc2v", paper=PAPER["edt_cell"]),
    Set("edt_8x8", "edt_array", {"height": 8, "width": 8}, family="xc2v", hierarchical=True),
    Set("edt_16x16", "edt_array", {"height": 16, "width": 16}, family="xc2v", hierarchical=True),
    Set("edt_bfs_16", "edt_bfs", {"height": 16, "width": 16}, emit=True),
    Set("edt_bfs_32", "edt_bfs", {"height": 32, "width": 32}, emit=True),
    # The tile engine (issue 18): an 8x8 array over maps up to 64x64 in block RAM.
    Set("edt_tile_8x8", "edt_tile_engine", {"t_r": 8, "t_c": 8, "max_h": 64, "max_w": 64}, emit=True,
        beyond="the paper's future work: a small array over a map in block RAM"),
    # ... and a 4x8 array over maps up to 512x512 (maze512-1-0) whose state lives outside (an SDRAM controller).
    Set("edt_tile_ext", "edt_tile_engine", {"t_r": 4, "t_c": 8, "max_h": 512, "max_w": 512, "store": "external"},
        emit=True, beyond="the tile engine with its per-pixel state in an external store (maze512-1-0: 13.9 Mbit)"),
    # ... and the engine with that state in a DRAM behind four of a controller's native ports (LiteDRAM's),
    # reading the next two visits' windows during this one (prefetch: hides the DRAM's latency) and writing
    # back only the rows a visit changed (skip_clean: the DRAM's bandwidth), a BFS row in 2 native words, not 3
    # (bfs_slots: maze512-1-0 through LiteDRAM 1,087,798 -> 1,005,378 engine cycles at 37.2 MHz).  3x8: with LiteDRAM's controller
    # and PHY in one top on the ECPIX-5's LFE5UM5G-85F (scripts/fit_dram_top.py) the 4x8 (83 %) does not
    # route; the 3x8 (69-72 %) does.
    Set("edt_tile_dram", "edt_tile_engine", {"t_r": 3, "t_c": 8, "max_h": 512, "max_w": 512, "store": "dram",
                                              "dram_ports": 4, "prefetch": 2, "skip_clean": 1, "bfs_slots": 1},
        emit=True, beyond="the tile engine with its per-pixel state in a DRAM (a 16-bit DDR3 behind LiteDRAM)"),
)

# (top, params) of every set make verilog emits, in order.
DEFAULT_SETS = [(s.top, dict(s.params)) for s in SETS if s.emit]
# The sets make synth and make bench synthesize, in report order.
SYNTHESIZED = tuple(s for s in SETS if s.family)


def get(name):
    """The set named ``name``."""
    for s in SETS:
        if s.name == name:
            return s
    raise KeyError(f"no parameter set {name!r} in the catalog; sets: {', '.join(s.name for s in SETS)}")


@dataclass(frozen=True)
class Goal:
    """A row of issue 17's timing-closure table: top ``top`` at ``params``
    placed on the LFE5U-85F (``seeds`` place-and-route seeds, nextpnr's
    ``router``) against ``goal_mhz``; ``start``: its clock when the issue
    was filed; ``remedy``: what the path that remains would take, where the
    goal is not met (the modules' READMEs, timing sections, hold the steps
    tried)."""

    label: str
    top: str
    params: dict
    start: str
    goal_mhz: float
    remedy: str = ""
    seeds: int = 3
    router: str = "router1"


# The 32x32, 64x64 and den312d maps' planners (bench's planner_params: 6x12 blocks, p_max 256).
_MAP_PLANNER = {"n": 6, "m": 12, "p_max": 256}
_RAM_READ = ("routing between RAMs that fill most of the part's EBR rows: a register after the bank "
             "multiplexer (a cycle more per iteration, p+3, or per value read), placement constraints per cluster")

TIMING_GOALS = (
    Goal("harmonic node", "harmonic_node", {}, "219 MHz (iCE40-HX8K)", 300),
    Goal("harmonic cluster (1Kx18 RAM)", "harmonic_cluster", {"depth": 1024}, "65.7 MHz (iCE40), 83 MHz (ECP5)",
         200, "the nodes' write bits kept apart from the Stable logic; a fabric register after the RAM's output "
              "register (read latency 3, P_MIN 5: a cycle more per iteration)"),
    Goal("harmonic block 6x12 (2x2 blocks)", "harmonic_block", BLOCK, "65.0 MHz (iCE40)", 200,
         "the AND of the 72 Stable flags pipelined per cluster (the flags a cycle later: a visit K*L+8); the "
         "border RAMs' write data from a register"),
    Goal("planner, fixed point (2x2 blocks of 6x12, p_max 62)", "harmonic_planner", PLANNER, "not timed", 150,
         "the clusters' `run` and the Counters' start loads from registers set a cycle ahead (a visit K*L+8; "
         "the cycle-neutral versions were tried and gave nothing within the seeds' spread: hdl/harmonic/README.md)"),
    Goal("planner, block exponents (same)", "harmonic_planner", {**PLANNER, "block_exponents": 1}, "not timed",
         150, "e_b, the neighbours' exponents and the re-pick registered over a visit's lead-in (they change only "
              "between visits: a cycle per visit of the exponent option)"),
    Goal("the 32x32 maps' planner (6x3 blocks of 6x12, p_max 256)", "harmonic_planner",
         {**_MAP_PLANNER, "br": 6, "bc": 3, "depth": 8192}, "not timed", 150,
         "the Counters' start loads (`p + 1`, `base + p + 1`) from registers set with p and the base"),
    Goal("empty-16-16's planner (6x3 blocks of 3x6, p_max 256)", "harmonic_planner",
         {"n": 3, "m": 6, "br": 6, "bc": 3, "p_max": 256, "depth": 8192}, "not timed", 150,
         "the FSM's START into the Controller from a register (mostly routing)"),
    Goal("the 64x64 maps' planner (11x6 blocks)", "harmonic_planner",
         {**_MAP_PLANNER, "br": 11, "bc": 6, "depth": 32768}, "not timed", 150, _RAM_READ),
    Goal("den312d's planner (14x6 blocks)", "harmonic_planner",
         {**_MAP_PLANNER, "br": 14, "bc": 6, "depth": 32768}, "not timed", 150, _RAM_READ),
    Goal("DFLC core, Table 1, sequential", "dflc_core", {"fll": "table1"}, "57.6 MHz (iCE40)", 150),
    Goal("DFLC core, Table 1, parallel", "dflc_core", {"fll": "table1", "par": 1}, "58.6 MHz (iCE40)", 150),
    Goal("EDT/BFS cell (the paper's, 16x16 widths)", "edt_cell", {"height": 16, "width": 16}, "29.8 MHz (iCE40)",
         100, "one iteration a clock is the loop neighbour -> candidate adder -> comparators -> selection -> "
              "register: two images interleaved in a two-stage cell (C-slow), an interface change"),
    Goal("EDT/BFS array's own top (8x8)", "edt_bfs", {"height": 8, "width": 8}, "not timed", 100,
         "the cell's loop (above) across the array's routing"),
    Goal("EDT/BFS tile engine (4x8 cells, 128x128 RAM)", "edt_tile_engine",
         {"t_r": 4, "t_c": 8, "max_h": 128, "max_w": 128}, "not built", 100,
         "the path read-out's address loop (RAM word -> pixel parent -> next address) registered at two "
         "cycles more per path pixel, then the cell's loop (above); the cell's enables beside its MIN gave "
         "the cell alone 40.9 -> 55.5 MHz but the external-store top no longer routed (hdl/edt_bfs/README.md)",
         seeds=1, router="router2"),
    Goal("EDT/BFS tile engine, external store (4x8 cells, maps to 512x512)", "edt_tile_engine",
         {"t_r": 4, "t_c": 8, "max_h": 512, "max_w": 512, "store": "external"}, "not built", 100,
         "the cell's loop (above); narrower hop keys (a longest-path parameter) to pay for the enables' "
         "comparators", router="router2"),
)
