"""Progress and estimates of long runs, for every command.

* :class:`Progress`: one line on stderr, rewritten in place, only when
  stderr is a terminal (``SIM_PROGRESS=1`` forces it, ``0`` silences it),
  and only once the run has taken ``delay`` seconds: a piped run or a short
  one prints nothing extra.  The line is cleared when the run ends.
* :func:`announce`: a run estimated to take longer than :data:`LONG`
  seconds says so on stderr before it starts (piped or not): how long, and
  from what the estimate comes.
"""

import os
import sys
import time

__all__ = ["Progress", "announce", "duration", "LONG"]

LONG = 600.0          # seconds: a run estimated longer than this says so before it starts


def duration(seconds):
    """``seconds`` in words: "40 s", "12 min", "3.5 h", "2.1 days"."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 90 * 60:
        return f"{seconds / 60:.0f} min"
    if seconds < 48 * 3600:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"


def _enabled(stream):
    forced = os.environ.get("SIM_PROGRESS")
    if forced is not None:
        return forced == "1"
    return hasattr(stream, "isatty") and stream.isatty()


class Progress:
    """``with Progress("harmonic model", total=None) as bar: bar.update(done, "p = 32")``."""

    def __init__(self, what, total=None, unit="", delay=2.0, interval=0.5, stream=None):
        self.what, self.total, self.unit = what, total, unit
        self.delay, self.interval = delay, interval
        self.stream = stream or sys.stderr
        self.on = _enabled(self.stream)
        self.t0 = time.monotonic()
        self.last = 0.0
        self.shown = False

    def update(self, done=None, note=""):
        if not self.on:
            return
        now = time.monotonic()
        if now - self.t0 < self.delay or now - self.last < self.interval:
            return
        self.last = now
        elapsed = now - self.t0
        parts = [self.what]
        if done is not None and self.total:
            frac = min(1.0, done / self.total)
            left = f", about {duration(elapsed / frac - elapsed)} left" if frac > 0.02 else ""
            parts.append(f"{done}/{self.total} {self.unit} ({100 * frac:.0f} %{left})".replace("  ", " "))
        elif done is not None:
            parts.append(f"{done} {self.unit}".strip())
        if note:
            parts.append(note)
        parts.append(f"{duration(elapsed)} so far")
        text = ": ".join(parts[:2]) + (", " + ", ".join(parts[2:]) if len(parts) > 2 else "")
        self.stream.write("\r\033[K" + text[:200])
        self.stream.flush()
        self.shown = True

    def close(self):
        if self.shown:
            self.stream.write("\r\033[K")
            self.stream.flush()
            self.shown = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def announce(prog, seconds, what, basis):
    """Tell the user before a run estimated at ``seconds`` (> :data:`LONG`) starts."""
    if seconds > LONG:
        print(f"{prog}: note: {what} will take about {duration(seconds)} ({basis}); "
              "Ctrl-C stops it", file=sys.stderr, flush=True)


class Ticker(Progress):
    """A :class:`Progress` line that also moves on its own, once a second,
    while work it cannot watch runs (a simulator in a subprocess): the
    elapsed time, then whatever :meth:`status` last said, or ``poll()``
    returns (when given and not None: a status the work leaves in a file)."""

    def __init__(self, what, note="building / simulating", poll=None, **kw):
        import threading
        super().__init__(what, **kw)
        self.note, self.poll = note, poll
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        if self.on:
            self.thread.start()

    def _run(self):
        while not self.done.wait(1.0):
            if self.poll is not None:
                self.note = self.poll() or self.note
            self.update(note=self.note)

    def status(self, note):
        self.note = note
        self.update(note=note)

    def close(self):
        self.done.set()
        if self.thread.is_alive():
            self.thread.join()
        super().close()
