"""The parameter machinery: definitions, validation, change listeners and persistence.

One :class:`ParamDef` describes a tunable value once (name, type, default, unit, range,
description); :mod:`companion.param_table` gathers every subsystem's definitions into the
single table that becomes both the MAVLink parameter set and the documentation
(``usv params --markdown``).  :class:`ParamStore` holds the live values, refuses bad ones
with a reason, and persists atomically (write to a temporary file, fsync, rename).
"""

from __future__ import annotations

import contextlib
import math
import os
import tempfile
import time
import tomllib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

MAX_PARAM_NAME_LEN = 16
"""MAVLink's param_id is a 16-character field."""


class ParamError(ValueError):
    """A parameter name or value was refused; the message says why."""


@dataclass(frozen=True, slots=True)
class ParamDef:
    """One parameter: the single source for the MAVLink parameter and its documentation."""

    name: str
    default: float
    min: float
    max: float
    unit: str
    description: str
    is_int: bool = False
    choices: tuple[tuple[int, str], ...] = ()
    reboot_required: bool = False

    def __post_init__(self) -> None:
        if not self.name or len(self.name) > MAX_PARAM_NAME_LEN or not self.name.isascii():
            raise ValueError(f"parameter name {self.name!r} must be 1-16 ASCII characters")
        if self.name != self.name.upper():
            raise ValueError(f"parameter name {self.name!r} must be upper case")
        if not (self.min <= self.default <= self.max):
            raise ValueError(f"{self.name}: default {self.default} outside [{self.min}, {self.max}]")

    def range_text(self) -> str:
        if self.choices:
            return ", ".join(f"{v}={label}" for v, label in self.choices)
        return f"[{_fmt(self.min)}, {_fmt(self.max)}]" + (f" {self.unit}" if self.unit else "")

    def validate(self, value: object) -> float:
        """Return ``value`` coerced to this parameter's type, or raise :class:`ParamError`."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ParamError(f"{self.name}: expected a number, got {value!r}")
        number = float(value)
        if not math.isfinite(number):
            raise ParamError(f"{self.name}: {value!r} is not a finite number")
        if self.is_int:
            if number != round(number):
                raise ParamError(f"{self.name}: expected an integer, got {value!r}")
            number = float(round(number))
        if self.choices and int(number) not in {v for v, _ in self.choices}:
            raise ParamError(f"{self.name}: {_fmt(number)} is not one of {self.range_text()}")
        if not (self.min <= number <= self.max):
            raise ParamError(f"{self.name}: {_fmt(number)} is out of range {self.range_text()}")
        return number


def _fmt(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


Listener = Callable[[str, float], None]


class ParamStore:
    """Live parameter values for one vehicle, validated against their definitions."""

    def __init__(self, defs: Iterable[ParamDef], path: Path | None = None) -> None:
        self._defs: dict[str, ParamDef] = {}
        for d in defs:
            if d.name in self._defs:
                raise ValueError(f"parameter {d.name} is defined twice")
            self._defs[d.name] = d
        self._order = list(self._defs)
        self._values: dict[str, float] = {n: float(d.default) for n, d in self._defs.items()}
        self._listeners: list[Listener] = []
        self._set_listeners: list[Listener] = []
        self.path = path
        self.load_warnings: list[str] = []
        if path is not None:
            remove_stale_temp_files(path)
        if path is not None and path.exists():
            self.load_warnings = self._load(path)

    # -- lookup -------------------------------------------------------------------------
    def __contains__(self, name: object) -> bool:
        return name in self._defs

    def __len__(self) -> int:
        return len(self._order)

    def names(self) -> list[str]:
        """Names in table order; the index of a name is its MAVLink param_index."""
        return list(self._order)

    def definition(self, name: str) -> ParamDef:
        try:
            return self._defs[name]
        except KeyError:
            raise ParamError(f"unknown parameter {name!r}") from None

    def index_of(self, name: str) -> int:
        return self._order.index(self.definition(name).name)

    def name_at(self, index: int) -> str:
        if not 0 <= index < len(self._order):
            raise ParamError(f"parameter index {index} out of range [0, {len(self._order) - 1}]")
        return self._order[index]

    def get(self, name: str) -> float:
        self.definition(name)
        return self._values[name]

    def get_int(self, name: str) -> int:
        return int(self.get(name))

    def get_or(self, name: str, fallback: float) -> float:
        """The value of ``name``, or ``fallback`` if this table has no such parameter (a store
        built for one part in a unit test)."""
        return self._values[name] if name in self._defs else fallback

    # -- change -------------------------------------------------------------------------
    def set(self, name: str, value: object, *, persist: bool = True) -> float:
        """Validate and store a value; listeners run and the store is saved on change."""
        new = self.definition(name).validate(value)
        old = self._values[name]
        self._values[name] = new
        if new != old:
            for listener in tuple(self._listeners):
                listener(name, new)
            if persist and self.path is not None:
                self.save()
        for listener in tuple(self._set_listeners):
            listener(name, new)
        return new

    def add_listener(self, listener: Listener) -> None:
        """Call ``listener(name, value)`` whenever a value changes."""
        self._listeners.append(listener)

    def add_set_listener(self, listener: Listener) -> None:
        """Call ``listener(name, value)`` after every accepted set, changed or not (a reload of the
        launcher is written with the count it already had)."""
        self._set_listeners.append(listener)

    # -- persistence ----------------------------------------------------------------------
    def save(self, path: Path | None = None) -> None:
        """Write the values that differ from their defaults, atomically."""
        target = path or self.path
        if target is None:
            return
        lines = ["# usv-companion parameters (values that differ from defaults)"]
        for name in self._order:
            value = self._values[name]
            if value != self._defs[name].default:
                shown = str(int(value)) if self._defs[name].is_int else repr(float(value))
                lines.append(f"{name} = {shown}")
        atomic_write_text(target, "\n".join(lines) + "\n")

    def _load(self, path: Path) -> list[str]:
        """Load saved values; unknown or invalid entries are reported, never fatal."""
        warnings: list[str] = []
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, tomllib.TOMLDecodeError) as exc:
            return [f"{path}: cannot read saved parameters ({exc}); using defaults"]
        for name, value in data.items():
            try:
                self._values[name] = self.definition(name).validate(value)
            except ParamError as exc:
                warnings.append(f"{path}: {exc}; ignored")
        return warnings

    def markdown(self) -> str:
        """The parameter table as Markdown: the documentation generated from the one source."""
        rows = ["| Name | Default | Range | Unit | Description |", "|---|---|---|---|---|"]
        for name in self._order:
            d = self._defs[name]
            rng = d.range_text() if d.choices else f"{_fmt(d.min)} .. {_fmt(d.max)}"
            rows.append(f"| `{name}` | {_fmt(d.default)} | {rng} | {d.unit} | {d.description} |")
        return "\n".join(rows) + "\n"


STALE_TEMP_S = 60.0
"""A temporary file of :func:`atomic_write_text` older than this was left by a killed process."""


def remove_stale_temp_files(path: Path, older_than_s: float = STALE_TEMP_S) -> int:
    """Delete the temporary files a process killed inside :func:`atomic_write_text` left next to
    ``path`` (only those older than ``older_than_s``, never one being written); returns how many."""
    removed = 0
    now = time.time()
    with contextlib.suppress(OSError):
        for tmp in path.parent.glob(f".{path.name}.*"):
            with contextlib.suppress(OSError):
                if now - tmp.stat().st_mtime > older_than_s:
                    tmp.unlink()
                    removed += 1
    return removed


def atomic_write_text(path: Path, text: str) -> None:
    """Replace ``path`` with ``text`` so that a crash leaves either the old or the new file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)
