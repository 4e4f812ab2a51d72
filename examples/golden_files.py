"""What both examples' ``make_golden.py`` share: write the generated files
beside the script, or with ``--check`` only compare them with the stored ones
(tb/ip/test_ip_fusesoc.py runs the check: the stored values are the model's)."""

import sys


def write_or_check(here, files, check):
    """Write ``files`` ({name: text}) into ``here``; with ``check`` compare
    instead and name the stale ones.  True when nothing was stale."""
    if check:
        stale = [n for n, text in files.items() if (here / n).read_text() != text]
        if stale:
            print(f"stale: {', '.join(stale)} (rerun without --check)")
        return not stale
    for name, text in files.items():
        (here / name).write_text(text)
    return True


def run(main):
    """The scripts' command line: ``[--check]``; exit 1 when stale."""
    sys.exit(0 if main(check="--check" in sys.argv[1:]) else 1)
