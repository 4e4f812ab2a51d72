"""FuseSoC generator navcores_harmonic (see navcores_gen.py)."""
from navcores_gen import main

main("harmonic")
