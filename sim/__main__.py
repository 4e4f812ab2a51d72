"""``python -m sim <command> ...``: the project's one command line.

Every command is a module ``sim/<command>.py`` with a docstring (its first
line is the help), ``add_arguments(parser)`` and ``run(args) -> int``.  Errors
reach the user as one line and a non-zero exit code, never as a traceback
(``SIM_DEBUG=1`` shows the traceback of an unexpected error).
"""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
