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

    [ukf]                              # optional: noise identified from the same logs
    q_diag = [0.0, 0.0, 0.0, 0.004, 0.002, 7e-5]   # Eq. 6 Q, a continuous intensity (Q dt per step)
    r_diag = [0.01, 0.01, 8e-7]                    # Eq. 5 R
    source = "identified"

Regressor names are those of :data:`companion.models.qlpv.QLPV_MASK`.  A missing file, an
unknown regressor or a non-finite value raises :class:`ModelParamsError` naming it.  The
``[ukf]`` table is used only when the setting ``models.ukf_noise`` is "identified".
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np

from companion.models.base import DOF_NAMES
from companion.models.qlpv import QLPVModel
from companion.models.ukf import UKFSettings

DEFAULT_PARAMS_PATH = Path(__file__).with_name("default_params.toml")
"""Shipped default: identified by ``usv identify`` on simulator logs (chapter sine protocol)."""


class ModelParamsError(ValueError):
    """params.toml cannot be used; the message names the key."""


def dump_model_params(model: QLPVModel, path: Path | str, source: str = "",
                      ukf: UKFSettings | None = None) -> None:
    """Write ``model`` (and optionally identified UKF noise) as params.toml, atomically."""
    lines = ["[model]", 'kind = "qlpv"', f"thrust_speed_coeff = {model.thrust_speed_coeff!r}"]
    if source:
        lines.append(f"source = {_toml_str(source)}")
    table = model.param_table()
    for dof in DOF_NAMES:
        lines.append("")
        lines.append(f"[model.{dof}]")
        for name, value in table[dof].items():
            lines.append(f"{_toml_str(name)} = {float(value)!r}")
    if ukf is not None:
        lines += ["", "[ukf]", f"q_diag = [{', '.join(repr(float(x)) for x in ukf.q_diag)}]",
                  f"r_diag = [{', '.join(repr(float(x)) for x in ukf.r_diag)}]", 'source = "identified"']
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    tmp.replace(path)


def _toml_str(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _read_toml(path: Path) -> dict[str, object]:
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ModelParamsError(f"{path}: cannot read model parameters ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ModelParamsError(f"{path}: not valid TOML ({exc})") from None


def load_model_params(path: Path | str | None = None) -> QLPVModel:
    """Load params.toml (default: the shipped :data:`DEFAULT_PARAMS_PATH`)."""
    path = Path(path) if path is not None else DEFAULT_PARAMS_PATH
    data = _read_toml(path)
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


def load_ukf_settings(path: Path | str | None = None) -> UKFSettings | None:
    """The ``[ukf]`` table of params.toml as UKF settings (chapter alpha/beta/kappa), or None
    when the file has none.  Non-finite, negative or wrongly sized entries raise
    :class:`ModelParamsError` naming the key."""
    path = Path(path) if path is not None else DEFAULT_PARAMS_PATH
    data = _read_toml(path)
    ukf = data.get("ukf")
    if ukf is None:
        return None
    if not isinstance(ukf, dict):
        raise ModelParamsError(f"{path}: [ukf] must be a table")
    diags = {}
    for key, size in (("q_diag", 6), ("r_diag", 3)):
        value = ukf.get(key)
        if not isinstance(value, list) or len(value) != size or not all(_nonneg(x) for x in value):
            raise ModelParamsError(f"{path}: ukf.{key} must be a list of {size} finite numbers >= 0, "
                                   f"got {value!r}")
        diags[key] = tuple(float(x) for x in value)
    if min(diags["r_diag"]) <= 0:
        raise ModelParamsError(f"{path}: ukf.r_diag entries must be > 0 (a noiseless sensor makes the "
                               f"filter singular), got {list(diags['r_diag'])}")
    return UKFSettings(q_diag=diags["q_diag"], r_diag=diags["r_diag"])


def _nonneg(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) and x >= 0


def resolve_params_path(state_dir: Path, configured: str = "") -> Path:
    """Which params.toml the companion uses: the configured path, else
    ``<state_dir>/model/params.toml`` if it exists, else the shipped default."""
    if configured:
        return Path(configured)
    local = Path(state_dir) / "model" / "params.toml"
    return local if local.exists() else DEFAULT_PARAMS_PATH
