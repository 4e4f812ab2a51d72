"""The RTL engines: what ``python -m sim ... --engine icarus|verilator``, the tests and the benchmarks run.

* :mod:`.runner`: (top, parameters, simulator) -> an emitted, built and run
  cocotb test module, each build in its own directory.
* :mod:`.stream`: the one valid/ready stream driver (source with idle
  cycles, sink with back-pressure, monitor, reset, cycle count, payloads
  packed by the cores' ``data.Layout``).
* The cocotb drivers, one per core, built on it: :mod:`.dflc_driver`,
  :mod:`.planner_driver`, :mod:`.edt_bfs_driver` (and :mod:`.clock`: the
  clock period and the reset pulse of the jobs).
* The cocotb jobs, run inside the simulator on a JSON job file:
  :mod:`.dflc_job`, :mod:`.planner_job`, :mod:`.edt_bfs_job`,
  :mod:`.track_job` (the tracker's closed loop on the DFLC RTL), and
  :mod:`.simspeed` (the simulation-speed probe of the benchmarks).

Imports only navcores.hdl and navcores.models (tb/test_layers.py checks it).
"""
