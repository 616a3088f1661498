import subprocess
from pathlib import Path

import pytest

from companion.config import ConfigError, load_config, parse_config
from companion.param_table import all_param_defs

from .conftest import usv_command


def test_defaults_work_for_sitl() -> None:
    cfg = load_config(None, all_param_defs())
    assert cfg["links.udp_targets"] == ["127.0.0.1:14550", "127.0.0.1:14540"]
    assert cfg["links.tcp_listen"] == "127.0.0.1:5760"
    assert cfg["vehicle.profile"] == "ardurover"


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ({"links": {"tcp_prot": 1}},
         r"unknown config key 'links.tcp_prot'; known keys in \[links\]: .*links.tcp_listen"),
        ({"nosuch": {"x": 1}}, "unknown config key 'nosuch.x'; known sections"),
        ({"sensors": {"gnss_baud": 10}},
         r"sensors.gnss_baud: invalid value 10; accepted: int in \[1200, 4e\+06\]"),
        ({"vehicle": {"profile": "px4"}},
         "vehicle.profile: invalid value 'px4'; accepted: one of 'ardurover'"),
        ({"links": {"udp_targets": ["localhost"]}}, "links.udp_targets: invalid entry 'localhost'"),
        ({"links": {"tcp_listen": "127.0.0.1:70000"}}, r"links.tcp_listen: .*port must be 1..65535"),
        ({"links": {"serial": ["/dev/ttyUSB1:fast"]}}, "links.serial: .*baud must be a positive integer"),
        ({"sim": {"speedup": float("nan")}}, "sim.speedup: invalid value nan"),
        ({"params": {"USV_TURN_RAD": 1000}}, r"params.USV_TURN_RAD: 1000 is out of range \[0.5, 50\] m"),
        ({"params": {"NOT_A_PARAM": 1}}, "unknown parameter params.NOT_A_PARAM"),
    ],
)
def test_bad_keys_and_values_name_the_key_and_the_accepted_range(doc: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_config(doc, all_param_defs())


def test_params_table_sets_initial_parameter_values() -> None:
    cfg = parse_config({"params": {"USV_TURN_RAD": 3}}, all_param_defs())
    assert cfg.params == {"USV_TURN_RAD": 3.0}


@pytest.mark.parametrize(
    ("content", "needle"),
    [
        ("[links]\ntcp_port = 5760\n", "links.tcp_port"),
        ("[sim]\nseed = -4\n", "sim.seed"),
        ("this is not toml ===", "not valid TOML"),
    ],
)
def test_cli_reports_a_bad_config_in_one_line_and_exits_nonzero(
    tmp_path: Path, usv_env: dict[str, str], content: str, needle: str
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(content)
    proc = subprocess.run([*usv_command(), "sitl", "--config", str(path)], capture_output=True, text=True,
                          env=usv_env, timeout=60)
    assert proc.returncode == 2
    assert needle in proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def test_cli_reports_a_missing_config_file(tmp_path: Path, usv_env: dict[str, str]) -> None:
    proc = subprocess.run([*usv_command(), "companion", "--config", str(tmp_path / "nope.toml")],
                          capture_output=True, text=True, env=usv_env, timeout=60)
    assert proc.returncode == 2
    assert "cannot read config file" in proc.stderr and "Traceback" not in proc.stderr
