"""Widths and layouts of the EDT/BFS tile engine (issue 18), all derived from the largest map.

One pixel's RAM state is :func:`models.edt_bfs_tiled.state_bits`' word: ``di``
(NONE = all ones while not done), signed ``dx`` / ``dy`` (the NNT vector
p - nearest obstacle), ``hop`` (NONE = all ones while not visited) and
``parent`` (0..8).  done, visited, the cfr and the squared distance d2
(the paper's delta = k^2 + k - d2) are derived where a tile is loaded, so
they cost no RAM bits.  The RAM holds
``p = T_c`` pixels of a map row per word, and two *field groups* per word
that are written separately: the EDT's (di, dx, dy) and the BFS's
(hop, parent).
"""

from amaranth.hdl import Signal, Value, signed
from amaranth.lib import data

from navcores.models.edt_bfs import widths
from navcores.models.edt_bfs_tiled import state_bits

from ..params import Constraint, Param

__all__ = ["TILE_PARAMS", "TILE_CONSTRAINTS", "MAX_CELLS", "MAX_SIDE", "MAX_EXT_PIXELS", "pixels",
           "named", "flat", "tile_widths", "pixel_layout", "edt_layout", "bfs_layout", "cell_layout", "nb_layout",
           "EDT_FIELDS", "BFS_FIELDS"]

MAX_CELLS = 256         # T_r * T_c: a 16 x 16 array of the paper's cells is ~120k LUT4, beyond the LFE5U-85F
MAX_SIDE = 4096         # a map side (issue 18: real maps are 200 .. 4000 cells a side)
MAX_EXT_PIXELS = 1 << 22    # a store outside: 2048 x 2048 pixels of ~60 bits fill a ULX3S's 32 MB SDRAM


def pixels(p):
    """The largest map's pixel count, for the RAM-size constraints' messages."""
    return {"n": p["max_h"] * p["max_w"]}


# The array and the largest map: the parameters of the tile engine and of its DRAM side, checked alike.
TILE_PARAMS = (
    Param("t_r", int, lo=2, hi=32, doc="array rows T_r",
          message="array rows t_r {value!r}: must be an integer in {lo}..{hi}"),
    Param("t_c", int, lo=2, hi=32, doc="array columns T_c (pixels per RAM word)",
          message="array columns t_c {value!r}: must be an integer in {lo}..{hi}"),
    Param("max_h", int, lo=3, hi=MAX_SIDE, doc="largest map height (the RAM)",
          message="largest map height max_h {value!r}: must be an integer in {lo}..{hi}"),
    Param("max_w", int, lo=3, hi=MAX_SIDE, doc="largest map width (the RAM)",
          message="largest map width max_w {value!r}: must be an integer in {lo}..{hi}"),
)
TILE_CONSTRAINTS = (
    Constraint("max_h > t_r and max_w > t_c", lambda p: p["max_h"] > p["t_r"] and p["max_w"] > p["t_c"],
               "largest map {max_h}x{max_w} fits one {t_r}x{t_c} tile: the RAM must hold at least two "
               "tiles each way (a map of one tile is the untiled core's, edt_bfs)"),
    Constraint(f"t_r * t_c <= {MAX_CELLS}", lambda p: p["t_r"] * p["t_c"] <= MAX_CELLS,
               "array {t_r}x{t_c} has {n} cells: at most " + str(MAX_CELLS) +
               " (16x16 is ~120k LUT4, more than the largest ECP5)", lambda p: {"n": p["t_r"] * p["t_c"]}),
    Constraint(f"max_h * max_w <= {MAX_EXT_PIXELS} (external)",
               lambda p: p["max_h"] * p["max_w"] <= MAX_EXT_PIXELS,
               "largest map {max_h}x{max_w} has {n} pixels: an external store holds at most "
               + str(MAX_EXT_PIXELS) + " (2048 x 2048 pixels of ~60 bits fill a 32 MB SDRAM)",
               pixels),
)

EDT_FIELDS = ("di", "dx", "dy")
BFS_FIELDS = ("hop", "parent")


def _bits(n):
    return max(1, int(n).bit_length())


def tile_widths(t_r, t_c, max_h, max_w):
    """Widths of a ``t_r`` x ``t_c`` engine whose RAM holds maps up to ``max_h`` x ``max_w``, checked.

    ``di``, ``dx``, ``dy``, ``hop``, ``parent``: the RAM fields
    (:func:`models.edt_bfs_tiled.state_bits`); ``k``: the level counter
    (1..k_max, :func:`models.edt_bfs.widths`); ``kk``: ``K(k) = k^2 + k``
    (0..k_max^2 + k_max), the cells' EDT threshold; ``d2``: the squared
    distance ``dx^2 + dy^2`` of a done pixel and a cell's candidate d2_i,
    both at most ``d2_max = (max_h-1)^2 + (max_w-1)^2`` (a candidate only
    counts for a cell inside the map with a done neighbour, and then its
    vector ``p - q`` joins two pixels of the map: eq. 1, invariant E of
    :mod:`models.edt_bfs_tiled`); ``val``: the cell register holding d2
    (EDT) or hop (BFS), and the MIN selection's unsigned key: the EDT's
    candidate d2_i or the BFS's hop.
    """
    w = widths(max_h, max_w)
    f = state_bits(max_h, max_w)["fields"]
    words = -(-max_w // t_c)
    d2 = _bits(w["d2_max"])
    # the bounds the docstring states, checked at elaboration
    assert w["d2_max"] < 1 << d2 and w["k_max"] ** 2 + w["k_max"] < 1 << w["delta"], (w, d2)
    assert w["k_di"] ** 2 + w["k_di"] >= w["d2_max"] and w["k_max"] < 1 << w["k"], w
    assert max_h - 1 < 1 << (f["dx"] - 1) and max_w - 1 < 1 << (f["dy"] - 1), f
    assert max_h * max_w <= (1 << f["hop"]) - 1 and w["k_di"] < (1 << f["di"]) - 1, f     # NONE above every value
    return {
        "di": f["di"], "dx": f["dx"], "dy": f["dy"], "hop": f["hop"], "parent": f["parent"],
        "bits": sum(f.values()),
        "k": w["k"], "k_di": w["k_di"], "kk": w["delta"], "d2": d2,
        "val": max(d2, f["hop"]),
        "row": _bits(max_h - 1), "col": _bits(max_w - 1),
        "height": _bits(max_h), "width": _bits(max_w),
        "words": words,                                   # word columns of the widest map
        "tile_rows": -(-max_h // t_r), "tile_cols": words,
        "tr": _bits(-(-max_h // t_r) - 1), "tc": _bits(words - 1),
        "iters": _bits(t_r * t_c + 1),                    # BFS iterations of one visit
    }


def pixel_layout(w):
    """One pixel's RAM state (both field groups)."""
    return data.StructLayout({"di": w["di"], "dx": signed(w["dx"]), "dy": signed(w["dy"]),
                              "hop": w["hop"], "parent": w["parent"]})


def edt_layout(w):
    """The EDT's field group of a pixel."""
    return data.StructLayout({"di": w["di"], "dx": signed(w["dx"]), "dy": signed(w["dy"])})


def bfs_layout(w):
    """The BFS's field group of a pixel."""
    return data.StructLayout({"hop": w["hop"], "parent": w["parent"]})


def cell_layout(w):
    """A window cell's register (tile cells and halo cells alike).

    ``present``: inside the map; ``flag``: done before this level (EDT,
    di <= k-1) / visited (BFS, hop != NONE); ``fresh``: a halo pixel made done
    earlier in this level (di = k); ``cfr``: in the collision-free region;
    ``chg``: this visit made the pixel done (EDT) / lowered its hop, or it is
    a root (BFS); ``val``: d2 = dx^2 + dy^2 as loaded (EDT) / hop (BFS);
    ``dx``, ``dy``: the vector; ``aux``: di (EDT) / parent (BFS); ``edt``:
    loaded as ``present`` in an EDT visit, 0 in a BFS one: the gate of the
    neighbours' ADD-SUB on this register's d2 (:class:`~hdl.edt_bfs.tile_cell.TileCell`),
    a flip-flop beside them instead of the engine's ``phase``, whose net
    reached every cell's eight adders: 12.7 ns of routing on the LFE5U-85F.
    """
    return data.StructLayout({
        "present": 1, "flag": 1, "fresh": 1, "cfr": 1, "chg": 1, "edt": 1,
        "val": w["val"], "dx": signed(w["dx"]), "dy": signed(w["dy"]),
        "aux": max(w["di"], w["parent"]),
    })


def nb_layout(w):
    """What a cell shows its neighbours: ``flag``, ``ram`` (done in RAM now: flag | fresh), ``val``, ``dx``,
    ``dy``, ``edt`` (:func:`cell_layout`'s)."""
    return data.StructLayout({"flag": 1, "ram": 1, "val": w["val"], "dx": signed(w["dx"]),
                              "dy": signed(w["dy"]), "edt": 1})


def named(m, name, value, shape=None):
    """``value`` as a combinational signal.  Amaranth emits an expression anew
    wherever it is used; a signal is emitted once (and simulated once)."""
    s = Signal(shape if shape is not None else Value.cast(value).shape(), name=name)
    m.d.comb += s.eq(value)
    return s


def flat(layout, name):
    """A signal of ``layout``'s width, and a view of it with ``layout``'s fields.

    A signal whose shape is a layout makes Amaranth emit a named wire per
    field; in an array of cells those are thousands of wires that only make
    the Verilog, the Icarus netlist and Verilator's C++ larger.
    """
    s = Signal(layout.size, name=name)
    return s, layout(s)
