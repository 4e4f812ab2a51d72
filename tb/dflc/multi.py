"""Test top: several DflcStream configurations side by side in one design.

Not one of hdl.emit's tops: the regression builds it through the runner's
``factory`` (``run("dflc_multi", {"set": "regress"}, sim, ..., factory=DflcMulti)``,
module ``dflc_multi_setregress``).  Its controllers are the test fixtures in
tb/dflc/fll/, given by path.
"""

from pathlib import Path

from amaranth.hdl import Module
from amaranth.lib import wiring

from navcores.hdl.dflc.top import DflcStream, config_for, split_params
from navcores.hdl.params import Param, check

__all__ = ["DflcMulti", "SETS"]

FIXTURES = Path(__file__).resolve().parent / "fll"

# Named sets of configurations; each key prefixes its instance's ports
# (``n3_i_stream__valid`` ...).  "regress" covers, between them, the four
# antecedent operators, both dividers, n = 1, 2, 3 and 4, fewer and unequal MF
# counts, trapezoids with gaps, missing rules, the parallel option, and the
# Table 2 pipeline generics (hdl/dflc/pipe.py): every generic at 0 (its
# minimum) and at 4 somewhere, in sequential and parallel instances, both
# orders of each pair of routes the core synchronizes (w vs c, psr4 vs cpr6,
# cpr7 vs cpr8), and the paper's own Table 2 values.  The paper's default
# configuration (Table 1, default generics) is not here: the regression runs
# it alone as dflc_stream_table1, the build `python -m sim dflc` uses (see
# tb/dflc/test_dflc_stream.py).  Latency L (hdl/dflc/core.py latency) in the comments.
_ZERO = {"psr1_no": 0, "cpr3_no": 1, "cpr2_no": 0, "cpr5_no": 0, "psr4_no": 0, "cpr6_no": 0}
SETS = {
    "regress": {
        "n3": {"fll": "n3_prod", "div": "array",                  # prod, array, n=3, 5/3/4 MFs,
               **_ZERO, "cpr9_no": 0},                            #   every register at 0 / min; L 12
        "tr": {"fll": "trap_max", "par": 1,                       # max, LUT, trapezoids, parallel,
               "psr1_no": 4, "cpr3_no": 4, "psr3_no": 4,          #   the front at 4; L 27
               "cpr1_no": 4, "cpr4_no": 4},
        "or": {"fll": "mf5_or", "div": "array", "par": 1,         # probor, array, 5/4 MFs, parallel,
               **_ZERO, "psr2_no": 4, "cpr6_no": 3,               #   c longer than w, cpr6 > psr4,
               "cpr7_no": 3, "cpr9_no": 4},                       #   cpr7 > cpr8, array in 4; L 19
        "n1": {"fll": "n1", "psr1_no": 1, "psr2_no": 4,           # n=1, LUT, sequential,
               "psr3_no": 1, "psr4_no": 1, "cpr1_no": 1,          #   the paper's Table 2 values; L 19
               "cpr2_no": 1, "cpr3_no": 3, "cpr4_no": 0, "cpr5_no": 2, "cpr6_no": 1,
               "cpr7_no": 0, "cpr8_no": 0, "cpr9_no": 2},
        "n1m": {"fll": "n1", "div": "array",                      # n=1, array, every generic at 4; L 45
                **{k: 4 for k in ("psr1_no", "psr2_no", "psr3_no", "psr4_no", "cpr1_no", "cpr2_no",
                                  "cpr3_no", "cpr4_no", "cpr5_no", "cpr6_no", "cpr7_no", "cpr8_no",
                                  "cpr9_no")}},
        "n4": {"fll": "n4", "cpr2_no": 0, "psr2_no": 1,           # n=4, 16 rules per sample, LUT,
               "cpr5_no": 4, "psr4_no": 4, "cpr6_no": 2,          #   w longer than c, psr4 > cpr6,
               "cpr7_no": 1, "cpr8_no": 4, "cpr9_no": 4},         #   cpr8 > cpr7, the back at 4; L 36
    },
}
# The stems above name the fixtures tb/dflc/fll/<stem>.fll, which hdl takes by path.
for _params in (p for configs in SETS.values() for p in configs.values()):
    _params["fll"] = str(FIXTURES / f"{_params['fll']}.fll")


class DflcMulti(wiring.Component):
    """The DflcStream instances of one of :data:`SETS`, each with its own
    ``<key>_i_stream`` / ``<key>_o_stream`` ports, sharing clock and reset.

    Exists so that the regression needs one simulator build, not one per
    configuration (a Verilator build takes ~30-60 s); every instance is the
    very DflcStream component ``hdl.emit`` emits alone as ``dflc_stream_<fll>...``.
    """

    PARAMS = (Param("set", str, "regress", choices=tuple(sorted(SETS)), doc="named set of configurations",
                    message="set = {value!r}: expected one of {choices}"),)

    def __init__(self, set="regress"):
        check(self.PARAMS, set=set)
        self.set = set
        self.tops = {}
        members = {}
        for key, params in SETS[set].items():
            p, par, pipe = split_params(params)
            top = DflcStream(config_for(**p), parallel=par, pipe=pipe)
            self.tops[key] = top
            for name, member in top.signature.members.items():
                members[f"{key}_{name}"] = member
        super().__init__(members)

    def elaborate(self, platform):
        m = Module()
        for key, top in self.tops.items():
            m.submodules[key] = top
            for name in top.signature.members:     # each instance's streams pass through
                wiring.connect(m, wiring.flipped(getattr(self, f"{key}_{name}")), getattr(top, name))
        return m
