"""A dashboard stand-in for the MQTT integration tests: a separate process that subscribes to
``usv/<vehicle>/#`` with aiomqtt, reconnects whenever the broker goes away (0.2 s apart), and
writes every message as one JSON line (topic, payload text, retain flag, wall time, connection
number) to the output file.

    python -m tests.mqtt.subscriber PORT OUT.jsonl [TOPIC_FILTER]
"""

from __future__ import annotations

import asyncio
import json
import os
import sys
import time

import aiomqtt


async def main(port: int, out_path: str, topic_filter: str) -> None:
    connection = 0
    with open(out_path, "a", encoding="utf-8") as out:
        while True:
            try:
                identifier = f"test-dashboard-{os.getpid()}"
                async with aiomqtt.Client("127.0.0.1", port, identifier=identifier) as client:
                    connection += 1
                    await client.subscribe(topic_filter, qos=1)
                    event = {"event": "subscribed", "conn": connection, "wall_s": time.time()}
                    out.write(json.dumps(event) + "\n")
                    out.flush()
                    async for message in client.messages:
                        payload = message.payload if isinstance(message.payload, bytes) else b""
                        out.write(json.dumps({"topic": str(message.topic), "payload": payload.decode(),
                                              "retain": bool(message.retain), "qos": message.qos,
                                              "wall_s": time.time(), "conn": connection}) + "\n")
                        out.flush()
            except aiomqtt.MqttError:
                await asyncio.sleep(0.2)


if __name__ == "__main__":
    asyncio.run(main(int(sys.argv[1]), sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else "usv/#"))
