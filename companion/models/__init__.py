"""Velocity models of the boat (qLPV Eq. 3-4 and Table 3 baselines), the UKF model-error estimator
built on them (Eq. 5-11), logs and identification."""
