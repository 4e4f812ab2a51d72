"""Parameter specifications of the emitted tops: one declaration per parameter.

A top component declares its parameters once, as a class attribute beside its
``__init__``::

    PARAMS = (Param("p_max", int, lo=2, doc="largest precision"),)
    CONSTRAINTS = (Constraint("p_max + 2 <= depth", lambda p: ..., "message {p_max}"),)

and its ``__init__`` checks its arguments with :func:`check` (same messages as
before: the component's own one-line errors).  ``python -m hdl.emit --list``
and the manifests read the very same declarations, so the ranges a user sees
are the ranges the component enforces, never a second copy.

Amaranth warns about an elaboratable that is "created but never used".  A
component whose ``__init__`` refuses its parameters was never a design:
:func:`checked_init` on that ``__init__`` silences the half-built object
(and the parts it had built).  A component built only to be described (its
signature, parameters, ``timing()``), as ``hdl.emit``'s manifests do, is
marked with :func:`unelaborated`.
"""

import functools
from dataclasses import dataclass, field

from amaranth.hdl import Elaboratable

__all__ = ["Param", "Constraint", "REQUIRED", "check", "describe", "parse", "checked_init", "unelaborated"]


class _Required:
    def __repr__(self):
        return "REQUIRED"


REQUIRED = _Required()


@dataclass(frozen=True)
class Param:
    """One parameter: ``type`` is int, str or bool; ``lo`` / ``hi`` bound an int
    (inclusive, None = unbounded); ``choices`` lists the allowed values;
    ``message`` is the component's error text, formatted with ``name``,
    ``value``, ``lo``, ``hi``, ``choices`` (default: a generic one)."""

    name: str
    type: type = int
    default: object = REQUIRED
    lo: int | None = None
    hi: int | None = None
    choices: tuple | None = None
    doc: str = ""
    message: str | None = None
    none_ok: bool = False           # None is a valid value (e.g. "derived from the others")

    def allowed(self):
        """The allowed values, in words (for --list and messages)."""
        if self.choices is not None:
            return "one of " + ", ".join(str(c) for c in self.choices)
        if self.type is bool:
            return "0 or 1"
        if self.type is int:
            if self.lo is not None and self.hi is not None:
                return f"{self.lo}..{self.hi}"
            if self.lo is not None:
                return f">= {self.lo}"
            if self.hi is not None:
                return f"<= {self.hi}"
            return "any integer"
        return "any string"

    def error(self, value):
        text = self.message or "{name} = {value!r}: must be {allowed}"
        return ValueError(text.format(name=self.name, value=value, lo=self.lo, hi=self.hi,
                                      choices=self.choices, allowed=self.allowed()))

    def check(self, value):
        """``value`` if allowed, else the component's ValueError."""
        if value is None and (self.none_ok or self.default is None):
            return value
        if self.type is bool:
            if value not in (0, 1, True, False) or isinstance(value, float):
                raise self.error(value)
            return value
        if self.type is int and (not isinstance(value, int) or isinstance(value, bool)):
            raise self.error(value)
        if self.type is str and not isinstance(value, str):
            raise self.error(value)
        if self.choices is not None and value not in self.choices:
            raise self.error(value)
        if self.lo is not None and value < self.lo or self.hi is not None and value > self.hi:
            raise self.error(value)
        return value

    def parse(self, text):
        """A command-line value (``name=text``) -> a checked value of the right type."""
        if self.none_ok and text.lower() == "none":
            return None
        if self.type in (int, bool):
            try:
                value = int(text, 0)
            except ValueError:
                raise ValueError(f"{self.name}={text}: expected an integer ({self.allowed()})") from None
        else:
            value = text
        return self.check(value)

    def describe(self):
        d = {"name": self.name, "type": self.type.__name__, "allowed": self.allowed(), "doc": self.doc}
        d["default"] = None if self.default is REQUIRED else self.default
        d["required"] = self.default is REQUIRED
        if self.lo is not None:
            d["min"] = self.lo
        if self.hi is not None:
            d["max"] = self.hi
        if self.choices is not None:
            d["choices"] = list(self.choices)
        return d


@dataclass(frozen=True)
class Constraint:
    """A rule across parameters: ``test(values) -> bool``; ``message`` is
    formatted with the values (and whatever ``extra(values)`` adds); ``why``:
    the reason of a bound, for --list."""

    text: str
    test: object = field(compare=False)
    message: str = ""
    extra: object = field(default=None, compare=False)
    why: str = ""

    def check(self, values):
        if not self.test(values):
            more = self.extra(values) if self.extra else {}
            raise ValueError((self.message or f"parameters violate {self.text}").format(**values, **more))


def check(params, constraints=(), **values):
    """Check ``values`` against the declarations (each parameter, then the
    constraints, in declaration order, with the defaults of the parameters
    not given; when a required one is missing, no constraint); returns them.  Raises the component's
    ValueError (TypeError for an unknown name)."""
    names = {p.name for p in params}
    unknown = sorted(set(values) - names)
    if unknown:
        raise TypeError(f"unknown parameter{'s' * (len(unknown) > 1)} {', '.join(unknown)}; "
                        f"expected {', '.join(p.name for p in params)}")
    for p in params:
        if p.name in values:
            p.check(values[p.name])
    # the constraints see the defaults of the parameters not given (a caller
    # that checks a subset still gets every constraint those values break)
    full = {p.name: values.get(p.name, p.default) for p in params}
    if all(v is not REQUIRED for v in full.values()):
        for c in constraints:
            c.check(full)
    return values


def describe(params, constraints=()):
    return {"parameters": [p.describe() for p in params],
            "constraints": [c.text for c in constraints]}


def parse(params, assignments):
    """``["name=value", ...]`` -> {name: value} (each value parsed and checked)."""
    by_name = {p.name: p for p in params}
    out = {}
    for a in assignments:
        name, eq, text = a.partition("=")
        if not eq or not name:
            raise ValueError(f"{a!r}: parameters are name=value")
        if name not in by_name:
            known = ", ".join(by_name) or "none"
            raise ValueError(f"unknown parameter {name!r}; this top takes: {known}")
        if name in out:
            raise ValueError(f"parameter {name} given twice")
        out[name] = by_name[name].parse(text)
    return out


def unelaborated(component):
    """Mark ``component``, and every elaboratable it holds in its attributes
    (lists, tuples and dicts of them too), as built on purpose without being
    elaborated: no "created but never used" warning.  Returns ``component``."""
    seen = set()

    def mark(obj):
        if id(obj) in seen:
            return
        seen.add(id(obj))
        if isinstance(obj, (list, tuple)):
            parts = obj
        elif isinstance(obj, dict):
            parts = obj.values()
        elif isinstance(obj, Elaboratable):
            obj._MustUse__silence = True        # the switch of Amaranth's warning (amaranth._unused)
            parts = vars(obj).values()
        else:
            return
        for part in parts:
            mark(part)

    mark(component)
    return component


def checked_init(init):
    """Decorator of a component's ``__init__`` that checks its parameters: when
    it refuses them (raises), the half-built component, which Amaranth
    created before ``__init__`` ran, is no design, so it leaves no "created
    but never used" warning behind (:func:`unelaborated`)."""
    @functools.wraps(init)
    def __init__(self, *args, **kwargs):
        try:
            init(self, *args, **kwargs)
        except Exception:
            unelaborated(self)
            raise
    return __init__
