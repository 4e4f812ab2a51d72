"""Memories whose contents are undefined until written: no initial block in the Verilog.

Amaranth 0.5's ``Memory`` always has an initial value (``init=[]`` means
zeros) and its Verilog backend writes it word by word (``initial begin
mem[0] = 34'h0; ... end``).  For the EDT/BFS tile engine's state store (6
memories of up to ``max_h * ceil(ceil(max_w / T_c) / 3)`` words) that is most
of the file, and yosys' Verilog front end turns each line into a memory
initialisation of its own: at 2x2 cells on a 256x256 map (3.5 MB of Verilog,
66 048 init lines) ``read_verilog`` alone ran for more than 6 minutes without
finishing, against 99 s for the whole ``synth_ecp5`` without them.

A memory built by :func:`undefined_memory` carries the attribute
:data:`UNDEFINED_INIT`, and :func:`strip_undefined_init` (which
``hdl.emit.verilog_text`` applies to every emitted module) removes its
initial block.  Its contents are then undefined until written: X in Icarus,
zero in Verilator (its default ``--x-initial``) and in an ECP5 or iCE40
block RAM without INITVAL (the bitstream clears them); the component that
uses one must never let an unwritten word reach an output or a decision
(its docstring says how), and the RTL tests on Icarus, where such a word is
X, check it.
"""

import re

from amaranth.lib.memory import Memory

__all__ = ["UNDEFINED_INIT", "undefined_memory", "strip_undefined_init", "strip_zero_init"]

UNDEFINED_INIT = "navcores.undefined_init"

# yosys' write_verilog: the attribute, the memory's declaration, then (if any) its initial block.
_DECL = re.compile(r"^[ \t]*\(\* \\" + re.escape(UNDEFINED_INIT) + r"\s*=\s*[^*]*\*\)\n"
                   r"(?:[ \t]*\(\*[^*]*\*\)\n)*"           # the memory's other attributes (no_rw_check ...)
                   r"[ \t]*reg (?:\[\d+:\d+\] )?(\S+) +\[\d+:\d+\];\n", re.M)
_ZERO = re.compile(r"[ \t]*(\S+) ?\[\d+\] = \d+'[bdh]0+;")


def undefined_memory(*, shape, depth, src_loc_at=0):
    """A ``Memory(shape=shape, depth=depth)`` whose Verilog has no initial block."""
    return Memory(shape=shape, depth=depth, init=[], attrs={UNDEFINED_INIT: 1}, src_loc_at=1 + src_loc_at)


def _initial_blocks(text, decl):
    """Each memory declaration ``decl`` matches that an initial block
    follows: (the match, the block's start and end, its word lines, whether
    every word is zero)."""
    for m in decl.finditer(text):
        start = m.end()
        if not text.startswith("  initial begin\n", start):
            continue
        end = text.index("\n  end\n", start) + len("\n  end\n")
        lines = text[start:end].splitlines()[1:-1]
        yield m, start, end, lines, all(_is_zero(line, m[1]) for line in lines)


def _is_zero(line, name):
    z = _ZERO.fullmatch(line)
    return bool(z) and z[1] == name


def _cut(text, spans):
    """``text`` without the (start, end) spans, in order."""
    out, pos = [], 0
    for start, end in spans:
        out.append(text[pos:start])
        pos = end
    out.append(text[pos:])
    return "".join(out)


def strip_undefined_init(text):
    """``text`` (yosys' Verilog) without the initial blocks of the memories marked
    :data:`UNDEFINED_INIT`.  Such a block must set every word to zero (the
    memory was made with no init): anything else is an error, never dropped."""
    spans = []
    for m, start, end, lines, zero in _initial_blocks(text, _DECL):
        if not zero:
            line = next(line for line in lines if not _is_zero(line, m[1]))
            raise ValueError(f"memory {m[1]} is marked {UNDEFINED_INIT} but has an initial value: {line.strip()}")
        spans.append((start, end))
    return _cut(text, spans)


# A memory's declaration (yosys' write_verilog): name, then its address range.
_DECL_MEM = re.compile(r"^[ \t]*reg (?:\[\d+:\d+\] )?(\S+) +\[(\d+):(\d+)\];\n", re.M)


def strip_zero_init(text, min_words=1024):
    """``text`` (yosys' Verilog) without the initial blocks of the memories of
    at least ``min_words`` words whose every word is zero: for synthesis
    only.  Such a memory becomes block RAM, and a block RAM without initial
    values (ECP5 INITVAL, iCE40 INIT, Virtex-II / Spartan-3 INIT) configures
    to zero, so the hardware is the same; yosys'
    Verilog front end makes each init line a memory initialisation of its
    own: the 11x6-block harmonic planner (7 MB of Verilog, 200,000 init
    lines) did not leave read_verilog in 15 minutes, and its whole
    synth_ecp5 takes 2 minutes without them.  Simulation keeps the zeros."""
    return _cut(text, [(start, end) for m, start, end, _, zero in _initial_blocks(text, _DECL_MEM)
                       if zero and abs(int(m[2]) - int(m[3])) + 1 >= min_words])
