"""DFLC fuzzy controller core (paper 003, Fig. 8): see hdl/dflc/README.md."""
