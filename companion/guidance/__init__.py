"""Guidance: desired course and speed over ground from positions (the chapter's tracker module).

Pure functions and small stateful followers with explicit units; no bus, no clock.  The
control stack (:mod:`companion.control`) turns their course/speed into actuator commands.
"""
