import json
import subprocess

from .conftest import usv_command


def test_usv_bench_prints_one_json_object_with_every_benchmark(usv_env: dict[str, str]) -> None:
    proc = subprocess.run([*usv_command(), "bench", "--quick", "--only", "mavlink_codec"],
                          capture_output=True, text=True, env=usv_env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert set(result) == {"meta", "benchmarks"}
    codec = result["benchmarks"]["mavlink_codec"]
    assert codec["encode_msgs_per_s"] > 0 and codec["parse_msgs_per_s"] > 0
    assert "HEARTBEAT" in codec["messages"] and "GLOBAL_POSITION_INT" in codec["messages"]


def test_every_registered_benchmark_module_has_a_run_function() -> None:
    import importlib

    from benchmarks import BENCHMARKS

    for name, module_name in BENCHMARKS.items():
        assert callable(importlib.import_module(module_name).run), name
