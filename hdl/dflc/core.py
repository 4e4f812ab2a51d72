"""The DFLC core (paper 003 Fig. 8 U_fpga_fc): MF degrees, active rules, defuzzification."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from ..params import Param, check
from .addr_gen import AddrGen
from .cons_map import ConsMap
from .divider import Divider
from .integrator import Integrator
from .mf_gen import MfGen, bits_for
from .rule_sel import RuleSel
from .tnorm import Tnorm

__all__ = ["DflcCore", "latency", "CPR_KEYS"]


CPR_KEYS = ("cpr_mf", "cpr_mult", "cpr_div")


def latency(config, parallel=False, cpr_mf=0, cpr_mult=0, cpr_div=0):
    """Cycles from the input handshake to ``o_valid``: 2^n + 8 (9 parallel),
    plus the extra pipeline registers."""
    return (1 if parallel else 1 << config.n) + 8 + cpr_mf + cpr_mult + cpr_div


class DflcCore(wiring.Component):
    """Zero-order Takagi-Sugeno inference, bit-exact with ``models.dflc.Dflc.infer``.

    Parameters (Table 2 generics; all but ``parallel`` are in the
    ``models.dflc.DflcConfig`` that :func:`models.dflc.load_fll` builds from a
    .fll file): ip_no = n (1..4), ip_sz, MF_ip_no (per input), dy_ip,
    MF_op_no, MF_op_sz, op_sz, sel_op, div_type.  ``parallel`` (beyond the
    paper) evaluates the 2^n active rules at once: one sample per clock.
    Component pipeline registers (Table 2 CPR generics, each 0 .. 4 extra
    register stages, each adding one cycle of latency): ``cpr_mf`` after the
    MF generators' multiply-add (cpr3, trap_gen_p), ``cpr_mult`` after the
    w*c multiplier (cpr6, mult), ``cpr_div`` inside the divider (cpr9,
    div_array: the restoring array is cut into cpr_div + 1 groups of rows).
    The paper's other CPR/PSR positions are fixed here (see the table).

    Pipeline (Fig. 8; sample accepted at cycle t, P = 2^n, combination k):

    =============  ========================================================
    cycle          stage
    =============  ========================================================
    t              ``i_valid & i_ready``: codes into the MF generators
    t+1            segment of each input (MfGen stage 1, psr1 / trap_gen_p)
    t+2+k          degrees held; combination k: rule selector, t-norm,
                   rule index to the consequent ROM (addr_gen_p, rule_sel_p,
                   minmax_p)
    t+3+k          w registered; singleton index read (cons_map_p)
    t+4+k          singleton code read (s_rom)
    t+5+k          w*c and w registered (mult), "no rule" zeroes both
    t+6+P-1        sums final (int_uns / int_sig), divider starts
    t+P+8          ``o_valid`` with ``o_y`` and ``o_zero`` (div_array)
    =============  ========================================================

    In the parallel option all 2^n combinations go through their own rule
    selector, t-norm, ROMs and multiplier in the t+2 .. t+5 stages and an
    adder tree replaces the integrators: latency 9, one sample per clock.
    With the paper's Table 2 setting, one sample every 4 clocks, latency 12.

    Ports
    -----
    i_valid : In(1), i_codes : In(ArrayLayout(ip_sz, n)), i_ready : Out(1)
        Input sample; accepted when both valid and ready (one every 2^n
        cycles; always ready in the parallel option).
    o_valid : Out(1), o_y : Out(op_sz), o_zero : Out(1)
        One cycle per sample, in order; ``o_zero``: total firing strength 0,
        ``o_y`` is then the configuration's ``zero_code``.
    """

    # The CPR parameters (hdl.emit's dflc_* tops list them; the rest is the config).
    PARAMS = tuple(Param(k, int, 0, lo=0, hi=4, doc="extra pipeline registers (Table 2 CPR)",
                         message="{name} = {value!r}: extra pipeline registers must be {lo} .. {hi}")
                   for k in CPR_KEYS)

    def __init__(self, config, parallel=False, cpr_mf=0, cpr_mult=0, cpr_div=0):
        c = config
        check(self.PARAMS, cpr_mf=cpr_mf, cpr_mult=cpr_mult, cpr_div=cpr_div)
        self.cpr = {"cpr_mf": cpr_mf, "cpr_mult": cpr_mult, "cpr_div": cpr_div}
        if not 1 <= c.n <= 4:
            raise ValueError(f"ip_no = {c.n}: must be 1 to 4")
        if any(k < 2 for k in c.mf_ip_no):
            raise ValueError(f"MF_ip_no = {c.mf_ip_no}: every input needs at least 2 MFs")
        if c.op_sz < c.mf_op_sz:
            raise ValueError(f"op_sz = {c.op_sz} < MF_op_sz = {c.mf_op_sz}")
        if parallel not in (True, False, 0, 1):
            raise ValueError(f"parallel = {parallel!r}: expected a boolean")
        self.config, self.parallel = c, bool(parallel)
        self.sw_w = bits_for(c.s_max)
        self.swc_w = bits_for(c.s_max * ((1 << c.mf_op_sz) - 1))
        super().__init__({
            "i_valid": In(1), "i_codes": In(data.ArrayLayout(c.ip_sz, c.n)), "i_ready": Out(1),
            "o_valid": Out(1), "o_y": Out(c.op_sz), "o_zero": Out(1),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"initiation_interval_cycles": 1 if self.parallel else 1 << self.config.n,
                "latency_cycles": latency(self.config, self.parallel, **self.cpr),
                "latency": "i_valid & i_ready to o_valid"}

    def elaborate(self, platform):
        m = Module()
        c = self.config
        n, K = c.n, 1 << c.n
        accept = Signal()
        m.d.comb += accept.eq(self.i_valid & self.i_ready)

        gens = []
        for j, spec in enumerate(c.inputs):
            g = MfGen(spec, c.ip_sz, c.dy_ip, cpr=self.cpr["cpr_mf"])
            m.submodules[f"mf_gen{j}"] = g
            m.d.comb += [g.x.eq(self.i_codes[j]), g.v_in.eq(accept)]
            gens.append(g)
        v2 = gens[0].v_out

        if self.parallel:
            m.d.comb += self.i_ready.eq(1)
            combos = [(k, 1, 1, 1) for k in range(K)]   # (k, active, first, last)
        else:
            m.submodules.addr_gen = ag = AddrGen(n)
            m.d.comb += [ag.start.eq(v2), ag.accept.eq(accept), self.i_ready.eq(ag.ready)]
            combos = [(ag.k, ag.active, ag.first, ag.last)]

        w_m_all, wc_m_all = [], []
        v_m = first_m = last_m = None
        for q, (k, active, first, last) in enumerate(combos):
            sel = RuleSel(c)
            tn = Tnorm(n, c.dy_ip, c.sel_op)
            cm = ConsMap(c)
            m.submodules[f"rule_sel{q}"] = sel
            m.submodules[f"tnorm{q}"] = tn
            m.submodules[f"cons_map{q}"] = cm
            m.d.comb += sel.k.eq(k)
            for j, g in enumerate(gens):
                m.d.comb += [getattr(sel, f"base_{j}").eq(g.base), getattr(sel, f"mu0_{j}").eq(g.mu0),
                             getattr(sel, f"mu1_{j}").eq(g.mu1),
                             getattr(tn, f"deg_{j}").eq(getattr(sel, f"deg_{j}"))]
            m.d.comb += cm.rule.eq(sel.rule)
            # Stages R (t+3+k) and C (t+4+k): w and the flags follow the two ROM reads.
            w_r, w_c = Signal(c.dy_ip, name=f"w_r{q}"), Signal(c.dy_ip, name=f"w_c{q}")
            m.d.sync += [w_r.eq(tn.w), w_c.eq(w_r)]
            # Stage M (t+5+k): implication PROD (the multiplier); no rule -> weight 0.
            w_m = Signal(c.dy_ip, name=f"w_m{q}")
            wc_m = Signal(c.dy_ip + c.mf_op_sz, name=f"wc_m{q}")
            m.d.sync += [w_m.eq(Mux(cm.none, 0, w_c)), wc_m.eq(Mux(cm.none, 0, w_c * cm.c))]
            w_m_all.append(w_m)
            wc_m_all.append(wc_m)
            if q == 0:
                flags = []
                for name, src in (("v", (v2 if self.parallel else active)), ("first", first), ("last", last)):
                    r, cc, mm = (Signal(name=f"{name}_r"), Signal(name=f"{name}_c"), Signal(name=f"{name}_m"))
                    m.d.sync += [r.eq(src), cc.eq(r), mm.eq(cc)]
                    flags.append(mm)
                v_m, first_m, last_m = flags

        in_w = (self.sw_w, self.swc_w) if self.parallel else (c.dy_ip, c.dy_ip + c.mf_op_sz)
        # CPR after the multiplier: delay the products and their flags alike.
        for d in range(self.cpr["cpr_mult"]):
            sigs = w_m_all + wc_m_all + [v_m, first_m, last_m]
            nxt = [Signal.like(sg, name=f"{sg.name}_d{d}") for sg in sigs]
            m.d.sync += [a.eq(b) for a, b in zip(nxt, sigs)]
            K2 = len(w_m_all)
            w_m_all, wc_m_all = nxt[:K2], nxt[K2:2 * K2]
            v_m, first_m, last_m = nxt[2 * K2:]

        m.submodules.integrator = integ = Integrator(*in_w, self.sw_w, self.swc_w)
        if self.parallel:   # adder tree: the whole sample in one cycle
            m.d.comb += [integ.w.eq(sum(w_m_all)), integ.wc.eq(sum(wc_m_all))]
        else:
            m.d.comb += [integ.w.eq(w_m_all[0]), integ.wc.eq(wc_m_all[0])]
        m.d.comb += [integ.valid.eq(v_m), integ.first.eq(first_m), integ.last.eq(last_m)]

        m.submodules.divider = div = Divider(c, self.sw_w, self.swc_w, cpr=self.cpr["cpr_div"])
        m.d.comb += [div.sw.eq(integ.sw), div.swc.eq(integ.swc), div.v_in.eq(integ.done),
                     self.o_valid.eq(div.v_out), self.o_y.eq(div.y), self.o_zero.eq(div.zero)]
        return m
