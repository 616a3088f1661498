"""Geofence: the FENCE plan's zones (:mod:`.zones`), the breach logic with a predicted stopping
distance (:mod:`.monitor`) and the pipeline stage that enforces it on the vehicle (:mod:`.guard`)."""
