"""navcores: the project's one installed name (navcores.models, navcores.hdl, navcores.sim).

The layers keep their folders at the top of the source tree (models/, hdl/,
sim/); pyproject.toml maps them under this package (setuptools
``package-dir``), so a wheel holds navcores/{models,hdl,sim}/ beside this
file and an editable install finds each mapped folder through setuptools'
editable finder.  In a source tree that is not installed (a clone on
PYTHONPATH, the directory ``python -m sim`` runs from), this folder holds
only this file: the package's path is then the tree's root, so that
``navcores.hdl`` is ./hdl.  The modules import each other across layers as
``navcores.<layer>...`` and are loaded once, under that name.
"""

import os as _os

_here = _os.path.dirname(_os.path.abspath(__file__))
if not _os.path.isdir(_os.path.join(_here, "hdl")):       # a source tree: the layers are beside this folder
    __path__ = [_os.path.dirname(_here)]
