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

__all__ = ["counters", "word_bits", "ram_image", "from_ram_image", "convert_mantissa"]


def counters(c, p):
    """Addresses the Counters unit presents in iteration cycle c (0 .. p+1):
    ``(cntR, r_cnt, cntW)``.  A synchronous RAM answers one cycle later, so
    cntR = p+1-c makes the nodes see the flag at c = 0 and value bit k at
    c = k+1 (LSB first); r_cnt = (c-1) mod (p+2) streams bit p at c = 3 down
    to bit 0 at c = 1 of the next iteration (MSB first); cntW = (p+4-c) mod
    (p+2) writes each result bit two bit positions behind the data read."""
    if not 0 <= c <= p + 1:
        raise ValueError(f"cycle {c} outside 0 .. p+1 = {p + 1}")
    return p + 1 - c, (c - 1) % (p + 2), (p + 4 - c) % (p + 2)


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
