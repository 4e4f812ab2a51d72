"""Test top: several DflcStream configurations side by side in one design."""

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import Flow

from ..params import Param, check
from .top import DflcStream, config_for, split_params

__all__ = ["DflcMulti", "SETS"]

# Named sets of configurations; each key prefixes its instance's ports
# (``t1_i_stream__valid`` ...).  "regress" covers, between them, the four
# antecedent operators, both dividers, n = 1, 2, 3 and 4, fewer and unequal MF
# counts, trapezoids with gaps, missing rules, the parallel option and the
# CPR pipeline registers (with the default instance at the paper's setting).
SETS = {
    "regress": {
        "t1": {"fll": "table1"},                                  # Tables 2-3: min, LUT, n=2, 9x9
        "n3": {"fll": "n3_prod", "div": "array",                  # prod, array, n=3, 5/3/4 MFs,
               "cpr_mult": 1, "cpr_div": 3},                      #   pipelined array
        "tr": {"fll": "trap_max", "par": 1, "cpr_mf": 2},         # max, LUT, trapezoids, parallel
        "or": {"fll": "mf5_or", "div": "array", "par": 1,         # probor, array, 5/4 MFs, parallel,
               "cpr_div": 2},                                     #   pipelined array
        "n1": {"fll": "n1", "cpr_div": 1},                        # n=1, LUT, sequential
        "n4": {"fll": "n4", "cpr_mf": 1},                         # n=4, 16 rules per sample
    },
}


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
            p, par, cpr = split_params(params)
            top = DflcStream(config_for(**p), parallel=par, cpr=cpr)
            self.tops[key] = top
            for name, member in top.signature.members.items():
                members[f"{key}_{name}"] = member
        super().__init__(members)

    def elaborate(self, platform):
        m = Module()
        for key, top in self.tops.items():
            m.submodules[key] = top
            for name, member in top.signature.members.items():
                outer = getattr(self, f"{key}_{name}")
                if member.flow == Flow.In:
                    m.d.comb += _connect_in(outer, getattr(top, name))
                else:
                    m.d.comb += _connect_out(outer, getattr(top, name))
        return m


def _connect_in(outer, inner):
    return [inner.payload.eq(outer.payload), inner.valid.eq(outer.valid), outer.ready.eq(inner.ready)]


def _connect_out(outer, inner):
    return [outer.payload.eq(inner.payload), outer.valid.eq(inner.valid), inner.ready.eq(outer.ready)]
