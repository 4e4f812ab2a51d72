"""DFLC components refuse bad parameters in __init__ with messages naming the numbers."""

import pytest

from hdl.dflc.addr_gen import AddrGen
from hdl.dflc.core import DflcCore, latency
from hdl.dflc.divider import Divider
from hdl.dflc.top import DflcStream, config_for, resolve_fll, stream_latency
from hdl.dflc.tnorm import Tnorm
from hdl.emit import top_name


def test_bad_parameters():
    c = config_for()
    with pytest.raises(ValueError, match="cpr_mf = 5"):
        DflcCore(c, cpr_mf=5)
    with pytest.raises(ValueError, match="cpr_div = -1"):
        DflcCore(c, cpr_div=-1)
    with pytest.raises(ValueError, match="parallel = 'yes'"):
        DflcCore(c, parallel="yes")
    with pytest.raises(ValueError, match="sel_op = 'xor'"):
        Tnorm(2, 8, "xor")
    with pytest.raises(ValueError, match="ip_no = 5"):
        AddrGen(5)
    with pytest.raises(ValueError, match="cpr_div = 9"):
        Divider(c, 10, 22, cpr=9)
    with pytest.raises(ValueError, match="op_sz = 8 < MF_op_sz = 12"):
        config_for(op_sz=8)
    with pytest.raises(ValueError, match="fll = 'nope'"):
        resolve_fll("nope")
    with pytest.raises(TypeError, match="unexpected parameters"):
        DflcStream(c, fll="table1")


def test_names_and_latency():
    assert top_name("dflc_stream", {"fll": "table1"}) == "dflc_stream_table1"
    assert top_name("dflc_core", {"fll": "table1", "par": 1}) == "dflc_core_table1_par1"
    c = config_for()
    assert latency(c) == 12 and stream_latency(c) == 13
    assert stream_latency(c, parallel=True) == 10
    assert stream_latency(c, cpr_mf=1, cpr_mult=2, cpr_div=1) == 17
    s = DflcStream(fll="table1", par=1, cpr_div=2)
    assert s.parallel and s.cpr == {"cpr_div": 2}
