"""The MAVLink mission protocol for MISSION, FENCE and RALLY plans (MISSION_ITEM_INT).

Upload (ground station -> boat): MISSION_COUNT, then the boat requests every item with
MISSION_REQUEST_INT and validates it on arrival (an invalid item ends the upload with the
MAV_MISSION_RESULT code of :mod:`companion.mission.validate`); a request that gets no
answer within :data:`ITEM_TIMEOUT_S` (0.25 s, PX4's mission retry timeout) is repeated up to
:data:`MAX_RETRIES` times (10 s of silence); the
plan is installed and persisted only when complete and valid, then MISSION_ACK.  A ground
station that sends the last item again (its MISSION_ACK was lost) gets the same MISSION_ACK
again, as from PX4, instead of silence.

Download: MISSION_REQUEST_LIST -> MISSION_COUNT; items are served statelessly for any
request, so lost packets only cost the ground station a retry.

Item 0 under the ``ardurover`` profile: QGroundControl, Mission Planner and MAVProxy put a
placeholder for home at item 0 of an ArduPilot mission; MAVSDK's Mission plugin does not.
A complete upload is classified by :func:`companion.mission.convention.classify`: a
placeholder is stored as such (never executed, and served back filled with the current home,
as ArduPilot does), anything else is the first mission item (served back exactly as
uploaded); an empty mission downloads as home alone, as from ArduPilot.  An upload whose
item 0 could be either is refused with MAV_MISSION_INVALID and a STATUSTEXT saying how to make
it unambiguous; the accepting STATUSTEXT names the convention.  The ``generic`` profile has no
placeholder.

Also: MISSION_CLEAR_ALL, MISSION_SET_CURRENT (answered with MISSION_CURRENT) and
MISSION_ITEM_REACHED broadcast when AUTO reports progress.
"""

from __future__ import annotations

import asyncio
import logging
import math
from dataclasses import dataclass, field
from typing import Any

from companion.app import Context
from companion.link.dialect import mav
from companion.link.endpoint import Link
from companion.link.manager import LinkManager
from companion.mavlink import telemetry
from companion.messages import GuidedTarget, ModeNumber, Severity
from companion.mission import convention, route
from companion.mission import validate as v
from companion.mission.items import MissionItem, MissionType
from companion.vehicle import Vehicle

log = logging.getLogger(__name__)

GUIDED_ITEM = 2
"""MISSION_ITEM.current value of a guided-mode target (ArduPilot)."""
ITEM_TIMEOUT_S = 0.25
"""A ground station waits for the next request, not resending its item: MAVSDK gives up after
about six of its 0.5 s timeouts, so with 1.5 s here a 30 %-lossy link failed MAVSDK's uploads
(measured through benchmarks/lossy_link.py); 0.25 s is PX4's MAVLINK_MISSION_RETRY_TIMEOUT."""
MAX_RETRIES = 40
CHECK_PERIOD_S = 0.05


@dataclass
class Upload:
    """An upload in progress on one link for one mission type."""

    link: Link
    peer: tuple[int, int]
    mission_type: int
    count: int
    items: list[MissionItem] = field(default_factory=list)
    deadline_s: float = 0.0
    retries: int = 0

    @property
    def expected(self) -> int:
        return len(self.items)


def item_from_msg(msg: Any) -> MissionItem:
    """MISSION_ITEM_INT (or the float MISSION_ITEM) -> :class:`MissionItem`."""
    if msg.get_type() == "MISSION_ITEM_INT":
        x, y = int(msg.x), int(msg.y)
    else:  # MISSION_ITEM: degrees as float; NaN becomes an impossible value so validation refuses it
        x = round(msg.x * 1e7) if math.isfinite(msg.x) else 2**31 - 1
        y = round(msg.y * 1e7) if math.isfinite(msg.y) else 2**31 - 1
    return MissionItem(seq=int(msg.seq), frame=int(msg.frame), command=int(msg.command), param1=msg.param1,
                       param2=msg.param2, param3=msg.param3, param4=msg.param4, x=x, y=y, z=msg.z,
                       current=int(msg.current), autocontinue=int(msg.autocontinue),
                       mission_type=int(getattr(msg, "mission_type", 0)))


class MissionService:
    """Serves the mission protocol on every link."""

    def __init__(self, ctx: Context, links: LinkManager, vehicle: Vehicle, *,
                 validator: v.MissionValidator = v.BUILT_IN,
                 item_timeout_s: float = ITEM_TIMEOUT_S, max_retries: int = MAX_RETRIES) -> None:
        self.ctx = ctx
        self.links = links
        self.vehicle = vehicle
        self.validator = validator
        self.store = vehicle.missions
        self.item_timeout_s = item_timeout_s
        self.max_retries = max_retries
        self.uploads: dict[tuple[int, int], Upload] = {}
        self.finished: dict[tuple[int, int], tuple[int, int]] = {}
        """(link, mission type) -> (item count, MISSION_ACK result) of the last upload that ended
        with its last item: a repeat of that item means our MISSION_ACK was lost, so it is resent."""
        self.completed_uploads = 0
        d = links.dispatcher
        d.on("MISSION_COUNT", self._on_count)
        d.on("MISSION_ITEM_INT", self._on_item)
        d.on("MISSION_ITEM", self._on_item)
        d.on("MISSION_REQUEST_LIST", self._on_request_list)
        d.on("MISSION_REQUEST_INT", self._on_request)
        d.on("MISSION_REQUEST", self._on_request)
        d.on("MISSION_CLEAR_ALL", self._on_clear)
        d.on("MISSION_SET_CURRENT", self._on_set_current)
        d.on("MISSION_ACK", self._on_ack)
        vehicle.reached_listeners.append(self._on_reached)

    @property
    def home_first(self) -> bool:
        return self.vehicle.profile == "ardurover"

    # -- helpers ------------------------------------------------------------------------
    def _ack(self, link: Link, peer: tuple[int, int], result: int, mission_type: int) -> None:
        link.send(mav.MAVLink_mission_ack_message(peer[0], peer[1], result, mission_type))

    def _request(self, up: Upload) -> None:
        up.link.send(mav.MAVLink_mission_request_int_message(up.peer[0], up.peer[1], up.expected,
                                                             up.mission_type))
        up.deadline_s = self.ctx.clock.now_s() + self.item_timeout_s

    def _refuse(self, up: Upload, problem: v.ItemProblem) -> None:
        self.uploads.pop((id(up.link), up.mission_type), None)
        self._ack(up.link, up.peer, problem.code, up.mission_type)
        self.vehicle.status(f"Mission upload refused: {problem.reason}", Severity.WARNING)

    # -- upload -------------------------------------------------------------------------
    def _on_count(self, link: Link, msg: Any) -> None:
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        mtype = int(getattr(msg, "mission_type", 0))
        if mtype not in tuple(MissionType):
            self._ack(link, peer, v.UNSUPPORTED, mtype)
            return
        count = int(msg.count)
        self.finished.pop((id(link), mtype), None)
        if count == 0:
            self.uploads.pop((id(link), mtype), None)
            self.store.replace(mtype, [])
            self._ack(link, peer, v.ACCEPTED, mtype)
            return
        capacity = v.MAX_ITEMS[mtype] + (1 if self.home_first and mtype == MissionType.MISSION else 0)
        if count > capacity:
            self._ack(link, peer, v.NO_SPACE, mtype)
            self.vehicle.status(f"Mission upload refused: {count} items exceed {capacity}", Severity.WARNING)
            return
        up = Upload(link, peer, mtype, count)
        self.uploads[(id(link), mtype)] = up
        self._request(up)

    def _on_item(self, link: Link, msg: Any) -> None:
        mtype = int(getattr(msg, "mission_type", 0))
        up = self.uploads.get((id(link), mtype))
        if up is None:
            if int(msg.current) == GUIDED_ITEM and mtype == MissionType.MISSION:
                self._guided_item(link, msg)
                return
            finished = self.finished.get((id(link), mtype))
            if finished is not None and int(msg.seq) == finished[0] - 1:  # our MISSION_ACK was lost
                self._ack(link, (msg.get_srcSystem(), msg.get_srcComponent()), finished[1], mtype)
            return  # else a late duplicate after the upload finished, or no upload: ignore
        seq = int(msg.seq)
        if seq != up.expected:
            if seq < up.expected:
                self._request(up)  # our request was answered twice or lost: ask again for the next one
            return
        item = item_from_msg(msg).with_seq(seq)
        maybe_home = (self.home_first and seq == 0 and mtype == MissionType.MISSION
                      and convention.looks_like_home(item))
        # fully checked at the end if not home
        problem = self.validator.validate_item(item, home_item=maybe_home)
        if problem is not None:
            self._refuse(up, problem)
            if seq == up.count - 1:
                self.finished[(id(link), mtype)] = (up.count, problem.code)
            return
        up.items.append(item)
        up.retries = 0
        if up.expected < up.count:
            self._request(up)
            return
        problem = self._store(mtype, up.items)
        if problem is not None:
            self._refuse(up, problem)
            self.finished[(id(link), mtype)] = (up.count, problem.code)
            return
        del self.uploads[(id(link), mtype)]
        self.finished[(id(link), mtype)] = (up.count, v.ACCEPTED)
        self._ack(link, up.peer, v.ACCEPTED, mtype)

    def _guided_item(self, link: Link, msg: Any) -> None:
        """A MISSION_ITEM(_INT) with current = 2: ArduPilot's "guided mode waypoint" (MAVProxy's
        ``guided``): a new GUIDED target, answered with MISSION_ACK (ACCEPTED; ERROR outside GUIDED;
        INVALID_PARAM5_X/6_Y for a bad or refused position, with a STATUSTEXT)."""
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        item = item_from_msg(msg)
        vehicle = self.vehicle
        if vehicle.modes.current.number != ModeNumber.GUIDED:
            self._ack(link, peer, v.ERROR, MissionType.MISSION)
            vehicle.status("Guided target refused: not in GUIDED", Severity.WARNING)
            return
        problem = self.validator.validate_item(item.with_seq(0))
        reason = None if problem is not None else vehicle.target_problem(item.lat_deg, item.lon_deg)
        if problem is not None or reason is not None:
            code = problem.code if problem is not None else v.INVALID_PARAM5_X
            self._ack(link, peer, code, MissionType.MISSION)
            why = problem.reason if problem is not None else reason
            vehicle.status(f"Guided target refused: {why}", Severity.WARNING)
            return
        vehicle.guided_target = GuidedTarget(item.lat_deg, item.lon_deg, None, None, self.ctx.clock.now_s())
        self._ack(link, peer, v.ACCEPTED, MissionType.MISSION)

    def install(self, mission_type: int, items: list[MissionItem]) -> v.ItemProblem | None:
        """Install a complete plan as a finished upload does, for a client in the same process
        (``usv campaign``): every item checked as it would be on arrival, then item 0's convention,
        the whole plan, storage and the accepting STATUSTEXT.  The problem (nothing installed, and a
        STATUSTEXT saying why) or ``None``."""
        items = [item.with_seq(seq) for seq, item in enumerate(items)]
        for item in items:
            maybe_home = (self.home_first and item.seq == 0 and mission_type == MissionType.MISSION
                          and convention.looks_like_home(item))
            problem = self.validator.validate_item(item, home_item=maybe_home)
            if problem is not None:
                self.vehicle.status(f"Mission upload refused: {problem.reason}", Severity.WARNING)
                return problem
        problem = self._store(mission_type, items)
        if problem is not None:
            self.vehicle.status(f"Mission upload refused: {problem.reason}", Severity.WARNING)
        return problem

    def _store(self, mtype: int, items: list[MissionItem]) -> v.ItemProblem | None:
        """Item 0's convention, the whole plan, storage; the problem, or ``None`` and the plan stored
        (and announced)."""
        verdict = self._convention(mtype, items)
        if verdict.convention is None:
            return v.ItemProblem(v.INVALID, verdict.reason)
        home_item = verdict.convention is convention.Convention.HOME_PLACEHOLDER
        problem = self.validator.validate_plan(items, home_first=home_item)
        if problem is None:
            problem = self._destinations_problem(mtype, items[1:] if home_item else items)
        if problem is not None:
            return problem
        try:
            self.store.replace(mtype, items, home_item=home_item)
        except OSError as exc:
            return v.ItemProblem(v.ERROR, f"mission not saved: {exc}")
        self.completed_uploads += 1
        kind = MissionType(mtype).name.lower()
        how = f" ({verdict.reason})" if mtype == MissionType.MISSION and self.home_first else ""
        self.vehicle.status(f"{kind.capitalize()} received: {len(items)} items{how}")
        return None

    def _destinations_problem(self, mtype: int, items: list[MissionItem]) -> v.ItemProblem | None:
        """The first mission item whose position the vehicle refuses (the geofence; INVALID_PARAM5_X,
        the code of a position the item must not have), then the first leg between them (from home;
        INVALID), :func:`companion.mission.route.route_problem`; rally points are checked as places."""
        vehicle = self.vehicle
        if mtype == MissionType.RALLY:
            for item in items:
                if (reason := vehicle.destination_problem(item.lat_deg, item.lon_deg)) is not None:
                    return v.ItemProblem(v.INVALID_PARAM5_X, f"rally point {item.seq}: {reason}")
            return None
        if mtype != MissionType.MISSION:
            return None
        home = None if vehicle.home is None else (vehicle.home.lat_deg, vehicle.home.lon_deg)
        return route.route_problem(items, home, self.validator.needs_position, vehicle.destination_problem,
                                   vehicle.legs_problem)

    def _convention(self, mtype: int, items: list[MissionItem]) -> convention.Verdict:
        """How item 0 of a complete upload is to be read (always plain without home-first)."""
        if not (self.home_first and mtype == MissionType.MISSION):
            return convention.Verdict(convention.Convention.PLAIN, "")
        home = self.vehicle.home
        return convention.classify(items, None if home is None else (home.lat_deg, home.lon_deg))

    async def run(self) -> None:
        """Repeat unanswered item requests; give up after :attr:`max_retries`."""
        while True:
            await self.ctx.clock.sleep(CHECK_PERIOD_S)
            now_s = self.ctx.clock.now_s()
            if len(self.finished) > 64:  # links come and go (TCP): keep the memory bounded
                self.finished.clear()
            for key, up in list(self.uploads.items()):
                if up.link.closed:
                    del self.uploads[key]
                elif now_s >= up.deadline_s:
                    if up.retries >= self.max_retries:
                        del self.uploads[key]
                        self._ack(up.link, up.peer, v.OPERATION_CANCELLED, up.mission_type)
                        self.vehicle.status(f"Mission upload timed out at item {up.expected}",
                                            Severity.WARNING)
                    else:
                        up.retries += 1
                        self._request(up)

    # -- download -----------------------------------------------------------------------
    def download_plan(self, mission_type: int) -> list[MissionItem]:
        """What a download returns: the plan as uploaded, a home placeholder filled with the current
        home; no mission under ``ardurover`` is home alone, as ArduPilot serves it (MAVProxy's
        ``wp list`` waits for at least one item)."""
        plan = self.store.items(mission_type)
        home = self.vehicle.home
        if not (self.home_first and mission_type == MissionType.MISSION and home is not None):
            return plan
        home_item = MissionItem.home(home.lat_deg, home.lon_deg, home.alt_m)
        if not plan:
            return [home_item]
        if self.vehicle.first_mission_seq == 1:
            plan[0] = home_item
        return plan

    def _on_request_list(self, link: Link, msg: Any) -> None:
        mtype = int(getattr(msg, "mission_type", 0))
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        if mtype not in tuple(MissionType):
            self._ack(link, peer, v.UNSUPPORTED, mtype)
            return
        link.send(mav.MAVLink_mission_count_message(peer[0], peer[1], len(self.download_plan(mtype)), mtype))

    def _on_request(self, link: Link, msg: Any) -> None:
        mtype = int(getattr(msg, "mission_type", 0))
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        if mtype not in tuple(MissionType):
            self._ack(link, peer, v.UNSUPPORTED, mtype)
            return
        plan = self.download_plan(mtype)
        seq = int(msg.seq)
        if not 0 <= seq < len(plan):
            self._ack(link, peer, v.INVALID_SEQUENCE, mtype)
            return
        it = plan[seq]
        current = 1 if (mtype == MissionType.MISSION and seq == self.vehicle.current_seq) else 0
        if msg.get_type() == "MISSION_REQUEST_INT":
            link.send(mav.MAVLink_mission_item_int_message(
                peer[0], peer[1], seq, it.frame, it.command, current, it.autocontinue, it.param1, it.param2,
                it.param3, it.param4, it.x, it.y, it.z, mtype))
        else:
            link.send(mav.MAVLink_mission_item_message(
                peer[0], peer[1], seq, it.frame, it.command, current, it.autocontinue, it.param1, it.param2,
                it.param3, it.param4, it.lat_deg, it.lon_deg, it.z, mtype))

    def _on_ack(self, link: Link, msg: Any) -> None:
        return None  # end of a download: nothing to clean up (downloads are stateless)

    # -- other --------------------------------------------------------------------------
    def _on_clear(self, link: Link, msg: Any) -> None:
        mtype = int(getattr(msg, "mission_type", 0))
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        if mtype not in (*tuple(MissionType), mav.MAV_MISSION_TYPE_ALL):
            self._ack(link, peer, v.UNSUPPORTED, mtype)
            return
        self.store.clear(mtype)
        self._ack(link, peer, v.ACCEPTED, mtype)

    def _on_set_current(self, link: Link, msg: Any) -> None:
        reason = self.vehicle.set_current(int(msg.seq))
        if reason:
            self.vehicle.status(f"Set current refused: {reason}", Severity.WARNING)
        link.send(telemetry.mission_current(self.ctx, self.vehicle))

    def _on_reached(self, seq: int) -> None:
        self.links.broadcast(mav.MAVLink_mission_item_reached_message(seq))

    async def stop(self) -> None:
        self.uploads.clear()
        await asyncio.sleep(0)
