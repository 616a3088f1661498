"""Identification on simulator logs, through the code ``usv identify`` runs: the qLPV model
against both baselines (J, Eq. 12), the active model's 1 s predictions (Eq. 5-11), and the
``usv identify`` command's report, params.toml and errors.

Training: chapter protocol (sine +-pi/3 at 30 % throttle, 10 s period), seed 1, calm, 90 s.
Validation (60 s each, other seeds): sine in calm water; sine, zig-zag and random in a
0.1 m/s current with Hs 0.05 m waves.  Criteria that the measurements do not meet are
strict xfails carrying the measured figures (benchmarks/identify.py reports them too), so
they show up in every run and turn into failures the moment they start to hold.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from benchmarks.identify import CURRENT, WAVES, simulated_record
from companion.app import Context
from companion.clock import SimClock
from companion.config import default_config
from companion.models.base import DOF_NAMES, LinearInParamsModel
from companion.models.logs import Record
from companion.models.params_file import dump_model_params, load_model_params, load_ukf_settings
from companion.models.pipeline import JTable, Validation, identify_models, ratios, validate
from companion.runtime import build_companion, build_context
from sim_bridge.maneuvers import run_maneuver, write_log_csv
from tests.conftest import usv_command

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def fitted() -> tuple[dict[str, LinearInParamsModel], dict[str, Record]]:
    train = [simulated_record("sine", 1, duration_s=90.0)]
    models = {n: f.model for n, f in identify_models(train).items()}
    vals = {
        "sine_calm": simulated_record("sine", 2),
        "sine": simulated_record("sine", 2, CURRENT, WAVES),
        "zigzag": simulated_record("zigzag", 3, CURRENT, WAVES),
        "random": simulated_record("random", 4, CURRENT, WAVES),
    }
    return models, vals


@pytest.fixture(scope="module")
def validations(fitted: tuple[dict[str, LinearInParamsModel], dict[str, Record]]) -> dict[str, Validation]:
    """Every validation log through :func:`validate` once (J tables and the held-error bound)."""
    models, vals = fitted
    return {k: validate(models, rec) for k, rec in vals.items()}


@pytest.fixture(scope="module")
def tables(validations: dict[str, Validation]) -> dict[str, JTable]:
    return {k: v.table for k, v in validations.items()}


def _qlpv_beats_baselines(t: JTable) -> None:
    for d in DOF_NAMES:
        q = t["qlpv"]["free_run"][d]
        assert q < t["linearized"]["free_run"][d] and q < t["nomoto_sideslip"]["free_run"][d], (d, t)


def _active_one_third(t: JTable) -> None:
    r = ratios(t)["ahead"]
    assert all(r[d] <= 1 / 3 for d in DOF_NAMES), r


@pytest.mark.parametrize("validation", ["sine_calm", "sine"])
def test_qlpv_beats_both_baselines_in_free_run_on_sine(tables: dict[str, JTable], validation: str) -> None:
    _qlpv_beats_baselines(tables[validation])


def test_qlpv_beats_both_baselines_in_free_run_on_zigzag(tables: dict[str, JTable]) -> None:
    _qlpv_beats_baselines(tables["zigzag"])


def test_qlpv_beats_both_baselines_in_free_run_on_random(tables: dict[str, JTable]) -> None:
    _qlpv_beats_baselines(tables["random"])


@pytest.mark.parametrize("validation", ["sine_calm", "sine", "zigzag", "random"])
@pytest.mark.xfail(
    strict=True,
    reason="measured: ratio 0.78-1.01 with the chapter's Q (as a rate) and R, the held delta_nu gated by "
    "its learnt usefulness (1.4-12.9 held as Eq. 5 holds it).  Not reachable on these "
    "logs: even the exact model error held over 1 s gives 0.5-1.9 (the bound test below); its "
    "correlation with itself 1 s later is -0.25..0.7",
)
def test_active_model_one_second_ahead_is_a_third_of_qlpv(tables: dict[str, JTable], validation: str) -> None:
    _active_one_third(tables[validation])


@pytest.mark.parametrize("validation", ["sine_calm", "sine", "zigzag", "random"])
def test_no_held_model_error_reaches_one_third_on_simulator_logs(
    validations: dict[str, Validation], validation: str
) -> None:
    """Why the test above fails: on the simulator's logs the qLPV model error does not persist
    over the 1 s horizon, so even the exact model error (from the truth columns) held over it
    (a perfect UKF) stays above one third of the no-model-error J on some DOF.  If the simulator or the model
    changes so that it does persist, this fails and the criterion above becomes reachable."""
    bound = validations[validation].held_bound  # held_error_bound of the qLPV model, 1 s horizon
    assert bound is not None
    assert bound.reference.startswith("truth")
    assert max(bound.ratio.values()) > 1 / 3, bound.as_dict()


def test_active_model_helps_where_the_model_error_is_slow(tables: dict[str, JTable]) -> None:
    """A weaker, met property: on yaw in the random manoeuvre (model error from throttle
    changes the sine training never saw) the held delta_nu improves the 1-s prediction."""
    assert ratios(tables["random"])["ahead"]["r"] < 1.0


# --- the command line -------------------------------------------------------------------------


def _usv(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*usv_command(), *args], capture_output=True, text=True, timeout=120)


def _usv_start(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([*usv_command(), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def _finish(proc: subprocess.Popen[str]) -> subprocess.CompletedProcess[str]:
    """``proc`` waited for (killed after 120 s), as :func:`subprocess.run` returns it."""
    try:
        stdout, stderr = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise
    return subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)


def test_usv_identify_writes_report_and_loadable_params(tmp_path: Path) -> None:
    write_log_csv(run_maneuver("sine", duration_s=40.0, seed=1), tmp_path / "train.csv")
    write_log_csv(
        run_maneuver("sine", duration_s=20.0, seed=2, current=CURRENT, waves=WAVES), tmp_path / "val.csv"
    )
    args = ["identify", str(tmp_path / "train.csv"), "--validate", str(tmp_path / "val.csv"), "--report"]
    # the JSON run and the text run are independent processes: run side by side (wall time only)
    json_run = _usv_start(*args, str(tmp_path / "rep"), "--json")
    text_run = _usv_start(*args, str(tmp_path / "rep2"))
    out, text = _finish(json_run), _finish(text_run)
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert set(data["j"]) == {"linearized", "nomoto_sideslip", "qlpv"}
    assert set(data["j"]["qlpv"]) == {"free_run", "ahead", "ahead_active"}
    assert all(np.isfinite(v) for modes in data["j"].values() for row in modes.values() for v in row.values())
    for name in (
        "params.toml",
        "report.md",
        "input.png",
        "predicted_u.png",
        "predicted_v.png",
        "predicted_r.png",
        "model_error.png",
    ):
        assert (tmp_path / "rep" / name).stat().st_size > 0, name
    model = load_model_params(tmp_path / "rep" / "params.toml")
    assert model.param_table()["u"]["Tcos"] > 0
    noise = load_ukf_settings(tmp_path / "rep" / "params.toml")
    assert noise is not None and noise.r_diag == tuple(data["ukf_identified"]["r_diag"])
    bound = data["held_error_bound"]
    assert bound["reference"].startswith("truth") and set(bound["oracle_ratio"]) == {"u", "v", "r"}
    report = (tmp_path / "rep" / "report.md").read_text()
    assert "chapter Table 3 (published, real boat, reference only)" in report
    assert "Can a held model error reach one third" in report
    assert text.returncode == 0 and "qLPV" in text.stdout and "Nomoto" in text.stdout


def test_usv_identify_broken_csv_is_one_line_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("t,u,v,r,throttle,delt\n" + "".join(f"{0.01 * i},1,0,0,0.3,0\n" for i in range(50)))
    out = _usv("identify", str(bad), "--validate", str(bad), "--report", str(tmp_path / "rep"))
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "'delta'" in lines[0] and "misnamed" in lines[0]
    assert not (tmp_path / "rep").exists()


# --- the companion uses params.toml ---------------------------------------------------------------


def _ctx(overrides: dict[str, str]) -> Context:
    cfg = default_config().with_overrides(overrides)
    return build_context(cfg, SimClock())


def test_companion_loads_params_toml_from_state_dir_and_config(tmp_path: Path) -> None:
    from tests.models.helpers import reference_qlpv

    ref = reference_qlpv(c_thrust=0.123)
    dump_model_params(ref, tmp_path / "state" / "model" / "params.toml")
    ctx = _ctx({"vehicle.state_dir": str(tmp_path / "state")})
    services = build_companion(ctx)
    used = services.estimator.model
    assert services.control.model is used  # the active-model law flies the same model
    np.testing.assert_array_equal(used.theta, ref.theta)
    assert used.thrust_speed_coeff == 0.123
    other = reference_qlpv(c_thrust=0.0)
    dump_model_params(other, tmp_path / "elsewhere.toml")
    ctx2 = _ctx(
        {"vehicle.state_dir": str(tmp_path / "state"), "models.params_file": str(tmp_path / "elsewhere.toml")}
    )
    assert build_companion(ctx2).estimator.model.thrust_speed_coeff == 0.0
