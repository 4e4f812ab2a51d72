"""FuseSoC generator navcores_dflc (see navcores_gen.py)."""
from navcores_gen import main

main("dflc")
