"""Upload checks of the payload mission items (31000 launch-at, 31001 sample-here): bad items
are refused at upload with the MAV_MISSION_* code of the offending parameter."""

from __future__ import annotations

import math

import pytest

from companion.link.dialect import mav
from companion.mission import items as mi
from companion.mission import validate as v
from companion.mission.items import MissionItem
from companion.mission.validate import ItemRule, MissionValidator
from companion.payloads.launcher import PAYLOAD as LAUNCHER
from companion.payloads.registry import PayloadRegistry
from companion.payloads.sampler import PAYLOAD as SAMPLER
from mavlink_dialect import UsvCmd
from tests.mavlink.sitl_gcs import run_until_done, sitl_with_gcs
from tests.mavlink.test_params_missions import download, upload

LAT_E7, LON_E7 = 417700000, 1234300000
NAN = math.nan


def _item(command: int, p1: float = 0.0, p2: float = 0.0, p3: float = 0.0, p4: float = 0.0, *,
          x: int = LAT_E7 + 2000, y: int = LON_E7, seq: int = 1) -> MissionItem:
    return MissionItem(seq=seq, frame=mi.FRAME_GLOBAL_RELATIVE_ALT_INT, command=command, param1=p1, param2=p2,
                       param3=p3, param4=p4, x=x, y=y)


@pytest.fixture
def validator(tmp_path) -> MissionValidator:
    """The upload checks of a vehicle with the launcher and the sampler (their mission actions)."""
    import dataclasses

    from tests.mavlink.helpers import make_ctx

    ctx = make_ctx()
    ctx = dataclasses.replace(ctx, config=ctx.config.with_overrides({"vehicle.state_dir": str(tmp_path)}))
    actions = PayloadRegistry(ctx, (LAUNCHER, SAMPLER)).mission_actions
    return MissionValidator({c: ItemRule(a.needs_position, a.check) for c, a in actions.items()})


@pytest.mark.parametrize("item", [
    _item(UsvCmd.NAV_SAMPLE_HERE), _item(UsvCmd.NAV_SAMPLE_HERE, 4, 2.0, 30.0, 250.0),
    _item(UsvCmd.NAV_SAMPLE_HERE, NAN, NAN, NAN, NAN), _item(UsvCmd.NAV_LAUNCH_AT, NAN),
    _item(UsvCmd.NAV_LAUNCH_AT, 359.5, 5.0), _item(UsvCmd.NAV_LAUNCH_AT, 0.0),
    _item(UsvCmd.NAV_LAUNCH_AT, 90.0, 0.0, 15.0), _item(UsvCmd.NAV_LAUNCH_AT, 90.0, 0.0, NAN),
])
def test_good_payload_items_accepted(item: MissionItem, validator: MissionValidator) -> None:
    assert validator.validate_item(item) is None


@pytest.mark.parametrize("item,code", [
    (_item(UsvCmd.NAV_SAMPLE_HERE, 5), v.INVALID_PARAM1),
    (_item(UsvCmd.NAV_SAMPLE_HERE, -1), v.INVALID_PARAM1),
    (_item(UsvCmd.NAV_SAMPLE_HERE, 1.5), v.INVALID_PARAM1),
    (_item(UsvCmd.NAV_SAMPLE_HERE, math.inf), v.INVALID_PARAM1),
    (_item(UsvCmd.NAV_SAMPLE_HERE, 1, 0.1), v.INVALID_PARAM2),
    (_item(UsvCmd.NAV_SAMPLE_HERE, 1, 80.0), v.INVALID_PARAM2),
    (_item(UsvCmd.NAV_SAMPLE_HERE, 1, -2.0), v.INVALID_PARAM2),
    (_item(UsvCmd.NAV_SAMPLE_HERE, 1, 0, -5.0), v.INVALID_PARAM3),
    (_item(UsvCmd.NAV_SAMPLE_HERE, 1, 0, 0, 1e6), v.INVALID_PARAM4),
    (_item(UsvCmd.NAV_SAMPLE_HERE, 1, 0, 0, math.inf), v.INVALID_PARAM4),
    (_item(UsvCmd.NAV_SAMPLE_HERE, x=0, y=0), v.INVALID_PARAM5_X),
    (_item(UsvCmd.NAV_SAMPLE_HERE, x=95 * 10**7), v.INVALID_PARAM5_X),
    (_item(UsvCmd.NAV_SAMPLE_HERE, y=-181 * 10**7), v.INVALID_PARAM6_Y),
    (_item(UsvCmd.NAV_LAUNCH_AT, 400.0), v.INVALID_PARAM1),
    (_item(UsvCmd.NAV_LAUNCH_AT, -10.0), v.INVALID_PARAM1),
    (_item(UsvCmd.NAV_LAUNCH_AT, NAN, -1.0), v.INVALID_PARAM2),
    (_item(UsvCmd.NAV_LAUNCH_AT, NAN, 1e5), v.INVALID_PARAM2),
    (_item(UsvCmd.NAV_LAUNCH_AT, 90.0, 0.0, -5.0), v.INVALID_PARAM3),
    (_item(UsvCmd.NAV_LAUNCH_AT, 90.0, 0.0, 200.0), v.INVALID_PARAM3),  # beyond the rope
    (_item(UsvCmd.NAV_LAUNCH_AT, 90.0, 0.0, math.inf), v.INVALID_PARAM3),
])
def test_bad_payload_items_refused_with_code(item: MissionItem, code: int,
                                            validator: MissionValidator) -> None:
    problem = validator.validate_item(item)
    assert problem is not None and problem.code == code, problem


@pytest.mark.integration
async def test_bad_sample_item_refused_at_upload_over_mavlink() -> None:
    """The full stack (lockstep SITL) registers the checks; a ground station's upload of a plan
    with a bad sample item is refused with INVALID_PARAM1 and installs nothing."""
    home = MissionItem.home(41.77, 123.43, 0.0)
    async with sitl_with_gcs() as (h, gcs):
        bad = [home, _item(16, seq=1), _item(UsvCmd.NAV_SAMPLE_HERE, 7, seq=2)]
        ack = await run_until_done(h, upload(gcs, bad))
        assert ack.type == mav.MAV_MISSION_INVALID_PARAM1
        bad_radius = [home, _item(UsvCmd.NAV_SAMPLE_HERE, 1, 500.0, seq=1)]
        assert (await run_until_done(h, upload(gcs, bad_radius))).type == mav.MAV_MISSION_INVALID_PARAM2
        bad_bearing = [home, _item(UsvCmd.NAV_LAUNCH_AT, 720.0, seq=1)]
        assert (await run_until_done(h, upload(gcs, bad_bearing))).type == mav.MAV_MISSION_INVALID_PARAM1
        assert len(await run_until_done(h, download(gcs))) <= 1  # nothing was installed
        good = [home, _item(UsvCmd.NAV_SAMPLE_HERE, 2, 1.5, 0, 100, seq=1),
                _item(UsvCmd.NAV_LAUNCH_AT, 90, seq=2)]
        assert (await run_until_done(h, upload(gcs, good))).type == mav.MAV_MISSION_ACCEPTED
        assert len(await run_until_done(h, download(gcs))) == 3
