"""cocotb job: run the harmonic Cluster RTL on one 3x6 window of a map.

Reads the job (precision, initial words, boundary ring) from the JSON file
named by $HARMONIC_JOB, loads it through the host port, iterates until the
cluster itself reports all 18 nodes stable (its ``all_stable`` flag, as the
block controller's Early module will use it), runs one check iteration for
the local-maximum flags, stops, reads the RAM back and writes everything it
saw to $HARMONIC_RESULT.  It checks nothing itself: sim/demo.py compares the
result with the golden model.
"""

import json
import os
from pathlib import Path

import cocotb
import numpy as np

from models.harmonic import ram_image
from tb.harmonic.cluster_bench import ClusterBench, Command
from tb.harmonic.serial import start


def _ints(a):
    return [[int(v) for v in row] for row in a]


@cocotb.test()
async def cluster_window(dut):
    job = json.loads(Path(os.environ["HARMONIC_JOB"]).read_text())
    p, limit = job["p"], job["max_iterations"]
    h = np.array(job["h"], dtype=object)
    const = np.array(job["const"], dtype=bool)
    ring = np.array(job["ring"], dtype=object)
    await start(dut)
    bench = ClusterBench(dut, p, ring)
    await bench.host_write(ram_image(h, const, p))

    words, dones = [], []
    state = {"stop_at": None}

    def decide(k):
        # The flags of iteration k-2 are the latest known when iteration k's
        # command is taken; once they say "stable", check once and stop.
        if state["stop_at"] is None and (k >= limit or (len(dones) and dones[-1].all_stable)):
            state["stop_at"] = k + 1
        if state["stop_at"] is None:
            return Command()
        return Command(enable=False) if k < state["stop_at"] else Command(run=False, enable=False)

    def on_words(k, hk, ck):
        words.append({"h": _ints(hk), "const": [[bool(v) for v in row] for row in ck]})

    await bench.iterate(decide, on_words=on_words, on_done=lambda k, d: dones.append(d),
                        max_cycles=(limit + 4) * (p + 2) + 10)
    readback = await bench.host_read(p + 2)
    result = {
        "p": p,
        "words": words,
        "stable": [[[bool(v) for v in row] for row in d.stable] for d in dones],
        "checked": [d.checked for d in dones],
        "local_max": [[[bool(v) for v in row] for row in d.local_max] for d in dones],
        "done_cycles": [d.cycle for d in dones],
        "readback": readback,
    }
    Path(os.environ["HARMONIC_RESULT"]).write_text(json.dumps(result))
