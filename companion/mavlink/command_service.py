"""Answers COMMAND_LONG and COMMAND_INT through the command registry.

Rules (MAVLink command protocol):

* exactly one final COMMAND_ACK per command, sent on the link it came from;
* unknown id -> ``MAV_RESULT_UNSUPPORTED``;
* NaN/infinite in a required parameter -> ``MAV_RESULT_DENIED`` + STATUSTEXT reason;
* a handler that has not finished after :data:`IN_PROGRESS_AFTER_S` gets an IN_PROGRESS ack
  first (handlers may send their own progress with ``cmd.progress(percent)``);
* a retransmission of a command that is still running is answered IN_PROGRESS, not run twice;
* a repeat of a command accepted moments ago (a retry whose ACK was lost, a duplicated frame) is
  answered with the cached ACK, not run again (:mod:`companion.mavlink.command_history`);
* a handler exception -> ``MAV_RESULT_FAILED``; the process carries on.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import Any

from companion.app import Context
from companion.link.dialect import mav
from companion.link.endpoint import Link
from companion.link.manager import LinkManager
from companion.mavlink.command_history import CommandHistory, command_signature
from companion.mavlink.commands import MAV_RESULT, CommandRegistry, CommandRequest, CommandResult
from companion.messages import Severity
from companion.vehicle import Vehicle

log = logging.getLogger(__name__)

IN_PROGRESS_AFTER_S = 0.2
"""A handler running longer than this (vehicle clock) is acknowledged IN_PROGRESS first."""

_Key = tuple[int, int, int, int]


class CommandService:
    """Receives commands from every link and answers them."""

    def __init__(self, ctx: Context, links: LinkManager, vehicle: Vehicle, registry: CommandRegistry) -> None:
        self.ctx = ctx
        self.links = links
        self.vehicle = vehicle
        self.registry = registry
        self._running: dict[_Key, tuple[asyncio.Task[None], list[int]]] = {}
        self._tasks: set[asyncio.Task[None]] = set()
        self.history = CommandHistory()
        """Recently accepted commands: their repeats get the cached ACK."""
        links.dispatcher.on("COMMAND_LONG", self._on_command)
        links.dispatcher.on("COMMAND_INT", self._on_command)

    def _on_command(self, link: Link, msg: Any) -> None:
        is_int = msg.get_type() == "COMMAND_INT"
        if is_int:
            params = (msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y), msg.z)
            frame, confirmation = int(msg.frame), 0
        else:
            params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
            frame, confirmation = 0, int(msg.confirmation)
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        key = (id(link), src[0], src[1], int(msg.command))
        running = self._running.get(key)
        if running is not None and not running[0].done():
            self.send_ack(link, int(msg.command), MAV_RESULT.IN_PROGRESS, src, progress=running[1][0])
            return
        values = tuple(float(p) for p in params)
        signature = command_signature(frame, values, is_int)
        repeat = self.history.repeat_of(src, int(msg.command), signature, self.ctx.clock.now_s(),
                                        state=self._state())
        if repeat is not None:
            self.send_ack(link, int(msg.command), repeat.result, src, result_param2=repeat.result_param2)
            if self.history.first_repeat(src, int(msg.command)):
                window_s = self.history.window_s
                self.vehicle.status(f"Command {int(msg.command)} repeated within {window_s:.0f} s:"
                                    " earlier ACK resent, not run again")
            return
        progress = [0]

        def progress_cb(percent: int) -> None:
            progress[0] = percent
            self.send_ack(link, int(msg.command), MAV_RESULT.IN_PROGRESS, src, progress=percent)

        cmd = CommandRequest(int(msg.command), values, is_int=is_int, frame=frame,  # type: ignore[arg-type]
                             source_system=src[0], source_component=src[1], confirmation=confirmation,
                             progress_cb=progress_cb, link=link)
        task = asyncio.get_running_loop().create_task(self._execute(link, cmd, src),
                                                      name=f"cmd-{msg.command}")
        self._running[key] = (task, progress)
        self._tasks.add(task)

        def done(t: asyncio.Task[None]) -> None:
            self._tasks.discard(t)
            if self._running.get(key, (None,))[0] is t:
                del self._running[key]

        task.add_done_callback(done)

    def _state(self) -> tuple[bool, int]:
        """What a repeat must find unchanged to be answered from the cache: armed and mode."""
        return (bool(self.vehicle.armed), int(self.vehicle.modes.current.number))

    async def _execute(self, link: Link, cmd: CommandRequest, src: tuple[int, int]) -> None:
        result = await self._run_handler(link, cmd, src)
        self.send_ack(link, cmd.command, result.result, src, result_param2=result.result_param2)
        if result.after_ack is not None:
            try:
                result.after_ack()
            except Exception:
                log.exception("after-ack action of command %d failed", cmd.command)
        self.history.record(src, cmd.command, command_signature(cmd.frame, cmd.params, cmd.is_int),
                            result.result, result.result_param2, self.ctx.clock.now_s(),
                            accepted=result.result == MAV_RESULT.ACCEPTED, state=self._state())
        if result.reason and result.result not in (MAV_RESULT.ACCEPTED, MAV_RESULT.IN_PROGRESS):
            self.vehicle.status(result.reason, Severity.WARNING)
        elif result.reason:
            self.vehicle.status(result.reason)

    async def _run_handler(self, link: Link, cmd: CommandRequest, src: tuple[int, int]) -> CommandResult:
        spec = self.registry.get(cmd.command)
        if spec is None:
            log.debug("unsupported command %d from %s", cmd.command, link.name)
            return CommandResult.unsupported()
        bad = cmd.nan_params(spec.required_params)
        if bad:
            names = ", ".join(f"param{i}" for i in bad)
            return CommandResult.denied(f"{spec.name}: {names} must be a finite number")
        task = asyncio.ensure_future(spec.handler(cmd))
        timer = asyncio.ensure_future(self.ctx.clock.sleep(IN_PROGRESS_AFTER_S))
        try:
            done, _ = await asyncio.wait({task, timer}, return_when=asyncio.FIRST_COMPLETED)
            if task not in done:
                cmd.progress(0)
                await asyncio.wait({task})
            result = task.result()
        except asyncio.CancelledError:
            task.cancel()
            raise
        except Exception as exc:
            log.exception("command %d handler failed", cmd.command)
            return CommandResult.failed(f"{spec.name} failed: {exc}")
        finally:
            timer.cancel()
        if not isinstance(result, CommandResult):
            log.error("command %d handler returned %r, not a CommandResult", cmd.command, result)
            return CommandResult.failed(f"{spec.name}: internal error")
        return result

    def send_ack(self, link: Link, command: int, result: int, src: tuple[int, int], *, progress: int = 0,
                 result_param2: int = 0) -> None:
        link.send(mav.MAVLink_command_ack_message(command, result, progress, result_param2, src[0], src[1]))

    async def stop(self) -> None:
        for task in list(self._tasks):
            task.cancel()
        for task in list(self._tasks):
            with contextlib.suppress(BaseException):
                await task
