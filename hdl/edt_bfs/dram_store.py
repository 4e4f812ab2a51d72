"""The tile engine's per-pixel state in a DRAM, behind a LiteDRAM-style native port.

:class:`DramStore` serves :class:`~hdl.edt_bfs.state_ram.StateSignature`
(the engine's window-row reads and word writes) from a DRAM controller's
native user port (:class:`NativePortSignature`: LiteDRAM's ``cmd`` /
``wdata`` / ``rdata``), for maps whose state exceeds the part's block RAM
(issue 18: maze512-1-0's 13.9 Mbit against the LFE5U-85F's 3.7).
"""

from amaranth.hdl import Cat, Const, Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.fifo import SyncFIFO, SyncFIFOBuffered
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from ..ram_init import undefined_memory
from .state_ram import StateSignature
from .tile_layouts import BFS_FIELDS, EDT_FIELDS, bfs_layout, edt_layout, pixel_layout

__all__ = ["DramStore", "NativePortSignature", "dram_layout", "port_of_row", "local_row", "load_bits",
           "BANK_AT", "PORTS"]

DESCRIPTORS = 4         # reads in flight between the command side and the answer side
BEATS = 16              # write data beats given and not yet taken by the controller
# Where the map row's 3 low bits go in the native address (dram_layout).  LiteDRAM's controller for
# this DDR3 takes the bank from native address bits 7..9 (its column is bits 0..6): with the row's
# low bits from bit 6, two map rows share a DRAM row and a window's 6 rows spread over 3-4 banks,
# whose rows stay open.  Measured on room-64-64-8 through LiteDRAM (engine cycles, bits 4..9):
# 26,800 / 24,511 / 23,756 / 25,924 / 29,299 / 34,081 (9: the plain row-major order).
ROW_BITS_AT = 6
# LiteDRAM's bank is native address bits 7..9 for this DDR3 (its ROW_BANK_COL mapping: 10 column
# bits less the 3 of the 1:2-rate PHY's burst of 8).  Its crossbar locks a native port to one bank
# while the bank has commands queued (litedram/core/crossbar.py: a port's answers stay in order), and
# one store issues one native command a cycle: with several ports, a store on each (RowRouter), port
# i serves the rows whose words are in banks with low bits i (port_of_row: ROW_BITS_AT makes those
# bank bits row bits), so a window's rows are read, and a tile's rows written, by several at once.
BANK_AT = 7
PORTS = (1, 2, 4)


def _port_bits(ports):
    """Where the port's bits sit in a map row with ``ports`` ports, and how many: (first, count)."""
    lo, bits = BANK_AT - ROW_BITS_AT, (ports - 1).bit_length()
    assert ports in PORTS and 0 <= lo and lo + bits <= 3, (ports, lo)
    return lo, bits


def port_of_row(row, ports):
    """The native port whose store holds map row ``row`` (an Amaranth value) with ``ports`` ports: the
    low bits of its words' bank (``BANK_AT``), which are row bits (``ROW_BITS_AT``)."""
    lo, bits = _port_bits(ports)
    return row[lo:lo + bits] if bits else 0


def local_row(row, ports):
    """Map row ``row`` (an Amaranth value or an int) among the rows of its port's store: without the bits
    :func:`port_of_row` takes (they are the same for every row a store holds)."""
    lo, bits = _port_bits(ports)
    if isinstance(row, int):
        return (row & ((1 << lo) - 1)) | ((row >> (lo + bits)) << lo)
    return Cat(row[:lo], row[lo + bits:]) if bits else row


def load_bits(w, p, max_h, ports, data_width=128, bfs_slots=False):
    """Each of ``ports`` stores' on-chip bits with ``changed`` (:class:`DramStore`: the load's obstacle
    bits, the edge slots' and the written bits of the A, B and E words; with ``bfs_slots`` the B slot
    word's again, in the banks its neighbours' writes look up): (blocks, bits a block)."""
    lay = dram_layout(w, p, max_h, data_width, bfs_slots)
    rows = max(local_row(r, ports) for r in range(max_h)) + 1
    return rows << lay["wb"], (p + 2 + lay["a"] + lay["b"] + lay["e"] * (1 if lay["wb"] > 1 else 2)
                               + (1 if bfs_slots else 0))


def NativePortSignature(addr_width, data_width):
    """A DRAM controller's native user port, seen from the user (LiteDRAM's
    ``user_port_native``): ``cmd`` (out: ``addr`` in words of ``data_width``
    bits, ``we``), ``wdata`` (out: ``data``, ``we`` one bit a byte; one beat
    per write command, in command order), ``rdata`` (in: one beat per read
    command, in command order).  A read returns every write whose command
    was accepted before it."""
    return wiring.Signature({
        "cmd": Out(stream.Signature(data.StructLayout({"addr": addr_width, "we": 1}))),
        "wdata": Out(stream.Signature(data.StructLayout({"data": data_width, "we": data_width // 8}))),
        "rdata": In(stream.Signature(data.StructLayout({"data": data_width}))),
    })


def _bytes(bits):
    return -(-bits // 8)


def dram_layout(w, p, max_h, data_width=128, bfs_slots=False):
    """Where :class:`DramStore` keeps word (``row``, ``wcol``): a block of
    ``2**kb`` native words at address ``((row << wb) | wcol) << kb``, with
    the three low bits of ``row`` moved down to bit ``ROW_BITS_AT`` (the
    bits above shifted up: a window's rows over several DRAM banks):

    * ``a`` words (from offset 0): the EDT field group (di, dx, dy) of the
      word's ``p`` pixels, packed (``p * edt`` bits);
    * ``b`` words (from offset ``a``): the BFS group (hop, parent), packed,
      then from byte ``cfr_byte`` of the region a bit per pixel: the pixel is
      in the cfr by its di (``none`` or above d_far), kept by a store with
      ``changed`` (:class:`DramStore`) so that a BFS read need not read the
      ``a`` words for di;
    * ``e`` words (from offset ``a + b``): the *edge slots*, copies of the
      last pixel of word ``wcol - 1`` (slot 0, ``left``) and the first of
      word ``wcol + 1`` (slot 1, ``right``), each slot the EDT group then the
      BFS group, each group from a byte boundary (a write of one group is a
      byte-masked write).  Both slots in one native word when they fit
      (``e = 1``), else one each.

    With ``bfs_slots`` the B words also hold, from byte ``bslot`` of the
    region (all in B word ``bslot_word``), the edge slots' BFS groups (slot
    0 then slot 1, ``b_slot`` bytes each) and a byte per slot whose bit 0
    says the pixel it copies *left* the cfr (the EDT made it di <= d_far);
    the cfr bits of the word's own pixels are kept the same way (1: left;
    the cfr is then: not an obstacle and not left), so the load's B words
    do not depend on the map: a BFS read needs no E word.

    So a window row (the word and one pixel either side) is ``a`` + ``e``
    reads for an EDT visit, ``b + e`` for a BFS visit with the cfr bits
    (``b`` with ``bfs_slots``),
    ``a + b + e`` for the rest, all in one block (one
    DRAM row); a write of one group is its ``a`` (or ``b``) words plus one
    byte-masked write into each neighbour's edge word.  Returns a dict of
    those numbers, ``cfr_byte``, ``slot`` (the slot's size in bytes), ``bslot``, ``b_slot``,
    ``bslot_word`` (None without ``bfs_slots``), ``bslot_at(s)`` -> (slot
    ``s``'s BFS group, its "left" byte: bytes of the B region), ``edt_byte`` /
    ``bfs_byte`` (each group's first byte in a slot), ``slot_at(s)`` ->
    (edge word, first byte) and ``addr_width``.
    """
    e_bits, b_bits = edt_layout(w).size, bfs_layout(w).size
    assert data_width % 8 == 0 and data_width >= 32, data_width
    cfr_byte = _bytes(p * b_bits)
    nb = data_width // 8
    b_end = cfr_byte + _bytes(p)                # the B region's bytes
    bslot = b_slot = None
    if bfs_slots:
        b_slot = _bytes(b_bits)
        span = 2 * b_slot + 2                   # both slots' BFS groups, then their "left" bytes
        if span > nb:
            raise ValueError(f"the edge slots' BFS groups ({span} bytes) are wider than a native word "
                             f"({data_width} bits)")
        bslot = b_end if b_end // nb == (b_end + span - 1) // nb else -(-b_end // nb) * nb     # in one word
        b_end = bslot + span
    a, b = -(-p * e_bits // data_width), -(-b_end // nb)
    slot = _bytes(e_bits) + _bytes(b_bits)
    if slot > data_width // 8:
        raise ValueError(f"a pixel's state ({slot} bytes) is wider than a native word ({data_width} bits)")
    e = 1 if 2 * slot <= data_width // 8 else 2
    kb = max(0, (a + b + e - 1).bit_length())
    wb = max(1, (w["words"] - 1).bit_length())
    rb = max(1, (max_h - 1).bit_length())
    # the row's low bits at ROW_BITS_AT even when a row's blocks take fewer address bits (a small map)
    return {"a": a, "b": b, "e": e, "kb": kb, "wb": wb, "rb": rb, "addr_width": rb + max(wb + kb, ROW_BITS_AT),
            "cfr_byte": cfr_byte, "slot": slot, "edt_byte": 0, "bfs_byte": _bytes(e_bits), "data_width": data_width,
            "slot_at": (lambda s: (s, 0) if e == 2 else (0, s * slot)),
            "bfs_slots": bfs_slots, "bslot": bslot, "b_slot": b_slot,
            "bslot_word": bslot // nb if bfs_slots else None,
            "bslot_at": (lambda s: (bslot + s * b_slot, bslot + 2 * b_slot + s))}


def _slot_write(wd, wbe, src, byte, lay, px, groups):
    """A neighbour's edge slot at ``byte`` of native word ``wd`` <- pixel ``src``: the EDT group's
    bytes enabled if ``groups[0]``, the BFS group's if ``groups[1]``."""
    cut = px["dy"].offset + px["dy"].width          # the EDT group is the pixel's low bits
    eb, bb = byte + lay["edt_byte"], byte + lay["bfs_byte"]
    e_mask = ((1 << _bytes(cut)) - 1) << eb
    b_mask = ((1 << _bytes(px.size - cut)) - 1) << bb
    return [wd[eb * 8:eb * 8 + cut].eq(src[:cut]), wd[bb * 8:bb * 8 + px.size - cut].eq(src[cut:]),
            wbe.eq(Mux(groups[0], e_mask, 0) | Mux(groups[1], b_mask, 0))]


def _lowest(m, mask, n, name):
    """One-hot of the lowest set bit of ``mask`` (``n`` bits) and its index."""
    hot = Signal(n, name=f"{name}_hot")
    idx = Signal(range(max(n, 2)), name=f"{name}_idx")
    m.d.comb += hot.eq(mask & -mask)
    for i in reversed(range(n)):
        with m.If(mask[i]):
            m.d.comb += idx.eq(i)
    return hot, idx


class DramStore(wiring.Component):
    """Every pixel's state in a DRAM behind a native port (:func:`dram_layout`).

    Parameters
    ----------
    w : dict
        :func:`~hdl.edt_bfs.tile_layouts.tile_widths` (``words``: word
        columns of the widest map).
    p : int
        Pixels per word (T_c).
    max_h : int
        Rows of the largest map.
    data_width : int
        The native port's word (LiteDRAM: 128 for a 16-bit DDR3, a burst of
        8, 64 for an 8-bit DDR3); a pixel's two groups must fit one word.
    max_reads : int
        Native reads unanswered at most: the depth of the FIFO that takes
        the answers (always ready: LiteDRAM's native port does not wait for
        ``rdata.ready``, a word not taken is lost).
    changed : bool
        The writes carry the pixels they change and the pixels' cfr bits
        (:func:`~hdl.edt_bfs.state_ram.write_layout`): a write issues only
        the native words holding a changed pixel (a group word any of whose
        pixels changed; a neighbour's edge slot when the pixel it copies
        changed); an EDT write also writes the word's cfr bits when one of
        its changed pixels left the cfr (:func:`dram_layout`: a byte-masked
        write of the B word holding them, which a BFS write leaves out; the
        EDT changes a pixel once, from not done, in the cfr, to done, in the
        cfr iff its di exceeds d_far), and a read asking for di and the
        BFS group without the vector (the BFS visits', the goals') skips the
        ``a`` words: its answer's di is ``none`` for a pixel in the cfr, 0
        for one outside (all the engine reads di for there), the edge
        pixels' di as stored (the slot holds it).  And the load (a write of
        both groups: the map's initial state, di 0 or none, vector 0, hop
        none, parent 0) issues nothing: the store keeps the block's
        obstacle bits (di = 0) on chip, the obstacle bits of the pixels its
        edge slots copy, and a *written* bit per A, B and E word, cleared by
        the load; a read of a word not written since is answered from the
        obstacle bits, and the first write to it is a whole word, the bytes
        it does not enable from the same initial state.  So the DRAM holds
        what it would had the load written the word: the load costs no
        native command (maze512-1-0 on the 3x8 array: 262,144 writes), and
        a word no visit changed is never read.
    ports : int
        The stores the map rows are spread over (:func:`port_of_row`): this
        store's on-chip bits hold only its rows (:func:`load_bits`).
    bfs_slots : bool
        With ``changed``: the edge slots' BFS groups, and whether the pixel
        each copies left the cfr, in the B words (:func:`dram_layout`): a
        BFS read is ``b`` native words, not ``b + e``.  A BFS write puts its
        edge pixels into its neighbours' B words instead of their E words,
        and an EDT write whose edge pixel left the cfr says so there too
        (byte-masked; the first write to a B word goes whole, and the load's
        B words are the same for every map, so that needs no obstacle bit
        of the neighbour's).

    Ports
    -----
    :class:`~hdl.edt_bfs.state_ram.StateSignature` (``rd``, ``rd_data``,
    ``wr``): the engine's side; ``dram`` : Out(:class:`NativePortSignature`)
    the controller's port (``addr_width`` = ``dram_layout(...)["addr_width"]``:
    the DRAM must hold ``2**addr_width`` native words).

    Operation (with ``changed``: the on-chip bits of the command on offer
    are looked up a cycle before it is taken, so it is taken in its second
    cycle on offer at the earliest, and its words not written
    since the load are not read, or written whole): one engine command at
    a time becomes its native commands,
    lowest offset first (a read: the groups it asks for, then the edge
    words; a write: its group's words, then the right neighbour's left slot
    and the left neighbour's right slot, byte-masked; a neighbour outside
    the widest map is skipped), one a cycle while the port is ready; the
    next engine command is accepted in the cycle its predecessor's last
    native command loads while the command register is empty (else in the
    cycle after: the port's ``ready`` does not reach the engine side).  A
    write's data beat waits in a FIFO of ``BEATS`` until the controller asks
    for it (LiteDRAM: some cycles after the command), so writes go one a
    cycle too.  Reads in flight are
    described in a FIFO of ``DESCRIPTORS`` (which words each brings); the
    answers enter a FIFO of ``max_reads`` words, and the answer side
    collects them into one window row and holds it until taken.  The whole
    store is reset with its controller (it runs on the controller's clock;
    :class:`~hdl.edt_bfs.state_cdc.StateCdc` keeps the engine's reset from
    it).  Order:
    the controller's (a read after a write to the same word sees it), so
    StateSignature's contract holds.  Timing: an EDT read takes ``a + e``
    port cycles, a BFS read ``a + b + e`` (``b + e`` with ``changed``), a write ``a`` (or ``b``) + 2, at
    best (one native command a cycle); answers follow the controller's
    latency.
    """

    def __init__(self, w, p, max_h, data_width=128, max_reads=16, changed=False, ports=1, bfs_slots=False):
        if not 1 <= max_reads <= 256:
            raise ValueError(f"max_reads {max_reads}: must be 1..256")
        if ports not in PORTS:
            raise ValueError(f"ports {ports}: must be one of {PORTS}")
        if bfs_slots and not changed:
            raise ValueError("bfs_slots needs changed (the cfr bits and the on-chip written bits)")
        self.w, self.p, self.max_h, self.max_reads, self.changed = w, p, max_h, max_reads, changed
        self.ports, self.bfs_slots = ports, bfs_slots
        self.lay = dram_layout(w, p, max_h, data_width, bfs_slots)
        super().__init__({
            **StateSignature(w, p, changed).members,
            "dram": Out(NativePortSignature(self.lay["addr_width"], data_width)),
        })

    def elaborate(self, platform):
        m = Module()
        w, p, lay = self.w, self.p, self.lay
        dw, a, b, e = lay["data_width"], lay["a"], lay["b"], lay["e"]
        nb = dw // 8
        px = pixel_layout(w)
        n_rd = a + b + e            # a read's steps: A words, B words, edge words
        # a write's: A words, B words, the two neighbours' E slots (and with bfs_slots their B slots)
        n_wr = a + b + 2 + (2 if self.bfs_slots else 0)
        n = max(n_rd, n_wr)
        e_lay, b_lay = edt_layout(w), bfs_layout(w)

        # -- the command side: the engine command being issued
        busy_mask = Signal(n)           # its native commands still to go (bit = step)
        is_wr = Signal()
        row = Signal(w["row"])
        wcol = Signal(range(w["words"]))
        wmask = Signal(2)               # a write's groups: bit 0 EDT, bit 1 BFS
        word = Signal(px.size * p)      # a write's pixels
        cfr = Signal(p) if self.changed else Const(0, p)        # and their cfr bits
        hot, step = _lowest(m, busy_mask, n, "step")

        cmd, wdata = self.dram.cmd, self.dram.wdata
        # A step loads the command register and, for a write, puts its data beat in a FIFO (the
        # controller asks for the beat some cycles after taking the command: LiteDRAM's write
        # latency); the next step loads when the register is free: one native command a cycle.
        c_valid = Signal()
        c_cmd = Signal(cmd.payload.shape().size)
        m.submodules.beats = beats = SyncFIFOBuffered(width=wdata.payload.shape().size, depth=BEATS)
        active = busy_mask != 0
        cmd_go = cmd.valid & cmd.ready
        step_done = Signal()            # the step loads the registers
        # A controller may not hold its answers back (LiteDRAM's native port drops a word its
        # user does not take): they go into a FIFO of ``max_reads`` words, always ready, since
        # a read loads only while fewer than ``max_reads`` are unanswered (``in_flight``: loaded
        # and not yet taken out of that FIFO).
        in_flight = Signal(range(self.max_reads + 1))
        m.d.comb += [cmd.valid.eq(c_valid), cmd.payload.eq(c_cmd),
                     wdata.valid.eq(beats.r_rdy), wdata.payload.eq(beats.r_data), beats.r_en.eq(wdata.ready),
                     step_done.eq(active & (~c_valid | cmd_go)
                                  & Mux(is_wr, beats.w_rdy, in_flight < self.max_reads))]
        wd = Signal(lay["data_width"])              # the step's command, data and byte enables
        wbe = Signal(nb)
        addr = Signal(lay["addr_width"])
        m.d.sync += [c_valid.eq(step_done | (c_valid & ~cmd_go)),
                     c_cmd.eq(Mux(step_done, Cat(addr, is_wr), c_cmd))]
        m.d.comb += [beats.w_en.eq(step_done & is_wr), beats.w_data.eq(Cat(wd, wbe))]
        rest = Signal(n)
        m.d.comb += rest.eq(Mux(step_done, busy_mask & ~hot, busy_mask))

        # reads in flight: which of the n_rd steps each one issued (with ``changed``: also whether it
        # asked for the A words, which of its words come from the on-chip bits, and those bits)
        n_ab = a + b
        m.submodules.desc = desc = SyncFIFOBuffered(width=n_rd + (1 + n_rd + p + 2 + self.bfs_slots if self.changed
                                                                 else 0),
                                                    depth=DESCRIPTORS)
        # The next command is taken when the last step of this one loads in this cycle, judged from
        # registers alone (the command register empty, room for its beat or answer), not from the
        # port's ready: that path (the controller's arbitration -> this take -> the on-chip bits'
        # writes and the engine side's ready) set the controller's clock in the whole top.  Whether
        # one step is left is a register too (``one_left``, from the mask it loads), not a carry
        # chain on ``busy_mask``: the engine side's ready leaves the store for the router and the
        # buffer before it, placed apart from the stores.
        one_left = Signal(init=1)
        last_step = Signal()            # one step to go, and it loads in this cycle
        m.d.comb += last_step.eq(one_left & ~c_valid & Mux(is_wr, beats.w_rdy, in_flight < self.max_reads))
        free = ~active | last_step
        rcmd, wcmd = self.rd.payload, self.wr.payload
        if self.changed:
            # The on-chip bits (the class's docstring), looked up a cycle before a command is taken: the read ports are addressed by the
            # command on offer (a write before a read, as they are taken), and a command is taken
            # only when the lookup of the cycle before was its own; the ports are transparent to the
            # writes of the command taken in that cycle, the only ones in between.
            depth, _ = load_bits(w, p, self.max_h, self.ports, dw)
            wb = lay["wb"]
            # Block k's: ``obst`` its pixels' obstacle bits, ``written`` its A and B words' written
            # bits (undefined until the load writes them: the engine reads and writes only words of
            # the map it loaded); ``l_obst`` / ``r_obst`` the obstacle bit of the pixel its left /
            # right edge slot copies (the load of block k - 1 / k + 1 writes it) and its E words'
            # written bits in ``e_written[bank]``, bank: bit 1 of the word column (a write looks up
            # both its neighbours' at once, and k - 1 and k + 1 differ there); these three are zero
            # until written (a write's neighbour may lie outside the map: its slot is written all
            # the same, from defined bits).
            m.submodules.obst = obst = undefined_memory(shape=p, depth=depth)
            m.submodules.written = written = undefined_memory(shape=n_ab, depth=depth)
            m.submodules.l_obst = l_obst = Memory(shape=1, depth=depth, init=[])
            m.submodules.r_obst = r_obst = Memory(shape=1, depth=depth, init=[])
            e_written = [Memory(shape=e, depth=depth >> 1 if wb > 1 else depth, init=[]) for _ in range(2)]
            ports = {}
            for name, mem in (("o", obst), ("w", written), ("l", l_obst), ("r", r_obst),
                              ("e0", e_written[0]), ("e1", e_written[1])):
                if name.startswith("e"):
                    m.submodules[f"e_written{name[1]}"] = mem
                wp = mem.write_port()
                ports[name] = (mem.read_port(transparent_for=(wp,)), wp)
            (o_rp, o_wp), (w_rp, w_wp), (l_rp, l_wp), (r_rp, r_wp) = (ports[n] for n in "owlr")
            on_wr = self.wr.valid
            c_col = Signal(wb)              # the command on offer: its block's word column, local row
            c_row = Signal(len(local_row(wcmd.row, self.ports)))
            m.d.comb += [c_col.eq(Mux(on_wr, wcmd.wcol, rcmd.wcol)),
                         c_row.eq(local_row(Mux(on_wr, wcmd.row, rcmd.row), self.ports))]

            def key(dc):
                """The on-chip address of the block ``dc`` word columns right of the one on offer."""
                return Cat((c_col + dc)[:wb], c_row)

            def bank(dc):
                return (c_col + dc)[1] if wb > 1 else Const(0)

            def e_key(dc):
                """That block's address in its ``e_written`` bank (the word column without its bank bit)."""
                col = (c_col + dc)[:wb]
                return Cat(col[0], col[2:], c_row) if wb > 1 else key(dc)

            # The lookup of the cycle before was the write's when the write was on offer then and not
            # taken (a payload on offer stays until taken), the read's when the read was and no
            # write: registers, so the ready does not wait for a comparison of the command.
            looked_wr, looked_rd = Signal(), Signal()
            m.d.sync += [looked_wr.eq(self.wr.valid & ~self.wr.ready),
                         looked_rd.eq(self.rd.valid & ~self.wr.valid & ~self.rd.ready)]
            r_ok = c_col != w["words"] - 1          # the block on offer has a right / left neighbour
            l_ok = c_col != 0
            m.d.comb += [o_rp.addr.eq(key(0)), w_rp.addr.eq(key(0)), o_wp.addr.eq(key(0)), w_wp.addr.eq(key(0)),
                         l_rp.addr.eq(Mux(on_wr, key(-1), key(0))), r_rp.addr.eq(Mux(on_wr, key(1), key(0))),
                         l_wp.addr.eq(key(1)), r_wp.addr.eq(key(-1))]
            # a write looks up its neighbours' E words' written bits, a read its own
            e_rd = []
            for i in range(2):
                rp, wp = ports[f"e{i}"]
                m.d.comb += rp.addr.eq(Mux(on_wr, Mux(r_ok & (bank(1) == i), e_key(1), e_key(-1)), e_key(0)))
                e_rd.append(rp.data)
            e_right, e_left, e_own = (Mux(bank(dc), e_rd[1], e_rd[0]) for dc in (1, -1, 0))
            if self.bfs_slots:
                # The B slot word's written bits in banks by the word column's low bits: a write looks
                # up its own and both its neighbours' at once (three columns in a row: three banks;
                # with two columns of blocks, the one neighbour inside).  Zero until written, as
                # e_written.
                sb = min(2, wb)
                bs_ports = []
                for i in range(1 << sb):
                    mem = m.submodules[f"bs_written{i}"] = Memory(shape=1, depth=depth >> sb, init=[])
                    wp = mem.write_port()
                    bs_ports.append((mem.read_port(transparent_for=(wp,)), wp))

                def bs_bank(dc):
                    return (c_col + dc)[:sb]

                def bs_key(dc):
                    return Cat((c_col + dc)[sb:wb], c_row)
                for i, (rp, _) in enumerate(bs_ports):
                    m.d.comb += rp.addr.eq(Mux(bs_bank(0) == i, bs_key(0),
                                               Mux(on_wr & r_ok & (bs_bank(1) == i), bs_key(1), bs_key(-1))))
                bs_rd = Cat(*[rp.data for rp, _ in bs_ports])
                bs_own, bs_right, bs_left = (bs_rd.bit_select(bs_bank(dc), 1) for dc in (0, 1, -1))
        else:
            looked_wr = looked_rd = Const(1)
        take_wr = self.wr.valid & free & (looked_wr | (wcmd.edt & wcmd.bfs if self.changed else 0))
        take_rd = self.rd.valid & free & ~self.wr.valid & desc.w_rdy & looked_rd
        m.d.comb += [self.wr.ready.eq(free & looked_wr),
                     self.rd.ready.eq(free & ~self.wr.valid & desc.w_rdy & looked_rd)]
        # with the cfr bits in the B words, di alone for a BFS group read is not a reason to read A
        need_a = (rcmd.nnt | (rcmd.di & ~rcmd.bfs)) if self.changed else (rcmd.di | rcmd.nnt)
        # with bfs_slots the edge pixels' BFS groups and cfr come with the B words: E only for A's fields
        e_need = (need_a | ~rcmd.bfs) if self.bfs_slots else Const(1)
        rd_steps = Cat(*([need_a] * a), *([rcmd.bfs] * b), *([e_need] * e))
        right_ok = wcmd.wcol != w["words"] - 1
        left_ok = wcmd.wcol != 0

        def cfr_bytes(k):
            """The byte enables of the cfr bits in B word k (dram_layout's cfr_byte)."""
            return ((((1 << _bytes(p)) - 1) << lay["cfr_byte"]) >> (k * nb)) & ((1 << nb) - 1)

        if self.changed:
            # a group word goes when a pixel it holds (any of its bits) changed; a neighbour's
            # slot when the pixel it copies changed (step a + b: our last pixel, a + b + 1: our first)
            e_bits, b_bits = e_lay.size, b_lay.size
            touched = [Cat(*[wcmd.changed[j] for j in range(p)
                             if j * bits < (s + 1) * dw and (j + 1) * bits > s * dw]).any()
                       for bits, count in ((e_bits, a), (b_bits, b)) for s in range(count)]
            # an EDT write also writes the B word(s) holding the cfr bits when a pixel left the cfr:
            # the EDT changes a pixel once, from not done (in the cfr) to done at di = k, in the cfr
            # iff k > d_far (its ``cfr`` bit), so a changed pixel with its cfr bit 0 is one that left
            cfr_word = [cfr_bytes(s) != 0 for s in range(b)]
            left_cfr = (wcmd.changed & ~wcmd.cfr).any()
            group_go = [*[wcmd.edt & t for t in touched[:a]],
                        *[(wcmd.bfs & t) | (wcmd.edt & left_cfr) if cw else wcmd.bfs & t
                          for t, cw in zip(touched[a:], cfr_word)]]
            edge_go = [right_ok & wcmd.changed[p - 1], left_ok & wcmd.changed[0]]
            b_slot_go = []
            if self.bfs_slots:
                # the E slots take the EDT group alone; the B slots a BFS write's group, and an EDT
                # write's "left" byte when the edge pixel left the cfr
                b_slot_go = [g & (wcmd.bfs | (wcmd.edt & ~wcmd.cfr[j])) for g, j in zip(edge_go, (p - 1, 0))]
                edge_go = [wcmd.edt & g for g in edge_go]
            wr_steps = Cat(*group_go, *edge_go, *b_slot_go)
        else:
            wr_steps = Cat(*([wcmd.edt] * a), *([wcmd.bfs] * b), right_ok, left_ok)
        rd_go, desc_data = rd_steps, rd_steps
        if self.changed:
            # The load (both groups) issues nothing: it writes its obstacle bits (its first and last
            # into its neighbours' l_obst and r_obst) and clears its written bits.  Another write sets
            # the written bits of the words it issues (its neighbours' E words for its slots).
            is_load = wcmd.edt & wcmd.bfs
            wr_steps = Mux(is_load, 0, wr_steps)
            obst_bits = Cat(*[wcmd.word[j].di == 0 for j in range(p)])
            m.d.comb += [w_wp.en.eq(take_wr), w_wp.data.eq(Mux(is_load, 0, w_rp.data | wr_steps[:n_ab])),
                         o_wp.en.eq(take_wr & is_load), o_wp.data.eq(obst_bits),
                         l_wp.en.eq(take_wr & is_load & r_ok), l_wp.data.eq(obst_bits[p - 1]),
                         r_wp.en.eq(take_wr & is_load & l_ok), r_wp.data.eq(obst_bits[0])]
            slot_bit = [1 << lay["slot_at"](sl)[0] for sl in range(2)]        # a slot's E word
            for i in range(2):
                _, wp = ports[f"e{i}"]
                right, left = wr_steps[n_ab], wr_steps[n_ab + 1]
                with m.If(take_wr & is_load & (bank(0) == i)):
                    m.d.comb += [wp.en.eq(1), wp.addr.eq(e_key(0)), wp.data.eq(0)]
                with m.Elif(take_wr & right & (bank(1) == i)):
                    m.d.comb += [wp.en.eq(1), wp.addr.eq(e_key(1)), wp.data.eq(e_right | slot_bit[0])]
                with m.Elif(take_wr & left & (bank(-1) == i)):
                    m.d.comb += [wp.en.eq(1), wp.addr.eq(e_key(-1)), wp.data.eq(e_left | slot_bit[1])]
            own_written = w_rp.data
            if self.bfs_slots:          # the B slot word's bit from its banks
                bw = a + lay["bslot_word"]
                own_written = Cat(w_rp.data[:bw], bs_own, w_rp.data[bw + 1:])
                for i, (_, wp) in enumerate(bs_ports):
                    with m.If(take_wr & (bs_bank(0) == i) & (is_load | wr_steps[bw])):
                        m.d.comb += [wp.en.eq(1), wp.addr.eq(bs_key(0)), wp.data.eq(~is_load)]
                    with m.Elif(take_wr & wr_steps[n_ab + 2] & (bs_bank(1) == i)):
                        m.d.comb += [wp.en.eq(1), wp.addr.eq(bs_key(1)), wp.data.eq(1)]
                    with m.Elif(take_wr & wr_steps[n_ab + 3] & (bs_bank(-1) == i)):
                        m.d.comb += [wp.en.eq(1), wp.addr.eq(bs_key(-1)), wp.data.eq(1)]
            # a read's words not written since the load come from the obstacle bits
            fresh = rd_steps & ~Cat(own_written, e_own)
            rd_go = rd_steps & ~fresh
            desc_data = Cat(rd_go, rd_steps[0], fresh, o_rp.data, l_rp.data, r_rp.data,
                            *([rd_steps[n_ab]] if self.bfs_slots else []))
            wr_fresh = Signal(n_ab)         # the write's words not written since the load
            wr_obst = Signal(p)             # and its obstacle bits
            slot_fresh = [Signal(e, name=f"slot{sl}_fresh") for sl in range(2)]   # the neighbours' E words
            slot_other = [Signal(name=f"slot{sl}_other") for sl in range(2)]      # and their other edge pixel
            with m.If(take_wr):
                m.d.sync += [wr_fresh.eq(~own_written), wr_obst.eq(o_rp.data), slot_fresh[0].eq(~e_right),
                             slot_fresh[1].eq(~e_left), slot_other[0].eq(r_rp.data), slot_other[1].eq(l_rp.data)]
            if self.bfs_slots:          # the neighbours' B slot words
                slot_bfresh = [Signal(name=f"slot{sl}_bfresh") for sl in range(2)]
                with m.If(take_wr):
                    m.d.sync += [slot_bfresh[0].eq(~bs_right), slot_bfresh[1].eq(~bs_left)]
        m.d.comb += [desc.w_data.eq(desc_data), desc.w_en.eq(take_rd)]
        busy_next = Signal(n)
        m.d.comb += busy_next.eq(Mux(take_wr, wr_steps, Mux(take_rd, rd_go, rest)))
        m.d.sync += [busy_mask.eq(busy_next), one_left.eq((busy_next & (busy_next - 1)) == 0)]
        with m.If(take_wr):
            m.d.sync += [is_wr.eq(1), row.eq(wcmd.row), wcol.eq(wcmd.wcol),
                         wmask.eq(Cat(wcmd.edt, wcmd.bfs)), word.eq(wcmd.word.as_value())]
            if self.changed:
                m.d.sync += cfr.eq(wcmd.cfr)
        with m.Elif(take_rd):
            m.d.sync += [is_wr.eq(0), row.eq(rcmd.row), wcol.eq(rcmd.wcol)]

        # the step's native word: block (row, wcol or a neighbour), offset
        kb, wb = lay["kb"], lay["wb"]
        col = Signal(range(w["words"] + 1))
        off = Signal(max(kb, 1))
        pix = data.ArrayLayout(px, p)(word)
        assert px["di"].offset == 0 and px["hop"].offset == px["dy"].offset + px["dy"].width

        def regions(pix, cfr):
            """A word of pixels ``pix`` with cfr bits ``cfr`` as its A words and its B words (dram_layout)."""
            edt_bits = Cat(*[pix[j].as_value()[:px["hop"].offset] for j in range(p)])
            bfs_bits = Cat(*[pix[j].as_value()[px["hop"].offset:] for j in range(p)])
            return (Cat(edt_bits, Const(0, a * dw - len(edt_bits))),
                    Cat(bfs_bits, Const(0, lay["cfr_byte"] * 8 - len(bfs_bits)), cfr,
                        Const(0, b * dw - lay["cfr_byte"] * 8 - p)))

        def load_pixel(v, obst):
            """``v`` <- the pixel the load writes for obstacle bit ``obst``: the engine's initial state
            (di 0 or none, hop none, the rest 0)."""
            return [v.di.eq(Mux(obst, 0, (1 << w["di"]) - 1)), v.hop.eq((1 << w["hop"]) - 1)]

        b_load = None
        if self.bfs_slots:
            # the load's B words with bfs_slots, the same for every map: each pixel's and each slot's
            # BFS group at hop none, parent 0, no pixel left the cfr
            g = ((1 << w["hop"]) - 1) << b_lay["hop"].offset
            at = [j * b_lay.size for j in range(p)] + [lay["bslot_at"](sl)[0] * 8 for sl in range(2)]
            b_load = Const(sum(g << i for i in at), b * dw)

        def initial(obst, name):
            """The A and B words the load would have written for obstacle bits ``obst`` (cfr: not an
            obstacle)."""
            v = Signal(data.ArrayLayout(px, p), name=name)
            for j in range(p):
                m.d.comb += load_pixel(v[j], obst[j])
            a_words, b_words = regions(v, ~obst)
            return a_words, b_load if self.bfs_slots else b_words

        def edge_initial(left, right, name):
            """The E words the load would have written for edge pixels of obstacle bits ``left`` and
            ``right`` (both groups of each slot; bytes outside the slots 0)."""
            v = Signal(e * dw, name=name)
            for sl, ob in ((0, left), (1, right)):
                ew, byte = lay["slot_at"](sl)
                init = Signal(px, name=f"{name}_{sl}")
                m.d.comb += load_pixel(init, ob)
                at_e, at_b = ew * dw + (byte + lay["edt_byte"]) * 8, ew * dw + (byte + lay["bfs_byte"]) * 8
                cut = px["hop"].offset
                m.d.comb += [v[at_e:at_e + cut].eq(init.as_value()[:cut]),
                             v[at_b:at_b + px.size - cut].eq(init.as_value()[cut:])]
            return v

        edt_bits, b_region = regions(pix, ~cfr if self.bfs_slots else cfr)     # bfs_slots: "left" bits
        if self.changed:
            b_initial = initial(wr_obst, "wr_initial")[1]
            # the right neighbour's E words (slot 0: our last pixel), the left one's (slot 1: our first)
            slot_initial = [edge_initial(wr_obst[p - 1], slot_other[0], "right_initial"),
                            edge_initial(slot_other[1], wr_obst[0], "left_initial")]
            slot_data = []                  # each slot's write as it would go into a word written before
            for slot in range(2):
                swd, swbe = Signal(dw, name=f"slot{slot}_wd"), Signal(nb, name=f"slot{slot}_be")
                m.d.comb += _slot_write(swd, swbe, pix[p - 1 if slot == 0 else 0].as_value(),
                                        lay["slot_at"](slot)[1], lay, px, wmask)
                slot_data.append((swd, swbe))
            if self.bfs_slots:
                # each neighbour's B slot word: our edge pixel's BFS group (a BFS write), whether it left
                # the cfr (an EDT write)
                bslot_data = []
                for sl, j in ((0, p - 1), (1, 0)):
                    swd, swbe = Signal(dw, name=f"bslot{sl}_wd"), Signal(nb, name=f"bslot{sl}_be")
                    at, lb = (byte - lay["bslot_word"] * nb for byte in lay["bslot_at"](sl))      # in the word
                    m.d.comb += [swd[at * 8:at * 8 + b_lay.size].eq(pix[j].as_value()[px["hop"].offset:]),
                                 swd[lb * 8].eq(~cfr[j]),
                                 swbe.eq(Mux(wmask[1], ((1 << lay["b_slot"]) - 1) << at, 0)
                                         | Mux(wmask[0], 1 << lb, 0))]
                    bslot_data.append((swd, swbe))

        def whole(raw, init, be):
            """A word not written since the load, written whole: ``raw``'s bytes enabled by ``be``,
            the rest ``init``."""
            bits = Cat(*[Mux(be[i], Const(0xFF, 8), 0) for i in range(nb)])
            return (raw & bits) | (init & ~bits)
        m.d.comb += col.eq(wcol)
        with m.Switch(step):
            for s in range(n):
                with m.Case(s):
                    if s < a:                                   # A word s
                        m.d.comb += [off.eq(s), wd.eq(edt_bits[s * dw:(s + 1) * dw]), wbe.eq((1 << nb) - 1)]
                    elif s < a + b:                             # B word s - a
                        k = s - a
                        m.d.comb += [off.eq(s), wd.eq(b_region[k * dw:(k + 1) * dw])]
                        if self.changed:                        # BFS group bytes; cfr bytes (EDT)
                            cmask = cfr_bytes(k)
                            gmask = ((1 << nb) - 1) & ~cmask        # the BFS group's bytes
                            if self.bfs_slots:                      # (not the neighbours' slots)
                                gmask = Const((((1 << lay["cfr_byte"]) - 1) >> (k * nb)) & ((1 << nb) - 1), nb)
                            be = Mux(wmask[1], gmask, 0) | Mux(wmask[0], cmask, 0)
                            raw = b_region[k * dw:(k + 1) * dw]
                            # a word not written since the load goes whole (the A words always do)
                            m.d.comb += [wbe.eq(Mux(wr_fresh[s], (1 << nb) - 1, be)),
                                         wd.eq(Mux(wr_fresh[s], whole(raw, b_initial[k * dw:(k + 1) * dw], be), raw))]
                        else:
                            m.d.comb += wbe.eq((1 << nb) - 1)
                    else:
                        k = s - a - b
                        if k < e:                               # a read's edge word k
                            m.d.comb += off.eq(a + b + k)
                        if self.bfs_slots and 2 <= k < 4:       # a write's neighbour B slot
                            sl, bsw = k - 2, lay["bslot_word"]
                            swd, swbe = bslot_data[sl]
                            with m.If(is_wr):
                                m.d.comb += [col.eq(wcol + 1 if sl == 0 else wcol - 1), off.eq(a + bsw),
                                             wbe.eq(Mux(slot_bfresh[sl], (1 << nb) - 1, swbe)),
                                             wd.eq(Mux(slot_bfresh[sl],
                                                       whole(swd, b_load[bsw * dw:(bsw + 1) * dw], swbe), swd))]
                        if k < 2:                               # a write's neighbour slot
                            # step a+b: the right neighbour's left slot (slot 0) <- our last pixel;
                            # step a+b+1: the left neighbour's right slot (slot 1) <- our first pixel
                            slot = k
                            src = pix[p - 1 if slot == 0 else 0].as_value()
                            ew, byte = lay["slot_at"](slot)
                            with m.If(is_wr):
                                m.d.comb += [col.eq(wcol + 1 if slot == 0 else wcol - 1), off.eq(a + b + ew)]
                                if self.changed:    # an E word not written since the load goes whole
                                    swd, swbe = slot_data[slot]
                                    fresh_e = slot_fresh[slot][ew]
                                    init = slot_initial[slot][ew * dw:(ew + 1) * dw]
                                    m.d.comb += [wbe.eq(Mux(fresh_e, (1 << nb) - 1, swbe)),
                                                 wd.eq(Mux(fresh_e, whole(swd, init, swbe), swd))]
                                else:
                                    m.d.comb += _slot_write(wd, wbe, src, byte, lay, px, wmask)
        # the block's address ((row << wb) | wcol) << kb | off with the map row's 3 low bits moved
        # down to bit ROW_BITS_AT (dram_layout)
        lin = Cat(off[:kb] if kb else Const(0, 0), col[:wb], Const(0, max(0, ROW_BITS_AT - kb - wb)))
        m.d.comb += addr.eq(Cat(lin[:ROW_BITS_AT], row[:3], lin[ROW_BITS_AT:], row[3:]))

        # -- the answer side: collect one read's words, then present the window row
        rdata, out = self.dram.rdata, self.rd_data
        amask = Signal(n_rd)            # the words of the read being collected, still to come
        ahot, astep = _lowest(m, amask, n_rd, "ans")
        buf = [Signal(dw, name=f"buf{s}") for s in range(n_rd)]
        collecting = amask != 0
        m.submodules.answers = rf = SyncFIFO(width=dw, depth=self.max_reads)
        m.d.comb += [rf.w_data.eq(rdata.payload.data), rf.w_en.eq(rdata.valid), rdata.ready.eq(rf.w_rdy)]
        issued = step_done & ~is_wr
        word_go = rf.r_rdy & rf.r_en
        m.d.sync += in_flight.eq(in_flight + issued - word_go)
        last = collecting & (amask & ~ahot == 0)
        # the next read's description taken when the window row before is (its words from the
        # obstacle bits go into the buffers then)
        pop = ~collecting & desc.r_rdy & (~out.valid | out.ready)
        m.d.comb += [rf.r_en.eq(collecting & (~out.valid | out.ready)), desc.r_en.eq(pop)]
        with m.If(pop):
            m.d.sync += amask.eq(desc.r_data[:n_rd])
        if self.changed:
            got_a = Signal()            # the read being collected asked for the A words
            d_fresh = desc.r_data[n_rd + 1:2 * n_rd + 1]
            d_obst = desc.r_data[2 * n_rd + 1:][:p]
            d_left, d_right = desc.r_data[2 * n_rd + 1 + p], desc.r_data[2 * n_rd + 2 + p]
            init = Cat(*initial(d_obst, "rd_initial"), edge_initial(d_left, d_right, "rd_edge_initial"))
            with m.If(pop):
                m.d.sync += got_a.eq(desc.r_data[n_rd])
                for s in range(n_rd):
                    with m.If(d_fresh[s]):
                        m.d.sync += buf[s].eq(init[s * dw:(s + 1) * dw])
            if self.bfs_slots:          # the read asked for the E words; the obstacle bits (its cfr)
                got_e, a_obst, a_edge = Signal(), Signal(p), Signal(2)
                with m.If(pop):
                    m.d.sync += [got_e.eq(desc.r_data[2 * n_rd + 3 + p]), a_obst.eq(d_obst),
                                 a_edge.eq(Cat(d_left, d_right))]
        with m.If(word_go):
            m.d.sync += amask.eq(amask & ~ahot)
            with m.Switch(astep):
                for s in range(n_rd):
                    with m.Case(s):
                        m.d.sync += buf[s].eq(rf.r_data)
        with m.If(out.ready):
            m.d.sync += out.valid.eq(0)
        with m.If(word_go & last):
            m.d.sync += out.valid.eq(1)
        if self.changed:
            with m.If(pop & (desc.r_data[:n_rd] == 0)):     # every word from the obstacle bits: ready now
                m.d.sync += out.valid.eq(1)
        # the window row from the buffers (fields not asked for: whatever the buffer holds)
        a_bits, b_bits, e_bits = Cat(*buf[:a]), Cat(*buf[a:a + b]), Cat(*buf[a + b:])
        ans = out.payload
        none = (1 << w["di"]) - 1
        for j in range(p):
            g = e_lay(a_bits[j * e_lay.size:(j + 1) * e_lay.size])
            h = b_lay(b_bits[j * b_lay.size:(j + 1) * b_lay.size])
            m.d.comb += [getattr(ans.word[j], f).eq(getattr(g, f)) for f in EDT_FIELDS]
            m.d.comb += [getattr(ans.word[j], f).eq(getattr(h, f)) for f in BFS_FIELDS]
            if self.changed:                # a read without A: di from the cfr bit (none: in the cfr)
                in_cfr = b_bits[lay["cfr_byte"] * 8 + j]
                if self.bfs_slots:          # (the bit says "left": in the cfr, not an obstacle and not left)
                    in_cfr = ~in_cfr & ~a_obst[j]
                m.d.comb += ans.word[j].di.eq(Mux(got_a, g.di, Mux(in_cfr, none, 0)))
        for slot, dst in ((0, ans.left), (1, ans.right)):
            ew, byte = lay["slot_at"](slot)
            base = ew * dw + byte * 8
            g = e_lay(e_bits[base + lay["edt_byte"] * 8:][:e_lay.size])
            h = b_lay(e_bits[base + lay["bfs_byte"] * 8:][:b_lay.size])
            if self.bfs_slots:              # the BFS group and "left" byte from the B slot word
                at, lb = lay["bslot_at"](slot)
                h = b_lay(b_bits[at * 8:at * 8 + b_lay.size])
                in_cfr = ~b_bits[lb * 8] & ~a_edge[slot]
            m.d.comb += [getattr(dst, f).eq(getattr(g, f)) for f in EDT_FIELDS]
            m.d.comb += [getattr(dst, f).eq(getattr(h, f)) for f in BFS_FIELDS]
            if self.bfs_slots:              # a read without E: di from the cfr, as above
                m.d.comb += dst.di.eq(Mux(got_e, g.di, Mux(in_cfr, none, 0)))
        return m
