"""Tests of the cores as IP outside Python: hdl.emit, manifests, FuseSoC, the examples."""
