"""The MAVLink parameter protocol backed by the one parameter table.

* PARAM_REQUEST_LIST: every parameter as PARAM_VALUE (index, count), paced in small bursts
  so a radio is not flooded; a new request on the same link restarts the list.
* PARAM_REQUEST_READ: by name (``param_index`` -1) or by index.
* PARAM_SET: validated against the table (type, range, choices); accepted values are
  persisted atomically by :class:`~companion.params.ParamStore` and echoed on every link;
  a refused value echoes the old value to the sender and a STATUSTEXT says why.

Integer encoding depends on the profile: under ``ardurover`` integers travel as the float
of their value (ArduPilot's C cast, what MAVSDK and QGC expect from ArduPilot); under
``generic`` the int32 bytes are put in the float field (MAVLink's byte-wise encoding).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import struct
from typing import Any

from companion.app import Context
from companion.link.dialect import mav
from companion.link.endpoint import Link
from companion.link.manager import LinkManager
from companion.messages import Severity
from companion.params import ParamError
from companion.vehicle import Vehicle

log = logging.getLogger(__name__)

LIST_BURST = 25
"""Parameters sent per burst of a list download; bursts are LIST_PAUSE_S apart."""
LIST_PAUSE_S = 0.002

INT_TYPES = {mav.MAV_PARAM_TYPE_UINT8, mav.MAV_PARAM_TYPE_INT8, mav.MAV_PARAM_TYPE_UINT16,
             mav.MAV_PARAM_TYPE_INT16, mav.MAV_PARAM_TYPE_UINT32, mav.MAV_PARAM_TYPE_INT32}


def encode_value(value: float, is_int: bool, bytewise: bool) -> tuple[float, int]:
    """(param_value, param_type) for the wire."""
    if not is_int:
        return float(value), mav.MAV_PARAM_TYPE_REAL32
    if bytewise:
        return struct.unpack("<f", struct.pack("<i", int(value)))[0], mav.MAV_PARAM_TYPE_INT32
    return float(int(value)), mav.MAV_PARAM_TYPE_INT32


def decode_value(wire: float, param_type: int, is_int: bool, bytewise: bool) -> float:
    """The number a PARAM_SET means."""
    if is_int and bytewise and param_type in INT_TYPES:
        raw = struct.pack("<f", wire)
        if param_type in (mav.MAV_PARAM_TYPE_UINT8, mav.MAV_PARAM_TYPE_UINT16, mav.MAV_PARAM_TYPE_UINT32):
            return float(struct.unpack("<I", raw)[0])
        return float(struct.unpack("<i", raw)[0])
    return float(wire)


def _name(msg: Any) -> str:
    pid = msg.param_id
    if isinstance(pid, bytes):
        pid = pid.decode("ascii", "replace")
    return str(pid).rstrip("\x00").strip()


class ParamService:
    """Serves the parameter protocol on every link."""

    def __init__(self, ctx: Context, links: LinkManager, vehicle: Vehicle) -> None:
        self.ctx = ctx
        self.links = links
        self.vehicle = vehicle
        self.bytewise = vehicle.profile != "ardurover"
        self._list_tasks: dict[int, asyncio.Task[None]] = {}
        links.dispatcher.on("PARAM_REQUEST_LIST", self._on_list)
        links.dispatcher.on("PARAM_REQUEST_READ", self._on_read)
        links.dispatcher.on("PARAM_SET", self._on_set)
        links.security.on_deny("PARAM_SET", self._on_denied_set)

    def value_msg(self, name: str) -> Any:
        params = self.ctx.params
        definition = params.definition(name)
        value, ptype = encode_value(params.get(name), definition.is_int, self.bytewise)
        return mav.MAVLink_param_value_message(name.encode("ascii"), value, ptype, len(params),
                                               params.index_of(name))

    def _on_list(self, link: Link, msg: Any) -> None:
        old = self._list_tasks.pop(id(link), None)
        if old is not None:
            old.cancel()
        task = asyncio.get_running_loop().create_task(self._send_list(link), name=f"param-list-{link.name}")
        self._list_tasks[id(link)] = task
        task.add_done_callback(lambda t: self._list_tasks.pop(id(link), None)
                               if self._list_tasks.get(id(link)) is t else None)

    async def _send_list(self, link: Link) -> None:
        for index, name in enumerate(self.ctx.params.names()):
            if link.closed:
                return
            link.send(self.value_msg(name))
            if index % LIST_BURST == LIST_BURST - 1:
                await asyncio.sleep(LIST_PAUSE_S)  # pacing the socket, not vehicle behaviour

    def _on_read(self, link: Link, msg: Any) -> None:
        params = self.ctx.params
        try:
            name = params.name_at(int(msg.param_index)) if msg.param_index >= 0 else _name(msg)
            link.send(self.value_msg(params.definition(name).name))
        except ParamError as exc:
            log.debug("PARAM_REQUEST_READ from %s: %s", link.name, exc)

    def _on_denied_set(self, link: Link, msg: Any) -> None:
        """A PARAM_SET the security policy refused: answer with the unchanged value, as for a bad one."""
        name = _name(msg)
        if name in self.ctx.params:
            link.send(self.value_msg(self.ctx.params.definition(name).name))

    def _on_set(self, link: Link, msg: Any) -> None:
        name = _name(msg)
        params = self.ctx.params
        if name not in params:
            self.vehicle.status(f"Param set refused: unknown parameter {name!r}", Severity.WARNING)
            return
        definition = params.definition(name)
        value = decode_value(float(msg.param_value), int(msg.param_type), definition.is_int, self.bytewise)
        if definition.is_int and not self.bytewise:
            value = float(round(value)) if abs(value - round(value)) < 1e-3 else value
        try:
            params.set(name, value)
        except ParamError as exc:
            link.send(self.value_msg(name))
            self.vehicle.status(f"Param set refused: {exc}", Severity.WARNING)
            return
        except OSError as exc:  # disk full or read-only: the value is live but not saved
            self.vehicle.status(f"Param {name} set but not saved: {exc}", Severity.WARNING)
        if definition.reboot_required:
            self.vehicle.status(f"{name} takes effect after a restart")
        self.links.broadcast(self.value_msg(name))

    async def stop(self) -> None:
        for task in list(self._list_tasks.values()):
            task.cancel()
            with contextlib.suppress(BaseException):
                await task
