"""Velocity models of the boat (qLPV Eq. 3-4 and Table 3 baselines), logs and identification."""
