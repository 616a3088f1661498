"""The held-model-error bound, UKF noise identified from logs, and the companion using it.

The synthetic records here are the reference qLPV boat driven by the chapter's sine input
with a slowly varying unmodelled acceleration (a stand-in for a steady current or a thrust
loss) and the sensor noise of R: a case where the model error persists over the 1 s horizon,
so the active model of Eq. 5 should reach the chapter's one third once its noise fits the data.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from companion.config import default_config
from companion.estimation.service import EstimatorStage, load_companion_model, load_companion_ukf_settings
from companion.models.active_prediction import predict_active, predict_plain, run_filter
from companion.models.base import DOF_NAMES
from companion.models.evaluate import evaluate, j_of, reference
from companion.models.logs import Record
from companion.models.noise_fit import fit_ukf_noise
from companion.models.params_file import ModelParamsError, dump_model_params, load_ukf_settings
from companion.models.persistence import autocorrelation, held_error_bound
from companion.models.ukf import CHAPTER_R_DIAG, UKFSettings
from tests.models.helpers import reference_qlpv, sine_inputs

SENSOR_STD = np.sqrt(CHAPTER_R_DIAG)


def _record(period_s: float, seed: int, duration_s: float = 120.0) -> Record:
    model = reference_qlpv()
    t, thr, dl = sine_inputs(duration_s)
    amp = np.array([0.3, 0.1, 0.05])
    dnu = amp * np.sin(2 * np.pi * t[:, None] / period_s + np.array([0.0, 1.0, 2.0]))
    truth = model.simulate(t, np.array([1.0, 0.0, 0.0]), thr, dl, delta_nu=dnu)
    z = truth + np.random.default_rng(seed).normal(size=truth.shape) * SENSOR_STD
    return Record(f"synthetic {period_s} s model error", t, z, thr, dl, truth)


def test_autocorrelation_is_one_for_a_slow_series_and_low_for_white_noise() -> None:
    t = np.arange(0.0, 100.0, 0.01)
    slow = np.sin(2 * np.pi * t / 60.0)[:, None]
    white = np.random.default_rng(1).normal(size=(t.size, 1))
    assert autocorrelation(slow, 100)[0] > 0.98
    assert abs(autocorrelation(white, 100)[0]) < 0.05


@pytest.mark.slow
def test_bound_is_small_when_the_model_error_persists_and_large_when_it_does_not() -> None:
    model = reference_qlpv()
    slow = held_error_bound(model, _record(60.0, 1))
    assert all(slow.autocorr[d] > 0.95 for d in DOF_NAMES), slow
    assert all(slow.ratio[d] < 0.15 for d in DOF_NAMES), slow
    fast = held_error_bound(model, _record(1.0, 1))
    assert all(fast.ratio[d] > 1 / 3 for d in DOF_NAMES), fast


@pytest.mark.slow
def test_noise_fit_recovers_the_sensor_noise_and_the_active_model_reaches_one_third() -> None:
    model = reference_qlpv()
    train, val = _record(60.0, 1), _record(60.0, 2)
    noise = fit_ukf_noise(model, [train])
    np.testing.assert_allclose(noise.r_diag, CHAPTER_R_DIAG, rtol=0.1)
    assert noise.q_diag[:3] == (0.0, 0.0, 0.0) and all(q > 0 for q in noise.q_diag[3:])
    j = evaluate(model, val, settings=noise).j
    ratio = {d: j["ahead_active"][d] / j["ahead"][d] for d in DOF_NAMES}
    assert all(r < 1.0 for r in ratio.values()), ratio  # the whole record, learning the gain included
    # the held delta_nu itself (Eq. 5) reaches one third; so does the gated active model once its
    # gain has been learnt from the first minute of predictions
    run = run_filter(model, val, noise)
    idx, plain = predict_plain(model, val, run, 1.0)
    meas = reference(val)
    late = idx >= idx.size // 2
    for gated in (False, True):
        _, active = predict_active(model, val, run, 1.0, gated=gated)
        j0, j1 = j_of(plain[late], meas[idx][late]), j_of(active[late], meas[idx][late])
        assert all(j1[d] / j0[d] <= 1 / 3 for d in DOF_NAMES), (gated, j0, j1)


def test_params_toml_carries_the_identified_noise(tmp_path: Path) -> None:
    noise = UKFSettings(q_diag=(0.0, 0.0, 0.0, 4e-3, 2e-3, 7e-5), r_diag=(0.01, 0.01, 8e-7))
    path = tmp_path / "params.toml"
    dump_model_params(reference_qlpv(), path, ukf=noise)
    loaded = load_ukf_settings(path)
    assert loaded is not None and loaded.q_diag == noise.q_diag and loaded.r_diag == noise.r_diag
    dump_model_params(reference_qlpv(), tmp_path / "plain.toml")
    assert load_ukf_settings(tmp_path / "plain.toml") is None


@pytest.mark.parametrize(
    "bad", ["[1.0, 2.0]", "[0.01, nan, 1e-3]", "[0.01, -1.0, 1e-3]", "[0.01, 0.0, 1e-3]", '"x"']
)
def test_a_bad_ukf_table_is_refused_naming_the_key(tmp_path: Path, bad: str) -> None:
    path = tmp_path / "params.toml"
    dump_model_params(reference_qlpv(), path)
    with path.open("a") as f:
        f.write(f"\n[ukf]\nq_diag = [0.0, 0.0, 0.0, 1e-3, 1e-3, 1e-4]\nr_diag = {bad}\n")
    with pytest.raises(ModelParamsError, match=r"ukf\.r_diag"):
        load_ukf_settings(path)


def _stage(tmp_path: Path, choice: str) -> EstimatorStage:
    noise = UKFSettings(q_diag=(0.0, 0.0, 0.0, 4e-3, 2e-3, 7e-5), r_diag=(0.01, 0.01, 8e-7))
    dump_model_params(reference_qlpv(), tmp_path / "state" / "model" / "params.toml", ukf=noise)
    cfg = default_config().with_overrides({"vehicle.state_dir": str(tmp_path / "state"),
                                           "models.ukf_noise": choice})
    return EstimatorStage(load_companion_model(cfg), load_companion_ukf_settings(cfg))


def test_companion_uses_identified_noise_only_when_asked(tmp_path: Path) -> None:
    assert _stage(tmp_path / "a", "chapter").settings == UKFSettings()
    used = _stage(tmp_path / "b", "identified").settings
    assert used.r_diag == (0.01, 0.01, 8e-7) and used.q_diag[3] == 4e-3
