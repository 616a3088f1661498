"""Sensor drivers: the XW-GI5630 GPS-INS sentence parser (chapter Table 2) and the engine module."""
