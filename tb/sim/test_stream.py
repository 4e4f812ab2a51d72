"""The stream driver's pieces that need no simulator (sim/rtl/stream.py).

The driver itself runs in every core's cocotb tests (DFLC, planner,
EDT/BFS: bit-exact results with idle cycles and back-pressure, cycle counts,
resets).  Here, without a build: payload packing against the cores' own
layouts (bit positions, signed and enum fields, arrays, refusals), the pause
generators (seeded, at their rate), and the monitor's protocol check on a
stream played by hand (a stalled beat dropped or changed fails; outside a
stall, or in reset, it may change; handshakes and stalls are counted).
"""

import random

import pytest

from navcores.hdl.dflc.core import result_layout as dflc_result, sample_layout
from navcores.hdl.dflc.top import config_for
from navcores.hdl.edt_bfs.cell import cell_widths
from navcores.hdl.edt_bfs.edt_bfs import result_layout as edt_result
from navcores.hdl.harmonic.planner import Code, Op, command_layout, response_layout
from navcores.sim.rtl.stream import StreamMonitor, StreamProtocolError, pack, pauses, unpack


def test_pack_places_fields_by_the_layout():
    config = config_for()
    layout = sample_layout(config)                      # ArrayLayout: input j at bits j*ip_sz
    assert pack(layout, [3, 5]) == 3 | 5 << config.ip_sz
    assert unpack(layout, 3 | 5 << config.ip_sz) == [3, 5]
    res = dflc_result(config)
    assert unpack(res, 1234 | 1 << config.op_sz) == {"y": 1234, "zero": 1}
    cmd = command_layout((3, 3), 3, 6, 16)
    word = pack(cmd, {"op": Op.START, "p1": 8, "step": 8, "p_last": 16, "iters": 3})
    assert word & 7 == Op.START.value and (word >> cmd["iters"].offset) & 0xFF == 3
    assert pack(cmd, {"op": 6}) == 6                    # an op the enum does not name: its integer
    assert pack(cmd, 0x1234) == 0x1234                  # a word is taken as it is
    with pytest.raises(KeyError, match="'bogus' is not a field"):
        pack(cmd, {"bogus": 1})


def test_unpack_inverts_pack_signed_and_enum_fields():
    rng = random.Random(1)
    resp = response_layout(16, exponents=True, e_max=20)
    edt = edt_result(cell_widths(7, 9))
    for _ in range(200):
        v = {"code": Code.BUSY, "op": Op.DIRECTION, "g_row": rng.randrange(-1 << 17, 1 << 17),
             "g_col": rng.randrange(-1 << 17, 1 << 17), "value": rng.randrange(1 << 17),
             "exponent": rng.randrange(21), "cycles": rng.randrange(1 << 48)}
        got = unpack(resp, pack(resp, v))
        assert {k: got[k] for k in v} == v and got["busy"] == 0
        assert isinstance(got["code"], Code) and isinstance(got["op"], Op)
        e = {"dx": rng.randrange(-8, 8), "dy": rng.randrange(-16, 16), "row": rng.randrange(7), "last": 1}
        assert {k: unpack(edt, pack(edt, e))[k] for k in e} == e
    word = pack(resp, {"op": 7})
    assert unpack(resp, word)["op"] == 7                # no member: the integer
    assert pack(resp, {"g_row": -1}) == ((1 << 18) - 1) << resp["g_row"].offset


def test_pauses_are_seeded_and_at_their_rate():
    a = list(zip(range(2000), pauses(random.Random(7), 0.3)))
    b = list(zip(range(2000), pauses(random.Random(7), 0.3)))
    assert a == b
    rate = sum(p for _, p in a) / len(a)
    assert 0.26 < rate < 0.34, rate
    assert pauses(random.Random(7), 0) is None
    assert all(p for _, p in zip(range(10), pauses(None, 1.0)))


class _Signal:
    def __init__(self, value=0):
        self.value = value


class _Streams:                                         # what a monitor needs of Streams
    prefix, period_ns = "", 10

    def __init__(self):
        self.dut = type("Dut", (), {f"o_stream__{s}": _Signal() for s in ("valid", "ready", "payload")})()
        self._notify = set()


def _play(cycles, in_reset=()):
    """Play (valid, ready, payload) per cycle into a monitor; returns it."""
    mon = StreamMonitor(_Streams(), "o_stream")
    for cycle, (valid, ready, payload) in enumerate(cycles):
        mon.valid.value, mon.ready.value, mon.payload.value = valid, ready, payload
        mon._sample(cycle, cycle in in_reset)
    return mon


def test_monitor_records_handshakes_and_stalls():
    mon = _play([(1, 0, 5), (1, 0, 5), (1, 1, 5), (0, 1, 9), (1, 1, 6), (1, 0, 7), (1, 1, 7)])
    assert mon.beats == [(2, 5), (4, 6), (6, 7)] and mon.stalls == 3


@pytest.mark.parametrize("cycles,message", [
    ([(1, 0, 5), (0, 1, 5)], "valid dropped at cycle 1 without a handshake"),
    ([(1, 0, 5), (1, 1, 6)], "payload changed at cycle 1 while stalled"),
])
def test_monitor_fails_a_beat_dropped_or_changed_while_stalled(cycles, message):
    with pytest.raises(StreamProtocolError, match=message):
        _play(cycles)


def test_monitor_lets_reset_drop_a_stalled_beat():
    mon = _play([(1, 0, 5), (0, 0, 0), (1, 1, 3)], in_reset={1})
    assert mon.beats == [(2, 3)] and mon.stalls == 1
