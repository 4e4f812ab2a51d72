"""DFLC golden model (models/dflc.py) against pyfuzzylite and exact arithmetic.

* The Table 1 rule base as read from models/dflc_table1.fll (81 rules, the
  chosen missing value, the antisymmetry it rests on).
* Degrees of truth: at every code of every input of every shipped .fll, the
  model's ``(x*M + B) >> s`` equals round(full * membership) (half up) with the
  membership from pyfuzzylite's own Triangle/Trapezoid at the code's value.
* The prod rounding identity for every dy <= 11; the LUT divider's error
  against exact division.
* The model against pyfuzzylite's evaluation of the same .fll over a dense
  sweep (every breakpoint and its +-1 codes, the extremes, a grid): within the
  per-sample bound of the model docstring; the max/probor fixtures against a
  float evaluation of the same active-rule semantics.
* Refused .fll files name the term/rule/variable; encode saturates.
"""

import itertools
from pathlib import Path

import fuzzylite as fl
import numpy as np
import pytest

from navcores.models.dflc import DEFAULT_FLL, Dflc, FllError, load_fll, prod_round

FIXTURES = Path(__file__).resolve().parent / "fll"
ALL_FLL = [DEFAULT_FLL] + sorted(FIXTURES.glob("*.fll"))


def engine(path):
    return fl.FllImporter().from_file(str(path))


def sweep_codes(model, grid=256, extra=()):
    """Per input: breakpoints and +-1, extremes, a grid; then their product."""
    c = model.config
    top = (1 << c.ip_sz) - 1
    axes = []
    for spec in c.inputs:
        pts = {0, 1, top - 1, top, *range(0, top + 1, max(1, (top + 1) // grid))}
        for mf in spec.mfs:
            for p in mf.points:
                pts |= {p - 1, p, p + 1}
        for s in spec.seg_start:
            pts |= {s - 1, s, s + 1}
        axes.append(sorted(v for v in pts if 0 <= v <= top))
    if len(axes) > 2:        # keep 3- and 4-input sweeps moderate
        per = {3: 48, 4: 12}[len(axes)]
        axes = [a[:: max(1, len(a) // per)] + [a[-1]] for a in axes]
    return np.array(list(itertools.product(*axes)), dtype=np.int64)


def fl_eval(path, values):
    e = engine(path)
    for j, var in enumerate(e.input_variables):
        var.value = values[:, j]
    e.process()
    return np.asarray(e.output_variables[0].value, dtype=float), e


def fl_total_strength(e, model, values):
    """Sum of the rule activation degrees pyfuzzylite computes."""
    block = e.rule_blocks[0]
    tot = np.zeros(len(values))
    for rule in block.rules:
        tot = tot + np.asarray(rule.activation_degree, dtype=float)
    return tot


def float_reference(model, values):
    """Float evaluation of the active-combination semantics (for max/probor),
    degrees from pyfuzzylite's terms, exact singleton values."""
    c = model.config
    e = engine_for(model)
    codes = model.encode(values)
    degs = model.degrees(codes)
    K = 1 << c.n
    sw = np.zeros(len(values))
    swc = np.zeros(len(values))
    terms = [list(e.input_variables[j].terms) for j in range(c.n)]
    order = [[next(t for t in terms[j] if t.name == mf.name) for mf in spec.mfs]
             for j, spec in enumerate(c.inputs)]
    for k in range(K):
        idx = 0
        mus = []
        for j in range(c.n):
            m = degs[j][0] + ((k >> j) & 1)
            idx = idx + m * c.strides[j]
            mu = np.zeros(len(values))
            for q in np.unique(m):
                sel = m == q
                mu[sel] = order[j][q].membership(values[sel, j])
            mus.append(mu)
        w = mus[0]
        for mu in mus[1:]:
            w = np.maximum(w, mu) if c.sel_op == "max" else w + mu - w * mu
        s = np.array(c.rules)[idx]
        has = s < c.mf_op_no
        val = np.array(list(c.out_values) + [0.0])[s]
        sw += np.where(has, w, 0)
        swc += np.where(has, w * val, 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return swc / sw


_ENGINES = {}


def engine_for(model):
    return _ENGINES[model.config.name]


# ------------------------------------------------------------------ Table 1 --

def test_table1_rule_base():
    m = Dflc.from_fll()
    c = m.config
    assert c.n == 2 and c.mf_ip_no == (9, 9) and c.mf_op_no == 5 and len(c.rules) == 81
    assert c.sel_op == "min" and c.div_type == "lut" and c.off_grid == ()
    assert all(r < 5 for r in c.rules), "Table 1 is complete"
    # MF order is by peak: n180 .. p180 and nvb .. pvb
    t1, t2 = c.inputs[0].terms, c.inputs[1].terms
    val = dict(zip(c.out_terms, (-2, -1, 0, 1, 2)))
    T = np.array([[val[c.out_terms[c.rules[i * 9 + j]]] for j in range(9)] for i in range(9)])
    # the chosen missing value: phi1 = z, phi2 = nvb -> nb
    assert T[t1.index("z"), t2.index("nvb")] == -2
    # the row of z is antisymmetric about its centre
    z = T[t1.index("z")]
    assert (z == -z[::-1]).all()
    # p135 / n135 rows: point antisymmetry
    assert (T[t1.index("p135")] == -T[t1.index("n135")][::-1]).all()
    assert c.singletons == (0, 1024, 2048, 3071, 4095) and c.zero_code == 2048


def test_prod_rounding_identity():
    for dy in range(2, 12):
        f = (1 << dy) - 1
        a = np.arange(f + 1, dtype=np.int64)[:, None]
        b = a.T
        assert np.array_equal(prod_round(a, b, dy), (2 * a * b + f) // (2 * f)), dy


@pytest.mark.parametrize("path", ALL_FLL, ids=lambda p: p.stem)
def test_degrees_every_code(path):
    """Degree generator = round(full * pyfuzzylite membership), every code."""
    m = Dflc.from_fll(path)
    c = m.config
    e = engine(path)
    codes = np.arange(1 << c.ip_sz)
    checked = 0
    for j, spec in enumerate(c.inputs):
        x = np.zeros((len(codes), c.n), dtype=np.int64)
        x[:, j] = codes
        base, mu = m.degrees(x)[j]
        vals = m.decode_inputs(x)[:, j]
        terms = {t.name: t for t in e.input_variables[j].terms}
        want = np.zeros((len(codes), len(spec.mfs)))
        for q, mf in enumerate(spec.mfs):
            want[:, q] = terms[mf.name].membership(vals)
        q_want = np.floor(want * c.full + 0.5).astype(np.int64)
        for slot in (0, 1):
            assert np.array_equal(mu[:, slot], q_want[np.arange(len(codes)), base + slot]), (spec.name, slot)
        # the MFs outside the two slots are zero (overlap 2)
        mask = np.ones_like(q_want, dtype=bool)
        mask[np.arange(len(codes)), base] = False
        mask[np.arange(len(codes)), base + 1] = False
        assert not (want[mask] > 0).any(), spec.name
        checked += 2 * len(codes)
    assert checked == 2 * c.n * (1 << c.ip_sz)


def test_lut_divider_error():
    """The LUT reciprocal is within 3/4 code of exact division for every Sw."""
    m = Dflc.from_fll()
    c = m.config
    rng = np.random.default_rng(1)
    sw = np.repeat(np.arange(1, c.s_max + 1), 8)
    cmax = (1 << c.mf_op_sz) - 1
    frac = rng.random(len(sw))
    frac[::8], frac[1::8] = 0.0, 1.0
    swc = np.floor(frac * cmax * sw).astype(np.int64)
    y = m.divide(swc, sw)
    err = np.abs(y - swc * 2 ** c.frac / sw)
    assert err.max() < 0.75, err.max()
    ya = Dflc.from_fll(div_type="array").divide(swc, sw)
    assert np.abs(ya - swc * 2 ** c.frac / sw).max() <= 0.5


# ------------------------------------------------- model vs pyfuzzylite --

@pytest.mark.parametrize("path,widths", [
    (DEFAULT_FLL, {}),
    (DEFAULT_FLL, {"div_type": "array"}),
    (DEFAULT_FLL, {"ip_sz": 10, "dy_ip": 6, "mf_op_sz": 8, "op_sz": 10}),
    (FIXTURES / "n3_prod.fll", {}),
    (FIXTURES / "n1.fll", {"div_type": "array"}),
    (FIXTURES / "n4.fll", {}),
], ids=["table1", "table1-array", "table1-narrow", "n3_prod", "n1", "n4"])
def test_model_vs_pyfuzzylite(path, widths):
    m = Dflc.from_fll(path, **widths)
    codes = sweep_codes(m)
    values = m.decode_inputs(codes)
    ref, e = fl_eval(path, values)
    y, zero = m.infer(codes)
    got = m.decode(y)
    bound = m.error_bound(codes)
    live = ~zero
    err = np.abs(got - ref)
    bad = live & ~(err <= bound)
    assert not bad.any(), (f"{bad.sum()} samples over the bound, first at codes {codes[bad][0]}: "
                           f"model {got[bad][0]}, pyfuzzylite {ref[bad][0]}, bound {bound[bad][0]}")
    # zero strength: pyfuzzylite's total strength is below K e_w / full
    tot = fl_total_strength(e, m, values)
    lim = (1 << m.config.n) * m.weight_error_lsb() / m.config.full
    assert (tot[zero] <= lim + 1e-12).all()
    assert live.sum() > 0.5 * len(codes)
    print(f"{path.stem} {widths}: {len(codes)} samples, max |error| {err[live].max():.3g} "
          f"(bound: max {bound[live].max():.3g}, median {np.median(bound[live]):.3g}), "
          f"{zero.sum()} zero-strength")


@pytest.mark.parametrize("name", ["mf5_or", "trap_max"])
def test_snorm_vs_float(name):
    path = FIXTURES / f"{name}.fll"
    m = Dflc.from_fll(path)
    _ENGINES[m.config.name] = engine(path)
    codes = sweep_codes(m)
    values = m.decode_inputs(codes)
    ref = float_reference(m, values)
    y, zero = m.infer(codes)
    live = ~zero
    err = np.abs(m.decode(y) - ref)
    bound = m.error_bound(codes)
    assert (err[live] <= bound[live]).all()
    assert live.sum() > 0.5 * len(codes)
    if name == "trap_max":
        assert zero.any(), "the trapezoid gaps give zero firing strength"
        assert (y[zero] == m.config.zero_code).all()


def test_table1_full_plane_sample_and_evaluate():
    m = Dflc.from_fll()
    v = np.array([[0.0, 0.0], [179.99, -180.0], [1e3, -1e3], [-45.0, 45.0]])
    yv, y, zero = m.evaluate(v)
    codes = m.encode(v)
    assert codes.tolist()[2] == [4095, 0], "saturation"
    assert codes.tolist()[0] == [2048, 2048]
    assert np.array_equal(m.decode(y), yv) and not zero.any()
    assert m.input_names == ("phi1", "phi2") and m.output_name == "u"
    with pytest.raises(ValueError, match="NaN"):
        m.encode([[np.nan, 0.0]])
    with pytest.raises(ValueError, match="codes"):
        m.infer([[4096, 0]])


# ------------------------------------------------------------ refusals --

BASE = """Engine: bad
InputVariable: a
  range: 0.000 1.000
  term: a0 Triangle 0.000 0.000 0.500
  term: a1 {mf}
  term: a2 Triangle 0.500 1.000 1.000
InputVariable: b
  range: 0.000 1.000
  term: b0 Triangle 0.000 0.000 1.000
  term: b1 Triangle 0.000 1.000 1.000
OutputVariable: y
  range: 0.000 1.000
  aggregation: none
  defuzzifier: WeightedAverage TakagiSugeno
  term: lo Constant 0.000
  term: hi {out}
{more}RuleBlock: r
  conjunction: Minimum
  disjunction: Maximum
{rules}"""
GOOD = dict(mf="Triangle 0.000 0.500 1.000", out="Constant 1.000", more="",
            rules="  rule: if a is a0 and b is b0 then y is lo\n  rule: if a is a1 and b is b1 then y is hi\n")


@pytest.mark.parametrize("change,match", [
    ({"mf": "Gaussian 0.500 0.200"}, "term a1 is Gaussian"),
    ({"mf": "Triangle 0.000 0.500 1.000", "rules": GOOD["rules"].replace("b1", "b9")}, "rule"),
    ({"out": "Linear 1.000 0.000 0.000"}, "term hi is Linear"),
    ({"more": "OutputVariable: z\n  range: 0 1\n  term: k Constant 0\n"}, "2 output variables"),
    ({"rules": "  rule: if a is a0 then y is lo\n"}, "rule 'if a is a0 then y is lo'.*input.*b"),
    ({"rules": "  rule: if a is very a0 and b is b0 then y is lo\n"}, "hedges"),
    ({"rules": "  rule: if a is a0 and b is b0 then y is lo\n  rule: if a is a1 or b is b1 then y is hi\n"},
     "mix 'and' and 'or'"),
    ({"rules": "  rule: if a is a0 and b is b0 then y is lo\n  rule: if a is a0 and b is b0 then y is hi\n"},
     "same antecedent"),
    ({"out": "Constant 2.000"}, "term hi = 2.0 is outside the range"),
])
def test_refused(tmp_path, change, match):
    text = BASE.format(**{**GOOD, **change})
    path = tmp_path / "bad.fll"
    path.write_text(text)
    with pytest.raises(FllError, match=match) as info:
        load_fll(path)
    assert str(path) in str(info.value)


def test_good_base_loads(tmp_path):
    path = tmp_path / "good.fll"
    path.write_text(BASE.format(**GOOD))
    c = load_fll(path)
    assert c.n == 2 and c.mf_ip_no == (3, 2) and c.rules.count(c.mf_op_no) == 4


def test_overlap_three(tmp_path):
    text = BASE.format(**GOOD).replace("term: a2 Triangle 0.500 1.000 1.000", "term: a2 Triangle 0.300 1.000 1.000")
    path = tmp_path / "bad.fll"
    path.write_text(text)
    with pytest.raises(FllError, match="terms a0, a1, a2 overlap at a = 0.3"):
        load_fll(path)


def test_non_adjacent_overlap(tmp_path):
    text = BASE.format(**{**GOOD, "mf": "Triangle 0.700 0.800 0.900"})
    text = text.replace("term: a2 Triangle 0.500 1.000 1.000", "term: a2 Triangle 0.450 1.000 1.000")
    path = tmp_path / "bad.fll"
    path.write_text(text)
    with pytest.raises(FllError, match="terms a0 and a2 overlap at a = 0.4.* not neighbours"):
        load_fll(path)


def test_bad_widths():
    with pytest.raises(ValueError, match="op_sz = 8 < MF_op_sz = 12"):
        load_fll(DEFAULT_FLL, op_sz=8)
    with pytest.raises(ValueError, match="div_type"):
        load_fll(DEFAULT_FLL, div_type="newton")
    with pytest.raises(FllError, match="cannot read"):
        load_fll("/nonexistent/x.fll")
