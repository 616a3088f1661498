"""The payloads of one vehicle and the API other parts call (MAVLink commands, AUTO mission items).

:class:`Payloads` is created by :class:`~companion.payloads.service.PayloadService`.  The AUTO
mode executes the dialect's mission items through it:

* ``USV_CMD_NAV_SAMPLE_HERE`` (31001): once the boat circles inside the acceptance radius,
  ``job = payloads.start_sample(bottle, fill_s, volume_ml, mission_seq=seq, target=(lat, lon),
  accept_radius_m=...)``; a ``str`` is a refusal (skip the item with a STATUSTEXT), otherwise
  keep circling until ``job.done.done()``; ``job.status`` is then ``complete``/``failed``/``aborted``.
* ``USV_CMD_NAV_LAUNCH_AT`` (31000): at the point, bow on the bearing, stopped for
  ``USV_LNCH_HOLD_S``: ``reason = await payloads.mission_fire(seq)`` (arms and fires in one
  go: the uploaded and started mission item is the operator's explicit intent; every
  physical interlock still applies; ``None`` = fired).
"""

from __future__ import annotations

from dataclasses import dataclass

from companion.app import Context
from companion.messages import Severity, StatusText
from companion.payloads.launcher import RopeLauncher
from companion.payloads.samplelog import SampleLog
from companion.payloads.sampler import SampleJob, SampleRequest, WaterSampler
from companion.payloads.topics import PayloadOutputs


@dataclass
class Payloads:
    """The rope launcher, the water sampler, their shared outputs and the durable log."""

    ctx: Context
    outputs: PayloadOutputs
    samplelog: SampleLog
    launcher: RopeLauncher
    sampler: WaterSampler

    def announce(self, text: str, severity: Severity = Severity.INFO) -> None:
        """A STATUSTEXT for the operator."""
        self.ctx.bus.topic("status_text", StatusText).publish(
            StatusText(t_s=self.ctx.clock.now_s(), severity=severity, text=text[:50])
        )

    def start_sample(
        self,
        bottle: int = 0,
        fill_s: float | None = None,
        volume_ml: float | None = None,
        *,
        mission_seq: int | None = None,
        target: tuple[float, float] | None = None,
        accept_radius_m: float | None = None,
    ) -> SampleJob | str:
        """Start a sample (see :class:`SampleRequest`); a refusal is announced and returned."""
        request = SampleRequest(
            bottle=bottle,
            fill_s=fill_s,
            volume_ml=volume_ml,
            mission_seq=mission_seq,
            target_lat_deg=target[0] if target else None,
            target_lon_deg=target[1] if target else None,
            accept_radius_m=accept_radius_m,
        )
        result = self.sampler.start(request)
        if isinstance(result, str):
            self.announce(result, Severity.WARNING)
        else:
            self.announce(f"sampler: filling bottle {result.bottle}")
        return result

    async def mission_fire(self, mission_seq: int | None = None) -> str | None:
        """Arm and fire for a mission item; the refusal reason (announced) or None when fired."""
        reason = self.launcher.arm(self.ctx.params.get("USV_LNCH_ARM_S"))
        if reason is None:
            reason = await self.launcher.fire(mission_seq=mission_seq)
        if reason is not None:
            self.announce(reason, Severity.WARNING)
        else:
            self.announce_launch()
        return reason

    def announce_launch(self) -> None:
        last = self.launcher.last_launch
        heading = f" hdg {last.heading_deg:.0f}" if last and last.heading_deg is not None else ""
        self.announce(f"launcher: FIRED{heading}", Severity.WARNING)
