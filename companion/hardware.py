"""The boat's hardware seam: the GPS-INS link in, the servo link out.

:class:`HardwareIoService` opens both byte links (serial devices, pseudo-terminals or UDP from
the configuration; in SITL the simulator hands over ready-made links, :class:`HardwareLinks`),
feeds the GPS-INS bytes to the parser, which runs the :class:`~companion.pipeline.Pipeline` on
every navigation sample, and gives the pipeline's servo output its link.  Without samples for
``USV_NAV_TMO_S`` it still refreshes the servo frame at 10 Hz, so failsafe commands reach the
servos when the GPS-INS is silent.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from companion.app import BaseService, Context
from companion.pipeline import Pipeline
from companion.sensors.gpsins import GpsInsParser
from companion.transport import ByteLink, open_link

log = logging.getLogger(__name__)

REFRESH_S = 0.1
"""Servo frame refresh period without navigation samples."""


@dataclass(frozen=True)
class HardwareLinks:
    """Ready-made links to the boat's hardware (the simulator or a test gives them); ``None``
    opens the one configured in ``sensors.gnss_port`` / ``servos.port``."""

    gnss: ByteLink | None = None
    servo: ByteLink | None = None


class HardwareIoService(BaseService):
    """Opens the GPS-INS and servo links, runs the pipeline per sample, refreshes servos."""

    name = "hardware-io"

    def __init__(self, ctx: Context, pipeline: Pipeline, links: HardwareLinks | None = None,
                 extra_sentences: Mapping[str, Callable[[list[str]], None]] | None = None) -> None:
        """``extra_sentences``: the payloads' sentences of the GPS-INS box (name -> handler)."""
        self.ctx = ctx
        self.pipeline = pipeline
        self.given = links or HardwareLinks()
        self.parser = GpsInsParser(ctx.clock, ctx.bus, pipeline.on_sample, extra_sentences)
        self.gnss: ByteLink | None = None
        self.servo: ByteLink | None = None

    def _link(self, given: ByteLink | None, setting: str, baud: int) -> ByteLink | None:
        if given is not None:
            return given
        spec = str(self.ctx.config[setting])
        if not spec:
            return None
        return open_link(spec, self.ctx.clock, baud, what=setting)

    async def start(self) -> None:
        baud = int(self.ctx.config["sensors.gnss_baud"])
        self.gnss = self._link(self.given.gnss, "sensors.gnss_port", baud)
        self.servo = self._link(self.given.servo, "servos.port", baud)
        if self.gnss is None:
            log.warning("no GPS-INS link (sensors.gnss_port is empty): the control loop will not run")
        else:
            self.gnss.set_receiver(self.parser.feed)
            await self.gnss.open()
        if self.servo is not None:
            await self.servo.open()
            if self.servo is not self.gnss:
                self.servo.set_receiver(lambda _data: None)
        self.pipeline.output.link = self.servo

    async def run(self) -> None:
        clock = self.ctx.clock
        timeout_s = self.ctx.params.get_or("USV_NAV_TMO_S", 0.5)
        while True:
            await clock.sleep(REFRESH_S)
            last = self.pipeline.last_sample_s
            if last is None or clock.now_s() - last > timeout_s:
                self.pipeline.refresh()

    async def stop(self) -> None:
        self.pipeline.output.link = None
        for link in (self.gnss, self.servo):
            if link is not None:
                await link.close()
        await asyncio.sleep(0)
