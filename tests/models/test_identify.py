"""Identification on synthetic qLPV data, identifiability errors, log validation, params.toml."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from companion.models.baselines import LinearizedModel
from companion.models.evaluate import evaluate
from companion.models.identify import IdentificationError, fit_least_squares, fit_qlpv
from companion.models.logs import LogError, Record, read_log
from companion.models.params_file import ModelParamsError, dump_model_params, load_model_params
from tests.models.helpers import reference_qlpv, sine_inputs


def _record(duration_s: float = 90.0, noise: bool = True, seed: int = 0,
            throttle_steps: bool = False) -> Record:
    model = reference_qlpv()
    t, thr, dl = sine_inputs(duration_s)
    if throttle_steps:
        thr = 0.3 + 0.15 * np.sign(np.sin(2 * np.pi * t / 17.0))
    truth = model.simulate(t, np.array([0.5, 0.0, 0.0]), thr, dl)
    rng = np.random.default_rng(seed)
    meas = truth + (rng.normal(size=truth.shape) * [0.02, 0.02, 0.002] if noise else 0.0)
    return Record("synthetic", t, meas, thr, dl, truth)


@pytest.mark.slow
def test_least_squares_recovers_qlpv_parameters_and_thrust_map() -> None:
    fit = fit_qlpv([_record(throttle_steps=True)])
    ref = reference_qlpv()
    assert fit.model.thrust_speed_coeff == pytest.approx(ref.thrust_speed_coeff, abs=0.01)
    f = ref.FEATURES
    for j, name in ((0, "Tcos"), (0, "u"), (1, "v"), (1, "Tsin"), (2, "Tsin"), (2, "|r|r")):
        assert fit.model.theta[j, f.index(name)] == pytest.approx(ref.theta[j, f.index(name)], rel=0.15)
    assert np.all(fit.std[ref.theta != 0] > 0)
    assert max(fit.cond) < 1e5
    ev = evaluate(fit.model, _record(60.0, seed=5))
    assert max(ev.j["free_run"].values()) < 0.05


def test_missing_steering_excitation_is_named() -> None:
    rec = _record(30.0)
    straight = Record("straight", rec.t_s, rec.nu * [1, 0, 0], rec.throttle, rec.delta_rad * 0, rec.nu_true)
    with pytest.raises(IdentificationError, match="'delta' is not excited"):
        fit_qlpv([straight])


def test_constant_throttle_regressor_is_dropped_with_a_warning() -> None:
    fit = fit_least_squares(LinearizedModel(np.zeros((3, 6)), name="linearized"), [_record()])
    assert any("'throttle' not identifiable" in w and "'throttle' not excited" in w for w in fit.warnings)
    assert fit.model.theta[0, 2] == 0.0
    assert np.all(np.isfinite(fit.model.theta))


def _write(path: Path, header: str, rows: list[str]) -> Path:
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def test_log_errors_name_the_problem(tmp_path: Path) -> None:
    good = [f"{0.01 * i},1.0,0.0,0.0,0.3,0.1" for i in range(20)]
    ok = read_log(_write(tmp_path / "ok.csv", "t,u,v,r,throttle,delta", good))
    assert len(ok) == 20 and ok.nu_true is None
    with pytest.raises(LogError, match=r"'delta'.*misnamed"):
        read_log(_write(tmp_path / "a.csv", "t,u,v,r,throttle,delt", good))
    with pytest.raises(LogError, match=r"NaN.*line"):
        bad = [*good[:5], "0.05,nan,0,0,0.3,0.1", *good[6:]]
        read_log(_write(tmp_path / "b.csv", "t,u,v,r,throttle,delta", bad))
    with pytest.raises(LogError, match="not strictly increasing at line 7"):
        read_log(_write(tmp_path / "c.csv", "t,u,v,r,throttle,delta", [*good[:5], *good[3:]]))
    with pytest.raises(LogError, match="cannot read"):
        read_log(tmp_path / "missing.csv")


def test_params_file_round_trip_and_errors(tmp_path: Path) -> None:
    ref = reference_qlpv()
    dump_model_params(ref, tmp_path / "p.toml", source="test")
    back = load_model_params(tmp_path / "p.toml")
    np.testing.assert_array_equal(back.theta, ref.theta)
    assert back.thrust_speed_coeff == ref.thrust_speed_coeff
    assert load_model_params().param_table()["u"]["Tcos"] > 0  # shipped default loads
    (tmp_path / "bad.toml").write_text('[model]\n[model.u]\n"w" = 1.0\n[model.v]\n[model.r]\n')
    with pytest.raises(ModelParamsError, match="unknown regressor 'w'"):
        load_model_params(tmp_path / "bad.toml")
