"""The asyncio test ground station (shared with the benchmarks)."""

from benchmarks.mavlink_gcs import AsyncGcs, free_port

__all__ = ["AsyncGcs", "free_port"]
