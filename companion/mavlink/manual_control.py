"""MAVLink MANUAL_CONTROL (msg 69) -> pilot input on the bus (MANUAL passthrough, CRUISE steering).

Read as ArduPilot Rover does (``GCS_MAVLINK_Rover::handle_manual_control``): only messages
addressed to this vehicle (``target`` = SYSID_THISMAV) count; ``y`` is steering and ``z`` is
throttle (see :mod:`companion.control.manual_input` for the scaling); and a MANUAL_CONTROL counts
as a ground-station heartbeat for the GCS failsafe, since a joystick ground station keeps
sending it.  The normalised input is published on ``manual_control``.
"""

from __future__ import annotations

from typing import Any

from companion.app import Context
from companion.control.manual_input import from_manual_control
from companion.link.endpoint import Link
from companion.link.manager import LinkManager
from companion.messages import MANUAL_CONTROL_TOPIC


def register_manual_control(ctx: Context, links: LinkManager) -> None:
    """Handle MANUAL_CONTROL on every link of ``links``."""
    topic = ctx.bus.topic(MANUAL_CONTROL_TOPIC)

    def on_manual_control(link: Link, msg: Any) -> None:
        if int(getattr(msg, "target", -1)) != links.system_id:
            return  # aimed at another vehicle
        link.gcs.heard(heartbeat=False)
        topic.publish(from_manual_control(ctx.clock.now_s(), float(msg.y), float(msg.z)))

    links.dispatcher.on("MANUAL_CONTROL", on_manual_control)
