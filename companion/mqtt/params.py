"""Publication rates of the MQTT state topics (Hz of the vehicle clock; 0 turns a topic off).

Records and events (``sample``, ``launch``, ``failsafe``) have no rate: each is published once,
as soon as it exists (or the broker is back).
"""

from __future__ import annotations

from companion.params import ParamDef

PARAMS: tuple[ParamDef, ...] = (
    ParamDef("USV_MQTT_POS_HZ", 2.0, 0.0, 10.0, "Hz",
             "MQTT topic 'position' (lat, lon, heading, speed and course over ground): publications per "
             "second of vehicle time; 0 off."),
    ParamDef("USV_MQTT_STAT_HZ", 1.0, 0.0, 10.0, "Hz",
             "MQTT topic 'status' (mode, armed): publications per second (also on every change); 0 off."),
    ParamDef("USV_MQTT_LINK_HZ", 1.0, 0.0, 10.0, "Hz",
             "MQTT topic 'link' (ground-station link and failsafe state): publications per second; 0 off."),
    ParamDef("USV_MQTT_ENG_HZ", 1.0, 0.0, 10.0, "Hz",
             "MQTT topic 'engine' (rpm, running): publications per second; 0 off."),
    ParamDef("USV_MQTT_CUR_HZ", 0.5, 0.0, 10.0, "Hz",
             "MQTT topic 'current' (estimated water current): publications per second; 0 off."),
    ParamDef("USV_MQTT_LNCH_HZ", 0.5, 0.0, 10.0, "Hz",
             "MQTT topic 'launcher' (pressure, armed, shots): publications per second; 0 off."),
    ParamDef("USV_MQTT_SMPL_HZ", 0.5, 0.0, 10.0, "Hz",
             "MQTT topic 'sampler' (bottles, volumes, pump): publications per second; 0 off."),
)
