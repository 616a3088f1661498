"""Operator overrides of free servo outputs (MAV_CMD_DO_SET_SERVO, MAV_CMD_DO_SET_RELAY).

The servo frame has :data:`~companion.actuators.servo.N_CHANNELS` outputs.  Most are owned by
the autopilot and carry safety-critical functions (the ``USV_CH_*`` parameters): nozzle,
throttle, ignition and RC/GCS selector (:data:`OWNED_CHANNEL_PARAMS`), and every output a
payload declares (rope-launcher trigger, sampler pump and sampler valve; see
:mod:`companion.payloads.registry`).  An operator override may never drive those: the launcher
must stay behind its interlocks, the engine behind arming and the failsafes, the bottles behind
the sample log.  Only the remaining *free* outputs (channel 2 with the default wiring) accept
an override.

Relays (DO_SET_RELAY) are on/off outputs on free channels too: relay ``n`` (0-based, as in
MAVLink) drives the channel in parameter ``USV_RLY{n}_CH`` (0 = not wired; by default relay 0
is channel 2, the auxiliary output, e.g. a searchlight or horn) with ``USV_SW_PWM_ON`` /
``USV_SW_PWM_OFF``.  Ownership is checked twice: when the command arrives (refused with the
function's name) and again for every frame (:meth:`ServoMap.pulses` drops an override whose
channel became autopilot-owned after a parameter change).
"""

from __future__ import annotations

from collections.abc import Iterable

from companion.params import ParamStore

N_RELAYS = 4
"""Relay instances 0..N_RELAYS-1 (each with its ``USV_RLY{n}_CH`` parameter)."""

OWNED_CHANNEL_PARAMS: tuple[tuple[str, int, str], ...] = (
    ("USV_CH_NOZZLE", 1, "nozzle (steering)"),
    ("USV_CH_THROTTLE", 3, "throttle"),
    ("USV_CH_IGNITION", 5, "ignition"),
    ("USV_CH_SELECTOR", 6, "RC/GCS selector"),
)
"""Parameter, default channel and function of the boat's own outputs (payloads add theirs)."""


def owned_channels(params: ParamStore,
                   payload_outputs: Iterable[tuple[str, int, str]] = ()) -> dict[int, str]:
    """1-based channel -> function of every output the autopilot owns (never overridable):
    the boat's own and ``payload_outputs`` (parameter, default channel, function)."""
    owned: dict[int, str] = {}
    for name, default, function in (*OWNED_CHANNEL_PARAMS, *payload_outputs):
        channel = int(params.get_or(name, default))
        owned.setdefault(channel, function)
    return owned


def relay_channel(params: ParamStore, relay: int) -> int:
    """1-based output channel of relay ``relay`` (0: not wired)."""
    return int(params.get_or(f"USV_RLY{relay}_CH", 0)) if 0 <= relay < N_RELAYS else 0


def override_refusal(owned: dict[int, str], channel: int, n_channels: int) -> str | None:
    """Why ``channel`` (1-based) cannot be overridden (short, for a STATUSTEXT: the owned
    output's function from ``owned``, or "not wired"), or ``None`` if it is a free output."""
    if not 1 <= channel <= n_channels:
        return f"not wired (outputs 1-{n_channels})"
    return owned.get(channel)
