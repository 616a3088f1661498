"""params.toml: the identified qLPV model, written by ``usv identify`` and loaded by the companion.

Format (TOML)::

    [model]
    kind = "qlpv"
    thrust_speed_coeff = 0.07          # c in T~ = throttle^2 - c throttle u (s/m)
    source = "usv identify sine.csv"   # free text
    [model.u]                          # u_dot row: regressor name -> lumped coefficient
    "u" = -0.25
    "|u|u" = -0.06
    ...
    [model.v]
    ...
    [model.r]
    ...

Regressor names are those of :data:`companion.models.qlpv.QLPV_MASK`.  A missing file, an
unknown regressor or a non-finite value raises :class:`ModelParamsError` naming it.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np

from companion.models.base import DOF_NAMES
from companion.models.qlpv import QLPVModel

DEFAULT_PARAMS_PATH = Path(__file__).with_name("default_params.toml")
"""Shipped default: identified by ``usv identify`` on simulator logs (chapter sine protocol)."""


class ModelParamsError(ValueError):
    """params.toml cannot be used; the message names the key."""


def dump_model_params(model: QLPVModel, path: Path | str, source: str = "") -> None:
    """Write ``model`` as params.toml (atomically: temporary file then rename)."""
    lines = ["[model]", 'kind = "qlpv"', f"thrust_speed_coeff = {model.thrust_speed_coeff!r}"]
    if source:
        lines.append(f"source = {_toml_str(source)}")
    table = model.param_table()
    for dof in DOF_NAMES:
        lines.append("")
        lines.append(f"[model.{dof}]")
        for name, value in table[dof].items():
            lines.append(f"{_toml_str(name)} = {float(value)!r}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    tmp.replace(path)


def _toml_str(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def load_model_params(path: Path | str | None = None) -> QLPVModel:
    """Load params.toml (default: the shipped :data:`DEFAULT_PARAMS_PATH`)."""
    path = Path(path) if path is not None else DEFAULT_PARAMS_PATH
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ModelParamsError(f"{path}: cannot read model parameters ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ModelParamsError(f"{path}: not valid TOML ({exc})") from None
    model = data.get("model")
    if not isinstance(model, dict):
        raise ModelParamsError(f"{path}: missing [model] table")
    if model.get("kind", "qlpv") != "qlpv":
        raise ModelParamsError(f"{path}: model.kind {model.get('kind')!r} unsupported; accepted: 'qlpv'")
    c = model.get("thrust_speed_coeff", 0.0)
    if isinstance(c, bool) or not isinstance(c, int | float) or not math.isfinite(c) or c < 0:
        raise ModelParamsError(f"{path}: model.thrust_speed_coeff must be a finite number >= 0, got {c!r}")
    theta = np.zeros((3, len(QLPVModel.FEATURES)))
    for j, dof in enumerate(DOF_NAMES):
        row = model.get(dof)
        if not isinstance(row, dict):
            raise ModelParamsError(f"{path}: missing [model.{dof}] table")
        for name, value in row.items():
            if name not in QLPVModel.MASK[j]:
                raise ModelParamsError(f"{path}: model.{dof}: unknown regressor {name!r}; accepted: "
                                       + ", ".join(QLPVModel.MASK[j]))
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise ModelParamsError(f"{path}: model.{dof}.{name} must be a finite number, got {value!r}")
            theta[j, QLPVModel.FEATURES.index(name)] = float(value)
    return QLPVModel(theta, name="qLPV", thrust_speed_coeff=float(c), meta={"path": str(path)})


def resolve_params_path(state_dir: Path, configured: str = "") -> Path:
    """Which params.toml the companion uses: the configured path, else
    ``<state_dir>/model/params.toml`` if it exists, else the shipped default."""
    if configured:
        return Path(configured)
    local = Path(state_dir) / "model" / "params.toml"
    return local if local.exists() else DEFAULT_PARAMS_PATH
