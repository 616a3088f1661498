"""The one parameter table: every subsystem's :class:`~companion.params.ParamDef` list.

Adding a parameter: put its ``ParamDef`` in the ``PARAMS`` tuple of the subsystem's
``params`` module (or add a new module and one line below); a payload declares its own in its
``PayloadDef`` (:mod:`companion.payloads.registry`).  Order here is the MAVLink
param_index order, so append rather than insert once a release is out.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from companion.params import ParamDef

if TYPE_CHECKING:
    from companion.payloads.registry import PayloadDef

CORE_PARAMS: tuple[ParamDef, ...] = (
    ParamDef("SYSID_THISMAV", 1, 1, 255, "", "MAVLink system id of this vehicle.", is_int=True,
             reboot_required=True),
    ParamDef("FRAME_CLASS", 2, 2, 2, "", "ArduPilot Rover frame class; 2 = boat (read by GCS software).",
             is_int=True, choices=((2, "Boat"),)),
)


def all_param_defs(extra_payloads: Sequence[PayloadDef] = ()) -> tuple[ParamDef, ...]:
    """Every parameter of the product, in param_index order; the built-in payloads' in their
    place, those of ``extra_payloads`` (added to a vehicle, e.g. a test fixture) at the end."""
    from companion.actuators.params import PARAMS as ACTUATOR_PARAMS
    from companion.control.params import PARAMS as CONTROL_PARAMS
    from companion.fence.params import PARAMS as FENCE_PARAMS
    from companion.guidance.hold_params import PARAMS as HOLD_PARAMS
    from companion.guidance.params import PARAMS as GUIDANCE_PARAMS
    from companion.link.params import PARAMS as LINK_PARAMS
    from companion.mavlink.params import PARAMS as MAVLINK_PARAMS
    from companion.mqtt.params import PARAMS as MQTT_PARAMS
    from companion.navhealth.params import PARAMS as NAVHEALTH_PARAMS
    from companion.payloads.registry import built_in_payloads, payload_params

    return (CORE_PARAMS + GUIDANCE_PARAMS + CONTROL_PARAMS + payload_params(built_in_payloads())
            + MAVLINK_PARAMS + ACTUATOR_PARAMS + LINK_PARAMS + HOLD_PARAMS + FENCE_PARAMS + NAVHEALTH_PARAMS
            + MQTT_PARAMS + payload_params(extra_payloads))
