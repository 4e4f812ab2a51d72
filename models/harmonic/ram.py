"""Node storage: the word layout, a cluster's RAM image, the Counters'
addresses and how a stored word is read across a block border (paper 000,
sections 5.1, 5.2; block exponents: beyond the paper, issue 10).

Number format
-------------
A node's word is p+2 bits, one bit per RAM address, most significant first
from the word's base: offset 0 holds the constant flag (the paper's extra MSB,
5.2), offset 1 + (p - k) holds value bit k, so the integer bit sits at offset
1 and the LSB at offset p+1.  Raising the precision therefore only appends LSB
addresses; the bits already stored keep their place (a precision change moves
no data).  RAM word ``a`` of a 3x6 cluster holds bit ``a`` of its 18 nodes, node
``r*cols + c`` in bit ``r*cols + c`` (the paper's 18-bit-wide block RAM, 5.4).

Rounding
--------
Storing and reading a word is exact.  Across a block border with block
exponents (:func:`convert_mantissa`) a neighbour's mantissa is shifted to the
reader's exponent: right shifts floor (the dropped bits are lost), left shifts
saturate at the word's top 2**(p+1) - 1 (a clamp).  Serially both are timing:
the border stream is read -s bits late, or delayed by s cycles.
"""

import numpy as np

from .node import one

__all__ = ["READ_LATENCY", "WRITE_LATENCY", "P_MIN", "SHIFT_STEP", "pads", "iteration_cycles", "read_offset",
           "counters", "strobes", "word_bits", "ram_image", "from_ram_image", "convert_mantissa"]


# The cluster's pipeline (hdl/harmonic/cluster.py): the block RAM answers a
# read two cycles after the address (its output register: REGMODE OUTREG on
# an ECP5 DP16KD), and a node's write bit is a register, written one cycle
# after it is computed.  An iteration reads the words the previous one wrote,
# so a word must be written before it is read again: that holds in p+2
# cycles from p = 4 on; a smaller p pads its iterations to 6 cycles.
READ_LATENCY = 2        # cycles from a read address to the data the nodes see
WRITE_LATENCY = 1       # cycles from a node's result bit to its RAM write
P_MIN = READ_LATENCY + WRITE_LATENCY + 1    # the least p whose iteration is p+2 cycles
SHIFT_STEP = READ_LATENCY + WRITE_LATENCY + 1   # rotation per (padded) shift iteration (block exponents)


def pads(p, shift=False):
    """Pad cycles at the start of an iteration at precision ``p``: 0 for
    p >= P_MIN, else P_MIN - p (a word is written before it is read again);
    a shift iteration (block exponents) has at least 1: it writes each bit
    rotated by :data:`SHIFT_STEP` positions, which never overwrites a bit
    before it is read (a rotation by r lands r - READ_LATENCY cycles after
    the read of the bit it overwrites, which needs r <= READ_LATENCY +
    WRITE_LATENCY + 1) and, with one pad, writes the bits that wrap around
    (top to bottom) before the next iteration reads them (r >=
    READ_LATENCY + WRITE_LATENCY + 2 - pads): no read and write of one
    address in one cycle."""
    return max(P_MIN - p, 1 if shift else 0)


def iteration_cycles(p, shift=False):
    """Cycles of one iteration: p+2 for p >= P_MIN (and no shift)."""
    return p + 2 + pads(p, shift)


def read_offset(x, p, shift=False):
    """The word offset whose bit the nodes see in cycle x of an iteration
    (0 .. L-1): S = :func:`pads` pad cycles (they read offset 0, the
    flag, and ignore it), the flag at x = S, value bit k at x = S+1+k
    (offset 1 + p - k): LSB first."""
    S, L = pads(p, shift), iteration_cycles(p, shift)
    if not 0 <= x < L:
        raise ValueError(f"cycle {x} outside 0 .. L-1 = {L - 1}")
    return 0 if x <= S else L - x


def counters(x, p, shift=False):
    """Offsets the Counters unit presents while the nodes are ``READ_LATENCY``
    cycles before cycle x of an iteration (x = 0 .. L-1, L =
    :func:`iteration_cycles`): ``(cntR, r_cnt, cntW)``.  cntR is
    :func:`read_offset` (x): the read port's address, whose data the nodes see
    two cycles later; r_cnt the same slots MSB first (bit p at x = S+1, 0 in
    pads and at the flag), for the border's MSB-first reads (block
    exponents); cntW the write address of the registered result bit, the
    offset read five cycles earlier: a node's result bit k is computed when
    it sees bit k+2 (eq. 2's division by 4, two bit positions late), one
    cycle later it is written (``WRITE_LATENCY``)."""
    S, L = pads(p, shift), iteration_cycles(p, shift)
    lag = READ_LATENCY + WRITE_LATENCY + 2
    return read_offset(x, p, shift), (0 if x <= S else x - S), read_offset((x - lag) % L, p, shift)


def strobes(u, p, shift=False):
    """The node strobes of iteration cycle u (the cycle the nodes see
    :func:`read_offset` (u)): ``mask`` (u <= S: pads and the flag, the adder's
    inputs masked), ``z`` (u = 0: the Maximum result latched), ``ph1``
    (u = 1: result bit p, the adder restarts), ``fl`` (u = 2: the previous
    iteration's flags), ``ph2`` (u = S+2: the flag written), ``wcyc``
    (cycle u writes a bit: all but 2 .. S+1)."""
    S, L = pads(p, shift), iteration_cycles(p, shift)
    if not 0 <= u < L:
        raise ValueError(f"cycle {u} outside 0 .. L-1 = {L - 1}")
    return {"mask": u <= S, "z": u == 0, "ph1": u == 1, "fl": u == 2, "ph2": u == S + 2,
            "wcyc": not 2 <= u <= S + 1}


def word_bits(v, flag, p):
    """The p+2 stored bits of one node, by address offset."""
    v = int(v)
    if not 0 <= v <= one(p):
        raise ValueError(f"value {v} outside [0, 2**{p}]")
    return [int(bool(flag))] + [(v >> (p - off)) & 1 for off in range(p + 1)]


def ram_image(h, const, p):
    """RAM words of a cluster: word ``a`` holds bit ``a`` of node ``r*cols + c``
    in bit ``r*cols + c`` (the 3x6 cluster packs its 18 nodes in one word)."""
    h = np.asarray(h, dtype=object)
    const = np.asarray(const, dtype=bool)
    words = [0] * (p + 2)
    for i, (v, f) in enumerate(zip(h.ravel(), const.ravel())):
        for a, bit in enumerate(word_bits(v, f, p)):
            words[a] |= bit << i
    return words


def from_ram_image(words, p, shape):
    """Inverse of :func:`ram_image`: ``(h, const)`` from p+2 RAM words."""
    n = shape[0] * shape[1]
    h = np.zeros(n, dtype=object)
    const = np.zeros(n, dtype=bool)
    for i in range(n):
        const[i] = bool((words[0] >> i) & 1)
        v = 0
        for off in range(1, p + 2):
            v = (v << 1) | ((words[off] >> i) & 1)
        h[i] = v
    return h.reshape(shape), const.reshape(shape)


def convert_mantissa(v, s, p):
    """A neighbour block's mantissa ``v`` seen from a block whose exponent is
    ``s`` larger (``s < 0``: smaller), both at word precision ``p``.

    ``s > 0`` (the reader is finer): ``v << s``, the LSB-first stream delayed
    by s cycles, saturated at the word's top ``2**(p+1) - 1`` (a clamp);
    ``s < 0``: ``v >> -s``, the stream read -s bits late (floor, the dropped
    bits are lost); ``s = 0``: ``v``.  Works on ints and on integer numpy
    arrays.  Returns ``(value, clamped)``, ``clamped`` True if any value hit
    the top.  Both branches are monotone in ``v``, which the termination
    argument of :func:`~models.harmonic.plan_exponents` needs.  The Border's
    exponent option (hdl/harmonic/border.py) does this serially."""
    cap = (1 << (p + 1)) - 1
    scalar = not isinstance(v, np.ndarray)
    arr = np.asarray(v, dtype=object) if scalar else v
    if s == 0:
        out, clamped = arr, False
    elif s < 0:
        out = arr >> -s if -s <= p + 1 else arr * 0
        clamped = False
    else:
        lim = cap >> s if s <= p + 1 else 0
        over = np.asarray(arr > lim, dtype=bool)
        safe = np.where(over, 0, arr)
        out = np.where(over, cap, safe << s if s <= p + 1 else safe)
        out = out.astype(arr.dtype) if not scalar else out
        clamped = bool(over.any())
    return (int(out) if scalar else out), clamped
