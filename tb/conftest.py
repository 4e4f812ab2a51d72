"""The regression's settings for every test module."""

import os

# Verilator models at g++ -O0: a regression build compiles in about half the
# time of -Os and its runs are short (sim/rtl/runner.py: verilator_opt_args).
os.environ.setdefault("NAVCORES_VERILATOR_OPT", "-O0")
