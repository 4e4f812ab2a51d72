"""Border nodes of a block: storage of the neighbouring blocks' edge values
(paper 000, sections 5.1 and 5.4)."""

from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import data, wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from ..block_ram import BlockRam
from ..params import REQUIRED, Param, check, checked_init

__all__ = ["Border", "BorderExponentsSignature", "SIDES"]

SIDES = ("N", "S", "W", "E")        # the border sides, in the order of the per-side fields
LANE = 18                           # border nodes per RAM word: the 1Kx18 block RAM's width


class BorderExponentsSignature(wiring.Signature):
    """The border conversion of the block-exponent option (issue 10, beyond
    the paper), seen from the Control module that drives it; the
    :class:`Border` takes the flipped form (``conversion``).  See the
    Border's "Block exponents" section for the timing.

    Parameters
    ----------
    stride : int
        RAM words per block (p_max + 2).
    e_max : int
        Largest block exponent.

    Members
    -------
    s : Out(StructLayout N, S, W, E of signed(bits(e_max) + 1))
        Per side, e_b - e_b' (the computed block's exponent minus the
        neighbour's): the conversion's shift.
    raw : Out(1)
        The MSB-first streams read unconverted (update visits), for ``lead``.
    scan : Out(1)
        The clamp scan's strobe (once per visit, before the iterations).
    scan_busy, clamped : In(1)
        The scan is on; some border node of the block is clamped.
    scan_len : In(range(stride + 1))
        The scan's length L (its cycles after the strobe).
    lead : In(StructLayout N, S, W, E of range(stride + 1))
        Per side, the smallest offset 1..p+1 at which a raw MSB-first read
        showed a 1 since the last ``scan`` (``stride``: none).
    """

    def __init__(self, stride, e_max):
        self.stride, self.e_max = stride, e_max
        L = range(stride + 1)
        super().__init__({
            "s": Out(data.StructLayout({side: signed(e_max.bit_length() + 1) for side in SIDES})),
            "raw": Out(1), "scan": Out(1),
            "scan_busy": In(1), "scan_len": In(L), "clamped": In(1),
            "lead": In(data.StructLayout({side: L for side in SIDES})),
        })

    def __eq__(self, other):
        return type(other) is type(self) and (self.stride, self.e_max) == (other.stride, other.e_max)


class Border(wiring.Component):
    """The border nodes around an n x m block of a map of BR x BC blocks.

    Four edge stores keep every block's edges: ``top`` (row 0, m border
    nodes), ``bottom`` (row n-1), ``left`` (column 0, n nodes) and ``right``
    (column m-1).  Each is packed like the clusters' RAMs (one bit per
    address, block b's words at base ``b*stride``, flag first then value
    bits MSB first) with 18 border nodes per RAM word (:data:`LANE`, the
    width of the paper's 1Kx18 block RAM): ceil(m/18) RAMs per row edge,
    ceil(n/18) per column edge, each one dual-port block RAM (port A reads
    LSB first, port B writes, as in the cluster: the nodes' Maximum compares
    LSB first too): 2*ceil(m/18) + 2*ceil(n/18) RAMs, 12 for the paper's
    36x66 block (its 204 border nodes in 12 block RAMs, 5.4), 18 for 48x96.
    A lane word holds one edge of one block, so the four sides read four
    blocks at once.

    Every write writes all lanes of the four edges at one address: the
    clusters' write port (all clusters write in lockstep) while the block
    that holds those nodes is computed, and the whole edge words the
    :class:`~hdl.harmonic.block.Block` assembles after a host write.  While
    block b = br*BC + bc is computed, the border nodes stream, with the
    clusters' read addresses and their two cycles of RAM latency (a
    registered read: the block RAM's output register):

    ==========  ==========================================  ===============
    border      the edge it reads                           block address
    ==========  ==========================================  ===============
    N (m bits)  bottom row of block b-BC                    B-k (k = BC)
    S (m bits)  top row of block b+BC                       B+k
    W (n bits)  right column of block b-1                   B-1
    E (n bits)  left column of block b+1                    B+1
    ==========  ==========================================  ===============

    A border outside the map (br = 0 for N, br = BR-1 for S, bc = 0 for W,
    bc = BC-1 for E) generates the constant 0 (an obstacle).  Every side
    streams ``h_*`` at ``base + cntR`` (LSB first: the Update and the
    Maximum).

    Parameters
    ----------
    n, m : int
        Block rows and columns.
    blocks : (BR, BC)
        Block rows and columns of the map.
    p_max : int
        Largest precision: ``stride`` = p_max + 2 RAM words per block.
    exponents : bool
        Block exponents (issue 10; default False: the ports and logic below
        do not exist and the module is the fixed-point one).  Each stream is
        read in the computed block's units, :func:`models.harmonic.convert_mantissa`
        bit for bit: see "Block exponents" below.
    e_max : int
        Largest block exponent (exponents only; 255: 8-bit registers).

    Block exponents
    ---------------
    Per side, ``s_*`` = e_b - e_b' (the computed block's exponent minus the
    neighbour's).  Value bit k of a word is at offset 1 + p - k, so the
    converted bit k (v >> -s for s < 0, v << s for s > 0) is at offset
    ``cntR + s``: a read offset, i.e. the stream read -s bits late or
    delayed by s cycles.  An offset outside 1 .. p+1
    (the shifted-in zeros, or bits shifted out) reads 0; the flag cycle
    (``cntR`` = 0) reads the flag unshifted.  The clamp (s > 0: a 1 in the
    top s bits, offsets 1 .. min(s, p+1), saturates the value at
    2^(p+1)-1) must be known before the LSB-first stream starts: a *scan*
    reads those offsets once per visit (the neighbours' words do not change
    while block b is computed) through the MSB-first port and keeps one
    ``over`` bit per border node; then every value bit of a clamped node
    streams 1.  ``clamped`` (OR of the over bits) marks block b saturated.

    ===========  ==========================================================
    cycle        scan (``scan`` strobe at t; ``scan_len`` = L)
    ===========  ==========================================================
    t            over cleared; offset 1 presented (if L > 0)
    t+j          offset 1+j presented (j < L); the data of offset j arrives
    t+L          the last data arrives; ``scan_busy`` low from t+L+1 (L = 0:
                 ``scan_busy`` is never high; the scan costs nothing)
    ===========  ==========================================================

    With block exponents a second read port reads MSB first (at ``r_cnt``:
    the scan, and the raw reads for ``lead``), also while the block writes,
    so each RAM has three ports (yosys doubles it).

    Exponent ports: ``p`` In (the run's precision), ``r_cnt`` In (the
    clusters' MSB-first counter) and ``conversion``
    In(:class:`BorderExponentsSignature`): ``s.N .. s.E`` In(signed),
    ``scan`` In(1), ``scan_busy`` Out(1), ``scan_len`` Out (max over the
    sides inside the map of clip(s, 0, p+1)), ``clamped`` Out(1); ``raw``
    In(1): the MSB-first streams read unconverted (update visits: the nodes
    do not use them), and ``lead.N .. lead.E`` Out: the smallest offset
    (1..p+1) at which a raw MSB-first read of that side showed a 1 since
    the last ``scan`` strobe (``stride``: none seen), i.e. the bit length
    p+2-lead of the largest neighbour value, for the re-pick.

    Ports
    -----
    br, bc : In
        Row and column of the block being computed (held during the visit).
    cntR : In
        The clusters' read address offset (relative to a block base).
    addr : In(range(depth))
        The clusters' absolute read address (base + cntR).
    w_addr : In(range(depth)); w_en : In(1)
    w_top, w_bottom : In(m); w_left, w_right : In(n)
        Edge write: absolute address, enable, every edge node's bit.
    h_N, h_S : Out(m); h_W, h_E : Out(n)
        The border streams.
    """

    # hdl.emit's names: br, bc are ``blocks`` = (BR, BC).
    PARAMS = (
        *(Param(k, int, default, lo=1, doc=doc, message=f"{k}={{value!r}}: must be an integer >= 1")
          for k, default, doc in (("n", REQUIRED, "block rows"), ("m", REQUIRED, "block columns"),
                                  ("br", 1, "block rows of the map (BR)"),
                                  ("bc", 1, "block columns of the map (BC)"))),
        Param("p_max", int, 30, lo=2, doc="largest precision (stride p_max + 2 words per block)",
              message="precision p_max={value!r} is not supported: p must be at least 2"),
        Param("exponents", bool, False, doc="block exponents (issue 10, beyond the paper)",
              message="exponents={value!r}: must be True or False"),
        Param("e_max", int, 255, lo=1, doc="largest block exponent (with exponents)",
              message="e_max={value!r}: must be an integer >= 1"),
    )

    @checked_init
    def __init__(self, n, m, blocks, p_max, exponents=False, e_max=255):
        BR, BC = blocks
        check(self.PARAMS, n=n, m=m, br=BR, bc=BC, p_max=p_max, exponents=exponents, e_max=e_max)
        stride = p_max + 2
        self.n, self.m, self.BR, self.BC, self.stride = n, m, BR, BC, stride
        self.depth = BR * BC * stride
        self.exponents = bool(exponents)
        self.e_max = e_max
        extra = {}
        if self.exponents:
            extra = {"p": In(range(stride)), "r_cnt": In(range(stride)),
                     "conversion": In(BorderExponentsSignature(stride, e_max))}
        super().__init__({
            "br": In(range(max(BR, 2))), "bc": In(range(max(BC, 2))),
            "cntR": In(range(stride)), "addr": In(range(self.depth)),
            "w_addr": In(range(self.depth)), "w_en": In(1),
            "w_top": In(m), "w_bottom": In(m), "w_left": In(n), "w_right": In(n),
            "h_N": Out(m), "h_S": Out(m), "h_W": Out(n), "h_E": Out(n),
            **extra,
        })

    def elaborate(self, platform):
        m = Module()
        S, BC = self.stride, self.BC
        b = Signal(range(max(self.BR * BC, 2)))
        m.d.comb += b.eq(self.br * BC + self.bc)
        sides = (
            # (RAM, width, data, out side, source-block offset, valid)
            ("bottom", self.m, self.w_bottom, "N", -BC, self.br != 0),
            ("top", self.m, self.w_top, "S", BC, self.br != self.BR - 1),
            ("right", self.n, self.w_right, "W", -1, self.bc != 0),
            ("left", self.n, self.w_left, "E", 1, self.bc != BC - 1),
        )
        for name, width, wdata, side, offset, valid in sides:
            src = Signal(range(self.depth), name=f"src_{side}")
            if self.exponents:
                m.d.comb += src.eq(Mux(valid, (b + offset) * S, 0))
            else:
                # The clusters' absolute read address plus the constant
                # distance to the neighbour block: no multiplier and one
                # adder before the RAM (outside the map the address is
                # anything: the data are masked).
                m.d.comb += src.eq(self.addr + offset * S)
            # The validity of the data follows its address by one cycle (the
            # MSB-first port) and by READ_LATENCY cycles (the registered
            # LSB-first streams, in step with the clusters' reads).
            ok, ok2 = Signal(name=f"ok_{side}"), Signal(name=f"ok2_{side}")
            m.d.sync += [ok.eq(valid), ok2.eq(ok)]
            if self.exponents:
                conv = self._shift(m, side, width, ok, ok2, valid)
            for k in range(-(-width // LANE)):
                sl = slice(k * LANE, min((k + 1) * LANE, width))
                # Reads hit the neighbour blocks' words, writes the computed
                # block's own (or, while idle, the host's, when no read is
                # used): never one address in one cycle, so yosys need not
                # emulate collisions (no logic between the RAM and its
                # output register).
                if not self.exponents:
                    # The LSB-first reads, registered (the block RAM's output
                    # register, as in the cluster: read latency 2, no address
                    # multiplexer before it: hdl/block_ram.py).
                    ram = BlockRam(sl.stop - sl.start, self.depth, attrs={"no_rw_check": 1})
                    m.submodules[f"ram_{name}_{k}"] = ram
                    m.d.comb += [ram.w_data.eq(wdata[sl]), ram.w_en.eq(self.w_en), ram.w_addr.eq(self.w_addr),
                                 ram.r_addr.eq(src),
                                 getattr(self, f"h_{side}")[sl].eq(Mux(ok2, ram.r_data, 0))]
                    continue
                ram = Memory(shape=sl.stop - sl.start, depth=self.depth, init=[], attrs={"no_rw_check": 1})
                m.submodules[f"ram_{name}_{k}"] = ram
                lsb = ram.read_port()
                wp = ram.write_port()
                m.d.comb += [wp.data.eq(wdata[sl]), wp.en.eq(self.w_en), wp.addr.eq(self.w_addr)]
                # The LSB-first read data register (read latency 2), and the
                # scan and the raw reads: a second read port, MSB first, also
                # while the block writes (yosys doubles the RAM).
                lsb_data = Signal(sl.stop - sl.start, name=f"lsb_{name}_{k}", reset_less=True)
                m.d.sync += lsb_data.eq(lsb.data)
                conv(src, sl, lsb, lsb_data, ram.read_port())
        if self.exponents:
            self._scan_control(m)
        return m

    # Block exponents (issue 10).  Not elaborated by default.

    def _scan_control(self, m):
        """The per-visit clamp scan's counter (see the class docstring)."""
        p1 = Signal(range(self.stride + 1))
        m.d.comb += p1.eq(self.p + 1)
        lens = []
        for side, valid in (("N", self.br != 0), ("S", self.br != self.BR - 1),
                            ("W", self.bc != 0), ("E", self.bc != self.BC - 1)):
            s = self.conversion.s[side]
            ln = Signal(range(self.stride + 1), name=f"scan_len_{side}")
            m.d.comb += ln.eq(Mux(~valid | (s <= 0), 0, Mux(s >= p1, p1, s)))
            lens.append(ln)
        acc = lens[0]
        for ln in lens[1:]:
            acc = Mux(ln > acc, ln, acc)
        x = self.conversion
        m.d.comb += x.scan_len.eq(acc)
        busy = Signal()
        j = Signal(range(self.stride + 1))
        m.d.comb += [
            self._pres.eq((x.scan & (x.scan_len != 0)) | busy),
            self._jcur.eq(Mux(x.scan, 0, j)),
            x.scan_busy.eq(busy | self._pres_r),
            x.clamped.eq(Cat(*self._overs).any()),
        ]
        m.d.sync += [self._pres_r.eq(self._pres), self._jr.eq(self._jcur)]
        with m.If(self._pres):
            m.d.sync += [j.eq(self._jcur + 1), busy.eq(self._jcur + 1 < x.scan_len)]

    def _shift(self, m, side, width, ok, ok2, valid):
        """One side's converted stream: read offset cntR + s, 0 outside
        offsets 1..p+1, the flag unshifted, all ones where clamped; the
        MSB-first port for the scan and the raw reads."""
        if not hasattr(self, "_pres"):
            self._pres, self._pres_r = Signal(), Signal()
            self._jcur, self._jr = Signal(range(self.stride + 1)), Signal(range(self.stride + 1))
            self._overs = []
        x = self.conversion
        s = x.s[side]
        over = Signal(width, name=f"over_{side}")
        self._overs.append(over)
        with m.If(x.scan):
            m.d.sync += over.eq(0)
        top = self.p + 1
        lead = x.lead[side]
        raw_r, roff_r = Signal(name=f"raw_{side}_r"), Signal(range(self.stride), name=f"roff_{side}_r")
        m.d.sync += [raw_r.eq(x.raw), roff_r.eq(self.r_cnt)]
        with m.If(x.scan):
            m.d.sync += lead.eq(self.stride)
        off = Signal(signed(max(self.stride, self.e_max).bit_length() + 3), name=f"off_{side}")
        flag, inr = Signal(name=f"flag_{side}"), Signal(name=f"inr_{side}")
        flag_r, inr_r = Signal(name=f"flag_{side}_r"), Signal(name=f"inr_{side}_r")
        flag_rr, inr_rr = Signal(name=f"flag_{side}_rr"), Signal(name=f"inr_{side}_rr")
        m.d.comb += [off.eq(self.cntR + s), flag.eq(self.cntR == 0), inr.eq((off >= 1) & (off <= top))]
        m.d.sync += [flag_r.eq(flag), inr_r.eq(inr), flag_rr.eq(flag_r), inr_rr.eq(inr_r)]
        addr = Signal(range(self.stride), name=f"addr_{side}")
        m.d.comb += addr.eq(Mux(flag | ~inr, 0, off[:len(addr)]))
        # The scan's accumulation: the data of offset 1+jr arrives now.
        sel_s = Signal(name=f"scan_sel_{side}")
        m.d.comb += sel_s.eq(self._pres_r & ok & (self._jr < s))

        def conv(src, sl, lsb, lsb_data, msb):
            m.d.comb += [lsb.addr.eq(src + addr),
                         msb.addr.eq(Mux(self._pres, src + 1 + self._jcur, src + self.r_cnt))]
            out = Mux(flag_rr, lsb_data, Mux(inr_rr, lsb_data, 0) | over[sl])
            m.d.comb += getattr(self, f"h_{side}")[sl].eq(Mux(ok2, out, 0))
            with m.If(sel_s):
                m.d.sync += over[sl].eq(over[sl] | msb.data)
            # The ring lead: a raw read of offset r_cnt (registered) with a 1.
            with m.If(raw_r & ~self._pres_r & ok & (roff_r >= 1) & (roff_r <= top) & msb.data.any()
                      & (roff_r < lead)):
                m.d.sync += lead.eq(roff_r)
        return conv
