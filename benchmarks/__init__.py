"""Benchmarks: every speed and accuracy figure of the project, printed as one JSON object.

Adding a benchmark: a module here with ``run(quick: bool) -> dict`` and one line in
:data:`BENCHMARKS`.  ``quick`` shortens runs (used by the shape test); figures in notes
and issues come from full runs (``usv bench``).
"""

BENCHMARKS: dict[str, str] = {
    "mavlink_codec": "benchmarks.mavlink_codec",
    "mavlink_link": "benchmarks.mavlink_link",
    "fence_legs": "benchmarks.fence_legs",
    "ukf": "benchmarks.ukf",
    "identify": "benchmarks.identify",
    "sim_plant": "benchmarks.sim_plant",
    "sim_lockstep": "benchmarks.sim_lockstep",
    "sim_sitl": "benchmarks.sim_sitl",
    "control": "benchmarks.control",
    "nav": "benchmarks.nav",
    "campaign": "benchmarks.campaign",
    "fuzz": "benchmarks.fuzz",
    "lossy_link": "benchmarks.lossy_sweep",
    "mqtt": "benchmarks.mqtt",
}
"""Benchmark name -> module with ``run(quick: bool) -> dict``."""
