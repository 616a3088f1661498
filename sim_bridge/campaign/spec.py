"""Campaign files (TOML): a mission, the vehicle's settings and the distributions run samples come from.

A campaign file::

    [campaign]
    name = "sampling_in_current"
    seed = 2026                 # run i draws its sample from (seed, i): reproducible, extendable
    description = "..."

    [mission]
    script = "water_sampling"   # a missions/ script whose plan is flown: water_sampling or rescue
    options = { points = ["25,0", "40,25", "20,45", "0,25"], speed = 3.0 }   # the script's own options
    # or an open-loop manoeuvre (no companion):
    # maneuver = "turn"         # sine, zigzag, turn, random (see `usv sim maneuver`)
    # options = { throttle = 0.5, amplitude_rad = 0.5, duration_s = 60 }
    # batch = "auto"            # vectorised batch plant: "auto" (when it applies), true, false

    [params]                    # vehicle parameters (MAVLink names), the same in every run
    USV_CTRL_TYPE = 1

    [config]                    # companion settings (dotted keys of the config file), every run
    "vehicle.profile" = "ardurover"

    [distributions]             # per run; a number is a constant
    current_speed_mps = { uniform = [0.0, 1.2] }
    current_toward_deg = { uniform = [0.0, 360.0] }
    wind_speed_mps = { normal = [4.0, 1.5] }       # mean, standard deviation (clipped to the range)
    payload_kg = { choice = [0.0, 35.0, 70.0] }
    seed = { integers = [1, 1000000] }             # the simulator's seed (default: drawn like this)

Variables (:data:`VARIABLES`, with the range each value must lie in): current speed and direction
(toward, oceanographic), current variability (``VAR`` of ``--current``), wind speed and direction
(from, meteorological), significant wave height and peak period (0: the simulator's default
4 sqrt(Hs)), payload mass, the GPS-INS noise scale (every Table 2 noise level times this) and the
simulator's seed.  Each variable of run ``i`` comes from its own generator seeded with
``(campaign seed, i, variable number)``, so adding runs or changing one distribution leaves the
other draws as they were.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from companion.config import ConfigError, default_config
from companion.param_table import all_param_defs
from companion.params import ParamError, ParamStore
from sim_bridge.maneuvers import KINDS as MANEUVER_KINDS

SCRIPTS = ("water_sampling", "rescue")
"""Mission scripts (``missions/``) whose plans a campaign can fly."""

VARIABLES: dict[str, tuple[float, float]] = {
    "current_speed_mps": (0.0, 5.0),
    "current_toward_deg": (-360.0, 720.0),
    "current_var": (0.0, 1.0),
    "wind_speed_mps": (0.0, 40.0),
    "wind_from_deg": (-360.0, 720.0),
    "wave_hs_m": (0.0, 3.0),
    "wave_tp_s": (0.0, 30.0),
    "payload_kg": (0.0, 70.0),
    "sensor_noise_scale": (0.0, 100.0),
    "seed": (0.0, 2.0**31 - 1.0),
}
"""Every variable a campaign can distribute, with the range its values must lie in."""

DEFAULT_SEED_RANGE = (1, 1_000_000)
DISTRIBUTION_KINDS = ("uniform", "normal", "choice", "integers")
BATCH_CHOICES = ("auto", True, False)


@dataclass(frozen=True, slots=True)
class Distribution:
    """One variable's distribution: ``constant`` (args: the value), ``uniform`` (low, high),
    ``normal`` (mean, std; clipped to the variable's range), ``choice`` (values), ``integers``
    (low, high inclusive)."""

    kind: str
    args: tuple[float, ...]
    low: float
    high: float

    @property
    def constant(self) -> float | None:
        return self.args[0] if self.kind == "constant" else None

    def draw(self, rng: np.random.Generator) -> float:
        a = self.args
        if self.kind == "constant":
            return a[0]
        if self.kind == "uniform":
            return float(rng.uniform(a[0], a[1]))
        if self.kind == "normal":
            return float(min(self.high, max(self.low, rng.normal(a[0], a[1]))))
        if self.kind == "choice":
            return float(a[int(rng.integers(0, len(a)))])
        return float(rng.integers(int(a[0]), int(a[1]) + 1))


def parse_distribution(name: str, value: Any) -> Distribution:
    """A TOML value (number or one-key table) as a :class:`Distribution`; ConfigError naming ``name``."""
    if name not in VARIABLES:
        raise ConfigError(f"[distributions] {name}: unknown variable; accepted: {', '.join(VARIABLES)}")
    low, high = VARIABLES[name]
    accepted = ("a number or one of {uniform = [LOW, HIGH]}, {normal = [MEAN, STD]}, {choice = [V, ...]}, "
                "{integers = [LOW, HIGH]}")

    def number(x: Any) -> float:
        if isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(float(x)):
            raise ConfigError(f"[distributions] {name}: {x!r} is not a number; accepted: {accepted}")
        return float(x)

    def inside(x: float) -> float:
        if not low <= x <= high:
            raise ConfigError(f"[distributions] {name}: {x:g} outside [{low:g}, {high:g}]")
        return x

    if not isinstance(value, Mapping):
        return Distribution("constant", (inside(number(value)),), low, high)
    if len(value) != 1 or next(iter(value)) not in DISTRIBUTION_KINDS:
        raise ConfigError(f"[distributions] {name}: invalid value {dict(value)!r}; accepted: {accepted}")
    kind, raw = next(iter(value.items()))
    if not isinstance(raw, list) or not raw:
        raise ConfigError(f"[distributions] {name}: {kind} needs a list of numbers")
    args = tuple(number(x) for x in raw)
    if kind in ("uniform", "integers", "normal") and len(args) != 2:
        raise ConfigError(f"[distributions] {name}: {kind} needs two numbers, got {len(args)}")
    if kind in ("uniform", "integers"):
        if args[0] > args[1]:
            raise ConfigError(f"[distributions] {name}: {kind} low {args[0]:g} above high {args[1]:g}")
        args = (inside(args[0]), inside(args[1]))
    elif kind == "normal":
        inside(args[0])
        if args[1] < 0.0:
            raise ConfigError(f"[distributions] {name}: normal standard deviation {args[1]:g} < 0")
    else:
        args = tuple(inside(x) for x in args)
    return Distribution(kind, args, low, high)


@dataclass(frozen=True, slots=True)
class Sample:
    """The conditions of one run."""

    index: int
    seed: int
    current_speed_mps: float = 0.0
    current_toward_deg: float = 0.0
    current_var: float = 0.0
    wind_speed_mps: float = 0.0
    wind_from_deg: float = 0.0
    wave_hs_m: float = 0.0
    wave_tp_s: float = 0.0
    payload_kg: float = 0.0
    sensor_noise_scale: float = 1.0

    @property
    def wind(self) -> str:
        """``--wind`` text."""
        return f"{self.wind_speed_mps!r},{self.wind_from_deg!r}"

    @property
    def current(self) -> str:
        """``--current`` text."""
        return f"{self.current_speed_mps!r},{self.current_toward_deg!r},{self.current_var!r}"

    @property
    def waves(self) -> str:
        """``--waves`` text (peak period omitted when 0: the simulator's default)."""
        if self.wave_hs_m <= 0.0:
            return "0"
        return f"{self.wave_hs_m!r},{self.wave_tp_s!r}" if self.wave_tp_s > 0.0 else f"{self.wave_hs_m!r}"

    def as_row(self) -> dict[str, float | int]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


SAMPLE_COLUMNS = tuple(f.name for f in fields(Sample))


@dataclass(frozen=True)
class CampaignSpec:
    """A parsed, validated campaign file."""

    name: str
    seed: int
    description: str
    script: str | None
    """Mission script flown in SITL (``None``: an open-loop manoeuvre)."""
    maneuver: str | None
    options: dict[str, Any]
    params: dict[str, float]
    config: dict[str, Any]
    distributions: dict[str, Distribution]
    batch: str | bool = "auto"
    source_text: str = field(default="", compare=False)

    @property
    def kind(self) -> str:
        """``mission`` (SITL runs of a script's plan) or ``maneuver``."""
        return "mission" if self.script else "maneuver"

    def sample(self, index: int) -> Sample:
        """Run ``index``'s conditions (independent of how many runs the campaign has)."""
        values: dict[str, float] = {}
        for number, name in enumerate(VARIABLES):
            dist = self.distributions.get(name)
            if dist is None:
                if name != "seed":
                    continue
                dist = Distribution("integers", (float(DEFAULT_SEED_RANGE[0]), float(DEFAULT_SEED_RANGE[1])),
                                    *VARIABLES["seed"])
            values[name] = dist.draw(np.random.default_rng([self.seed, index, number]))
        seed = int(values.pop("seed"))
        return Sample(index=index, seed=seed, **values)

    def script_args(self) -> argparse.Namespace:
        """The script's options parsed by the script's own parser."""
        assert self.script is not None
        return parse_script_options(self.script, self.options)

    def varying(self) -> list[str]:
        """Variables that are not constant in this campaign (in :data:`VARIABLES` order)."""
        out = [n for n, d in self.distributions.items() if d.constant is None and n != "seed"]
        return [n for n in VARIABLES if n in out]


def options_argv(options: Mapping[str, Any]) -> list[str]:
    """``{points = ["1,2", ...], speed = 3, reset_bottles = true}`` as command-line arguments.  A value
    starting with '-' (``"-15,10"``) gets a leading space, so argparse does not take it for an option
    (the scripts' number parsers ignore the space)."""

    def arg(value: Any) -> str:
        text = str(value)
        return " " + text if text.startswith("-") else text

    argv: list[str] = []
    for key, value in options.items():
        flag = "--" + key.replace("_", "-")
        if isinstance(value, bool):
            if value:
                argv.append(flag)
        elif isinstance(value, list):
            argv += [flag, *(arg(v) for v in value)]
        else:
            argv += [flag, arg(value)]
    return argv


def parse_script_options(script: str, options: Mapping[str, Any]) -> argparse.Namespace:
    """The mission script's ``parse_args`` on ``options``; its complaint as a ConfigError."""
    module = importlib.import_module(f"missions.{script}")
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            args: argparse.Namespace = module.parse_args(options_argv(options))
    except SystemExit:
        lines = [line for line in err.getvalue().splitlines() if line.strip()]
        raise ConfigError(f"[mission] options for {script}: {lines[-1] if lines else 'invalid'}") from None
    return args


def check_maneuver_options(options: Mapping[str, Any]) -> None:
    from sim_bridge.campaign.maneuver import MANEUVER_OPTIONS

    for key, value in options.items():
        if key not in MANEUVER_OPTIONS:
            raise ConfigError(f"[mission] options: unknown manoeuvre option {key!r}; accepted: "
                              f"{', '.join(MANEUVER_OPTIONS)}")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"[mission] options: {key} = {value!r} is not a number")


def parse_campaign(data: Mapping[str, Any], source: str = "<campaign>", text: str = "") -> CampaignSpec:
    """Validate a parsed campaign document; ConfigError naming the key and what is accepted."""
    known = {"campaign", "mission", "params", "config", "distributions"}
    for key in data:
        if key not in known:
            raise ConfigError(f"{source}: unknown table [{key}]; accepted: {', '.join(sorted(known))}")
    camp = dict(data.get("campaign", {}))
    name = str(camp.pop("name", Path(source).stem))
    seed = camp.pop("seed", 1)
    description = str(camp.pop("description", ""))
    if camp:
        raise ConfigError(f"[campaign] unknown key {next(iter(camp))!r}; accepted: name, seed, description")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"[campaign] seed: {seed!r} is not a non-negative integer")
    mission = dict(data.get("mission", {}))
    script, maneuver = mission.pop("script", None), mission.pop("maneuver", None)
    options = dict(mission.pop("options", {}))
    batch = mission.pop("batch", "auto")
    if mission:
        raise ConfigError(f"[mission] unknown key {next(iter(mission))!r}; accepted: script, maneuver, "
                          "options, batch")
    if (script is None) == (maneuver is None):
        raise ConfigError("[mission]: give exactly one of script (water_sampling, rescue) or maneuver "
                          f"({', '.join(MANEUVER_KINDS)})")
    if script is not None and script not in SCRIPTS:
        raise ConfigError(f"[mission] script: {script!r} unknown; accepted: {', '.join(SCRIPTS)}")
    if maneuver is not None and maneuver not in MANEUVER_KINDS:
        raise ConfigError(f"[mission] maneuver: {maneuver!r} unknown; accepted: {', '.join(MANEUVER_KINDS)}")
    if batch not in BATCH_CHOICES:
        raise ConfigError(f"[mission] batch: {batch!r}; accepted: \"auto\", true, false")
    if script is not None:
        parse_script_options(script, options)
    else:
        check_maneuver_options(options)
    store = ParamStore(all_param_defs())
    params: dict[str, float] = {}
    for pname, value in dict(data.get("params", {})).items():
        try:
            params[pname] = store.set(pname, value, persist=False)
        except ParamError as exc:
            raise ConfigError(f"[params] {exc}") from None
    config = dict(data.get("config", {}))
    for key in config:
        if key.startswith(("sim.", "links.")):
            raise ConfigError(f"[config] {key}: set per run by the campaign (distributions, no links)")
    default_config().with_overrides(config)  # validates every key and value
    dists = {n: parse_distribution(n, v) for n, v in dict(data.get("distributions", {})).items()}
    return CampaignSpec(name=name, seed=int(seed), description=description, script=script, maneuver=maneuver,
                        options=options, params=params, config=config, distributions=dists, batch=batch,
                        source_text=text)


def load_campaign(path: Path | str) -> CampaignSpec:
    """Read and validate a campaign file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the campaign file ({exc.strerror or exc})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None
    return parse_campaign(data, str(path), text)
