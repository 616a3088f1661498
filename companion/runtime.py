"""Wiring: the companion's parts, built once in start-up order into one typed record.

This is the one place that knows which parts make up the companion, what each one is given
and in which order the services start (links before the modules that send on them, the
hardware last, so every stage exists before samples flow).  The same wiring runs on the boat
(wall clock, serial devices) and in SITL (simulation clock, in-memory pipes or
pseudo-terminals to :mod:`sim_bridge`).  The 100 Hz path itself reads top to bottom in
:mod:`companion.pipeline`.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Sequence
from dataclasses import dataclass

from companion.actuators.servo import ServoMap
from companion.app import BaseService, Context, Service
from companion.bus import Bus
from companion.clock import Clock
from companion.config import Config, parse_host_port, parse_serial
from companion.control.system import ControlSystem
from companion.estimation.service import (
    EstimatorStage,
    load_companion_current_settings,
    load_companion_model,
    load_companion_ukf_backend,
    load_companion_ukf_settings,
)
from companion.fence.guard import FenceGuard
from companion.fence.plans import FencePlanCheck
from companion.hardware import HardwareIoService, HardwareLinks
from companion.link.manager import LinkManager
from companion.mavlink.commands import CommandRegistry
from companion.mavlink.service import MavlinkService
from companion.mavlink.telemetry import Telemetry
from companion.mission.cursor import MissionCursor
from companion.mission.store import MissionStore
from companion.mission.validate import ItemRule, MissionValidator
from companion.modes.manager import MODE_CLASSES, ModeManager
from companion.mqtt.commands import CommandTarget, MqttCommands
from companion.mqtt.outbox import OUTBOX_NAME, Outbox
from companion.mqtt.records import RecordFeed
from companion.mqtt.service import MqttService
from companion.mqtt.settings import mqtt_settings
from companion.mqtt.snapshot import StateSnapshot
from companion.navhealth.stage import NavHealth
from companion.param_table import all_param_defs
from companion.params import ParamStore
from companion.payloads.launcher.device import RopeLauncher
from companion.payloads.registry import PayloadDef, PayloadRegistry, built_in_payloads
from companion.payloads.sampler.device import WaterSampler
from companion.pipeline import LoopStats, Pipeline, ServoOutput
from companion.vehicle import Vehicle, home_placeholder_profile

log = logging.getLogger(__name__)


def build_context(config: Config, clock: Clock, extra_payloads: Sequence[PayloadDef] = ()) -> Context:
    """Parameters come from (lowest first): the table's defaults, the config file's
    ``[params]`` table, then values saved by the operator through a ground station.
    ``extra_payloads``: payloads beyond the built-in ones (their parameters join the table)."""
    state_dir = config.state_dir()
    state_dir.mkdir(parents=True, exist_ok=True)
    defs = all_param_defs(extra_payloads)
    params = ParamStore(defs)
    for name, value in config.params.items():
        params.set(name, value, persist=False)
    saved = ParamStore(defs, state_dir / "params.toml")
    for warning in saved.load_warnings:
        log.warning("%s", warning)
    for name in params.names():
        if saved.get(name) != saved.definition(name).default:
            params.set(name, saved.get(name), persist=False)
    params.path = state_dir / "params.toml"
    return Context(config=config, clock=clock, bus=Bus(), params=params)


@dataclass(frozen=True)
class Services:
    """Every part of one companion, in the order they were built (see :func:`build_companion`)."""

    ctx: Context
    payloads: PayloadRegistry
    """Rope launcher, water sampler (and any added payload), their sample log."""
    links: LinkManager
    """MAVLink transports (UDP, TCP, serial) and the message dispatcher."""
    commands: CommandRegistry
    """COMMAND_LONG / COMMAND_INT handlers: the vehicle's and the payloads'."""
    estimator: EstimatorStage
    """qLPV + UKF model error (Eq. 5-11), stage 2 of the pipeline."""
    control: ControlSystem
    """PID / active-model controller families and the actuator mapping (stage 4 of the pipeline)."""
    vehicle: Vehicle
    """Arming, home, targets, modes (stage 3 of the pipeline) and mission progress."""
    fence: FenceGuard
    """The geofence (stage 2b of the pipeline), target and pre-arm checks."""
    fence_plans: FencePlanCheck
    """The stored mission and rally points re-checked when the fence changes; AUTO refused on conflict."""
    nav_health: NavHealth
    """GPS-INS fault detection and the degraded action (stage 1 of the pipeline)."""
    pipeline: Pipeline
    """The 100 Hz path: sample -> estimator -> modes -> controller -> servo frame."""
    mavlink: MavlinkService
    """Everything the vehicle says and answers on its links."""
    hardware: HardwareIoService
    """GPS-INS in, servo frames out."""
    mqtt: MqttService | None = None
    """Telemetry, records and events for MQTT dashboards (``None``: no ``[mqtt] url``)."""

    def in_start_order(self) -> list[Service]:
        """The services with a life cycle, in start-up order (stopped in reverse)."""
        extra: list[Service] = [self.mqtt] if self.mqtt is not None else []
        return [self.links, self.mavlink, self.payloads, *extra, self.hardware]


def build_companion(ctx: Context, hardware: HardwareLinks | None = None,
                    extra_payloads: Sequence[PayloadDef] = ()) -> Services:
    """Build every part of the companion; ``hardware``: ready-made GPS-INS/servo links (SITL);
    ``extra_payloads``: payloads beyond the built-in ones (give the same to :func:`build_context`)."""
    config, params, clock, bus = ctx.config, ctx.params, ctx.clock, ctx.bus
    # the payloads first: they contribute commands, mission actions, outputs, telemetry, sentences
    payloads = PayloadRegistry(ctx, (*built_in_payloads(), *extra_payloads))
    actions = payloads.mission_actions
    streams = {s.msg_id: (s.rate_hz, s.stream_group) for s in payloads.status_messages}
    links = LinkManager(ctx, extra_streams=streams)
    commands = CommandRegistry()
    payloads.register_commands(commands)
    # the control side: model, estimator, controller families, modes, the vehicle they run on
    model = load_companion_model(config)
    estimator = EstimatorStage(model, load_companion_ukf_settings(config), load_companion_ukf_backend(config),
                               load_companion_current_settings(config))
    control = ControlSystem(params, clock, bus, model)
    profile = str(config["vehicle.profile"])
    mission = MissionCursor(MissionStore(config.state_dir() / "missions"), home_placeholder_profile(profile))
    vehicle = Vehicle(ctx, mission, ModeManager(MODE_CLASSES), control, actions)
    fence = FenceGuard(params, clock, bus, vehicle, mission.store)
    nav_health = NavHealth(params, clock, bus, vehicle)
    # the 100 Hz pipeline: sample -> estimator -> modes -> controller -> servo frame
    servo_map = ServoMap(params, payloads.servo_channels, overrides_us=vehicle.servo_overrides_us)
    output = ServoOutput(servo_map, clock, bus, LoopStats())
    pipeline = Pipeline(bus=bus, estimator=estimator, modes=vehicle.update_mode, controller=control,
                        output=output, mode_failed=vehicle.mode_failed, fence=fence.step,
                        nav_health=nav_health)
    # the MAVLink face and the hardware seam
    telemetry = Telemetry(ctx, vehicle, {s.msg_id: s.build for s in payloads.status_messages})
    validator = MissionValidator({a.command: ItemRule(a.needs_position, a.check) for a in actions.values()})
    fence_plans = FencePlanCheck(params, vehicle, mission.store, validator.needs_position)
    mavlink = MavlinkService(ctx, links, vehicle, commands, telemetry, validator, servo_map)
    hardware_io = HardwareIoService(ctx, pipeline, hardware, payloads.sentences)
    # MQTT dashboards, only when configured
    mqtt = build_mqtt(ctx, vehicle, links, payloads)
    return Services(ctx=ctx, payloads=payloads, links=links, commands=commands, estimator=estimator,
                    control=control, vehicle=vehicle, fence=fence, fence_plans=fence_plans,
                    nav_health=nav_health, pipeline=pipeline, mavlink=mavlink,
                    hardware=hardware_io, mqtt=mqtt)


def build_mqtt(ctx: Context, vehicle: Vehicle, links: LinkManager,
               payloads: PayloadRegistry) -> MqttService | None:
    """The MQTT service of ``[mqtt]`` (``None`` without ``mqtt.url``: nothing needs a broker)."""
    settings = mqtt_settings(ctx.config, ctx.params.get_int("SYSID_THISMAV"))
    if settings is None:
        return None
    launcher, sampler = payloads.find(RopeLauncher), payloads.find(WaterSampler)
    snapshot = StateSnapshot(ctx, vehicle, links, launcher, sampler)
    outbox = Outbox(ctx.config.state_dir() / OUTBOX_NAME)
    feed = RecordFeed(ctx, outbox, payloads.samplelog.path)
    commands = None
    if settings.commands_enabled:
        stop_pump = sampler.stop_pump if sampler is not None else None
        target = CommandTarget(vehicle.set_mode, stop_pump, vehicle.status)
        commands = MqttCommands(settings, target)
    return MqttService(ctx, settings, snapshot, outbox, feed, commands)


class ReadyBanner(BaseService):
    """Tells the operator where ground stations connect, once every service has started.

    Only endpoints that are really open are announced as such: a TCP port that could not be
    bound is printed as not available, with the reason (``LinkManager.unavailable``).
    """

    name = "ready-banner"

    def __init__(self, ctx: Context, title: str, links: LinkManager | None = None) -> None:
        self.ctx = ctx
        self.title = title
        self.links = links

    async def start(self) -> None:
        print(self.text(), flush=True)
        sys.stdout.flush()

    def text(self) -> str:
        cfg = self.ctx.config
        lines = [f"{self.title} ready"]
        for target in cfg["links.udp_targets"]:
            port = parse_host_port(target)[1]
            who = {14550: "QGroundControl", 14540: "MAVSDK (udpin://0.0.0.0:14540)"}.get(port, "GCS")
            lines.append(f"  MAVLink UDP -> {target}  ({who})")
        tcp = cfg["links.tcp_listen"]
        if tcp:
            problem = self.links.unavailable.get(f"TCP server {tcp}") if self.links is not None else None
            if problem is not None or (self.links is not None and self.links.tcp is None):
                lines.append(f"  MAVLink TCP server {tcp} NOT AVAILABLE ({problem or 'not open'})")
            else:
                lines.append(f"  MAVLink TCP server {tcp}  (MAVProxy: mavproxy.py --master=tcp:{tcp})")
        radios = {radio.device: radio for radio in self.links.serial} if self.links is not None else {}
        for port in cfg["links.serial"]:
            radio = radios.get(parse_serial(port, 0)[0])
            if radio is not None and not radio.is_open:
                lines.append(f"  MAVLink serial {port} NOT OPEN (cannot open the device; retrying)")
            else:
                lines.append(f"  MAVLink serial {port}")
        if cfg["mqtt.url"]:
            vehicle_id = cfg["mqtt.vehicle_id"] or f"usv{self.ctx.params.get_int('SYSID_THISMAV')}"
            lines.append(f"  MQTT {cfg['mqtt.url']}  (topics usv/{vehicle_id}/#, e.g. "
                         f"mosquitto_sub -L {cfg['mqtt.url']}/usv/{vehicle_id}/# -v)")
        lines.append(f"  state directory {cfg.state_dir()}")
        lines.append("  press Ctrl-C to stop")
        return "\n".join(lines)
