"""Pipeline-register generics of the DFLC (paper 003 section 7, Table 2 CPR/PSR)."""

from amaranth.hdl import Signal

__all__ = ["PIPE_KEYS", "PIPE_DEFAULTS", "PIPE_TABLE2", "PIPE_RANGE", "check_pipe", "delay"]

# Table 2: psr1..psr4 are path synchronization registers (the route they sit
# on), cpr1..cpr9 component pipeline registers (the component they belong to).
PIPE_KEYS = ("psr1_no", "psr2_no", "psr3_no", "psr4_no",
             "cpr1_no", "cpr2_no", "cpr3_no", "cpr4_no", "cpr5_no",
             "cpr6_no", "cpr7_no", "cpr8_no", "cpr9_no")

# This core's default: the design as it was before the generics were opened
# (latency 2^n + 8), with cpr6 3 and cpr9 6 so that one adder level of the
# fabric products (hdl/dflc/arith.py) lies between registers: 182 MHz on the
# LFE5U-85F (issue 17); latency 2^n + 15, still 2^n clocks per sample.  Every
# value is a register count on the route / in the component hdl/dflc/core.py's
# docstring names.
PIPE_DEFAULTS = {"psr1_no": 1, "psr2_no": 0, "psr3_no": 0, "psr4_no": 1,
                 "cpr1_no": 0, "cpr2_no": 1, "cpr3_no": 1, "cpr4_no": 0, "cpr5_no": 2,
                 "cpr6_no": 3, "cpr7_no": 0, "cpr8_no": 0, "cpr9_no": 6}

# The paper's chosen values (Table 2), as register counts at the same places.
PIPE_TABLE2 = {"psr1_no": 1, "psr2_no": 4, "psr3_no": 1, "psr4_no": 1,
               "cpr1_no": 1, "cpr2_no": 1, "cpr3_no": 3, "cpr4_no": 0, "cpr5_no": 2,
               "cpr6_no": 1, "cpr7_no": 0, "cpr8_no": 0, "cpr9_no": 2}

# Allowed range of each generic.  cpr3_no >= 1: the MF degree register,
# loaded once per sample, holds the degrees while the address generator walks
# the 2^n combinations (the input stream's payload is only valid at its
# handshake), so trap_gen_p needs it.  Everything else may be 0 (combinational).
PIPE_RANGE = {k: (0, 4) for k in PIPE_KEYS}
PIPE_RANGE["cpr3_no"] = (1, 4)
PIPE_RANGE["cpr9_no"] = (0, 8)


def check_pipe(pipe, op_sz=None):
    """Full generics dict from ``pipe`` (missing keys take PIPE_DEFAULTS);
    ValueError naming the generic and the number for anything out of range."""
    pipe = dict(pipe or {})
    unknown = sorted(set(pipe) - set(PIPE_KEYS))
    if unknown:
        raise ValueError(f"unknown pipeline generic(s) {unknown}; expected some of {list(PIPE_KEYS)}")
    full = {**PIPE_DEFAULTS, **pipe}
    for k in PIPE_KEYS:
        v, (lo, hi) = full[k], PIPE_RANGE[k]
        if k == "cpr9_no" and op_sz is not None:
            hi = min(hi, op_sz)          # the restoring array has op_sz rows to cut
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            why = " (the MF degree register is mandatory)" if k == "cpr3_no" else ""
            raise ValueError(f"{k} = {v!r}: pipeline registers must be {lo} .. {hi}{why}")
    return full


def delay(m, sigs, n, tag, reset_less=False):
    """``sigs`` through ``n`` plain registers each (n = 0: the signals themselves).
    ``reset_less``: data registers (only the valid bits beside them need the reset)."""
    sigs = list(sigs)
    for d in range(n):
        nxt = [Signal.like(s, name=f"{s.name}_{tag}{d}", reset_less=reset_less) for s in sigs]
        m.d.sync += [a.eq(b) for a, b in zip(nxt, sigs)]
        sigs = nxt
    return sigs
