"""DFLC: bit-exact model of the zero-order Takagi-Sugeno fuzzy controller core.

Paper 003 (Moustris, Deliparaschos, Tzafestas), sections 4-5 and 7: the
parametrized DFLC soft IP core (Fig. 8, Tables 2-3) running the 81-rule path
tracker of Table 1.  This module is the golden model of ``hdl/dflc``: the RTL
computes exactly what :meth:`Dflc.infer` computes, bit for bit.  A controller
is described by a fuzzylite FLL file (read with pyfuzzylite, see
:func:`load_fll`); the bit widths come from the paper's generics (Table 2).

Number formats and every rounding
---------------------------------
Names follow Table 2: n = ip_no inputs of ip_sz bits, MF_ip_no MFs per input,
degrees of dy_ip bits, MF_op_no singletons of MF_op_sz bits, op_sz output bits.
``full = 2^dy_ip - 1`` is the degree 1.0.

* **Input code** x in [0, 2^ip_sz - 1], unsigned.  A variable with FLL range
  [lo, hi] has code step ``(hi - lo) / 2^ip_sz``: value = lo + x * step, so
  lo is code 0 and hi itself lies one step above the top code (for the
  +-180 degree angles of Table 1 this is the binary angle: +180 = -180).
  :meth:`Dflc.encode` rounds half up, ``x = floor((v - lo)/step + 1/2)``, and
  saturates to [0, 2^ip_sz - 1] (hi and above give the top code; NaN is an
  error).  The RTL needs no saturation: every ip_sz-bit code is in range.
* **MF breakpoints** are moved to the nearest code, ``round((p - lo)/step)``
  (half up); on the shipped .fll files every breakpoint is already a whole
  code (``DflcConfig.off_grid`` lists the terms that were moved).  Between
  codes the MFs are pyfuzzylite's own Triangle / Trapezoid formulas, exactly.
* **Degree of truth** of MF j at code x: ``mu = round(full * MF_j(x))``,
  rounded half up, exact (|error| <= 1/2 LSB).  It is computed as the RTL
  does, ``mu = (x * M + B) >> s`` with one (M, B) pair per input segment and
  slot and one shift s per input; :func:`load_fll` picks the smallest s for
  which this equals the rounded value at *every* code, verified exhaustively.
* **Active rules.**  Overlap 2: at most two MFs of an input are non-zero at any
  code, and they are neighbours in the order of their peaks.  Each input is
  cut into segments; in a segment the two *slots* are MFs i and i+1 (i = the
  lower active MF, clamped to MF_ip_no - 2).  The 2^n combinations k of slots
  (bit j of k = slot of input j) are the active rules, one per clock.
* **Antecedent operator** (sel_op) over the n degrees, folded left:
  min and max exact; prod ``p(a, b) = (t + (t >> dy)) >> dy``,
  ``t = a*b + 2^(dy-1)``, which equals round(a*b/full) half up for all dy-bit
  a, b (checked exhaustively for dy <= 11 in the tests); probor
  ``a + b - p(a, b)``.  For max/probor the core, like the paper's
  architecture, sums only the 2^n slot combinations (an "or" rule base is not
  evaluated over all its rules).
* **Consequent map**: rule -> singleton index (ROM; a missing rule has weight
  0), singleton index -> code ``c = round((v - lo_o) * (2^MF_op_sz - 1) /
  (hi_o - lo_o))`` (half up), unsigned MF_op_sz bits; both ends of the output
  range are exact codes.
* **Implication PROD, aggregation SUM** (Table 3): ``Sw = sum w``,
  ``Swc = sum w * c``, exact integers.
* **Divider**, f = op_sz - MF_op_sz extra fraction bits (op_sz >= MF_op_sz):
  restoring array (div_type "array"): ``y = floor((2^(f+1) Swc + Sw) / (2 Sw))``
  = round(2^f Swc / Sw) half up, exact.  LUT reciprocal (div_type "lut"):
  ``R = round(2^r / Sw)`` half up, tabled for Sw = 1 .. 2^n full, with
  ``r = bitlen(2^f (2^MF_op_sz - 1) 2^n full) + 1``; ``y = (2^f Swc R +
  2^(r-1)) >> r``; its error against 2^f Swc / Sw is below 3/4 code.
* **Zero firing strength** (Sw = 0): y = ``zero_code`` (the output
  variable's FLL ``default`` value if finite, else the range's mid code) and
  the ``zero`` flag is set.
* **Output**: value = lo_o + y * (hi_o - lo_o) / ((2^MF_op_sz - 1) 2^f).

Bound against pyfuzzylite (WeightedAverage TakagiSugeno, aggregation none),
evaluated at the decoded input codes, for min and prod rule bases whose
breakpoints lie on the code grid, for every sample with Sw > 0
(:meth:`Dflc.error_bound`):

    |y_model - y_fl| <= e_w * K * spread / Sw  +  e_c  +  e_d * step_o

* e_w: weight error in LSB: 1/2 for min/max (one rounded degree), (2n-1)/2
  for prod/probor (n rounded degrees, n-1 rounded products);
* K: number of the 2^n active combinations that have a rule; spread: max - min
  of their quantized singleton values; Sw: the model's total strength.  (With
  weights w' = w + e, y' - y = sum e_k (c_k - y) / sum w', and y is a convex
  combination of the c_k.)
* e_c: the largest singleton quantization error |c_q - c| (<= step_c / 2);
* e_d: 1/2 (array) or 3/4 (LUT); step_o the output code step.
Where Sw = 0, pyfuzzylite's total strength is below K e_w / full.
For Table 1 (min, n = 2, Sw >= full because each input is a partition of
unity, spread <= 2) the worst case is 0.5*4*2/255 + 1.2e-4 + 0.75*4.9e-4 =
0.0163 on the [-1, 1] output (33 output codes); the measured maximum over the
74529-sample sweep of tb/dflc/test_dflc_model.py is 0.0117, at codes (1, 1):
there the true degrees 1/512 of three neighbouring rules round to 0 while
their singletons lie 2 away (nb beside pb at the +-180 wrap of Table 1).
Over the full 4096 x 4096 plane (scripts/dflc_plane.py) the maximum is the
same 0.01167 at (1, 1) and no sample exceeds its bound.
"""

from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

__all__ = ["SEL_OPS", "DIV_TYPES", "FllError", "Mf", "InputSpec", "DflcConfig",
           "load_fll", "Dflc", "prod_round", "DEFAULT_FLL"]

SEL_OPS = ("min", "prod", "max", "probor")        # Table 2 sel_op 0..3
DIV_TYPES = ("array", "lut")                      # Table 2 div_type 0..1
# Allowed widths (inclusive), checked by load_fll; hdl's parameter lists read them.
WIDTH_LIMITS = {"ip_sz": (2, 16), "dy_ip": (2, 16), "mf_op_sz": (2, 16), "op_sz": (2, 24)}
DEFAULT_FLL = Path(__file__).resolve().parent / "dflc_table1.fll"
_CONJ = {"Minimum": "min", "AlgebraicProduct": "prod"}
_DISJ = {"Maximum": "max", "AlgebraicSum": "probor"}
_INF = 1 << 62
FLL_MAX_BYTES = 16 << 20


class FllError(ValueError):
    """A .fll file the DFLC cannot implement; the message names the file and the fault."""


@dataclass(frozen=True)
class Mf:
    """One input MF: FLL term name, kind, FLL parameters and breakpoints in codes."""
    name: str
    kind: str                 # "Triangle" or "Trapezoid"
    params: tuple
    points: tuple             # integer codes, ascending


@dataclass(frozen=True)
class InputSpec:
    """One input variable and its MF degree generator tables.

    Segment q covers codes [seg_start[q], seg_start[q+1] - 1]; there the slots
    are MFs seg_base[q] and seg_base[q] + 1, with degrees
    ``(x * seg_m[q][slot] + seg_b[q][slot]) >> shift``.
    """
    name: str
    lo: float
    hi: float
    mfs: tuple                # Mf, in the order of their peaks (= MF index)
    seg_start: tuple
    seg_base: tuple
    seg_m: tuple              # ((M0, M1), ...)
    seg_b: tuple              # ((B0, B1), ...)
    shift: int

    @property
    def terms(self):
        return tuple(mf.name for mf in self.mfs)


@dataclass(frozen=True)
class DflcConfig:
    """Everything the model and the RTL need: widths (Table 2) and ROM contents."""
    name: str
    ip_sz: int
    dy_ip: int
    mf_op_sz: int
    op_sz: int
    div_type: str
    sel_op: str
    inputs: tuple             # InputSpec
    output_name: str
    out_lo: float
    out_hi: float
    out_terms: tuple          # singleton names, in FLL order (= singleton index)
    out_values: tuple         # their FLL values
    singletons: tuple         # their codes (MF_op_sz bits)
    rules: tuple              # flat rule table: singleton index, MF_op_no = no rule
    zero_code: int
    recip_bits: int           # r of the LUT reciprocal
    off_grid: tuple = ()      # terms whose breakpoints were moved to the code grid

    @property
    def n(self):
        return len(self.inputs)

    @property
    def mf_ip_no(self):
        return tuple(len(i.mfs) for i in self.inputs)

    @property
    def mf_op_no(self):
        return len(self.singletons)

    @property
    def full(self):
        return (1 << self.dy_ip) - 1

    @property
    def frac(self):
        return self.op_sz - self.mf_op_sz

    @property
    def s_max(self):
        """Largest total firing strength: 2^n * full."""
        return (1 << self.n) * self.full

    @property
    def strides(self):
        """Rule index = sum m_j * strides[j] (input 0 most significant)."""
        out, s = [], 1
        for k in reversed(self.mf_ip_no):
            out.append(s)
            s *= k
        return tuple(reversed(out))

    def recip(self, sw):
        """LUT reciprocal entry: round(2^r / Sw) half up (Sw >= 1)."""
        return ((1 << (self.recip_bits + 1)) + sw) // (2 * sw)


def prod_round(a, b, dy):
    """round(a*b / (2^dy - 1)) half up for dy-bit a, b, the way the RTL does it."""
    t = a * b + (1 << (dy - 1))
    return (t + (t >> dy)) >> dy


# ----------------------------------------------------------------- loading --

def _fr(x):
    return Fraction(x) if not isinstance(x, Fraction) else x


def _round_half_up(q):
    """floor(q + 1/2) of a Fraction."""
    return (q.numerator * 2 + q.denominator) // (2 * q.denominator)


def _pieces(mf):
    """The MF as affine pieces over the integers: [(start, slope, intercept)],
    each piece running to the next start; values in 0..1 (pyfuzzylite's formulas)."""
    p = mf.points
    zero = (Fraction(0), Fraction(0))
    one = (Fraction(0), Fraction(1))
    if mf.kind == "Triangle":
        a, b, c = p
        out = [(-_INF, *zero)]
        if b > a:
            out.append((a, Fraction(1, b - a), Fraction(-a, b - a)))
        if c > b:
            out.append((b, Fraction(-1, c - b), Fraction(c, c - b)))
        else:
            out.append((b, *one))
        out.append((c + 1, *zero))
    else:
        a, b, c, d = p
        out = [(-_INF, *zero)]
        if b > a:
            out.append((a, Fraction(1, b - a), Fraction(-a, b - a)))
        out.append((b, *one))
        if d > c:
            out.append((c + 1, Fraction(-1, d - c), Fraction(d, d - c)))
        out.append((d + 1, *zero))
    return out


def _piece_at(pieces, x):
    cur = pieces[0]
    for pc in pieces:
        if pc[0] <= x:
            cur = pc
    return cur[1], cur[2]


def _fit(aff, s0, s1, full, shift):
    """(M, B) with floor((x*M + B) / 2^shift) = round_half_up(full*(slope*x+icpt))
    for every integer x in [s0, s1], or None."""
    slope, icpt = aff
    x = np.arange(s0, s1 + 1, dtype=np.int64)
    # target q(x) = floor((P x + Q) / R), all integers
    fs, fi = full * slope, full * icpt + Fraction(1, 2)
    R = np.lcm(fs.denominator, fi.denominator)
    P, Q = int(fs * R), int(fi * R)
    q = (P * x + Q) // R
    M = (2 * P * (1 << shift) + R) // (2 * R)
    lo = int(np.max(q * (1 << shift) - M * x))
    hi = int(np.min((q + 1) * (1 << shift) - M * x)) - 1
    return (int(M), lo) if lo <= hi else None


def _input_spec(path, var, ip_sz, full, off_grid):
    name = var.name
    lo, hi = float(var.minimum), float(var.maximum)
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise FllError(f"{path}: input {name}: range {lo} {hi} must be finite and ascending")
    scale = Fraction(1 << ip_sz) / (_fr(hi) - _fr(lo))
    mfs = []
    for term in var.terms:
        kind = type(term).__name__
        if kind not in ("Triangle", "Trapezoid"):
            raise FllError(f"{path}: input {name}: term {term.name} is {kind}; the DFLC "
                           f"implements Triangle and Trapezoid MFs only")
        if float(term.height) != 1.0:
            raise FllError(f"{path}: input {name}: term {term.name} has height {term.height}; only 1.0")
        params = ((term.left, term.top, term.right) if kind == "Triangle" else
                  (term.bottom_left, term.top_left, term.top_right, term.bottom_right))
        if not all(np.isfinite(p) for p in params) or list(params) != sorted(params):
            raise FllError(f"{path}: input {name}: term {term.name}: breakpoints {params} "
                           f"must be finite and ascending")
        exact = [(_fr(p) - _fr(lo)) * scale for p in params]
        points = tuple(_round_half_up(e) for e in exact)
        if any(e != pt for e, pt in zip(exact, points)):
            off_grid.append(f"{name}.{term.name}")
        mfs.append(Mf(term.name, kind, tuple(float(p) for p in params), points))
    if len(mfs) < 2:
        raise FllError(f"{path}: input {name}: {len(mfs)} term(s); the DFLC needs at least 2 MFs per input")
    if len(mfs) > 64:
        raise FllError(f"{path}: input {name}: {len(mfs)} terms; at most 64 MFs per input")
    mfs.sort(key=lambda mf: (sum(mf.points[1:-1]) / (len(mf.points) - 2), mf.points))
    pieces = [_pieces(mf) for mf in mfs]
    top = 1 << ip_sz
    cuts = sorted({0} | {pc[0] for ps in pieces for pc in ps if 0 < pc[0] < top})
    bounds = list(zip(cuts, cuts[1:] + [top]))
    segs = []         # (start, end, base, aff0, aff1)
    for s0, s1 in bounds:
        s1 -= 1
        affs = [_piece_at(ps, s0) for ps in pieces]
        active = [j for j, (sl, ic) in enumerate(affs)
                  if sl * s0 + ic != 0 or sl * s1 + ic != 0]
        unit = (hi - lo) / top
        where = f"{name} = {lo + s0 * unit:g} .. {lo + s1 * unit:g}"
        if len(active) > 2:
            raise FllError(f"{path}: input {name}: terms {', '.join(mfs[j].name for j in active)} "
                           f"overlap at {where}; the DFLC allows at most two active MFs (overlap 2)")
        if len(active) == 2 and active[1] != active[0] + 1:
            raise FllError(f"{path}: input {name}: terms {mfs[active[0]].name} and "
                           f"{mfs[active[1]].name} overlap at {where} but are not neighbours")
        base = min(active[0] if active else 0, len(mfs) - 2)
        key = (base, affs[base], affs[base + 1])
        if segs and segs[-1][2:] == key:
            segs[-1] = (segs[-1][0], s1, *key)
        else:
            segs.append((s0, s1, *key))
    for shift in range(0, 48):
        fits = []
        for s0, s1, base, a0, a1 in segs:
            f0, f1 = _fit(a0, s0, s1, full, shift), _fit(a1, s0, s1, full, shift)
            if f0 is None or f1 is None:
                break
            fits.append((f0, f1))
        else:
            break
    else:
        raise FllError(f"{path}: input {name}: no degree generator constants found")
    return InputSpec(name=name, lo=lo, hi=hi, mfs=tuple(mfs),
                     seg_start=tuple(s[0] for s in segs), seg_base=tuple(s[2] for s in segs),
                     seg_m=tuple((f0[0], f1[0]) for f0, f1 in fits),
                     seg_b=tuple((f0[1], f1[1]) for f0, f1 in fits), shift=shift)


def _rule_terms(path, rule, inputs, output):
    """(dict input name -> term name, connective set, consequent term) of one rule."""
    from fuzzylite.rule import Operator, Proposition
    props, ops = [], set()

    def walk(node):
        if isinstance(node, Proposition):
            props.append(node)
        elif isinstance(node, Operator):
            ops.add(node.name)
            walk(node.left)
            walk(node.right)
        else:
            raise FllError(f"{path}: rule '{rule.text}': unsupported antecedent")
    walk(rule.antecedent.expression)
    found = {}
    for p in props:
        if p.hedges:
            raise FllError(f"{path}: rule '{rule.text}': hedges ({' '.join(h.name for h in p.hedges)}) "
                           f"are not supported")
        vname = p.variable.name
        if vname not in inputs:
            raise FllError(f"{path}: rule '{rule.text}': {vname} is not an input variable")
        if vname in found:
            raise FllError(f"{path}: rule '{rule.text}': input {vname} appears twice")
        found[vname] = p.term.name
    missing = [v for v in inputs if v not in found]
    if missing:
        raise FllError(f"{path}: rule '{rule.text}': no proposition on input(s) {', '.join(missing)}; "
                       f"every rule must name every input")
    concl = rule.consequent.conclusions
    if len(concl) != 1 or concl[0].variable.name != output.name or concl[0].hedges:
        raise FllError(f"{path}: rule '{rule.text}': the consequent must be one "
                       f"'{output.name} is <constant>'")
    if float(rule.weight) != 1.0:
        raise FllError(f"{path}: rule '{rule.text}': rule weight {rule.weight}; only 1.0")
    return found, ops, concl[0].term.name


def load_fll(path, *, ip_sz=12, dy_ip=8, mf_op_sz=12, op_sz=12, div_type="lut", sel_op=None):
    """Read a .fll file with pyfuzzylite and build the DFLC configuration.

    The widths are the paper's generics (Table 2 defaults).  ``sel_op``
    (min, prod, max, probor) overrides the antecedent operator the rule block
    names (the comparison with pyfuzzylite then no longer applies).  Raises
    :class:`FllError` naming the file and the variable / term / rule at fault.
    """
    import fuzzylite as fl

    path = Path(path)
    for what, v in (("ip_sz", ip_sz), ("dy_ip", dy_ip), ("mf_op_sz", mf_op_sz), ("op_sz", op_sz)):
        lo, hi = WIDTH_LIMITS[what]
        if not isinstance(v, int) or not lo <= v <= hi:
            raise ValueError(f"{what} = {v!r}: must be an integer in {lo}..{hi}")
    if op_sz < mf_op_sz:
        raise ValueError(f"op_sz = {op_sz} < MF_op_sz = {mf_op_sz}: the output must hold a singleton code")
    if div_type not in DIV_TYPES:
        raise ValueError(f"div_type = {div_type!r}: expected one of {DIV_TYPES}")
    override = sel_op
    if sel_op is not None and sel_op not in SEL_OPS:
        raise ValueError(f"sel_op = {sel_op!r}: expected one of {SEL_OPS}")
    try:
        data = path.read_bytes()
    except OSError as e:
        raise FllError(f"{path}: cannot read: {e.strerror or e}") from None
    if len(data) > FLL_MAX_BYTES:
        raise FllError(f"{path}: {len(data)} bytes; at most {FLL_MAX_BYTES >> 20} MiB (about 200,000 rule "
                       "lines) are read: pyfuzzylite holds the whole engine in memory")
    try:
        text = data.decode("utf-8")
        if "\0" in text:
            raise UnicodeDecodeError("utf-8", data, text.index("\0"), text.index("\0") + 1, "NUL")
    except UnicodeDecodeError as e:
        line = data[:e.start].count(b"\n") + 1
        raise FllError(f"{path}:{line}: byte 0x{data[e.start]:02x} is not UTF-8 text: not an FLL file") from None
    try:
        engine = fl.FllImporter().from_string(text)
    except Exception as e:  # noqa: BLE001 - pyfuzzylite raises many kinds
        raise FllError(f"{path}: not a valid FLL file: {type(e).__name__}: {e}") from None
    ins, outs = list(engine.input_variables), list(engine.output_variables)
    if not 1 <= len(ins) <= 4:
        raise FllError(f"{path}: {len(ins)} input variables; the DFLC takes 1 to 4 (ip_no)")
    if len(outs) != 1:
        raise FllError(f"{path}: {len(outs)} output variables "
                       f"({', '.join(o.name for o in outs)}); the DFLC has exactly one output")
    blocks = [b for b in engine.rule_blocks if b.enabled]
    if len(blocks) != 1:
        raise FllError(f"{path}: {len(blocks)} enabled rule blocks; expected exactly one")
    block, out = blocks[0], outs[0]
    full = (1 << dy_ip) - 1
    off_grid = []
    inputs = tuple(_input_spec(path, v, ip_sz, full, off_grid) for v in ins)

    o_lo, o_hi = float(out.minimum), float(out.maximum)
    if not (np.isfinite(o_lo) and np.isfinite(o_hi) and o_lo < o_hi):
        raise FllError(f"{path}: output {out.name}: range {o_lo} {o_hi} must be finite and ascending")
    cmax = (1 << mf_op_sz) - 1
    out_terms, out_values, singletons = [], [], []
    for term in out.terms:
        kind = type(term).__name__
        if kind != "Constant":
            raise FllError(f"{path}: output {out.name}: term {term.name} is {kind}; the DFLC "
                           f"implements constant (singleton) consequents only")
        v = float(term.value)
        if not o_lo <= v <= o_hi:
            raise FllError(f"{path}: output {out.name}: term {term.name} = {v} is outside the range "
                           f"{o_lo} {o_hi}")
        out_terms.append(term.name)
        out_values.append(v)
        singletons.append(_round_half_up((_fr(v) - _fr(o_lo)) * cmax / (_fr(o_hi) - _fr(o_lo))))
    if not out_terms:
        raise FllError(f"{path}: output {out.name} has no terms")
    frac = op_sz - mf_op_sz
    d = float(out.default_value)
    if np.isfinite(d):
        zc = _round_half_up((_fr(min(max(d, o_lo), o_hi)) - _fr(o_lo)) * cmax * (1 << frac)
                            / (_fr(o_hi) - _fr(o_lo)))
    else:
        zc = (cmax * (1 << frac) + 1) // 2

    # Rules -> flat table (input 0 most significant).
    names = [v.name for v in ins]
    index = [{mf.name: k for k, mf in enumerate(spec.mfs)} for spec in inputs]
    counts = [len(spec.mfs) for spec in inputs]
    none = len(singletons)
    table = [none] * int(np.prod(counts))
    conn = set()
    seen = {}
    for rule in block.rules:
        if not rule.is_loaded():
            raise FllError(f"{path}: rule '{rule.text}' does not load (unknown variable or term)")
        found, ops, cterm = _rule_terms(path, rule, names, out)
        conn |= ops
        flat = 0
        for j, v in enumerate(names):
            flat = flat * counts[j] + index[j][found[v]]
        if flat in seen:
            raise FllError(f"{path}: rule '{rule.text}' has the same antecedent as rule "
                           f"'{seen[flat]}'")
        seen[flat] = rule.text
        table[flat] = out_terms.index(cterm)
    if not seen:
        raise FllError(f"{path}: the rule block has no rules")
    if len(conn) > 1:
        raise FllError(f"{path}: the rules mix 'and' and 'or'; the DFLC has one antecedent operator")
    conj = type(block.conjunction).__name__ if block.conjunction else None
    disj = type(block.disjunction).__name__ if block.disjunction else None
    if conn == {"or"}:
        if disj not in _DISJ:
            raise FllError(f"{path}: disjunction {disj}: the DFLC implements Maximum and AlgebraicSum")
        sel_op = _DISJ[disj]
    elif conn == {"and"} or conj is not None:
        if conj not in _CONJ:
            raise FllError(f"{path}: conjunction {conj}: the DFLC implements Minimum and AlgebraicProduct")
        sel_op = _CONJ[conj]
    elif disj is not None:
        if disj not in _DISJ:
            raise FllError(f"{path}: disjunction {disj}: the DFLC implements Maximum and AlgebraicSum")
        sel_op = _DISJ[disj]
    else:
        sel_op = "min"           # one input, no operator: all four are the identity

    if override is not None:
        sel_op = override
    q_max = (1 << frac) * cmax * (1 << len(inputs)) * full
    return DflcConfig(
        name=engine.name or path.stem, ip_sz=ip_sz, dy_ip=dy_ip, mf_op_sz=mf_op_sz, op_sz=op_sz,
        div_type=div_type, sel_op=sel_op, inputs=inputs, output_name=out.name,
        out_lo=o_lo, out_hi=o_hi, out_terms=tuple(out_terms), out_values=tuple(out_values),
        singletons=tuple(singletons), rules=tuple(table), zero_code=zc,
        recip_bits=q_max.bit_length() + 1, off_grid=tuple(off_grid))


# ------------------------------------------------------------------- model --

class Dflc:
    """The DFLC golden model, vectorized over samples."""

    def __init__(self, config):
        self.config = config
        c = config
        self._rules = np.array(c.rules, dtype=np.int64)
        self._cons = np.array(list(c.singletons) + [0], dtype=np.int64)   # "no rule" -> c = 0
        self._big = 2 * c.recip_bits + 2 > 62

    @classmethod
    def from_fll(cls, path=DEFAULT_FLL, **widths):
        return cls(load_fll(path, **widths))

    @property
    def input_names(self):
        return tuple(i.name for i in self.config.inputs)

    @property
    def output_name(self):
        return self.config.output_name

    # -- codes <-> values
    def encode(self, values):
        """Input values (N, n) in the variables' units -> codes (N, n), saturating."""
        c = self.config
        v = np.asarray(values, dtype=float)
        if v.ndim == 1:
            v = v.reshape(1, -1) if v.size == c.n else v.reshape(-1, 1)
        if v.ndim != 2 or v.shape[1] != c.n:
            raise ValueError(f"expected values of shape (N, {c.n}), got {np.shape(values)}")
        out = np.empty(v.shape, dtype=np.int64)
        top = (1 << c.ip_sz) - 1
        for j, spec in enumerate(c.inputs):
            col = v[:, j]
            if np.isnan(col).any():
                raise ValueError(f"input {spec.name}: NaN at sample {int(np.argmax(np.isnan(col)))}")
            x = np.floor((col - spec.lo) * (1 << c.ip_sz) / (spec.hi - spec.lo) + 0.5)
            out[:, j] = np.clip(x, 0, top).astype(np.int64)
        return out

    def decode_inputs(self, codes):
        """Input codes -> values (the points the codes stand for)."""
        c = self.config
        codes = np.asarray(codes)
        return np.stack([spec.lo + codes[:, j] * ((spec.hi - spec.lo) / (1 << c.ip_sz))
                         for j, spec in enumerate(c.inputs)], axis=1)

    @property
    def output_step(self):
        c = self.config
        return (c.out_hi - c.out_lo) / (((1 << c.mf_op_sz) - 1) << c.frac)

    def decode(self, y_codes):
        """Output codes -> values in the output variable's units."""
        return self.config.out_lo + np.asarray(y_codes, dtype=float) * self.output_step

    # -- inference
    def _check_codes(self, codes):
        c = self.config
        codes = np.asarray(codes, dtype=np.int64)
        if codes.ndim == 1:
            codes = codes.reshape(1, -1)
        if codes.ndim != 2 or codes.shape[1] != c.n:
            raise ValueError(f"expected codes of shape (N, {c.n}), got {codes.shape}")
        if codes.size and (codes.min() < 0 or codes.max() >= (1 << c.ip_sz)):
            raise ValueError(f"input codes must lie in 0 .. {(1 << c.ip_sz) - 1}")
        return codes

    def degrees(self, codes):
        """Per input j: (base MF index i_j (N,), degrees (N, 2) of MFs i_j, i_j + 1)."""
        codes = self._check_codes(codes)
        out = []
        for j, spec in enumerate(self.config.inputs):
            x = codes[:, j]
            seg = np.searchsorted(np.array(spec.seg_start), x, side="right") - 1
            m = np.array(spec.seg_m, dtype=np.int64)[seg]
            b = np.array(spec.seg_b, dtype=np.int64)[seg]
            mu = (x[:, None] * m + b) >> spec.shift
            out.append((np.array(spec.seg_base, dtype=np.int64)[seg], mu))
        return out

    def tnorm(self, degs):
        """The antecedent operator (sel_op) folded left over a list of degree arrays."""
        c = self.config
        w = degs[0]
        for d in degs[1:]:
            if c.sel_op == "min":
                w = np.minimum(w, d)
            elif c.sel_op == "max":
                w = np.maximum(w, d)
            elif c.sel_op == "prod":
                w = prod_round(w, d, c.dy_ip)
            else:
                w = w + d - prod_round(w, d, c.dy_ip)
        return w

    def combos(self, codes):
        """The 2^n active rules of every sample, in clock order k = 0 .. 2^n - 1:
        (rule index (N, K), weight w (N, K), singleton code c (N, K), has_rule (N, K))."""
        c = self.config
        deg = self.degrees(codes)
        K = 1 << c.n
        N = deg[0][0].shape[0]
        rule = np.zeros((N, K), dtype=np.int64)
        w = np.zeros((N, K), dtype=np.int64)
        for k in range(K):
            bits = [(k >> j) & 1 for j in range(c.n)]
            idx = sum((base + bt) * s for (base, _), bt, s in zip(deg, bits, c.strides))
            rule[:, k] = idx
            w[:, k] = self.tnorm([mu[:, bt] for (_, mu), bt in zip(deg, bits)])
        sing = self._rules[rule]
        has = sing < c.mf_op_no
        w = np.where(has, w, 0)
        return rule, w, self._cons[sing], has

    def divide(self, swc, sw):
        """The divider: y code from Swc, Sw (Sw > 0 where it matters)."""
        c = self.config
        f = c.frac
        if self._big:
            swc, sw = swc.astype(object), sw.astype(object)
        safe = np.where(sw > 0, sw, 1)
        if c.div_type == "array":
            y = ((swc << (f + 1)) + safe) // (2 * safe)
        else:
            r = c.recip_bits
            R = ((1 << (r + 1)) + safe) // (2 * safe)
            y = (((swc << f) * R) + (1 << (r - 1))) >> r
        return np.asarray(y).astype(np.int64)

    def infer(self, codes):
        """Input codes (N, n) -> (y codes (N,), zero_strength (N,) bool), bit-exact with the RTL."""
        _, w, cc, _ = self.combos(codes)
        sw = w.sum(axis=1)
        swc = (w * cc).sum(axis=1)
        zero = sw == 0
        y = np.where(zero, self.config.zero_code, self.divide(swc, sw))
        return y.astype(np.int64), zero

    def evaluate(self, values):
        """Values (N, n) -> (y values, y codes, zero_strength)."""
        y, zero = self.infer(self.encode(values))
        return self.decode(y), y, zero

    # -- the bound against a float evaluation (docstring of the module)
    def weight_error_lsb(self):
        c = self.config
        return 0.5 if c.sel_op in ("min", "max") else (2 * c.n - 1) / 2

    def singleton_error(self):
        c = self.config
        step_c = (c.out_hi - c.out_lo) / ((1 << c.mf_op_sz) - 1)
        return max(abs(c.out_lo + q * step_c - v) for q, v in zip(c.singletons, c.out_values))

    def error_bound(self, codes):
        """Per-sample bound on |y_model - y_float| in output units (inf where Sw = 0)."""
        c = self.config
        _, w, cc, has = self.combos(codes)
        sw = w.sum(axis=1)
        step_c = (c.out_hi - c.out_lo) / ((1 << c.mf_op_sz) - 1)
        big = np.iinfo(np.int64).max
        hi = np.where(has, cc, -big).max(axis=1)
        lo = np.where(has, cc, big).min(axis=1)
        spread = np.where(has.any(axis=1), hi - lo, 0) * step_c
        k = has.sum(axis=1)
        e_d = 0.5 if c.div_type == "array" else 0.75
        with np.errstate(divide="ignore", invalid="ignore"):
            b = self.weight_error_lsb() * k * spread / sw
        b = np.where(sw > 0, b, np.inf)
        return b + self.singleton_error() + e_d * self.output_step + 1e-9
