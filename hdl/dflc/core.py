"""The DFLC core (paper 003 Fig. 8 U_fpga_fc): MF degrees, active rules, defuzzification."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ..params import Param, checked_init
from .addr_gen import AddrGen
from .cons_map import ConsMap
from .divider import Divider
from .integrator import Integrator
from .mf_gen import MfGen, bits_for
from .pipe import PIPE_DEFAULTS, PIPE_KEYS, PIPE_RANGE, PIPE_TABLE2, check_pipe, delay
from .rule_sel import RuleSel
from .tnorm import Tnorm

__all__ = ["DflcCore", "latency", "sample_layout", "result_layout",
           "PIPE_KEYS", "PIPE_DEFAULTS", "PIPE_TABLE2"]


def sample_layout(config):
    """One input sample: the n input codes, input j at bits [j*ip_sz, (j+1)*ip_sz)."""
    return data.ArrayLayout(config.ip_sz, config.n)


def result_layout(config):
    """One output: the code ``y`` (low bits) and ``zero`` (total firing strength 0) above it."""
    return data.StructLayout({"y": config.op_sz, "zero": 1})


def latency(config, parallel=False, **pipe):
    """Cycles from the ``i_stream`` handshake to ``o_stream.valid`` (the
    timing table of :class:`DflcCore`); 2^n + 8 (9 parallel) at the default
    generics."""
    g = check_pipe(pipe, op_sz=config.op_sz)
    p = 1 if parallel else 1 << config.n
    return (p + g["psr1_no"] + g["cpr3_no"] + g["psr3_no"] + g["cpr1_no"] + g["cpr4_no"]
            + max(g["cpr5_no"], g["cpr2_no"] + 1 + g["psr2_no"])
            + max(g["psr4_no"], g["cpr6_no"]) + max(g["cpr7_no"], g["cpr8_no"])
            + g["cpr9_no"] + 2)


class DflcCore(wiring.Component):
    """Zero-order Takagi-Sugeno inference, bit-exact with ``models.dflc.Dflc.infer``.

    Parameters (Table 2 generics; all but ``parallel`` and the pipeline
    generics are in the ``models.dflc.DflcConfig`` that
    :func:`models.dflc.load_fll` builds from a .fll file): ip_no = n (1..4),
    ip_sz, MF_ip_no (per input), dy_ip, MF_op_no, MF_op_sz, op_sz, sel_op,
    div_type.  ``parallel`` (beyond the paper) evaluates the 2^n active rules
    at once: one sample per clock.

    Pipeline generics (Table 2 PSR / CPR, keyword arguments named as in the
    paper; each is the number of registers at its place, 0 .. 4 unless noted;
    defaults :data:`PIPE_DEFAULTS`, the paper's values :data:`PIPE_TABLE2`).
    The paper names only the component (CPR) or the route (PSR) of each; where
    two routes meet, the core adds the difference to the shorter one as path
    synchronization registers (not a free choice: any other count would pair a
    weight with another rule's singleton), so those places add the maximum of
    the two to the latency:

    =========  =================  ==============================================
    generic    default (Table 2)  registers
    =========  =================  ==============================================
    psr1_no    1 (1)              ip_set -> trap_gen_p: the input code and its
                                  segment (MfGen stage 1; 0: combinational)
    cpr3_no    1 (3)              trap_gen_p: the degree register, 1 .. 4; the
                                  first is mandatory (loaded once per sample, it
                                  holds the degrees while addr_gen_p walks the
                                  2^n combinations); the others follow it
    psr3_no    0 (1)              route into rul_sel_p: the degrees and the
                                  address generator's start alike
    cpr1_no    0 (1)              addr_gen_p: its outputs (k, flags), and the
                                  degrees alongside to stay paired with them
    cpr4_no    0 (0)              rule_sel_p: rule index, selected degrees, flags
    cpr5_no    2 (2)              minmax_p: after the t-norm, on w
    cpr2_no    1 (1)              cons_map_p: the rule ROM read (0: asynchronous)
    (s_rom)    1 (fixed)          the singleton ROM's synchronous read; Table 2
                                  has no generic for it
    psr2_no    0 (4)              s_rom -> mult: on the singleton code; w and c
                                  meet at the multiplier after
                                  max(cpr5_no, cpr2_no + 1 + psr2_no)
    cpr6_no    1 (1)              mult: on w*c (0: combinational into int_sig)
    psr4_no    1 (1)              cpr5 -> int_uns: on w, parallel to the
                                  multiplier; both reach the integrators after
                                  max(psr4_no, cpr6_no)
    (int)      1 (fixed)          the accumulators themselves (aggregation SUM)
    cpr7_no    0 (0)              int_uns: after the sum of w
    cpr8_no    0 (0)              int_sig: after the sum of w*c; the divider
                                  takes both after max(cpr7_no, cpr8_no)
    (div in)   1 (fixed)          the divider's input register (the sums change
                                  with the next sample's first rule)
    cpr9_no    1 (2)              div_array: 0 .. min(4, op_sz), see Divider
    (div out)  1 (fixed)          the output register (y, zero, o_valid)
    =========  =================  ==============================================

    In the parallel option there is no address generator: cpr1_no and psr3_no
    then delay the degrees only, so one latency formula holds for both.  The
    paper's Table 2 values give latency 2^n + 17 here (21 for Table 1); the
    paper quotes "9 pipeline stages" for its whole chip without saying how the
    generics map to them.

    Pipeline at the defaults (Fig. 8; sample accepted at cycle t, P = 2^n,
    combination k):

    =============  ========================================================
    cycle          stage
    =============  ========================================================
    t              ``i_stream`` handshake: codes into the MF generators
    t+1            segment of each input (MfGen stage 1, psr1 / trap_gen_p)
    t+2+k          degrees held (cpr3); combination k: rule selector,
                   t-norm, rule index to the consequent ROM (addr_gen_p,
                   rule_sel_p, minmax_p)
    t+3+k          w registered (cpr5); singleton index read (cons_map_p)
    t+4+k          w registered (cpr5); singleton code read (s_rom)
    t+5+k          w*c (cpr6) and w (psr4) registered, "no rule" zeroes both
    t+6+P-1        sums final (int_uns / int_sig), divider starts
    t+P+8          ``o_stream.valid`` with ``y`` and ``zero`` (div_array)
    =============  ========================================================

    In general, latency (:func:`latency`) = P + psr1 + cpr3 + psr3 + cpr1 +
    cpr4 + max(cpr5, cpr2 + 1 + psr2) + max(psr4, cpr6) + max(cpr7, cpr8) +
    cpr9 + 2, and one sample every P clocks whatever the generics.  In the
    parallel option all 2^n combinations go through their own rule selector,
    t-norm, ROMs and multiplier and an adder tree replaces the integrators'
    accumulation: P = 1, latency 9 at the defaults, one sample per clock.

    Ports
    -----
    i_stream : In(stream.Signature(:func:`sample_layout`))
        Input samples (the n codes); one is taken when ``valid`` and
        ``ready`` are both high, at most one every 2^n cycles: ``ready`` is
        low for the 2^n - 1 cycles after a handshake (always high in the
        parallel option) and does not depend on ``valid``.
    o_stream : Out(stream.Signature(:func:`result_layout`, always_ready=True))
        One beat per sample, in order, ``latency`` cycles after its input
        handshake: ``payload.y`` and ``payload.zero`` (total firing strength
        0: ``y`` is then the configuration's ``zero_code``).  The pipeline
        is fixed and never stalls, so the stream has no back-pressure
        (``always_ready``: no ``ready`` port): the consumer takes every
        beat.  ``valid`` depends only on the pipeline.  To stall the
        output, meter the input: :class:`~hdl.dflc.top.DflcStream` admits a
        sample only when its output FIFO will have room.
    """

    # The pipeline generics (hdl.emit's dflc_* tops list them; the rest is the
    # config): one declaration, from hdl/dflc/pipe.py's ranges and defaults,
    # which check_pipe enforces.
    PARAMS = tuple(Param(k, int, PIPE_DEFAULTS[k], lo=PIPE_RANGE[k][0], hi=PIPE_RANGE[k][1],
                         doc=f"pipeline registers, Table 2 {k[:-3].upper()}")
                   for k in PIPE_KEYS)

    @checked_init
    def __init__(self, config, parallel=False, **pipe):
        c = config
        self.pipe = check_pipe(pipe, op_sz=c.op_sz)
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
            "i_stream": In(stream.Signature(sample_layout(c))),
            "o_stream": Out(stream.Signature(result_layout(c), always_ready=True)),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"initiation_interval_cycles": 1 if self.parallel else 1 << self.config.n,
                "latency_cycles": latency(self.config, self.parallel, **self.pipe),
                "latency": "i_stream handshake to o_stream.valid (o_stream: no back-pressure)"}

    def elaborate(self, platform):
        m = Module()
        c, g = self.config, self.pipe
        n, K = c.n, 1 << c.n
        accept = Signal()
        m.d.comb += accept.eq(self.i_stream.valid & self.i_stream.ready)

        gens = []
        for j, spec in enumerate(c.inputs):
            gen = MfGen(spec, c.ip_sz, c.dy_ip, psr=g["psr1_no"], cpr=g["cpr3_no"])
            m.submodules[f"mf_gen{j}"] = gen
            m.d.comb += [gen.x.eq(self.i_stream.payload[j]), gen.v_in.eq(accept)]
            gens.append(gen)
        # psr3 (route into rul_sel_p) delays the degrees and the start alike;
        # cpr1 (addr_gen_p's outputs) delays the degrees alongside.
        v2, = delay(m, [gens[0].v_out], g["psr3_no"], "psr3_")
        degs = [delay(m, [gen.base, gen.mu0, gen.mu1], g["psr3_no"] + g["cpr1_no"], "psr3_")
                for gen in gens]

        if self.parallel:
            m.d.comb += self.i_stream.ready.eq(1)
            v_sel, = delay(m, [v2], g["cpr1_no"], "cpr1_")
            combos = [(k, 1, 1, 1) for k in range(K)]   # (k, active, first, last)
        else:
            m.submodules.addr_gen = ag = AddrGen(n)
            m.d.comb += [ag.start.eq(v2), ag.accept.eq(accept), self.i_stream.ready.eq(ag.ready)]
            k_d, v_sel, first_d, last_d = delay(m, [ag.k, ag.active, ag.first, ag.last],
                                                g["cpr1_no"], "cpr1_")
            combos = [(k_d, v_sel, first_d, last_d)]

        # Where the w and c routes meet (the multiplier), and where w and w*c
        # reach the integrators, the shorter route gets the difference.
        d_wc = max(g["cpr5_no"], g["cpr2_no"] + 1 + g["psr2_no"])
        d_m = max(g["psr4_no"], g["cpr6_no"])
        w_m_all, wc_m_all = [], []
        flags = None
        for q, (k, active, first, last) in enumerate(combos):
            sel = RuleSel(c)
            tn = Tnorm(n, c.dy_ip, c.sel_op)
            cm = ConsMap(c, cpr=g["cpr2_no"])
            m.submodules[f"rule_sel{q}"] = sel
            m.submodules[f"tnorm{q}"] = tn
            m.submodules[f"cons_map{q}"] = cm
            m.d.comb += sel.k.eq(k)
            for j, (base, mu0, mu1) in enumerate(degs):
                m.d.comb += [sel.base[j].eq(base), sel.mu0[j].eq(mu0), sel.mu1[j].eq(mu1)]
            # cpr4 (rule_sel_p): the rule index and the selected degrees.
            sel_out = delay(m, [sel.rule, *sel.deg], g["cpr4_no"], f"cpr4_{q}_")
            m.d.comb += cm.rule.eq(sel_out[0])
            m.d.comb += [tn.deg[j].eq(sel_out[1 + j]) for j in range(n)]
            # cpr5 (minmax_p) on w, then the synchronization to the c route.
            if (g["cpr5_no"], d_wc) == (2, 2):   # the default: stages R and C of the table
                w_r, w_c = Signal(c.dy_ip, name=f"w_r{q}"), Signal(c.dy_ip, name=f"w_c{q}")
                m.d.sync += [w_r.eq(tn.w), w_c.eq(w_r)]
            else:
                w_c, = delay(m, [tn.w], d_wc, f"w_cpr5_{q}_")
            # psr2 (s_rom -> mult) on the singleton code, then synchronization to w.
            c_c, none_c = delay(m, [cm.c, cm.none], d_wc - g["cpr2_no"] - 1, f"psr2_{q}_")
            # Implication PROD (the multiplier); no rule -> weight 0.
            w_e, wc_e = Mux(none_c, 0, w_c), Mux(none_c, 0, w_c * c_c)
            if d_m == 1:    # the default: stage M of the table (psr4 = cpr6 = 1)
                w_m = Signal(c.dy_ip, name=f"w_m{q}")
                wc_m = Signal(c.dy_ip + c.mf_op_sz, name=f"wc_m{q}")
                m.d.sync += [w_m.eq(w_e), wc_m.eq(wc_e)]
            else:           # psr4 on w, cpr6 on w*c, the shorter synchronized
                w_p = Signal(c.dy_ip, name=f"w_p{q}")
                wc_p = Signal(c.dy_ip + c.mf_op_sz, name=f"wc_p{q}")
                m.d.comb += [w_p.eq(w_e), wc_p.eq(wc_e)]
                w_m, = delay(m, [w_p], d_m, f"psr4_{q}_")
                wc_m, = delay(m, [wc_p], d_m, f"cpr6_{q}_")
            w_m_all.append(w_m)
            wc_m_all.append(wc_m)
            if q == 0:      # the valid and first/last flags follow the same stages
                d_flags = g["cpr4_no"] + d_wc + d_m
                if d_flags == 3:
                    flags = []
                    for name, src in (("v", v_sel), ("first", first), ("last", last)):
                        r, cc, mm = (Signal(name=f"{name}_r"), Signal(name=f"{name}_c"),
                                     Signal(name=f"{name}_m"))
                        m.d.sync += [r.eq(src), cc.eq(r), mm.eq(cc)]
                        flags.append(mm)
                else:
                    srcs = [v_sel, Signal(name="first_s"), Signal(name="last_s")]
                    m.d.comb += [srcs[1].eq(first), srcs[2].eq(last)]
                    flags = delay(m, srcs, d_flags, "fl")
        v_m, first_m, last_m = flags

        in_w = (self.sw_w, self.swc_w) if self.parallel else (c.dy_ip, c.dy_ip + c.mf_op_sz)
        m.submodules.integrator = integ = Integrator(*in_w, self.sw_w, self.swc_w,
                                                     cpr_uns=g["cpr7_no"], cpr_sig=g["cpr8_no"])
        if self.parallel:   # adder tree: the whole sample in one cycle
            m.d.comb += [integ.w.eq(sum(w_m_all)), integ.wc.eq(sum(wc_m_all))]
        else:
            m.d.comb += [integ.w.eq(w_m_all[0]), integ.wc.eq(wc_m_all[0])]
        m.d.comb += [integ.valid.eq(v_m), integ.first.eq(first_m), integ.last.eq(last_m)]

        m.submodules.divider = div = Divider(c, self.sw_w, self.swc_w, cpr=g["cpr9_no"])
        m.d.comb += [div.sw.eq(integ.sw), div.swc.eq(integ.swc), div.v_in.eq(integ.done),
                     self.o_stream.valid.eq(div.v_out),
                     self.o_stream.payload.y.eq(div.y), self.o_stream.payload.zero.eq(div.zero)]
        return m
