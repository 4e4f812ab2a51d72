"""Drive a harmonic Cluster in simulation: host port, border words, iterations.

Used by the cluster regression (tb/harmonic/test_cluster.py).  The driver
emulates the border nodes around the 3x6 cluster: fixed words stored one bit
per address and read, with the cluster's two cycles of RAM latency
(models.harmonic.ram.READ_LATENCY), at the LSB-first addresses the cluster
presents (cntR).
"""

from dataclasses import dataclass, field

import numpy as np

from navcores.hdl.harmonic.cluster import COLS, ROWS
from navcores.models.harmonic import from_ram_image
from navcores.models.harmonic.ram import READ_LATENCY
from tb.harmonic.serial import SerialWord, next_cycle


def mask(flags):
    """Integer with bit i set where ``flags.flat[i]`` is true."""
    return sum(int(bool(b)) << i for i, b in enumerate(np.ravel(flags)))


def unmask(value, shape=(ROWS, COLS)):
    return np.array([(value >> i) & 1 for i in range(ROWS * COLS)], dtype=bool).reshape(shape)


@dataclass
class Command:
    """What the cluster does in one iteration (sampled at ``take``)."""
    run: bool = True
    enable: bool = True
    sel: np.ndarray = field(default_factory=lambda: np.zeros((ROWS, COLS), dtype=bool))
    sat: int = 0


@dataclass
class Done:
    """Flags of one finished iteration, as the cluster shows them at ``done``."""
    cycle: int               # cycles since the start request
    stable: np.ndarray
    local_max: np.ndarray
    all_stable: bool
    any_max: bool
    checked: bool


class ClusterDriver:
    def __init__(self, dut, p, ring):
        """``ring``: (5, 8) array whose outer ring holds the border values."""
        self.dut, self.p = dut, p
        self.border = {
            "N": [SerialWord(ring[0, c + 1], True, p) for c in range(COLS)],
            "S": [SerialWord(ring[ROWS + 1, c + 1], True, p) for c in range(COLS)],
            "W": [SerialWord(ring[r + 1, 0], True, p) for r in range(ROWS)],
            "E": [SerialWord(ring[r + 1, COLS + 1], True, p) for r in range(ROWS)],
        }
        for port in ("run", "enable", "Sel", "Sat", "host_we", "p", "clear", "base", "abort"):
            getattr(dut, port).value = 0

    async def host_write(self, words, base=0):
        for addr, word in enumerate(words, start=base):
            self.dut.host_addr.value = addr
            self.dut.host_wdata.value = word
            self.dut.host_we.value = 1
            await next_cycle(self.dut)
        self.dut.host_we.value = 0

    async def host_read(self, count):
        """Words 0 .. count-1, addresses one per cycle (the data comes
        READ_LATENCY cycles after its address)."""
        words = []
        for addr in range(count + READ_LATENCY - 1):
            if addr < count:
                self.dut.host_addr.value = addr
            await next_cycle(self.dut)
            if addr >= READ_LATENCY - 1:
                words.append(int(self.dut.host_rdata.value))
        return words

    def _drive_border(self, addr):
        for side, words in self.border.items():
            h = sum(w.bits[addr] << i for i, w in enumerate(words)) if addr is not None else 0
            getattr(self.dut, f"h_{side}_in").value = h

    async def iterate(self, decide, on_words=None, on_done=None, max_cycles=10**6, abort=None):
        """Start the cluster at precision p and iterate until it stops.

        ``decide(k)`` gives the :class:`Command` of iteration k (a command with
        ``run`` false stops the cluster); ``on_words(k, h, const)`` receives
        the 18 words the cluster read in iteration k, rebuilt from the ``h``
        bus; ``on_done(k, done)`` the flags of iteration k; ``abort(k,
        done)`` true: raise ``abort`` with that ``done`` (the cluster must be
        idle in the next cycle).  Returns the list of :class:`Done`.
        """
        dut, p = self.dut, self.p
        dut.p.value = p
        dut.run.value = 1
        image = [0] * (p + 2)
        commands, dones = [], []
        snapshots = 0
        addrs = [None] * READ_LATENCY           # the read addresses of the last cycles, oldest first
        t0 = None
        for cycle in range(max_cycles):
            addr = addrs[0]
            self._drive_border(addr)
            busy = bool(dut.busy.value)
            if t0 is None and busy:
                t0 = cycle - 1                    # the cycle run was seen idle
            if bool(dut.take.value):
                cmd = decide(len(commands))
                commands.append(cmd)
                dut.run.value = int(cmd.run)
                dut.enable.value = int(cmd.enable)
                dut.Sel.value = mask(cmd.sel)
                dut.Sat.value = int(cmd.sat)
            if bool(dut.done.value):
                done = Done(
                    cycle=cycle - t0,
                    stable=unmask(int(dut.stable.value)),
                    local_max=unmask(int(dut.local_max.value)),
                    all_stable=bool(dut.all_stable.value),
                    any_max=bool(dut.any_max.value),
                    checked=bool(dut.checked.value),
                )
                if on_done:
                    on_done(len(dones), done)
                dones.append(done)
                if abort is not None and abort(len(dones) - 1, done):
                    dut.abort.value = 1
                    dut.run.value = 0               # (run high while idle would start it again)
                    await next_cycle(dut)
                    dut.abort.value = 0
                    assert not bool(dut.busy.value), "busy after abort"
                    return dones
                if not commands[len(dones)].run:
                    return dones
            # The h bus carries the words at the address presented READ_LATENCY
            # cycles ago; offset 1 (value bit p) is the last one an iteration reads.
            if addr is not None:
                image[addr] = int(dut.h.value)
                if addr == 1:
                    if on_words:
                        on_words(snapshots, *from_ram_image(image, p, (ROWS, COLS)))
                    snapshots += 1
            addrs = addrs[1:] + [int(dut.cntR.value) if busy else None]
            await next_cycle(dut)
        raise AssertionError(f"p={p}: the cluster did not stop within {max_cycles} cycles")
