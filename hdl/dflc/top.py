"""DFLC stream top (paper 003 Fig. 8 flc_ip wrapper; FSL = a FIFO stream)."""

from pathlib import Path

from amaranth.hdl import Module, Shape, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.fifo import SyncFIFO
from amaranth.lib.wiring import In, Out

from navcores.models.dflc import DEFAULT_FLL, DIV_TYPES, SEL_OPS, WIDTH_LIMITS, load_fll

from ..params import Constraint, Param, check, checked_init

from .core import DflcCore, latency, result_layout, sample_layout
from .pipe import PIPE_KEYS, check_pipe

__all__ = ["DflcStream", "config_for", "resolve_fll", "stream_latency", "fifo_depth", "split_params",
           "core_from_params"]

# Where a stem is looked up: the controllers shipped in models/ (any other
# .fll, a test fixture or a user's, is given by its path).
FLL_DIRS = (DEFAULT_FLL.parent,)


def resolve_fll(fll):
    """A .fll path, or the stem of a shipped controller: ``table1`` ->
    models/dflc_table1.fll."""
    p = Path(str(fll))
    if p.suffix == ".fll" or "/" in str(fll):     # a path: the file itself, never a stem + ".fll"
        if p.is_file():
            return p
        raise ValueError(f"fll = {fll!r}: no such file" if not p.exists() else f"fll = {fll!r}: not a file")
    for d in FLL_DIRS:
        for cand in (d / f"dflc_{fll}.fll", d / f"{fll}.fll"):
            if cand.exists():
                return cand
    raise ValueError(f"fll = {fll!r}: no such .fll (looked for a path, and dflc_{fll}.fll / "
                     f"{fll}.fll in models/)")


def config_for(fll="table1", ip_sz=12, dy_ip=8, mf_op_sz=12, op_sz=12, div="lut", op=None):
    """The DflcConfig of an emitted top (keyword names as in the module name)."""
    return load_fll(resolve_fll(fll), ip_sz=ip_sz, dy_ip=dy_ip, mf_op_sz=mf_op_sz, op_sz=op_sz,
                    div_type=div, sel_op=op)


def fifo_depth(config, parallel, **pipe):
    """Output FIFO depth = the credit count: ceil(L / P) + 2 (L the core's
    latency at these generics, P the clocks per sample), so that a consumer
    that is always ready never throttles the input."""
    p = 1 if parallel else 1 << config.n
    return -(-latency(config, parallel, **pipe) // p) + 2


def stream_latency(config, parallel=False, **pipe):
    """Cycles from the i_stream handshake to o_stream.valid (empty output FIFO)."""
    return latency(config, parallel, **pipe) + 1


def split_params(params):
    """Top parameters -> (config_for kwargs, parallel, pipeline generics)."""
    p = dict(params)
    par = bool(p.pop("par", 0))
    pipe = {k: p.pop(k) for k in PIPE_KEYS if k in p}
    return p, par, pipe


def core_from_params(**params):
    """``hdl.emit``'s ``dflc_core``: the core of an emitted parameter set."""
    p, par, pipe = split_params(params)
    return DflcCore(config_for(**p), parallel=par, **pipe)


class DflcStream(wiring.Component):
    """The DFLC core between two valid/ready streams, honouring back-pressure.

    ``i_stream.payload`` is an ArrayLayout of n input codes (input j at bits
    [j*ip_sz, (j+1)*ip_sz)); ``o_stream.payload`` is ``{y: op_sz, zero: 1}``
    (y in the low bits, the zero-strength flag above it): the core's
    :func:`~hdl.dflc.core.sample_layout` and :func:`~hdl.dflc.core.result_layout`.

    The core's pipeline never stalls (its ``o_stream`` is ``always_ready``);
    instead the top admits a sample only when the output FIFO will have room
    for it: ``samples in flight + FIFO level < depth`` with depth =
    ceil(L / P) + 2, enough that a consumer that is always ready never
    throttles the input.  So at full throughput a sample
    enters every P = 2^n cycles (every cycle in the parallel option) and leaves
    ``stream_latency = L + 1`` cycles later (L = :func:`core.latency`; the
    FIFO adds one).  ``o_stream.valid`` depends on nothing but the FIFO.
    Reset (synchronous) empties the pipeline and the FIFO.

    Keyword parameters (``hdl.emit`` TOPS ``dflc_stream``): ``fll`` (stem or
    path), ``ip_sz``, ``dy_ip``, ``mf_op_sz``, ``op_sz``, ``div`` (lut /
    array), ``op`` (override sel_op), ``par`` (1: parallel option), and the
    pipeline generics of Table 2 ``psr1_no`` .. ``psr4_no``, ``cpr1_no`` ..
    ``cpr9_no`` (register counts, see :class:`core.DflcCore`; defaults
    :data:`core.PIPE_DEFAULTS`).  With an explicit ``config`` the generics
    come as the ``pipe`` dict.
    """

    # Keyword parameters; the widths' limits are load_fll's (models.dflc.WIDTH_LIMITS).
    PARAMS = (
        Param("fll", str, "table1", doc="a .fll path, or a stem: table1 = models/dflc_table1.fll"),
        *(Param(k, int, d, lo=WIDTH_LIMITS[k][0], hi=WIDTH_LIMITS[k][1], doc=doc,
                message="{name} = {value!r}: must be an integer in {lo}..{hi}")
          for k, d, doc in (("ip_sz", 12, "input code bits"), ("dy_ip", 8, "MF degree bits"),
                            ("mf_op_sz", 12, "singleton code bits (MF_op_sz)"),
                            ("op_sz", 12, "output code bits"))),
        Param("div", str, "lut", choices=DIV_TYPES, doc="divider (div_type)",
              message="div_type = {value!r}: expected one of {choices}"),
        Param("op", str, None, choices=SEL_OPS, none_ok=True,
              doc="antecedent operator override (sel_op; default: the .fll's)",
              message="sel_op = {value!r}: expected one of {choices}"),
        Param("par", bool, 0, doc="1: parallel option, one sample per clock"),
        *DflcCore.PARAMS,
    )
    CONSTRAINTS = (
        Constraint("op_sz >= mf_op_sz", lambda p: p["op_sz"] >= p["mf_op_sz"],
                   "op_sz = {op_sz} < MF_op_sz = {mf_op_sz}: the output must hold a singleton code"),
    )

    @checked_init
    def __init__(self, config=None, parallel=False, pipe=None, **kw):
        if config is None:
            check(self.PARAMS, self.CONSTRAINTS, **{**{p.name: p.default for p in self.PARAMS}, **kw})
            kw, par, pipe_kw = split_params(kw)
            parallel = parallel or par
            pipe = {**pipe_kw, **(pipe or {})}
            config = config_for(**kw)
        elif kw:
            raise TypeError(f"unexpected parameters {sorted(kw)} with an explicit config")
        check_pipe(pipe, op_sz=config.op_sz)
        self.config, self.parallel, self.pipe = config, bool(parallel), dict(pipe or {})
        self.depth = fifo_depth(config, self.parallel, **self.pipe)
        super().__init__({
            "i_stream": In(stream.Signature(sample_layout(config))),
            "o_stream": Out(stream.Signature(result_layout(config))),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"initiation_interval_cycles": 1 if self.parallel else 1 << self.config.n,
                "latency_cycles": stream_latency(self.config, self.parallel, **self.pipe),
                "latency": "i_stream handshake to o_stream.valid, output FIFO empty",
                "fifo_depth": self.depth}

    def elaborate(self, platform):
        m = Module()
        c = self.config
        m.submodules.core = core = DflcCore(c, self.parallel, **self.pipe)
        m.submodules.fifo = fifo = SyncFIFO(width=Shape.cast(result_layout(c)).width, depth=self.depth)
        inflight = Signal(range(self.depth + 1))
        room = Signal()
        m.d.comb += room.eq(inflight + fifo.level < self.depth)
        # Input: the core's stream behind a valve that closes while the FIFO
        # could not take one more result (valid and ready gated alike).
        accept = Signal()
        m.d.comb += [
            core.i_stream.payload.eq(self.i_stream.payload),
            core.i_stream.valid.eq(self.i_stream.valid & room),
            self.i_stream.ready.eq(core.i_stream.ready & room),
            accept.eq(self.i_stream.valid & self.i_stream.ready),
        ]
        # Core -> FIFO: the core's output is always_ready (no back-pressure),
        # the FIFO's write port is not, so no wiring.connect here: the credit
        # count above guarantees that w_rdy is high whenever a result comes.
        m.d.comb += [fifo.w_en.eq(core.o_stream.valid), fifo.w_data.eq(core.o_stream.payload)]
        # FIFO -> output: valid is the FIFO's r_rdy alone.
        wiring.connect(m, fifo.r_stream, wiring.flipped(self.o_stream))
        m.d.sync += inflight.eq(inflight + accept - core.o_stream.valid)
        return m
