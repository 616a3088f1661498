"""Wiring: build the shared context and the ordered list of companion services.

This is the one place that knows which services make up the companion and in which
order they start (links before the modules that publish on them, the control loop last).
The same list runs on the boat (wall clock, serial devices) and in SITL (simulation
clock, in-memory pipes or pseudo-terminals to :mod:`sim_bridge`).
"""

from __future__ import annotations

import logging
import sys

from companion.app import BaseService, Context, Service
from companion.bus import Bus
from companion.clock import Clock
from companion.config import Config
from companion.param_table import all_param_defs
from companion.params import ParamStore

log = logging.getLogger(__name__)


def build_context(config: Config, clock: Clock) -> Context:
    """Parameters come from (lowest first): the table's defaults, the config file's
    ``[params]`` table, then values saved by the operator through a ground station."""
    state_dir = config.state_dir()
    state_dir.mkdir(parents=True, exist_ok=True)
    params = ParamStore(all_param_defs())
    for name, value in config.params.items():
        params.set(name, value, persist=False)
    saved = ParamStore(all_param_defs(), state_dir / "params.toml")
    for warning in saved.load_warnings:
        log.warning("%s", warning)
    for name in params.names():
        if saved.get(name) != saved.definition(name).default:
            params.set(name, saved.get(name), persist=False)
    params.path = state_dir / "params.toml"
    return Context(config=config, clock=clock, bus=Bus(), params=params)


class ReadyBanner(BaseService):
    """Tells the operator where ground stations connect, once every service has started."""

    name = "ready-banner"

    def __init__(self, ctx: Context, title: str) -> None:
        self.ctx = ctx
        self.title = title

    async def start(self) -> None:
        cfg = self.ctx.config
        lines = [f"{self.title} ready"]
        for target in cfg["links.udp_targets"]:
            port = target.rpartition(":")[2]
            who = {"14550": "QGroundControl", "14540": "MAVSDK (udpin://0.0.0.0:14540)"}.get(port, "GCS")
            lines.append(f"  MAVLink UDP -> {target}  ({who})")
        if cfg["links.tcp_listen"]:
            lines.append(f"  MAVLink TCP server {cfg['links.tcp_listen']}  (MAVProxy: "
                         f"mavproxy.py --master=tcp:{cfg['links.tcp_listen']})")
        for port in cfg["links.serial"]:
            lines.append(f"  MAVLink serial {port}")
        lines.append(f"  state directory {cfg.state_dir()}")
        lines.append("  press Ctrl-C to stop")
        print("\n".join(lines), flush=True)
        sys.stdout.flush()


def build_companion_services(ctx: Context) -> list[Service]:
    """The companion's services in start-up order."""
    services: list[Service] = []
    from companion.estimation.service import make_estimator_stage  # qLPV + UKF model error (Eq. 5-11)
    from companion.loop import get_control_loop

    get_control_loop(ctx).add_stage("estimator", make_estimator_stage(ctx))  # before any controller
    from companion.mavlink.service import build_mavlink_services  # links, vehicle, commands, missions

    services.extend(build_mavlink_services(ctx))
    from companion.payloads.service import PayloadService  # rope launcher, water sampler

    services.append(PayloadService(ctx))
    from companion.loop import build_hardware_services  # GPS-INS parser, control loop, servo output

    services += build_hardware_services(ctx)  # last: every stage is registered before samples flow
    return services
