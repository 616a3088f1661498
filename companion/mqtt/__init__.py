"""MQTT telemetry for flood-response dashboards (issue 17), a service beside the MAVLink one.

* :mod:`.settings` -- the ``[mqtt]`` configuration (URL, credentials, TLS, commands), validated;
* :mod:`.params` -- the publication rate of every state topic (MAVLink parameters);
* :mod:`.topics` -- the topic scheme ``usv/<vehicle_id>/<topic>`` and the JSON of each topic;
* :mod:`.snapshot` -- reads the vehicle, its links and payloads into those JSON documents;
* :mod:`.outbox` -- the persistent outbox of records and events (SQLite, beside the sample log);
* :mod:`.records` -- feeds sample records, launch records and failsafe events into the outbox;
* :mod:`.commands` -- the optional, authenticated and allowlisted commands (RTL, HOLD, stop pump);
* :mod:`.service` -- the aiomqtt client: connect, publish, reconnect with backoff;
* :mod:`.broker` -- the embedded amqtt broker of ``usv sitl --mqtt-embedded``.

Nothing here runs unless ``[mqtt] url`` (or ``--mqtt`` / ``--mqtt-embedded``) is given.
"""
