"""Each disturbance moves the boat the way physics says; everything is seeded."""

from __future__ import annotations

import itertools
import math

import pytest

from companion.config import ConfigError
from sim_bridge.disturbances import parse_current, parse_waves, parse_wind, spec_from_strings
from sim_bridge.maneuvers import run_maneuver
from sim_bridge.plant import BoatPlant

DT = 0.01


def drift(wind: str = "0,0", current: str = "0,0", waves: str = "0", seconds: float = 60.0,
          seed: int = 3) -> tuple[float, float]:
    """Engine off, boat at rest: where is it after ``seconds``?"""
    plant = BoatPlant(disturbances=spec_from_strings(wind, current, waves), seed=seed)
    for _ in range(int(seconds / DT)):
        plant.step(DT, 0.0, 0.0, False)
    return plant.state.north_m, plant.state.east_m


def test_current_carries_the_boat_toward_its_direction_at_its_speed() -> None:
    n, e = drift(current="0.5,90", seconds=20.0)
    assert e == pytest.approx(10.0, rel=0.02) and abs(n) < 0.2
    n, e = drift(current="0.3,180", seconds=20.0)
    assert n == pytest.approx(-6.0, rel=0.02)


def test_wind_pushes_the_boat_downwind_and_more_with_stronger_wind() -> None:
    n1, e1 = drift(wind="5,270")   # from the west: toward east
    _n2, e2 = drift(wind="10,270")
    assert e1 > 1.0 and abs(n1) < 0.5 * e1
    assert e2 > 2.0 * e1  # force ~ V^2
    n3, _ = drift(wind="8,0")      # from the north: toward south
    assert n3 < -1.0


def test_waves_drift_the_boat_along_their_direction_of_travel() -> None:
    n, e = drift(waves="0.4,2.5,90", seconds=120.0)
    assert e > 1.0 and e > 3.0 * abs(n)
    calm = drift(seconds=120.0)
    assert calm == (0.0, 0.0)


def test_waves_make_the_boat_move_back_and_forth_and_yaw() -> None:
    plant = BoatPlant(disturbances=spec_from_strings(waves="0.5,3,45"), seed=2)
    rates = []
    for _ in range(3000):
        plant.step(DT, 0.0, 0.0, False)
        rates.append(plant.state.r_radps)
    assert max(rates) > 0.005 and min(rates) < -0.005


def test_same_seed_same_run_different_seed_different_run() -> None:
    kw = {"duration_s": 20.0, "wind": "6,200", "current": "0.4,30", "waves": "0.3"}
    a = run_maneuver("sine", seed=7, **kw)  # type: ignore[arg-type]
    b = run_maneuver("sine", seed=7, **kw)  # type: ignore[arg-type]
    c = run_maneuver("sine", seed=8, **kw)  # type: ignore[arg-type]
    for col in ("u", "x_true", "psi_true", "r"):
        assert (a[col] == b[col]).all()
    assert (a["u"] != c["u"]).any() and (a["x_true"] != c["x_true"]).any()


@pytest.mark.parametrize(("parse", "text", "flag"), [
    (parse_wind, "5", "--wind"), (parse_wind, "x,3", "--wind"), (parse_wind, "-1,0", "--wind"),
    (parse_current, "0.5", "--current"), (parse_current, "9,0", "--current"),
    (parse_waves, "a", "--waves"), (parse_waves, "5", "--waves"), (parse_waves, "0.3,0.1", "--waves"),
])
def test_bad_disturbance_flags_are_refused_with_the_flag_name_and_accepted_form(parse, text, flag) -> None:
    with pytest.raises(ConfigError) as info:
        parse(text)
    assert flag in str(info.value) and "accepted" in str(info.value)


def test_flag_conventions() -> None:
    assert parse_wind("5,270") == (5.0, pytest.approx(math.radians(270)))
    assert parse_current("0.5,90")[1] == pytest.approx(math.pi / 2)
    hs, tp, toward = parse_waves("0.25")
    assert hs == 0.25 and tp == pytest.approx(2.0) and toward is None


def test_a_slowly_varying_current_wanders_around_its_mean_and_carries_the_boat_with_it() -> None:
    """--current SPEED,TOWARD,VAR: the boat (engine off, hull moving with the water) drifts
    with whatever the current does at each instant; the current wanders slowly around the
    given mean with spreads VAR*SPEED and VAR rad."""
    from sim_bridge.disturbances import Environment
    from sim_bridge.hull import BoatParams

    # the boat moves exactly with the (varying) water: displacement = integral of the current
    plant = BoatPlant(disturbances=spec_from_strings(current="0.5,90,0.3"), seed=4)
    north = east = 0.0
    for _ in range(int(200.0 / DT)):
        plant.step(DT, 0.0, 0.0, False)
        cn, ce = plant.env.current_ned_mps()
        north, east = north + cn * DT, east + ce * DT
    assert plant.state.north_m == pytest.approx(north, abs=0.05)
    assert plant.state.east_m == pytest.approx(east, abs=0.05)
    steady_n, steady_e = drift(current="0.5,90", seconds=200.0)
    assert math.hypot(plant.state.north_m - steady_n, plant.state.east_m - steady_e) > 1.0

    # statistics over an hour of the current itself: mean, spreads, slowness
    env = Environment(spec_from_strings(current="0.5,90,0.2"), BoatParams(), seed=4)
    speeds, dirs = [], []
    for i in range(int(3600.0 / 0.1)):
        env.advance(0.1)
        if i % 10 == 0:
            speeds.append(env.current_speed_mps)
            dirs.append(env.current_toward_rad)
    mean_s, mean_d = sum(speeds) / len(speeds), sum(dirs) / len(dirs)
    std_s = math.sqrt(sum((s - mean_s) ** 2 for s in speeds) / len(speeds))
    std_d = math.sqrt(sum((d - mean_d) ** 2 for d in dirs) / len(dirs))
    assert mean_s == pytest.approx(0.5, abs=0.05) and mean_d == pytest.approx(math.pi / 2, abs=0.1)
    assert 0.05 < std_s < 0.2 and 0.1 < std_d < 0.4   # targets 0.1 m/s and 0.2 rad
    # slow: second to second the direction moves a small fraction of its spread (theory:
    # rms change = std sqrt(2 dt / tau) = 0.13 std for dt = 1 s, tau = 120 s)
    steps = [b - a for a, b in itertools.pairwise(dirs)]
    assert math.sqrt(sum(d * d for d in steps) / len(steps)) < 0.2 * std_d


def test_current_variability_is_parsed_and_checked() -> None:
    from sim_bridge.disturbances import parse_current_var

    assert parse_current_var("0.5,90") == (0.5, pytest.approx(math.pi / 2), 0.0)
    assert parse_current_var("0.5,90,0.25")[2] == 0.25
    for bad in ("0.5,90,2", "0.5,90,-0.1", "0.5,90,0.1,3"):
        with pytest.raises(ConfigError) as info:
            parse_current_var(bad)
        assert "--current" in str(info.value) and "VAR" in str(info.value)


@pytest.mark.parametrize("waves,wind,seed", [("0.3,3", "0,0", 1), ("0.5,2.5,45", "6,90", 2),
                                             ("1.2,6", "0,0", 3)])
def test_compiled_wave_force_is_bit_identical_to_the_numpy_reference(waves: str, wind: str,
                                                                       seed: int) -> None:
    import random

    from sim_bridge.disturbances import Environment
    from sim_bridge.hull import BoatParams

    env = Environment(spec_from_strings(wind=wind, waves=waves), BoatParams(), seed)
    rng = random.Random(seed)
    for _ in range(300):
        args = (rng.uniform(0, 600), rng.uniform(-300, 300), rng.uniform(-300, 300), rng.uniform(-7, 7),
                rng.uniform(170, 240))
        assert env.wave_force(*args) == env.wave_force_reference(*args)


def test_a_deep_copy_of_a_plant_continues_the_same_weather_and_leaves_the_original_alone() -> None:
    """``copy.deepcopy`` of a plant (the control bench tries an oracle from the same state)
    must continue the same gusts and wandering current as the original would, and running
    the copy must not change what the original does next (the noise is drawn in blocks)."""
    import copy

    def states(plant: BoatPlant, steps: int) -> list[tuple[float, ...]]:
        out = []
        for i in range(steps):
            plant.step(0.01, 0.3 if (i // 250) % 2 else -0.3, 0.6, True)
            s = plant.state
            out.append((s.north_m, s.east_m, s.psi_rad, s.u_mps, s.v_mps, s.r_radps))
        return out

    spec = spec_from_strings(wind="8,40", current="0.6,120,0.4", waves="0.2,2.5")
    reference, plant = BoatPlant(disturbances=spec, seed=9), BoatPlant(disturbances=spec, seed=9)
    assert states(reference, 3000) == states(plant, 3000)
    twin = copy.deepcopy(plant)
    ahead = states(reference, 9000)  # more than two 4096-value noise blocks past the copy
    assert states(twin, 9000) == ahead
    assert states(plant, 9000) == ahead


def test_a_deep_copy_of_the_gps_ins_continues_the_same_noise() -> None:
    import copy

    from sim_bridge.gpsins import GpsInsModel
    from sim_bridge.plant import PlantState

    state = PlantState(north_m=3.0, east_m=-2.0, psi_rad=0.4, u_mps=2.0, v_mps=0.1, r_radps=0.05)
    sensor = GpsInsModel(seed=4)
    for _ in range(1000):
        sensor.measure(state, 0.01)
    twin = copy.deepcopy(sensor)
    original = [sensor.sentences(sensor.measure(state, 0.01)) for _ in range(1000)]
    assert [twin.sentences(twin.measure(state, 0.01)) for _ in range(1000)] == original
