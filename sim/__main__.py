"""``python -m navcores.sim <command> ...`` (``python -m sim`` in a source tree): the project's one command line.

Every command is a module ``sim/<command>.py`` with a docstring (its first
line is the help), ``add_arguments(parser)`` and ``run(args) -> int``.  Exit
status 0 done, 1 ran but no result, 2 bad input (one line on stderr, never a
traceback; ``SIM_DEBUG=1`` shows the traceback of an unexpected error, which
exits with 70).
"""

import sys

# Absolute: run as ``python -m sim`` this file is the top-level package sim's
# __main__, and the commands must still be loaded once, as navcores.sim.*.
from navcores.sim.cli import main

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
