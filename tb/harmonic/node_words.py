"""Random words of the node-exponent format (models/harmonic/node_exponents.py), for its tests.

:func:`format_word` draws a word (v, e) inside the format, with the kinds
the update has to get right: zeros, normal words, denormals at e_max and
words at e = 0 using the headroom bits (a goal's neighbourhood; never above
the goal's 1).
"""

__all__ = ["format_word"]


def format_word(rng, p, h, e_max):
    """One word (v, e) of the format: 15 % zeros (v = 0, e = e_max), else an
    exponent of 0, random or e_max, a denormal at e_max half the time, the
    headroom in use at e = 0 30 % of the time, else a normal mantissa."""
    if rng.random() < 0.15:
        return 0, e_max
    e = rng.choice([0, rng.randrange(0, e_max + 1), e_max])
    if e == e_max and rng.random() < 0.5:
        return rng.randrange(1, 1 << (p - h)), e                    # denormal
    if e == 0 and rng.random() < 0.3:
        return rng.randrange(1 << (p - h), (1 << p) + 1), e         # a goal's neighbourhood: the headroom in use
    top = (1 << p) + 1 if e == 0 else 1 << (p + 1 - h)             # no value above the goal's 1
    return rng.randrange(1 << (p - h), top), e
