"""The EDT/BFS tile engine (issue 18): paper 004's cells as a T_r x T_c array over a map in block RAM."""

from amaranth.hdl import (Cat, ClockDomain, ClockSignal, Const, DomainRenamer, Module, Mux, ResetSignal, Signal,
                          signed)
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from navcores.models.edt_bfs import OFFSETS
from navcores.models.edt_bfs_tiled import Timing

from ..params import Constraint, Param, check, checked_init
from .frontier import FrontierFlags
from .dram_store import NativePortSignature, dram_layout
from .dram_stores import (BFS_SLOTS_PARAM, DRAM_CONSTRAINTS, DRAM_FIFO, DRAM_PORTS_PARAM, DRAM_WIDTH, SKIP_CLEAN_PARAM,
                          DramStores)
from .state_cdc import StateCdc
from .state_ram import StateRam, StateSignature
from .tile_array import TileArray
from .write_patch import WritePatch
from ..arith import divmod_const, times
from .tile_layouts import (MAX_CELLS, TILE_CONSTRAINTS, TILE_PARAMS, named, pixel_layout,
                           pixels, tile_widths)
from .worklist import Worklist, tile_layout

STATES = ("IDLE", "LOAD", "SCAN", "LEVEL", "SCHED0", "SCHED1", "READ", "ITER", "STORE",
          "GOAL0", "GOAL1", "PATH", "READOUT")

__all__ = ["TileEngine", "command_layout", "map_layout", "goal_layout", "result_layout", "visit_layout",
           "model_timing", "MAX_CELLS", "DRAM_WIDTH"]

MAX_PIXELS = 1 << 20    # on-chip state of a 1024 x 1024 map is ~50 Mbit: more than any FPGA's block RAM today
STORES = ("bram", "external", "dram")
PREFETCH_MAX = 3        # visits read ahead at most (each more: a WritePatch bank, a worklist read port)


def command_layout(w):
    """One job: the map size, d_far, the goal count, the start, what to stream out."""
    return data.StructLayout({
        "height": w["height"], "width": w["width"], "dfar": w["di"], "goals": 16,
        "start_row": w["row"], "start_col": w["col"], "path": 1, "readout": 1,
    })


def map_layout(p):
    """One map word: bit j = column w p + j of the row is an obstacle."""
    return data.StructLayout({"obst": p})


def goal_layout(w):
    return data.StructLayout({"row": w["row"], "col": w["col"]})


def result_layout(w):
    """A path pixel (``map`` = 0) or a pixel of the map read-out (``map`` = 1), with its state."""
    return data.StructLayout({
        "map": 1, "row": w["row"], "col": w["col"],
        "done": 1, "di": w["di"], "dx": signed(w["dx"]), "dy": signed(w["dy"]),
        "cfr": 1, "visited": 1, "hop": w["hop"], "parent": 4, "last": 1,
    })


def visit_layout(w):
    """The visit monitor: one cycle of ``valid`` at the end of each tile visit."""
    return data.StructLayout({"valid": 1, "bfs": 1, "r": range(w["tile_rows"]), "c": range(w["tile_cols"]),
                              "iterations": w["iters"], "marks": 4})


def model_timing(iter_cycles=1):
    """The cycle constants of :mod:`models.edt_bfs_tiled` that the engine with ``iter_cycles`` runs."""
    return Timing(iteration=iter_cycles)


def _above(value, limit):
    """value > limit, or 0 when the field cannot exceed it (no constant comparison in the Verilog)."""
    return value > limit if limit < (1 << len(value)) - 1 else Const(0)


class TileEngine(wiring.Component):
    """Parallel_Path_Plan (paper 004) on a ``t_r`` x ``t_c`` array over a map of up to ``max_h`` x ``max_w``.

    The golden model is :mod:`models.edt_bfs_tiled` (its docstring is the
    design and the proof): the map's per-pixel state lives in block RAM
    (:class:`~hdl.edt_bfs.state_ram.StateRam`); a worklist
    (:class:`~hdl.edt_bfs.worklist.Worklist`) picks a tile, the array
    (:class:`~hdl.edt_bfs.tile_array.TileArray`, cells
    :class:`~hdl.edt_bfs.tile_cell.TileCell`) loads it with a one-pixel halo,
    iterates, writes it back and marks the tiles to visit next.  EDT:
    level-synchronous, one iteration k per visit, exact (invariant E); BFS:
    per-pixel hop counts relaxed to convergence per visit, FIFO worklist
    (invariant B).  Results equal the untiled model's (and so the untiled
    core's) on every pixel.

    A job: a command, the map (``H * ceil(W / T_c)`` words, row-major), then
    (after the EDT) the goals, then the results: the path, then on request
    every pixel.

    Parameters
    ----------
    t_r, t_c : int
        The physical array (T_r x T_c cells, 2..32 a side, at most 256; a RAM
        word holds ``T_c`` pixels).
    max_h, max_w : int
        The largest map (the RAM: ``max_h * ceil(ceil(max_w / T_c) / 3)``
        words of ``T_c`` pixels in each of 3 banks; more than one tile each
        way, up to 4096 a side and 2^20 pixels, 2^22 with an external
        store).  The widths follow it
        (:func:`~hdl.edt_bfs.tile_layouts.tile_widths`).
    store : "bram", "external" or "dram"
        Where the per-pixel state lives: the engine's own block RAM
        (:class:`~hdl.edt_bfs.state_ram.StateRam`), or a store outside the
        engine behind the ``state`` port (an SDRAM controller, say), for
        maps whose state exceeds the part's block RAM (maze512-1-0: 13.9
        Mbit against the LFE5U-85F's 3.7), or a DRAM controller's native
        ports behind :class:`~hdl.edt_bfs.dram_stores.DramStores` (the
        ``dram`` ports, 128-bit words: LiteDRAM's for a 16-bit DDR3).
    dram_ports : 1, 2 or 4
        With ``store="dram"``: how many of the controller's native ports the
        engine uses (:class:`~hdl.edt_bfs.dram_stores.DramStores`: a
        :class:`~hdl.edt_bfs.dram_store.DramStore` on each and
        :class:`~hdl.edt_bfs.row_router.RowRouter` spreading the map rows
        over them (:func:`~hdl.edt_bfs.dram_store.port_of_row`: a
        word's port is its bank's low bits), so the stores issue and collect
        a window's rows at once (one store issues one native command a
        cycle, and LiteDRAM locks a port to one bank while the bank has
        commands queued).
    prefetch : 0 .. 3
        With a store outside (``external``, ``dram``): the visits whose
        window rows are read ahead.  Once a visit's own rows are read, it
        reads the windows of the worklist's next ``prefetch`` tiles (the
        worklist is a FIFO: a push never changes them), nearest first,
        while it loads, iterates and writes back; their answers wait in the
        store (``rd_data`` not taken) until their own visit's ``READ``,
        which reads only the rows not read yet: the store's latency is paid
        while the engine works.  A read given that early may reach the
        store before the writes of the visits between: a row loads through
        :class:`~hdl.edt_bfs.write_patch.WritePatch`, which lays the last
        ``prefetch`` visits' written tile rows over it, so every load sees
        the state the model's visit sees (same results and visit trace;
        the cycle counts are not the model's: fewer with StateRam's timing,
        the latency it hides, and a cycle less a visit: the worklist shows
        the next tile before its pop, so ``SCHED1`` pops and sets the window
        up at once).  0: the engine's Verilog is as without it.
    skip_clean : bool
        With a store outside: a tile row the visit did not change (no cell
        of it marked by an iteration that gave one of the phase's fields a
        new value: :class:`~hdl.edt_bfs.tile_cell.TileCell`'s ``dirty``) is
        not written back; its beat passes without a command (the same
        cycles, less of the store's bandwidth: on maze512-1-0 a third of
        the BFS visits' rows; with the prefetch it takes no beat either:
        ``STORE`` lasts max(dirty rows, marks) cycles); every write carries
        the pixels it changes and their cfr bits (``state``'s ``wr.changed``, ``wr.cfr``:
        :func:`~hdl.edt_bfs.state_ram.write_layout`), so a DRAM store
        issues only the native words holding a changed pixel and answers a
        BFS read without the words of di
        (:class:`~hdl.edt_bfs.dram_store.DramStore`).
    bfs_slots : bool
        With ``store="dram"`` and ``skip_clean``: the DRAM stores keep the
        edge pixels' BFS fields and cfr in the B words' spare bytes
        (:class:`~hdl.edt_bfs.dram_store.DramStore`'s ``bfs_slots``): a BFS
        read is ``b`` native words a window row instead of ``b + e`` (2
        instead of 3 at 3x8 over 512x512).  0: the engine's Verilog is as
        without it.

    Ports
    -----
    c_stream : In(stream of command_layout)
        ``height``, ``width`` (H, W: 1..max_h, 1..max_w; otherwise the
        command is refused: ``cmd_err``, nothing else happens), ``dfar``
        (d_far), ``goals`` (how many goal beats follow the EDT), ``start_row``
        / ``start_col`` (p_s) and ``path`` (stream the path), ``readout``
        (stream every pixel).  Taken in the idle state only.
    m_stream : In(stream of map_layout)
        The map, one word per beat, row-major: row r's words 0 ..
        ceil(W / T_c) - 1; bit j of word w = column w T_c + j is an obstacle
        (bits past W are ignored).
    g_stream : In(stream of goal_layout)
        ``goals`` goal pixels (p_g), taken after the EDT.  A goal outside
        the cfr is dropped (the paper's rule), outside the map too
        (``goal_err``).
    o_stream : Out(stream of result_layout)
        With ``path`` and the start reached: the path from p_s to a goal, one
        pixel per beat (``map`` = 0, Step 5).  Then with ``readout`` every
        pixel row-major (``map`` = 1): ``done`` (0 only without obstacles),
        ``di``, the vector ``dx`` / ``dy`` (p - nearest obstacle), ``cfr``,
        ``visited``, ``hop`` (BFS steps to the nearest goal), ``parent``.
        ``last`` marks the job's final beat.  A job may end without a beat
        (no path, no read-out): watch ``busy``.
    busy : Out(1)
        A job runs: from the cycle after the command's to its last cycle.
    cmd_err, start_err, goal_err : Out(1)
        The last command's size was out of range (job refused); its start
        lies outside the map (no path); a goal lay outside the map (dropped).
    path_found : Out(1)
        The start was reached (valid after the path phase).
    levels : Out
        EDT levels of the last job (the untiled ``iterations_edt`` = levels + 1).
    tile_visits : Out(32)
        Tile visits of the last job (EDT and BFS).
    visit : Out(visit_layout)
        A monitor: ``valid`` for one cycle as each visit ends, with its
        phase, tile, iterations and the tiles it enqueued (the model's
        ``trace``).
    state : In(StateSignature) (``store="external"`` only)
        The state store's port, the engine's side:
        ``rd`` (out: read a word column of a map row), ``rd_data`` (in:
        the answers, in order), ``wr`` (out: write a word's EDT or BFS
        fields); the contract in
        :class:`~hdl.edt_bfs.state_ram.StateSignature`.  The cycle counts
        below hold for a store with StateRam's timing (always ready,
        answers two cycles after the command); a slower store adds cycles
        and changes no result.
    dram : Out(NativePortSignature).array(dram_ports) (``store="dram"`` only)
        A DRAM controller's native user ports (``cmd``, ``wdata``,
        ``rdata``: :func:`~hdl.edt_bfs.dram_store.NativePortSignature`,
        128-bit words, ``addr_width`` from
        :func:`~hdl.edt_bfs.dram_store.dram_layout`), in the controller's
        clock domain: ``dram_clk``, ``dram_rst`` (its reset, the store's
        too; the engine's ``rst`` does not reach the store's side), where
        the store runs; :class:`~hdl.edt_bfs.state_cdc.StateCdc` crosses
        from ``clk``.  Cycle counts: those of the controller's
        timing and the crossing (more than the figures below); results the
        same.

    Timing (:mod:`models.edt_bfs_tiled`'s cycle model, ``Timing()``: sched
    2, latency 2, level 1, goal 3, stop 1; source always valid, sink always ready;
    cycles from the command's handshake, exclusive, to the last busy cycle;
    the RAM's read latency 2 is its read register and its output register,
    which keeps the block RAM's slow data output off the clock's paths)::

        load    = H * ceil(W / T_c)          one map word per beat (the frontier flags on the fly)
        scan    = tiles                      W_1: one tile per cycle
        EDT     = sum over levels (1 + sum over the level's visits: visit)
        goals   = 3 * goals                  read the goal's word (1 + latency); write hop 0, push its tile
        BFS     = sum over visits: visit
        path    = 1 + 2 * len(path)          (3 without a path; 0 without a start): a pixel's
                                             read needs the previous pixel's parent
        readout = 2 + H * W                  (0 without; the reads run ahead of the beats)
        visit   = 2 (pop; address, queued bits) + 2 (RAM latency) + window rows in the map
                  + iterations (EDT 1; BFS: until one changes nothing, + 1 to see that from the
                  registered OR of the cells' changes) + max(tile rows in the map, tiles enqueued)

    A synchronous reset at any point returns to idle; the next job rewrites
    every RAM word it reads (the load), the flag RAM and the queued bits
    (the scan).
    """

    PARAMS = TILE_PARAMS + (
        Param("store", str, "bram", choices=STORES,
              doc="the state store: the engine's block RAM, an external one on the state port, or a DRAM's "
                  "native port",
              message="state store {value!r}: must be {allowed}"),
        DRAM_PORTS_PARAM,
        Param("prefetch", int, 0, lo=0, hi=PREFETCH_MAX,
              doc="visits whose windows are read ahead, while this visit loads, iterates and writes (a "
                  "store outside: hides its latency; the cycle counts are then no longer the model's)",
              message="prefetch {value!r}: must be an integer in {lo}..{hi} (visits read ahead)"),
        SKIP_CLEAN_PARAM,
        BFS_SLOTS_PARAM,
        Param("iter_cycles", int, 1, lo=1, hi=2,
              doc="cycles an array iteration takes: 2 registers the cells' MIN winner between its comparators "
                  "and its multiplexers (a shorter clock path, a cycle more an iteration)",
              message="iter_cycles {value!r}: must be 1 or 2 (cycles an array iteration takes)"),
    )
    CONSTRAINTS = TILE_CONSTRAINTS[:2] + (
        Constraint(f"max_h * max_w <= {MAX_PIXELS} (bram)",
                   lambda p: p["store"] != "bram" or p["max_h"] * p["max_w"] <= MAX_PIXELS,
                   "largest map {max_h}x{max_w} has {n} pixels: the on-chip state store holds at most "
                   + str(MAX_PIXELS) + " (about 50 Mbit); store=external takes more",
                   pixels),
    ) + TILE_CONSTRAINTS[2:] + (
        Constraint("dram_ports == 1 or store == 'dram'", lambda p: p["dram_ports"] == 1 or p["store"] == "dram",
                   "dram_ports {dram_ports} with store={store}: only a DRAM store (store=dram) has native ports"),
        Constraint("not skip_clean or store != 'bram'", lambda p: not p["skip_clean"] or p["store"] != "bram",
                   "skip_clean with store=bram: the block RAM's writes cost no bandwidth; skip_clean is for a "
                   "store outside (external, dram)"),
        Constraint("not prefetch or store != 'bram'", lambda p: not p["prefetch"] or p["store"] != "bram",
                   "prefetch with store=bram: the block-RAM engine runs the model's cycle counts (its 2-cycle "
                   "latency leaves little to hide); prefetch is for a store outside (external, dram)"),
    ) + DRAM_CONSTRAINTS

    @checked_init
    def __init__(self, t_r, t_c, max_h, max_w, store="bram", dram_ports=1, prefetch=0, skip_clean=False,
                 iter_cycles=1, bfs_slots=False):
        check(self.PARAMS, self.CONSTRAINTS, t_r=t_r, t_c=t_c, max_h=max_h, max_w=max_w, store=store,
              dram_ports=dram_ports, prefetch=prefetch, skip_clean=skip_clean, iter_cycles=iter_cycles,
              bfs_slots=bfs_slots)
        self.bfs_slots = bool(bfs_slots)
        self.t_r, self.t_c, self.max_h, self.max_w, self.store = t_r, t_c, max_h, max_w, store
        self.dram_ports, self.prefetch, self.skip_clean = dram_ports, prefetch, bool(skip_clean)
        self.iter_cycles = iter_cycles
        self.cycle_timing = model_timing(iter_cycles)
        w = self.w = tile_widths(t_r, t_c, max_h, max_w)
        super().__init__({
            "c_stream": In(stream.Signature(command_layout(w))),
            "m_stream": In(stream.Signature(map_layout(t_c))),
            "g_stream": In(stream.Signature(goal_layout(w))),
            "o_stream": Out(stream.Signature(result_layout(w))),
            "busy": Out(1), "cmd_err": Out(1), "start_err": Out(1), "goal_err": Out(1),
            "path_found": Out(1), "levels": Out(w["k"]), "tile_visits": Out(32),
            "visit": Out(visit_layout(w)),
            **({"state": In(StateSignature(w, t_c, self.skip_clean))} if store == "external" else {}),
            **({"dram": Out(NativePortSignature(dram_layout(w, t_c, max_h, DRAM_WIDTH, self.bfs_slots)["addr_width"],
                                                DRAM_WIDTH)).array(dram_ports),
                "dram_clk": In(1), "dram_rst": In(1)} if store == "dram" else {}),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest (models.edt_bfs_tiled's cycle model)."""
        t = self.cycle_timing
        iterations = f"{t.iteration} * iterations" if t.iteration > 1 else "iterations"
        return {"load_cycles": "H * ceil(W / T_c)", "scan_cycles": "tiles",
                "edt_cycles": f"sum over levels ({t.level} + visits)", "goal_cycles": t.goal,
                "visit_cycles": f"{t.sched} + {t.latency} + window rows + {iterations} (+ {t.stop} in the BFS) "
                                "+ max(tile rows, marks)",
                "path_cycles": f"1 + {t.latency} * len(path)", "readout_cycles": f"{t.latency} + H * W",
                "note": "source always valid, sink always ready; back-pressure adds cycles"
                        + ("; the external store with StateRam's timing (always ready, answers 2 cycles after "
                           "the command); a slower store adds cycles" if self.store == "external" else "")
                        + ("; the DRAM's timing adds cycles (results the same)" if self.store == "dram" else "")}

    def elaborate(self, platform):
        m = Module()
        t_r, t_c, w = self.t_r, self.t_c, self.w
        nonedi = (1 << w["di"]) - 1
        nonehop = (1 << w["hop"]) - 1
        if self.store == "bram":
            m.submodules.ram = mem = StateRam(w, t_c, self.max_h)     # the store's ports (StateSignature)
        elif self.store == "dram":
            # The store on the controller's clock (dram_clk: it issues several native commands
            # per engine cycle), reset with the controller; the engine's side of StateSignature
            # crosses to it from a domain on the engine's clock that the engine's reset does not
            # clear (StateCdc drops the answers to reads made before a reset).
            m.domains.port = ClockDomain("port", reset_less=True)
            m.domains.dram = ClockDomain("dram")
            m.d.comb += [ClockSignal("port").eq(ClockSignal("sync")),
                         ClockSignal("dram").eq(self.dram_clk), ResetSignal("dram").eq(self.dram_rst)]
            m.submodules.cdc = mem = StateCdc(w, t_c, "port", "sync", "dram", depth=DRAM_FIFO,
                                              changed=self.skip_clean)
            m.submodules.stores = stores = DomainRenamer("dram")(
                DramStores(t_r, t_c, self.max_h, self.max_w, self.dram_ports, self.skip_clean, self.bfs_slots))
            for name in ("rd", "rd_data", "wr"):
                wiring.connect(m, getattr(mem.store, name), getattr(stores, name))
            for ours, theirs in zip(self.dram, stores.dram):
                wiring.connect(m, theirs, wiring.flipped(ours))
        else:
            mem = self.state
        m.submodules.work = work = Worklist(w, peek=self.prefetch)
        m.submodules.front = front = FrontierFlags(w, t_c)
        m.submodules.array = arr = TileArray(t_r, t_c, w, dirty=self.skip_clean, select_reg=self.iter_cycles == 2)

        state = Signal(range(len(STATES)))
        at = {name: named(m, f"at_{name.lower()}", state == n) for n, name in enumerate(STATES)}

        def goto(name):
            m.d.sync += state.eq(STATES.index(name))

        # -- job registers
        H = Signal(w["height"])
        W = Signal(w["width"])
        ncw = Signal(range(w["words"] + 1))       # word columns = tile columns of the map
        nr = Signal(range(w["tile_rows"] + 1))
        last_px = Signal(range(t_c))              # (W - 1) mod T_c: the last word's last pixel
        dfar = Signal(w["di"])
        goals_left = Signal(16)
        start = Signal(goal_layout(w))
        want_path = Signal()
        want_readout = Signal()
        bfs = Signal()                            # phase: 0 EDT, 1 BFS
        k = Signal(w["k"])
        kk = Signal(w["kk"])                      # K(k) = k^2 + k: the cells' EDT threshold (TileCell)
        rem = Signal(range(work.depth + 1))       # tiles of W_k still queued

        # -- the array's broadcast inputs
        m.d.comb += [arr.phase.eq(bfs), arr.k.eq(k), arr.kk.eq(kk), arr.dfar.eq(dfar)]

        # -- after a phase: the next one (and its first registers)
        cur = Signal(goal_layout(w))              # path: the pixel read / shown
        cur_w = Signal(range(w["words"]))         # its word column and pixel in the word (kept beside
        cur_j = Signal(range(t_c))                # cur.col, stepped with it: no division on the path)
        start_w = Signal(range(w["words"]))
        start_j = Signal(range(t_c))
        p_need = Signal()                         # path: a read is owed
        p_first = Signal()
        ro_row = Signal(w["row"])
        ro_w = Signal(range(w["words"]))
        ro_j = Signal(range(t_c))
        rr_row = Signal(w["row"])                 # read-out: the next word to read (ahead of ro_*)
        rr_w = Signal(range(w["words"]))
        rr_more = Signal()

        def after_bfs():
            with m.If(want_path & ~self.start_err):
                m.d.sync += [cur.eq(start), cur_w.eq(start_w), cur_j.eq(start_j), p_need.eq(1), p_first.eq(1)]
                goto("PATH")
            with m.Else():
                after_path()

        def after_path():
            with m.If(want_readout):
                m.d.sync += [ro_row.eq(0), ro_w.eq(0), ro_j.eq(0), rr_row.eq(0), rr_w.eq(0), rr_more.eq(1)]
                goto("READOUT")
            with m.Else():
                goto("IDLE")

        def after_edt():
            m.d.sync += bfs.eq(1)
            with m.If(goals_left != 0):
                goto("GOAL0")
            with m.Else():
                after_bfs()

        # -- IDLE: a command
        cmd = self.c_stream.payload
        ncw_new, _ = divmod_const(cmd.width + (t_c - 1), t_c)
        nr_new, _ = divmod_const(cmd.height + (t_r - 1), t_r)
        _, lp_new = divmod_const((cmd.width - 1)[:len(cmd.width)], t_c)   # width 0 is refused
        sw_new, sj_new = divmod_const(cmd.start_col, t_c)
        bad = Signal()
        m.d.comb += bad.eq((cmd.height == 0) | (cmd.width == 0)
                           | _above(cmd.height, self.max_h) | _above(cmd.width, self.max_w))
        lr = Signal(w["row"])
        lw = Signal(range(w["words"]))
        ltr = Signal(range(w["tile_rows"]))
        lj = Signal(range(t_r))
        with m.If(at["IDLE"] & self.c_stream.valid):
            m.d.sync += self.cmd_err.eq(bad)
            with m.If(~bad):
                m.d.sync += [
                    H.eq(cmd.height), W.eq(cmd.width), ncw.eq(ncw_new), nr.eq(nr_new), last_px.eq(lp_new),
                    dfar.eq(cmd.dfar), goals_left.eq(cmd.goals), start.row.eq(cmd.start_row),
                    start.col.eq(cmd.start_col), start_w.eq(sw_new), start_j.eq(sj_new),
                    want_path.eq(cmd.path), want_readout.eq(cmd.readout),
                    self.start_err.eq(cmd.path & ((cmd.start_row >= cmd.height) | (cmd.start_col >= cmd.width))),
                    self.goal_err.eq(0), self.path_found.eq(0), self.levels.eq(0), self.tile_visits.eq(0),
                    bfs.eq(0), k.eq(0), kk.eq(0), lr.eq(0), lw.eq(0), ltr.eq(0), lj.eq(0),
                ]
                goto("LOAD")
        m.d.comb += [self.c_stream.ready.eq(at["IDLE"]), self.busy.eq(~at["IDLE"]),
                     work.init.eq(at["IDLE"]), front.init.eq(at["IDLE"])]

        # -- LOAD: one map word per beat: the RAM's initial state, the frontier flags
        sr = Signal(range(w["tile_rows"]))        # the scan's tile
        sc = Signal(range(w["tile_cols"]))
        load_fire = named(m, "load_fire", at["LOAD"] & self.m_stream.valid & mem.wr.ready)
        row_end = named(m, "row_end", lw == ncw - 1)
        load_last = named(m, "load_last", row_end & (lr == H - 1))
        init_word = Signal(data.ArrayLayout(pixel_layout(w), t_c))
        for j in range(t_c):
            m.d.comb += [init_word[j].di.eq(Mux(self.m_stream.payload.obst[j], 0, nonedi)),
                         init_word[j].hop.eq(nonehop)]
        m.d.comb += [self.m_stream.ready.eq(at["LOAD"] & mem.wr.ready),
                     front.beat.eq(load_fire), front.obst.eq(self.m_stream.payload.obst),
                     front.row.eq(lr), front.wcol.eq(lw), front.tile_row.eq(ltr), front.tile_top.eq(lj == 0),
                     front.row_end.eq(row_end), front.last.eq(load_last), front.width.eq(W)]
        with m.If(load_fire):
            with m.If(row_end):
                m.d.sync += [lw.eq(0), lr.eq(lr + 1)]
                with m.If(lj == t_r - 1):
                    m.d.sync += [lj.eq(0), ltr.eq(ltr + 1)]
                with m.Else():
                    m.d.sync += lj.eq(lj + 1)
            with m.Else():
                m.d.sync += lw.eq(lw + 1)
            with m.If(load_last):
                m.d.sync += [sr.eq(0), sc.eq(0)]
                goto("SCAN")

        # -- SCAN: W_1 in raster order, and every tile's queued bit
        flag = named(m, "flag", front.flags.bit_select(sc, 1))
        scan_end_row = named(m, "scan_end_row", sc == ncw - 1)
        scan_last = named(m, "scan_last", (sr == nr - 1) & scan_end_row)
        m.d.comb += [front.scan_en.eq((load_fire & load_last) | (at["SCAN"] & scan_end_row & ~scan_last)),
                     front.scan_row.eq(Mux(at["SCAN"], sr + 1, 0))]
        push = Signal()
        push_tile = Signal(tile_layout(w))
        m.d.comb += [work.push.eq(push), work.push_tile.eq(push_tile)]
        queued_after = named(m, "queued_after", (work.count != 0) | push)   # the FIFO after this cycle (no adder)
        with m.If(at["SCAN"]):
            m.d.comb += [push.eq(flag), push_tile.r.eq(sr), push_tile.c.eq(sc),
                         work.clear.eq(~flag), work.clear_tile.r.eq(sr), work.clear_tile.c.eq(sc)]
            with m.If(scan_end_row):
                m.d.sync += [sc.eq(0), sr.eq(sr + 1)]
            with m.Else():
                m.d.sync += sc.eq(sc + 1)
            with m.If(scan_last):
                with m.If(queued_after):
                    goto("LEVEL")
                with m.Else():
                    after_edt()

        # A visit starts in SCHED0 (pop), then SCHED1 (the window's set-up from the popped tile);
        # with the prefetch the worklist shows the next tile before its pop (peek[0]), so a visit
        # starts in SCHED1, which pops and sets up in one cycle (a cycle less a visit).
        D = self.prefetch
        first_sched = "SCHED1" if D else "SCHED0"

        # -- LEVEL: W_{k+1} becomes W_k
        with m.If(at["LEVEL"]):
            m.d.sync += [k.eq(k + 1), kk.eq(kk + (k << 1) + 2), self.levels.eq(self.levels + 1),
                         rem.eq(work.count)]
            goto(first_sched)

        # -- a visit: SCHED0 pops, SCHED1 sets the window up (with the prefetch SCHED1 does both),
        # READ loads it, ITER, STORE
        vt = Signal(tile_layout(w))
        r0 = Signal(w["row"] + 1)
        win_first = Signal(w["row"])
        rows_left = Signal(range(t_r + 3))        # window rows still to read
        recv_left = Signal(range(t_r + 3))        # and to receive
        ld_row = Signal(range(t_r + 2))
        own = Signal(range(t_r + 1))              # tile rows inside the map
        col_present = Signal(t_c + 2)
        iters = Signal(w["iters"])
        stepped = Signal()                        # BFS: ITER has stepped the array in this visit
        sj = Signal(range(t_r + 1))               # store: rows written (with zero_clean: the row it writes)
        # With the prefetch (the cycles no longer the model's) and skip_clean, a clean row takes no
        # beat either: STORE writes the dirty rows inside the map, lowest first, while it pushes
        # the marks (max(dirty rows, marks) cycles, at least one).
        zero_clean = bool(D) and self.skip_clean
        wrote = Signal(t_r) if zero_clean else None  # the tile rows this visit's STORE wrote
        pushed = Signal(9)
        answer = Cat(mem.rd_data.payload.left, mem.rd_data.payload.word, mem.rd_data.payload.right)
        if D:                                     # (without it, the engine's Verilog is as before it)
            pf = [Signal(range(t_r + 3), name=f"pf{d + 1}") for d in range(D)]   # rows of visit +d's window read
            lvl = Signal(range(D + 1))            # the read offered: 0 none, d: the next row of visit +d
            hold = Signal(range(D + 1))           # one offered and not taken (its level): offered until taken
            pf_taken = named(m, "pf_taken", (lvl != 0) & mem.rd.ready)
            ld_map = Signal(w["row"])             # the map row of the next answer to load
            m.submodules.patch = patch = WritePatch(w, t_r, t_c, D)
            m.d.comb += patch.raw.eq(answer)
            answer = patch.loaded

        def pop():
            m.d.comb += work.pop.eq(1)
            with m.If(~bfs):
                m.d.sync += rem.eq(rem - 1)

        if not D:
            with m.If(at["SCHED0"]):
                pop()
                goto("SCHED1")

        def window(tile, pre):
            """A tile's first map row and column, its window's first map row (the halo row above,
            if any) and the window's rows inside the map."""
            r0 = named(m, f"{pre}_r0", times(tile.r, t_r), w["row"] + 1)
            c0 = named(m, f"{pre}_c0", times(tile.c, t_c), w["col"] + 1)
            first = named(m, f"{pre}_first", Mux(tile.r == 0, 0, r0 - 1), w["row"])
            last = named(m, f"{pre}_last", Mux(r0 + t_r >= H, H - 1, r0 + t_r), w["row"])
            return r0, c0, first, named(m, f"{pre}_rows", last - first + 1, range(t_r + 3))

        if D:                                     # the next visits' tiles (the first: this one)
            geo = [window(work.peek[d], f"n{d + 1}") for d in range(D)]
            head = work.peek[0]
            h_r0, h_c0, h_first, h_rows = geo[0]
        else:
            head = work.head
            h_r0, h_c0, h_first, h_rows = window(head, "h")
        m.d.comb += [work.look_at.eq(Mux(at["SCHED1"], head, 0))]
        with m.If(at["SCHED1"]):
            if D:
                pop()
            m.d.comb += [work.look.eq(1), arr.clear.eq(1)]
            m.d.sync += [
                vt.eq(head), r0.eq(h_r0), win_first.eq(h_first),
                rows_left.eq(h_rows - pf[0] - (pf_taken & (lvl == 1)) if D else h_rows), recv_left.eq(h_rows),
                ld_row.eq(Mux(head.r == 0, 1, 0)),
                own.eq(Mux(h_r0 + t_r > H, H - h_r0, t_r)),
                col_present.eq(Cat(head.c != 0, *[h_c0 + (b - 1) < W for b in range(1, t_c + 2)])),
                iters.eq(0), stepped.eq(0), (wrote if zero_clean else sj).eq(0), pushed.eq(0),
            ]
            goto("READ")

        # READ: one window row per beat (the RAM answers one cycle later); the rows the
        # prefetch read during the last visit are not read again
        rd_row = Signal(w["row"])
        if D:
            own_rd = named(m, "own_rd", rows_left != 0)
            with m.If(at["SCHED1"]):
                m.d.sync += [rd_row.eq(h_first + pf[0] + (pf_taken & (lvl == 1))), ld_map.eq(h_first)]
            with m.If(at["READ"] & mem.rd_data.valid):
                m.d.sync += ld_map.eq(ld_map + 1)
        else:
            own_rd = mem.rd.valid
            with m.If(at["SCHED1"]):
                m.d.sync += rd_row.eq(h_first)
        with m.If(at["READ"]):
            with m.If(own_rd & mem.rd.ready):
                m.d.sync += [rd_row.eq(rd_row + 1), rows_left.eq(rows_left - 1)]
            with m.If(mem.rd_data.valid):
                m.d.comb += arr.ld_en.eq(1)
                m.d.sync += [ld_row.eq(ld_row + 1), recv_left.eq(recv_left - 1)]
                with m.If(recv_left == 1):
                    goto("ITER")
        m.d.comb += [arr.ld_row.eq(ld_row), arr.ld_present.eq(col_present), arr.ld_px.eq(answer)]

        # Prefetch (D = prefetch): once this visit's own rows are read, the windows of the next
        # D visits (the worklist's next tiles: a FIFO, so no later push changes them) are read,
        # the nearest first, while this visit loads, iterates and writes back; their answers
        # wait in the store (rd_data not taken) until their visit's READ, which reads only the
        # rest.  Such a read may reach the store before the writes of the D visits before its
        # own: WritePatch lays those writes over the row as it loads (every earlier write was
        # given before the read, and the store keeps reads behind earlier writes).
        if D:
            free = named(m, "pf_free", (at["READ"] & ~own_rd) | at["ITER"] | at["STORE"])
            # A read offered stays offered until taken (a stream's valid does not drop), through
            # SCHED1 / LEVEL if need be (the peeked tiles are still the ones before the pop
            # there); at SCHED1 every level moves one down (visit +d becomes +d-1), and one of
            # visit +1 still waiting becomes the visit's own first read (the same command).
            with m.If(hold != 0):
                m.d.comb += lvl.eq(hold)
            with m.Elif(free):
                for d in range(D):                # the nearest visit first (its answers come first)
                    with (m.Elif if d else m.If)((work.count > d) & (pf[d] < geo[d][3])):
                        m.d.comb += lvl.eq(d + 1)
            m.d.sync += hold.eq(Mux((lvl != 0) & ~mem.rd.ready, Mux(at["SCHED1"], lvl - 1, lvl), 0))
            with m.If(at["SCHED1"]):
                m.d.sync += [pf[d].eq(pf[d + 1] + (pf_taken & (lvl == d + 2)) if d + 1 < D else 0)
                             for d in range(D)]
            with m.Else():
                for d in range(D):
                    with m.If(pf_taken & (lvl == d + 1)):
                        m.d.sync += pf[d].eq(pf[d] + 1)
            m.d.comb += [patch.init.eq(at["IDLE"]), patch.ld_row.eq(ld_map), patch.ld_c.eq(vt.c),
                         patch.bfs.eq(bfs)]

        # ITER: EDT one iteration; BFS until one changes nothing (counted), then one cycle (no step)
        # that sees it in arr.upd (Timing.stop: the cells' change bits are flip-flops, so the
        # FSM reads their OR a cycle after the step, and no cell's logic reaches the FSM)
        # With iter_cycles 2 each step follows a select cycle (the cells register their MIN's winner):
        # the first ITER cycle, then the cycle that reads arr.upd after each step.
        leave = bfs & stepped & ~arr.upd
        if self.iter_cycles == 2:
            armed = Signal()                      # this cycle steps (the last one was the select cycle)
            leave = leave & ~armed
        with m.If(at["ITER"]):
            with m.If(leave):
                goto("STORE")
            if self.iter_cycles == 2:
                with m.Elif(~armed):
                    m.d.sync += armed.eq(1)
            with m.Else():
                m.d.comb += arr.step.eq(1)
                m.d.sync += [iters.eq(iters + 1), stepped.eq(1)]
                if self.iter_cycles == 2:
                    m.d.sync += armed.eq(0)
                with m.If(~bfs):
                    goto("STORE")

        # STORE: tile rows back to RAM, one per beat; the marks, one enqueued tile per beat
        near = Signal(9)
        m.d.comb += near.eq(work.near & ~1)       # the tile itself was just popped
        pend = Signal(9)
        m.d.comb += pend.eq(arr.marks & ~near & ~pushed)
        low = Signal(9)
        m.d.comb += low.eq(pend & (~pend + 1))
        mark_tile = Signal(tile_layout(w))
        m.d.comb += mark_tile.eq(vt)
        for i, (dr, dc) in OFFSETS.items():
            with m.If(low[i]):
                m.d.comb += [mark_tile.r.eq(vt.r + dr), mark_tile.c.eq(vt.c + dc)]
        if zero_clean:
            todo = named(m, "store_todo", arr.dirty_rows & Cat(*[own > a for a in range(t_r)]) & ~wrote, t_r)
            hot = named(m, "store_hot", todo & (~todo + 1), t_r)
            for a in reversed(range(t_r)):
                with m.If(todo[a]):
                    m.d.comb += sj.eq(a)
            px_changed = named(m, "px_changed", arr.dirty, t_c)
            wr_go = store_wr = named(m, "store_wr", at["STORE"] & (todo != 0))
            wr_fire = named(m, "wr_fire", store_wr & mem.wr.ready)
            rows_done = (todo & ~Mux(wr_fire, hot, 0)) == 0
            with m.If(wr_fire):
                m.d.sync += wrote.eq(wrote | hot)
        else:
            store_wr = named(m, "store_wr", at["STORE"] & (sj < own))
            if self.skip_clean:
                # A tile row the visit left as it loaded it (its phase's fields: the group the write
                # writes) is not written: its beat passes without a command (the same cycles).  The
                # cells mark what they change (TileCell's dirty), so no copy of the rows as loaded.
                px_changed = named(m, "px_changed", arr.dirty, t_c)
                row_dirty = named(m, "row_dirty", px_changed.any())
                wr_go = named(m, "wr_go", store_wr & row_dirty)
                wr_fire = named(m, "wr_fire", store_wr & (mem.wr.ready | ~row_dirty))
            else:
                wr_go = store_wr
                wr_fire = named(m, "wr_fire", store_wr & mem.wr.ready)
            rows_done = (sj + wr_fire) >= own
        visit_end = named(m, "visit_end", at["STORE"] & rows_done & ((pend & ~low) == 0))
        all_marks = named(m, "all_marks", pushed | low)
        with m.If(at["STORE"]):
            m.d.comb += [push.eq(pend != 0), push_tile.eq(mark_tile)]
            m.d.sync += pushed.eq(pushed | low)
            if not zero_clean:
                with m.If(wr_fire):
                    m.d.sync += sj.eq(sj + 1)
            with m.If(visit_end):
                m.d.sync += [self.visit.valid.eq(1), self.visit.bfs.eq(bfs), self.visit.r.eq(vt.r),
                             self.visit.c.eq(vt.c), self.visit.iterations.eq(iters),
                             self.visit.marks.eq(sum(all_marks[i] for i in range(9))),
                             self.tile_visits.eq(self.tile_visits + 1)]
                with m.If(bfs):
                    with m.If(queued_after):
                        goto(first_sched)
                    with m.Else():
                        after_bfs()
                with m.Elif(rem != 0):
                    goto(first_sched)
                with m.Elif(queued_after):
                    goto("LEVEL")
                with m.Else():
                    after_edt()
        with m.If(~visit_end):
            m.d.sync += self.visit.valid.eq(0)
        if D:                                     # what this visit writes, for the next visits' loads
            m.d.comb += [patch.wr.eq(wr_fire), patch.wr_row.eq(sj), patch.wr_word.eq(arr.wb), patch.r0.eq(r0),
                         patch.own.eq(own), patch.c.eq(vt.c), patch.start.eq(at["ITER"]), patch.done.eq(visit_end)]
        m.d.comb += arr.wb_row.eq(sj)

        # -- GOAL0 / GOAL1: read the goal's word; write hop 0 and push its tile if it is in the cfr
        g = Signal(goal_layout(w))
        g_in = Signal()
        g_j = Signal(range(t_c))
        g_tile = Signal(tile_layout(w))
        gp = self.g_stream.payload
        g_wcol = named(m, "g_wcol", divmod_const(gp.col, t_c)[0], range(w["words"]))
        g_jn = named(m, "g_j_next", divmod_const(gp.col, t_c)[1], range(t_c))
        g_tr = named(m, "g_tile_row", divmod_const(gp.row, t_r)[0], range(w["tile_rows"]))
        goal_fire = named(m, "goal_fire", at["GOAL0"] & self.g_stream.valid & mem.rd.ready)
        m.d.comb += self.g_stream.ready.eq(at["GOAL0"] & mem.rd.ready)
        with m.If(at["GOAL0"]):
            m.d.comb += [work.look.eq(self.g_stream.valid), work.look_at.r.eq(g_tr), work.look_at.c.eq(g_wcol)]
        with m.If(goal_fire):
            inside = (gp.row < H) & (gp.col < W)
            m.d.sync += [g.eq(gp), g_in.eq(inside), g_j.eq(g_jn), g_tile.r.eq(g_tr), g_tile.c.eq(g_wcol)]
            with m.If(~inside):
                m.d.sync += self.goal_err.eq(1)
            goto("GOAL1")
        gword = mem.rd_data.payload.word
        gpx = named(m, "goal_px", gword[g_j], pixel_layout(w))
        g_cfr = named(m, "goal_cfr", g_in & ((gpx.di == nonedi) | (gpx.di > dfar)))
        goal_word = Signal(data.ArrayLayout(pixel_layout(w), t_c))
        for j in range(t_c):
            mine = g_j == j
            m.d.comb += [goal_word[j].eq(gword[j]),
                         goal_word[j].hop.eq(Mux(mine, 0, gword[j].hop)),
                         goal_word[j].parent.eq(Mux(mine, 0, gword[j].parent))]
        goal_done = named(m, "goal_done", at["GOAL1"] & mem.rd_data.valid & mem.wr.ready)
        with m.If(goal_done):
            m.d.comb += [push.eq(g_cfr & ~work.near[0]), push_tile.eq(g_tile)]
            m.d.sync += goals_left.eq(goals_left - 1)
            with m.If(goals_left == 1):
                with m.If(queued_after):
                    goto(first_sched)
                with m.Else():
                    after_bfs()
            with m.Else():
                goto("GOAL0")

        # -- PATH: from the start along the parents, one pixel per beat (Step 5)
        path_px = named(m, "path_px", mem.rd_data.payload.word[cur_j], pixel_layout(w))
        no_path = named(m, "no_path", p_first & (path_px.hop == nonehop))
        beat_path = named(m, "beat_path", at["PATH"] & mem.rd_data.valid & ~no_path)
        advance = named(m, "advance", beat_path & self.o_stream.ready & (path_px.parent != 0))
        nxt = Signal(goal_layout(w))
        nxt_w = Signal.like(cur_w)
        nxt_j = Signal.like(cur_j)
        m.d.comb += [nxt.eq(cur), nxt_w.eq(cur_w), nxt_j.eq(cur_j)]
        wrap = {1: (cur_j == t_c - 1, 1, 0), -1: (cur_j == 0, -1, t_c - 1)}   # crossing into the next word
        for i, (dr, dc) in OFFSETS.items():
            with m.If(path_px.parent == i):
                m.d.comb += [nxt.row.eq(cur.row + dr), nxt.col.eq(cur.col + dc)]
                if dc:
                    edge, dw, j_in = wrap[dc]
                    m.d.comb += [nxt_w.eq(Mux(edge, cur_w + dw, cur_w)), nxt_j.eq(Mux(edge, j_in, cur_j + dc))]
        if D:   # with a store outside (its latency a pixel's), the next pixel in the word read: no read
            stay = named(m, "path_stay", advance & (nxt.row == cur.row) & (nxt_w == cur_w))
            read_next, take = advance & ~stay, self.o_stream.ready & ~stay       # (the answer kept)
        else:
            read_next, take = advance, self.o_stream.ready
        with m.If(at["PATH"]):
            with m.If(mem.rd.valid):
                m.d.sync += p_need.eq(~mem.rd.ready)
            with m.If(mem.rd_data.valid):
                with m.If(no_path):
                    after_path()
                with m.Elif(self.o_stream.ready):
                    m.d.sync += [self.path_found.eq(1), p_first.eq(0)]
                    with m.If(path_px.parent == 0):
                        after_path()
                    with m.Else():
                        m.d.sync += [cur.eq(nxt), cur_w.eq(nxt_w), cur_j.eq(nxt_j)]

        # -- READOUT: every pixel, row-major, one per beat; the reads (rr_*) run ahead of the
        # beats (ro_*) as far as the RAM's pipeline takes them, so a word costs no latency
        ro_px = named(m, "ro_px", mem.rd_data.payload.word[ro_j], pixel_layout(w))
        ro_last_w = named(m, "ro_last_w", ro_w == ncw - 1)
        word_end = named(m, "word_end", Mux(ro_last_w, ro_j == last_px, ro_j == t_c - 1))
        ro_final = named(m, "ro_final", word_end & ro_last_w & (ro_row == H - 1))
        beat_ro = named(m, "beat_ro", at["READOUT"] & mem.rd_data.valid)
        rr_last_w = named(m, "rr_last_w", rr_w == ncw - 1)
        with m.If(at["READOUT"]):
            with m.If(mem.rd.valid & mem.rd.ready):
                with m.If(rr_last_w):
                    m.d.sync += [rr_w.eq(0), rr_row.eq(rr_row + 1)]
                    with m.If(rr_row == H - 1):
                        m.d.sync += rr_more.eq(0)
                with m.Else():
                    m.d.sync += rr_w.eq(rr_w + 1)
            with m.If(beat_ro & self.o_stream.ready):
                with m.If(ro_final):
                    goto("IDLE")
                with m.Elif(word_end):
                    m.d.sync += ro_j.eq(0)
                    with m.If(ro_last_w):
                        m.d.sync += [ro_w.eq(0), ro_row.eq(ro_row + 1)]
                    with m.Else():
                        m.d.sync += ro_w.eq(ro_w + 1)
                with m.Else():
                    m.d.sync += ro_j.eq(ro_j + 1)

        # -- the RAM's ports
        rd, wr = mem.rd.payload, mem.wr.payload
        with m.If((at["READ"] | (lvl != 0)) if D else at["READ"]):
            if D:                           # this visit's rows first, then the next visits'
                m.d.comb += [mem.rd.valid.eq(own_rd | (lvl != 0)), rd.di.eq(1), rd.nnt.eq(~bfs), rd.bfs.eq(bfs),
                             mem.rd_data.ready.eq(at["READ"])]
                with m.If(own_rd):
                    m.d.comb += [rd.row.eq(rd_row), rd.wcol.eq(vt.c)]
                for d in range(D):
                    with m.Elif(lvl == d + 1):
                        m.d.comb += [rd.row.eq(geo[d][2] + pf[d]), rd.wcol.eq(work.peek[d].c)]
            else:
                m.d.comb += [mem.rd.valid.eq(rows_left != 0), rd.row.eq(rd_row), rd.wcol.eq(vt.c),
                             rd.di.eq(1), rd.nnt.eq(~bfs), rd.bfs.eq(bfs), mem.rd_data.ready.eq(1)]
        with m.Elif(at["GOAL0"]):
            m.d.comb += [mem.rd.valid.eq(self.g_stream.valid), rd.row.eq(gp.row), rd.wcol.eq(g_wcol),
                         rd.di.eq(1), rd.bfs.eq(1)]
        with m.Elif(at["GOAL1"]):
            m.d.comb += mem.rd_data.ready.eq(mem.wr.ready)
        with m.Elif(at["PATH"]):
            pos = named(m, "path_pos", Mux(advance, nxt.as_value(), cur.as_value()), goal_layout(w))
            m.d.comb += [mem.rd.valid.eq(p_need | read_next), rd.row.eq(pos.row),
                         rd.wcol.eq(Mux(advance, nxt_w, cur_w)), rd.di.eq(1), rd.nnt.eq(1), rd.bfs.eq(1),
                         mem.rd_data.ready.eq(no_path | take)]
        with m.Elif(at["READOUT"]):
            m.d.comb += [mem.rd.valid.eq(rr_more), rd.row.eq(rr_row), rd.wcol.eq(rr_w),
                         rd.di.eq(1), rd.nnt.eq(1), rd.bfs.eq(1),
                         mem.rd_data.ready.eq(self.o_stream.ready & word_end)]
        wword = wr.word                         # the write's word
        if self.skip_clean:                     # each written pixel's cfr, by its di (meant for EDT writes),
            wword = Signal(data.ArrayLayout(pixel_layout(w), t_c))      # from a signal of its own (no
            m.d.comb += [wr.word.eq(wword),                             # loop through the payload)
                         wr.cfr.eq(Cat(*[(wword[j].di == nonedi) | (wword[j].di > dfar) for j in range(t_c)]))]
        with m.If(at["LOAD"]):
            m.d.comb += [mem.wr.valid.eq(self.m_stream.valid), wr.row.eq(lr), wr.wcol.eq(lw),
                         wr.edt.eq(1), wr.bfs.eq(1), wword.eq(init_word)]
            if self.skip_clean:                 # the load writes every pixel
                m.d.comb += wr.changed.eq((1 << t_c) - 1)
        with m.Elif(at["STORE"]):
            if self.skip_clean:
                m.d.comb += wr.changed.eq(px_changed)
            m.d.comb += [mem.wr.valid.eq(wr_go), wr.row.eq(r0 + sj), wr.wcol.eq(vt.c),
                         wr.edt.eq(~bfs), wr.bfs.eq(bfs), wword.eq(arr.wb)]
        with m.Elif(at["GOAL1"]):
            m.d.comb += [mem.wr.valid.eq(mem.rd_data.valid & g_cfr), wr.row.eq(g.row), wr.wcol.eq(g_tile.c),
                         wr.bfs.eq(1), wword.eq(goal_word)]
            if self.skip_clean:                 # the goal's pixel only (the others as read)
                m.d.comb += wr.changed.eq(Const(1, t_c) << g_j)

        # -- the result stream
        o = self.o_stream.payload
        px = Signal(pixel_layout(w))
        m.d.comb += px.eq(Mux(at["PATH"], path_px.as_value(), ro_px.as_value()))
        m.d.comb += [
            self.o_stream.valid.eq(beat_path | beat_ro),
            o.map.eq(at["READOUT"]),
            o.row.eq(Mux(at["PATH"], cur.row, ro_row)),
            o.col.eq(Mux(at["PATH"], cur.col, times(ro_w, t_c) + ro_j)),
            o.done.eq(px.di != nonedi), o.di.eq(px.di), o.dx.eq(px.dx), o.dy.eq(px.dy),
            o.cfr.eq((px.di == nonedi) | (px.di > dfar)), o.visited.eq(px.hop != nonehop),
            o.hop.eq(px.hop), o.parent.eq(px.parent),
            o.last.eq(Mux(at["PATH"], (path_px.parent == 0) & ~want_readout, ro_final)),
        ]
        return m
