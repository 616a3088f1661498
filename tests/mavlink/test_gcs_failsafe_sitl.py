"""Ground-station failsafe end to end, in lockstep SITL time (not wall time).

A ground station on loopback UDP sends HEARTBEATs every simulated second (from a control-loop
stage, so they follow the simulation clock), arms the boat and sends it out in GUIDED, then
goes silent.  After FS_GCS_TIMEOUT simulated seconds the companion switches to FS_ACTION's
mode with a STATUSTEXT; after USV_FS_ENG_STOP (the chapter's engine stop; shortened here to
keep the test's simulated duration modest) it disarms: ignition off at the simulator's servo
input, the engine stops and the boat coasts.  When the ground station comes back the failsafe
clears but nothing dangerous is restored: the boat stays disarmed in the failsafe mode.
"""

from __future__ import annotations

import asyncio
import math

import pytest

from companion.link.dialect import mav
from companion.mavlink.params import PARAMS
from companion.messages import NAV_TOPIC, ModeNumber, NavState
from sim_bridge.simboat import CH_IGNITION
from tests.mavlink.sitl_gcs import run_until_done, sitl_with_gcs

pytestmark = pytest.mark.integration

FS_GCS_TIMEOUT_S = 5.0
ENG_STOP_S = 25.0
MODE_GUIDED, MODE_RTL = ModeNumber.GUIDED, ModeNumber.RTL


def test_engine_stop_default_is_the_chapters_120_s() -> None:
    assert {p.name: p.default for p in PARAMS}["USV_FS_ENG_STOP"] == 120.0


async def test_gcs_loss_rtl_then_engine_stop_then_nothing_restored() -> None:
    params = {"FS_GCS_ENABLE": 1, "FS_GCS_TIMEOUT": FS_GCS_TIMEOUT_S, "FS_ACTION": 1,
              "USV_FS_ENG_STOP": ENG_STOP_S, "WP_SPEED": 4.0}
    async with sitl_with_gcs(params=params) as (h, gcs):
        heartbeats = {"on": True, "next_s": 0.0}

        def gcs_heartbeat(nav: NavState) -> None:
            if heartbeats["on"] and nav.t_s >= heartbeats["next_s"]:
                heartbeats["next_s"] = nav.t_s + 1.0
                gcs.heartbeat()

        h.ctx.bus.topic(NAV_TOPIC).add_listener(gcs_heartbeat)  # a GCS on simulated time
        await h.run_for(2.0)
        vehicle = h.services.vehicle
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        nav = vehicle.nav()
        assert nav is not None
        target_lat = nav.lat_deg + 300.0 / 111_320.0
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_REPOSITION, -1,
                                                  mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, 0,
                                                  round(target_lat * 1e7), round(nav.lon_deg * 1e7), 0,
                                                  as_int=True, frame=mav.MAV_FRAME_GLOBAL_INT))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        await h.run_for(15.0)
        assert vehicle.modes.current.number == MODE_GUIDED
        assert h.plant.state.speed_mps > 2.0 and h.plant.state.north_m > 20.0

        # The ground station goes silent.
        heartbeats["on"] = False
        last_hb_s = heartbeats["next_s"] - 1.0
        fs_text = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "GCS failsafe" in m.text, 60))
        while not fs_text.done():
            await h.run_for(0.1)
            assert h.clock.now_s() - last_hb_s < FS_GCS_TIMEOUT_S + 2.0, "no failsafe"
        action_s = h.clock.now_s() - last_hb_s
        assert FS_GCS_TIMEOUT_S <= action_s <= FS_GCS_TIMEOUT_S + 0.5  # simulated seconds
        assert vehicle.modes.current.number == MODE_RTL and vehicle.armed
        hb = await run_until_done(h, gcs.wait("HEARTBEAT", lambda m: m.custom_mode == MODE_RTL))
        assert hb.system_status == mav.MAV_STATE_CRITICAL
        assert h.plant.state.engine_running

        # Engine stop after USV_FS_ENG_STOP without ground-station data.
        while vehicle.armed:
            await h.run_for(0.1)
            assert h.clock.now_s() - last_hb_s < ENG_STOP_S + 2.0, "engine never stopped"
        stop_s = h.clock.now_s() - last_hb_s
        assert ENG_STOP_S <= stop_s <= ENG_STOP_S + 0.5
        speed_at_stop = h.plant.state.speed_mps
        assert speed_at_stop > 1.0  # still returning home when the engine stops
        await h.run_for(2.0)
        assert h.boat.pulses[CH_IGNITION] == 1100 and not h.plant.state.engine_running
        assert 0.0 < h.plant.state.speed_mps < speed_at_stop  # coasting, slowing down
        await h.run_for(10.0)
        assert h.plant.state.speed_mps < 0.5 * speed_at_stop

        # The ground station returns: the failsafe clears, the boat stays disarmed in RTL.
        cleared = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "failsafe cleared" in m.text, 30))
        heartbeats["on"] = True
        await run_until_done(h, cleared)
        await h.run_for(5.0)
        assert not vehicle.armed and vehicle.modes.current.number == MODE_RTL
        assert h.boat.pulses[CH_IGNITION] == 1100 and not h.plant.state.engine_running
        assert not math.isnan(h.plant.state.north_m)


async def test_gcs_loss_while_returning_home_keeps_rtl_until_home_and_still_stops_the_engine() -> None:
    """As ArduPilot Rover: a boat already in RTL is not switched to FS_ACTION's HOLD (which would
    leave it drifting); it goes on home, and the engine stop still comes after USV_FS_ENG_STOP."""
    params = {"FS_GCS_ENABLE": 1, "FS_GCS_TIMEOUT": FS_GCS_TIMEOUT_S, "FS_ACTION": 2,
              "USV_FS_ENG_STOP": ENG_STOP_S, "WP_SPEED": 4.0}
    async with sitl_with_gcs(params=params) as (h, gcs):
        heartbeats = {"on": True, "next_s": 0.0}

        def gcs_heartbeat(nav: NavState) -> None:
            if heartbeats["on"] and nav.t_s >= heartbeats["next_s"]:
                heartbeats["next_s"] = nav.t_s + 1.0
                gcs.heartbeat()

        h.ctx.bus.topic(NAV_TOPIC).add_listener(gcs_heartbeat)
        await h.run_for(2.0)
        vehicle = h.services.vehicle
        assert (await run_until_done(h, gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1))).result == 0
        nav = vehicle.nav()
        assert nav is not None
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_REPOSITION, -1,
                                                  mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, 0,
                                                  round((nav.lat_deg + 60.0 / 111_320.0) * 1e7),
                                                  round(nav.lon_deg * 1e7), 0, as_int=True,
                                                  frame=mav.MAV_FRAME_GLOBAL_INT))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        await h.run_for(20.0)
        assert vehicle.set_mode(MODE_RTL) is None and h.plant.state.north_m > 30.0

        heartbeats["on"] = False  # lost while returning
        last_hb_s = heartbeats["next_s"] - 1.0
        home_text = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "home reached" in m.text, 60))
        home_s = None
        while vehicle.armed:
            await h.run_for(0.1)
            if home_s is None and home_text.done():
                home_s = h.clock.now_s() - last_hb_s
            assert vehicle.modes.current.number == MODE_RTL  # never HOLD, before or after home
            assert h.clock.now_s() - last_hb_s < ENG_STOP_S + 2.0, "engine never stopped"
        assert ENG_STOP_S <= h.clock.now_s() - last_hb_s <= ENG_STOP_S + 0.5
        assert home_s is not None and FS_GCS_TIMEOUT_S + 2.0 < home_s < ENG_STOP_S  # lost before home
