"""Holding a point in a current on the full companion stack (lockstep SITL, issue 14): the
strategy is picked from the estimate the moment the boat starts holding, with no exploratory
loops, and a strong current is stemmed from the arrival on."""

from __future__ import annotations

import math

import pytest

from companion.guidance.geo import LocalFrame
from companion.messages import GuidedTarget, ModeNumber
from companion.mission import items as mi
from companion.mission.items import MissionItem, MissionType
from companion.modes.holding import CurrentStationTask, OrbitTask
from sim_bridge.sitl import SitlHarness

HOME = (41.77, 123.43)


def _pos(h: SitlHarness) -> tuple[float, float]:
    return h.plant.state.north_m, h.plant.state.east_m


GOTO_NE = (30.0, 30.0)
"""usv bench nav's go-to point (north, east m from home)."""


async def _guided_to_the_point(h: SitlHarness, max_s: float, step_s: float) -> bool:
    """2 s after start, arm and go GUIDED to :data:`GOTO_NE`; whether the boat came within 2 m of
    it within ``max_s`` (checked every ``step_s``)."""
    vehicle = h.services.vehicle
    await h.run_for(2.0)
    assert vehicle.arm() is None
    assert vehicle.set_mode(15) is None
    vehicle.guided_target = GuidedTarget(*LocalFrame(*HOME).to_lat_lon(*GOTO_NE), t_s=h.ctx.clock.now_s())
    return await h.run_until(lambda: math.dist(_pos(h), GOTO_NE) < 2.0, max_s, step_s)


async def _guided_to_the_point_and_hold(h: SitlHarness) -> None:
    """Arm, GUIDED to 30 m N / 30 m E (within 2 m), then 30 s on the point (usv bench nav's go-to)."""
    assert await _guided_to_the_point(h, 150.0, 0.1)
    await h.run_for(30.0)


async def _trial_then_orbit(h: SitlHarness, seconds: float) -> tuple[list[float], int | None]:
    """The boat's distance from :data:`GOTO_NE` every 0.05 s for ``seconds``, and the index of the
    first sample at which GUIDED's hold, having tried keeping station (a trial), orbits instead
    (``None``: not within ``seconds``)."""
    vehicle = h.services.vehicle
    tried, given_up, dists = False, None, []
    for _ in range(round(seconds / 0.05)):
        await h.run_for(0.05)
        dists.append(math.dist(_pos(h), GOTO_NE))
        task = vehicle.modes.current.task
        tried = tried or (isinstance(task, CurrentStationTask) and task.trial)
        if tried and given_up is None and isinstance(task, OrbitTask):
            given_up = len(dists) - 1
    return dists, given_up


def _upload_circle_items(h: SitlHarness, points: list[tuple[float, float]]) -> None:
    """A mission of LOITER_TIME items (40 s on a 2 m circle) at ``points`` (north, east m from home)."""
    frame = LocalFrame(*HOME)
    plan = [MissionItem.home(*HOME)] + [
        MissionItem.at(k, mi.CMD_NAV_LOITER_TIME, *frame.to_lat_lon(*p), param1=40.0, param3=2.0)
        for k, p in enumerate(points, start=1)]
    h.services.vehicle.missions.replace(MissionType.MISSION, plan)


async def _loiter_from_here(h: SitlHarness, samples: int, every_step: type | None = None) -> list[float]:
    """LOITER where the boat is; its distance from there every 0.5 s, ``samples`` times, with the
    hold task checked to be ``every_step`` at each sample when given."""
    vehicle = h.services.vehicle
    entry = _pos(h)
    assert vehicle.set_mode(5) is None
    dists = []
    for _ in range(samples):
        await h.run_for(0.5)
        dists.append(math.dist(_pos(h), entry))
        if every_step is not None:
            assert isinstance(vehicle.modes.current.task, every_step)
    return dists


async def test_guided_arrival_and_loiter_in_a_flood_stem_the_current() -> None:
    """1.2 m/s across the go-to leg, 3 m/s wind: GUIDED arrives from downstream bow into the
    current (main: 13 m past the point and back), then LOITER keeps station from its entry."""
    async with SitlHarness(seed=4, current="1.2,90", wind="3,270", full_stack=True) as h:
        await h.run_for(20.0)  # the estimator finds the current while the boat drifts
        vehicle = h.services.vehicle
        assert vehicle.arm() is None
        goal = (30.0, 30.0)
        assert vehicle.set_mode(15) is None
        vehicle.guided_target = GuidedTarget(*LocalFrame(*HOME).to_lat_lon(*goal), t_s=h.ctx.clock.now_s())
        start = _pos(h)
        unit = [(g - s) / math.dist(goal, start) for g, s in zip(goal, start, strict=True)]
        past = 0.0
        for _ in range(120):
            await h.run_for(0.5)
            n, e = _pos(h)
            past = max(past, (n - goal[0]) * unit[0] + (e - goal[1]) * unit[1])
        assert isinstance(vehicle.modes.current.task, CurrentStationTask)
        assert past < 6.0  # how far it ran past the point along the approach (measured 3.0-3.5 m)
        assert math.dist(_pos(h), goal) < 2.0
        entry = _pos(h)
        assert vehicle.set_mode(5) is None
        assert isinstance(vehicle.modes.current.task, CurrentStationTask)  # at once
        dists = []
        for _ in range(60):
            await h.run_for(0.5)
            dists.append(math.dist(_pos(h), entry))
        assert max(dists) < 1.5 and isinstance(vehicle.modes.current.task, CurrentStationTask)


async def test_loiter_in_a_weak_current_without_wind_tries_station_then_orbits() -> None:
    """0.4 m/s, weaker than the jet's 0.7 m/s idle creep, no wind, LOITER entered from CRUISE at
    2 m/s: it first keeps station bow into the current (wind from ahead could hold it there); the
    current does not set the boat back onto the point, so after 25 s it orbits the entry point,
    within USV_TURN_RAD + 0.5 m of it over the last 30 s (measured 1.7-2.3 m).  The try costs
    little: at most 7.0 m off (6.3 m orbiting at once; USV_HOLD_MODE 0, the behaviour before
    issue 14: 22.2 m).  The vehicle remembers it: the next hold in this current orbits at once."""
    async with SitlHarness(seed=3, current="0.4,0", full_stack=True) as h:
        vehicle = h.services.vehicle
        await h.run_for(2.0)
        assert vehicle.arm() is None
        assert vehicle.set_mode(20) is None  # CRUISE: make way so the current is observed
        vehicle.speed_override_mps = 2.0
        await h.run_for(40.0)
        entry = _pos(h)
        assert vehicle.set_mode(5) is None
        assert isinstance(vehicle.modes.current.task, CurrentStationTask)
        dists = []
        for _ in range(180):  # 90 s
            await h.run_for(0.5)
            dists.append(math.dist(_pos(h), entry))
        assert isinstance(vehicle.modes.current.task, OrbitTask)
        settled = dists[-60:]  # the last 30 s
        assert max(dists) < 8.0 and min(settled) > 1.0 and max(settled) < 2.8
        est = vehicle.water_current
        assert est is not None
        assert vehicle.station_trials.ruled_out((est.north_mps, est.east_mps), h.ctx.clock.now_s())


async def test_wind_from_ahead_holds_the_boat_on_its_point_in_a_current_weaker_than_the_creep() -> None:
    """0.5 m/s toward W with 6 m/s of wind from E and Hs 0.3 m (usv bench nav's first weather
    slot): bow into the current the boat also heads into the wind, which holds it where the idle
    jet alone would creep.  GUIDED arrives and keeps station; LOITER stays within 1 m of its entry
    point (measured 0.3 m; orbiting, as before USV_HOLD_TRY: 4.3-7.1 m)."""
    async with SitlHarness(seed=1, current="0.5,270", wind="6,90", waves="0.3", full_stack=True) as h:
        vehicle = h.services.vehicle
        await _guided_to_the_point_and_hold(h)
        assert isinstance(vehicle.modes.current.task, CurrentStationTask)
        dists = await _loiter_from_here(h, 120, every_step=CurrentStationTask)
        assert max(dists) < 1.0


async def test_loiter_in_a_flood_with_strong_wind_against_it_ferries_on_its_point() -> None:
    """1.2 m/s toward N with 6 m/s of wind from N and Hs 0.3 m: the wind on the stern of a boat bow
    into the current pushes the idling jet through the water at 1.0-1.5 m/s, faster than the
    current.  Bow straight upstream it crept 2 m up past its point before the bow came off the line
    (2.7 m off within 60 s); the ferry glide sets the bow up to 20 deg off upstream and weaves
    across the current on the point (measured 1.3 m, the last 30 s 0.8 m)."""
    async with SitlHarness(seed=4, current="1.2,0", wind="6,0", waves="0.3", full_stack=True) as h:
        await _guided_to_the_point_and_hold(h)
        dists = await _loiter_from_here(h, 120, every_step=CurrentStationTask)
        assert max(dists) < 2.0 and max(dists[60:]) < 1.5


async def test_loiter_orbit_in_wind_against_a_weak_current_stays_near_its_point() -> None:
    """0.3 m/s toward E with 6 m/s of wind and Hs 0.3 m waves against it (usv bench nav's third
    weather slot, tuning seed 3): the boat cannot stand on its point and orbits it; the wind
    pushes it off the orbit's circle, and the orbit brings it round with the thrust a jet needs to
    turn.  Within 5 m of the entry point over 120 s (measured 4.3 m; with the active model's
    low-speed turn cap on the orbit, 7.0 m).  Seeds 1-6 of this weather: 3.8-4.8 m.  The 3.5 m this
    test also asked of the last 60 s (measured 3.0 m on this seed) held on four of those six seeds
    before the ILOS integral's course gate (2.9-3.8 m) and on two after it (2.9-4.8 m; the gate
    changes GUIDED's go-to, not the orbit, and over the 53 cells of the nav grid LOITER's mean did
    not move): where a wind-driven orbit is after a minute moves by a metre with the state GUIDED
    hands over, so it is not a bound on the orbit (``docs/tuning.md``)."""
    async with SitlHarness(seed=3, current="0.3,90", wind="6,90", waves="0.3", full_stack=True) as h:
        vehicle = h.services.vehicle
        await _guided_to_the_point_and_hold(h)
        dists = await _loiter_from_here(h, 240)
        assert isinstance(vehicle.modes.current.task, OrbitTask)
        assert max(dists) < 5.0


async def test_loiter_in_slack_water_can_stop_the_engine_and_drift() -> None:
    """USV_HOLD_ESTOP 1, slack water with a 4 m/s breeze: LOITER stops the engine, lets the boat
    drift to USV_HOLD_DRIFT (3 m), restarts, comes back and stops again (off by default).  Measured:
    engine off about a third of the time, up to 7.6 m from the point (the restart and the turn
    back); HOLD drifts about 0.4 m/s, 50 m in these two minutes."""
    async with SitlHarness(seed=2, current="0,0", wind="4,0", full_stack=True,
                           params={"USV_HOLD_ESTOP": 1}) as h:
        vehicle = h.services.vehicle
        await h.run_for(2.0)
        assert vehicle.arm() is None
        assert vehicle.set_mode(20) is None  # CRUISE a while: the estimator sees slack water
        vehicle.speed_override_mps = 1.0
        await h.run_for(30.0)
        assert vehicle.set_mode(4) is None  # HOLD: coast to a stop first
        await h.run_for(15.0)
        entry = _pos(h)
        assert vehicle.set_mode(5) is None
        off_s, dists, restarted = 0.0, [], False
        for _ in range(240):
            await h.run_for(0.5)
            dists.append(math.dist(_pos(h), entry))
            off_s += 0.5 * (not h.plant.state.engine_running)
            restarted |= h.plant.state.engine_running and off_s > 0.0
        assert off_s > 25.0 and restarted  # drifted with the engine off, and came back under power
        assert max(dists) < 9.0


async def test_a_circle_item_downstream_of_a_held_one_in_a_flood_is_not_swept_past() -> None:
    """1.2 m/s toward south with 6 m/s of wind along it: after holding on the first circle, the boat runs
    25 m down the current to the next circle item at 3-4 m/s over ground and must turn into the
    current to hold there.  That turn is powered (USV_WP_TURN_SPD through the water, steered as a
    boat making way): turned by station keeping's speed loop, which idled the jet because the boat
    was faster over ground than the corner speed, it drifted bow downstream for 15 s and was swept
    56 m past the point (usv bench nav's tuning grid: 66.7 m from the circle).  The hold is on the
    side the boat is heading for: sent to the other side, its turn onto the leg to the abeam point
    ran through the circle, and it was swept 9.9 m off the circle while turning into the current."""
    async with SitlHarness(seed=1, current="1.2,180", wind="6,0", waves="0.3", full_stack=True) as h:
        vehicle = h.services.vehicle
        points = [(25.0, 25.0), (0.0, 25.0)]
        _upload_circle_items(h, points)
        await h.run_for(20.0)  # the estimator finds the current while the boat drifts
        assert vehicle.arm() is None
        assert vehicle.set_mode(ModeNumber.AUTO) is None
        near, on_circle, farthest_m, off_circle_m = False, False, 0.0, 0.0
        for _ in range(480):
            await h.run_for(0.5)
            if getattr(vehicle.modes.current, "seq", None) != 2:
                if near:
                    break
                continue
            d = math.dist(_pos(h), points[1])
            near = near or d < 15.0
            if near:
                farthest_m = max(farthest_m, d)
            on_circle = on_circle or d < 2.5
            if on_circle:  # usv bench nav's sampling-circle error
                off_circle_m = max(off_circle_m, abs(d - 2.0))
        assert near and on_circle
        assert farthest_m < 17.0  # never swept back out past the 15 m at which the item takes over
        assert off_circle_m < 1.5  # the chapter's 1.2 m and some room (measured 0.4 m)


async def test_a_station_trial_the_boat_runs_past_is_given_up_near_the_point() -> None:
    """0.5 m/s toward S (weaker than the jet's 0.7 m/s idle creep) with 6 m/s of wind against it
    and Hs 0.3 m: GUIDED's hold at the go-to point first tries keeping station bow into the
    current, and the wind drives the idling boat on up the current past the point at about 1 m/s.
    The trial is given up for the orbit within 5.5 m of the point (measured 4.4 m; before, when
    only 3 s of not being set back counted: 7.2 m), and the boat stays within 7.5 m of it over the
    first 60 s (measured 6.8 m)."""
    async with SitlHarness(seed=3, current="0.5,180", wind="6,180", waves="0.3", full_stack=True) as h:
        assert await _guided_to_the_point(h, 60.0, 0.05)
        dists, given_up = await _trial_then_orbit(h, 60.0)
        assert given_up is not None and dists[given_up] < 5.5
        assert max(dists) < 7.5


async def test_rtl_from_upstream_in_a_strong_current_keeps_station_down_onto_home() -> None:
    """1.2 m/s toward S with 3 m/s of wind from E: RTL from the go-to point, 42 m up the current,
    hands over to the station keeper at once, which lets the current set the idling boat back onto
    home with its bow clamped 70 deg off upstream.  Its headway along that bow is across the
    current, not creep: the keeper is never given up for the orbit, and the boat stays within 6 m
    of home after it first comes within 2 m (measured 4.6 m; when that headway counted as creep,
    the keeper was given up for the orbit 13 m out and the boat swung 11.0 m off home)."""
    async with SitlHarness(seed=102, current="1.2,180", wind="3,90", waves="0.15", full_stack=True) as h:
        vehicle = h.services.vehicle
        await _guided_to_the_point_and_hold(h)
        assert vehicle.set_mode(ModeNumber.RTL) is None
        orbited, arrived, after_m = False, False, 0.0
        for _ in range(1500):  # 75 s
            await h.run_for(0.05)
            orbited = orbited or isinstance(vehicle.modes.current.task, OrbitTask)
            home_m = math.hypot(*_pos(h))
            arrived = arrived or home_m <= 2.0
            after_m = max(after_m, home_m) if arrived else 0.0
        assert arrived and not orbited
        assert after_m < 6.0


async def test_an_orbit_taken_up_off_its_point_goes_round_it_the_boats_way_not_through_it() -> None:
    """0.3 m/s toward N with 3 m/s of wind from W: GUIDED arrives at 2.2 m/s, tries keeping station
    bow into the current, runs 8 m past and gives the trial up for the orbit 5.3 m south of the
    point while heading west, going round the point clockwise.  The orbit goes round the same way
    and comes in onto its 2 m circle: over the next 30 s the boat never comes within 1 m of the
    point (measured 1.9 m; when the orbit turned the other way, as a boat entering at the point
    would, the field took it straight through the point, 0.2 m, at 1.5 m/s and out 5.7 m the far
    side) and ends them on the circle."""
    async with SitlHarness(seed=2, current="0.3,0", wind="3,270", waves="0.15", full_stack=True) as h:
        assert await _guided_to_the_point(h, 60.0, 0.05)
        dists, given_up = await _trial_then_orbit(h, 80.0)
        assert given_up is not None
        orbiting = dists[given_up:given_up + 601]  # 30 s
        assert len(orbiting) == 601 and orbiting[0] > 4.0  # taken up well off the point
        assert min(orbiting) > 1.0
        assert 1.0 < orbiting[-1] < 3.0


async def test_loiter_entered_while_the_boat_circles_turns_on_into_its_orbit_not_back_out() -> None:
    """0.3 m/s toward S with 6 m/s of wind and Hs 0.3 m along it (usv bench nav's first weather
    slot): GUIDED orbits its point, and LOITER starts on the boat's position while it turns there
    at 20 deg/s or more.  The new orbit's entry turn goes on the way the boat turns until the
    orbit's heading is ahead of the bow; joining the field with the bow already past it reversed
    the turn, and the boat ran out at 2.5 m/s while the nozzle crossed (6.8 m from the point; 2.8 m
    turning on, seed 1 before the simulated GPS went WGS-84).  Seed 7: 5.2 m joining on either side,
    3.1 m turning on (seeds 1-12 where GUIDED circles then: 3.0-4.7 m, and 2.9-5.2 m joining on
    either side)."""
    async with SitlHarness(seed=7, current="0.3,180", wind="6,0", waves="0.3", full_stack=True) as h:
        vehicle = h.services.vehicle
        await _guided_to_the_point_and_hold(h)
        assert isinstance(vehicle.modes.current.task, OrbitTask)
        assert abs(h.plant.state.r_radps) > math.radians(20.0)  # circling when LOITER starts
        dists = await _loiter_from_here(h, 60, every_step=OrbitTask)
        assert max(dists) < 4.0


@pytest.mark.parametrize("seed", [1, 2])
async def test_loiter_pressed_at_rest_in_slack_water_runs_out_then_orbits_near_its_point(seed: int) -> None:
    """LOITER pressed with the boat at rest in calm water, right after arming: the boat runs out
    along its bow and the orbit's field turns it onto the circle; over the first minute it stays
    within 4 m of where LOITER was pressed (3.7-3.8 m measured) and orbits within 2.5 m from 20 s
    on.  The entry turn from the centre spun the boat for 5 s and ran it out 5.5-5.7 m."""
    async with SitlHarness(seed=seed, full_stack=True) as h:
        assert h.services is not None
        vehicle = h.services.vehicle
        await h.run_for(0.6)
        assert vehicle.arm() is None
        await h.run_for(0.1)
        start = _pos(h)
        assert vehicle.set_mode(ModeNumber.LOITER) is None
        first, later = 0.0, 0.0
        for k in range(600):
            await h.run_for(0.1)
            d = math.dist(_pos(h), start)
            first = max(first, d)
            if k >= 200:
                later = max(later, d)
        assert isinstance(vehicle.modes.current.task, OrbitTask)
        assert first <= 4.0 and later <= 2.5, (first, later)


async def test_a_circle_item_where_holding_failed_in_wind_against_the_current_circles_near_it() -> None:
    """0.8 m/s toward N with 6 m/s of wind from N and Hs 0.3 m (usv bench nav's third weather slot,
    tuning seed 3): the wind on the stern of a boat bow into the current runs the idling jet up it.
    GUIDED gives station keeping up for its orbit, and the first circle item's hold on its circle
    is given up too (the vehicle remembers the current).  The next circle item circles at once, on
    LOITER's hold orbit, and stays within 3.5 m of its circle (usv bench nav's sampling-circle
    error: measured 2.4 m).  Before, it held on its circle again, and the hold and the circle
    tracker's loops that followed took the boat 5.6 m off the circle."""
    async with SitlHarness(seed=3, current="0.8,0", wind="6,0", waves="0.3", full_stack=True) as h:
        vehicle = h.services.vehicle
        await _guided_to_the_point_and_hold(h)
        points = [(55.0, 30.0), (55.0, 55.0)]
        _upload_circle_items(h, points)
        assert vehicle.set_mode(ModeNumber.AUTO) is None
        held = {1: False, 2: False}
        on_circle, off_circle_m = False, 0.0
        for _ in range(1200):
            await h.run_for(0.5)
            seq = getattr(vehicle.modes.current, "seq", None)
            if seq not in (1, 2):
                if on_circle:
                    break
                continue
            held[seq] |= getattr(vehicle.modes.current.run.task, "stem", None) is not None
            d = math.dist(_pos(h), points[1])
            on_circle = on_circle or (seq == 2 and d < 2.5)
            if on_circle:  # usv bench nav's sampling-circle error
                off_circle_m = max(off_circle_m, abs(d - 2.0))
        assert held[1] and not held[2] and on_circle
        assert off_circle_m < 3.5
