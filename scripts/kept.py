"""Hand-written blocks of BENCHMARKS.md that the generated report carries.

`make bench` (scripts/bench.py), `bench.py --only ...` and
`bench_edt_tiled.py --md` rewrite BENCHMARKS.md section by section.  Some
measurements are not a bench run's: `make fit` runs with their history (the
timing-closure steps, a top placed before and after a change), whose commands
and commits the text names.  Such a block sits between :data:`OPEN` and
:data:`CLOSE`; a rewrite finds the blocks of the old report and puts each,
verbatim, at the end of the ``## `` section it was in (or at the report's end
when the new report has no such section), so a regenerated report loses no
measurement and never presents one of them as its own run's.
"""

import re

OPEN = "<!-- kept: not written by make bench (the commands and commits are in the text) -->"
CLOSE = "<!-- /kept -->"

_BLOCK = re.compile(rf"{re.escape(OPEN)}\n.*?{re.escape(CLOSE)}\n", re.S)
_TITLE = re.compile(r"^## (.+)$", re.M)
_END = re.compile(r"^Bench run time", re.M)


def blocks(text):
    """[(section title or None, block)] of ``text``, in order; a block
    includes its markers and its trailing newline."""
    out = []
    for m in _BLOCK.finditer(text):
        titles = _TITLE.findall(text[:m.start()])
        out.append((titles[-1] if titles else None, m.group(0)))
    return out


def carry(new, old):
    """``new`` with the kept blocks of ``old`` that it lacks, each at the end
    of its section (before the next ``## `` title or the run-time line)."""
    for title, block in blocks(old):
        if block in new:
            continue
        at = None
        if title is not None:
            m = re.search(rf"^## {re.escape(title)}\n", new, re.M)
            if m:
                nxt = [x.start() for x in (_TITLE.search(new, m.end()), _END.search(new, m.end())) if x]
                at = min(nxt) if nxt else len(new)
        if at is None:
            end = _END.search(new)
            at = end.start() if end else len(new)
        head = new[:at].rstrip("\n") + "\n\n"
        new = head + block + ("\n" + new[at:].lstrip("\n") if new[at:].strip() else "")
    return new


def replace_section(md, title, text):
    """Write markdown file ``md`` with its section ``## title`` (up to the next
    ``## ``) replaced by ``text``, or ``text`` added at its end if it has no
    such section; the kept blocks it held are carried (:func:`carry`)."""
    old = md.read_text()
    new = f"## {title}\n\n{text}\n"
    pattern = re.compile(rf"^## {re.escape(title)}\n.*?(?=^## |\Z)", re.S | re.M)
    md.write_text(carry(pattern.sub(lambda _: new + "\n", old) if pattern.search(old)
                        else old.rstrip("\n") + "\n\n" + new, old))
