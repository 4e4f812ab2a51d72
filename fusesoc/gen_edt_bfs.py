"""FuseSoC generator navcores_edt_bfs (see navcores_gen.py)."""
from navcores_gen import main

main("edt_bfs")
