"""DFLC components refuse bad parameters in __init__ with messages naming the numbers;
the latency formula and the output FIFO follow the pipeline generics (Table 2)."""

import pytest

from navcores.hdl.dflc.addr_gen import AddrGen
from navcores.hdl.dflc.cons_map import ConsMap
from navcores.hdl.dflc.core import PIPE_DEFAULTS, PIPE_KEYS, PIPE_TABLE2, DflcCore, latency
from navcores.hdl.dflc.divider import Divider
from navcores.hdl.dflc.integrator import Integrator
from navcores.hdl.dflc.mf_gen import MfGen
from navcores.hdl.dflc.pipe import PIPE_RANGE
from navcores.hdl.dflc.top import DflcStream, config_for, fifo_depth, resolve_fll, stream_latency
from navcores.hdl.dflc.tnorm import Tnorm
from navcores.hdl.emit import TOPS, top_name
from navcores.hdl.params import unelaborated

# A refused component leaves no "created but never used" warning (its
# __init__ is @checked_init); one built only to read its attributes says so
# with unelaborated().


def test_bad_parameters():
    c = config_for()
    with pytest.raises(ValueError, match="parallel = 'yes'"):
        DflcCore(c, parallel="yes")
    with pytest.raises(ValueError, match="sel_op = 'xor'"):
        Tnorm(2, 8, "xor")
    with pytest.raises(ValueError, match="ip_no = 5"):
        AddrGen(5)
    with pytest.raises(ValueError, match="op_sz = 8 < MF_op_sz = 12"):
        config_for(op_sz=8)
    with pytest.raises(ValueError, match="fll = 'nope'"):
        resolve_fll("nope")
    with pytest.raises(TypeError, match="unexpected parameters"):
        DflcStream(c, fll="table1")


@pytest.mark.parametrize("key", PIPE_KEYS)
def test_pipeline_generic_out_of_range(key):
    """Each generic one below its minimum and one above its maximum is refused by
    the core and the stream top, naming the generic, the number and the range."""
    c = config_for()
    lo, hi = PIPE_RANGE[key]
    for bad in (lo - 1, hi + 1):
        with pytest.raises(ValueError, match=rf"{key} = {bad}: pipeline registers must be {lo} \.\. {hi}"):
            DflcCore(c, **{key: bad})
        with pytest.raises(ValueError, match=rf"{key} = {bad}:"):
            DflcStream(fll="table1", **{key: bad})
        with pytest.raises(ValueError, match=rf"{key} = {bad}:"):
            latency(c, **{key: bad})
    for bad in (1.5, True, "2"):
        with pytest.raises(ValueError, match=rf"{key} = {bad!r}:"):
            DflcCore(c, **{key: bad})
    unelaborated(DflcCore(c, **{key: lo}))          # the ends themselves are accepted
    unelaborated(DflcCore(c, **{key: hi}))


def test_component_pipeline_refusals():
    c = config_for()
    spec = c.inputs[0]
    with pytest.raises(ValueError, match=r"cpr3_no = 0: .*1 \.\. 4 \(the MF degree register is mandatory\)"):
        MfGen(spec, 12, 8, cpr=0)
    with pytest.raises(ValueError, match="psr1_no = 5"):
        MfGen(spec, 12, 8, psr=5)
    with pytest.raises(ValueError, match="cpr2_no = -1"):
        ConsMap(c, cpr=-1)
    with pytest.raises(ValueError, match="cpr8_no = 7"):
        Integrator(8, 20, 10, 22, cpr_sig=7)
    with pytest.raises(ValueError, match="cpr9_no = 5"):
        Divider(c, 10, 22, cpr=5)
    with pytest.raises(ValueError, match=r"unknown pipeline generic\(s\) \['cpr_mf'\]"):
        DflcCore(c, cpr_mf=1)


def test_latency_formula():
    c = config_for()
    assert latency(c) == 12 and stream_latency(c) == 13            # 2^n + 8 (+1 FIFO)
    assert stream_latency(c, parallel=True) == 10
    assert latency(c, **PIPE_DEFAULTS) == 12
    # the paper's Table 2 values at this core's places: 2^n + 17
    assert latency(c, **PIPE_TABLE2) == 21
    # one more register on a route nothing runs beside adds one cycle
    for key in ("psr1_no", "cpr3_no", "psr3_no", "cpr1_no", "cpr4_no", "cpr9_no"):
        assert latency(c, **{key: PIPE_DEFAULTS[key] + 1}) == 13, key
    # synchronized routes: the longer one counts
    assert latency(c, cpr5_no=0) == 12 and latency(c, cpr5_no=3) == 13     # w vs cpr2 + s_rom + psr2
    assert latency(c, psr2_no=1) == 13 and latency(c, cpr2_no=0) == 12
    assert latency(c, cpr2_no=0, cpr5_no=0) == 11
    assert latency(c, psr4_no=0) == 12 and latency(c, psr4_no=0, cpr6_no=0) == 11
    assert latency(c, cpr7_no=2, cpr8_no=1) == 14 == latency(c, cpr7_no=1, cpr8_no=2)
    zero = dict(psr1_no=0, cpr3_no=1, cpr2_no=0, cpr5_no=0, psr4_no=0, cpr6_no=0, cpr9_no=0)
    assert latency(c, **zero) == 4 + 4          # P + cpr3 + the s_rom read + divider in/out
    assert latency(c, True, **{k: 4 for k in PIPE_KEYS}) == 1 + 20 + 9 + 4 + 4 + 4 + 2


def test_fifo_depth_follows_latency():
    """The output FIFO (= the credit count) holds ceil(L / P) + 2 samples, so a
    consumer that is always ready never throttles the input, whatever the generics."""
    c = config_for()
    assert unelaborated(DflcStream(fll="table1")).depth == 3 + 2      # today's size: ceil(12 / 4) + 2
    deep = {k: 4 for k in PIPE_KEYS}
    s = unelaborated(DflcStream(fll="table1", **deep))
    L = latency(c, **deep)
    assert L == 4 + 43 and s.depth == -(-L // 4) + 2 == fifo_depth(c, False, **deep) == 14
    assert unelaborated(DflcStream(fll="table1", par=1, **deep)).depth == L - 3 + 2


def test_names_and_emit():
    assert top_name("dflc_stream", {"fll": "table1"}) == "dflc_stream_table1"
    assert top_name("dflc_core", {"fll": "table1", "par": 1}) == "dflc_core_table1_par1"
    assert top_name("dflc_stream", {"fll": "table1", "cpr3_no": 3}) == "dflc_stream_cpr3_no3_table1"
    s = unelaborated(DflcStream(fll="table1", par=1, cpr9_no=2))
    assert s.parallel and s.pipe == {"cpr9_no": 2}
    core = unelaborated(TOPS["dflc_core"](fll="table1", par=1, cpr3_no=3, psr2_no=4))
    assert core.parallel and core.pipe == {**PIPE_DEFAULTS, "cpr3_no": 3, "psr2_no": 4}
