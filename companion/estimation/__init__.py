"""Active modeling in the 100 Hz pipeline: the estimator stage that runs the qLPV model's UKF
(chapter Eq. 5-11, :mod:`companion.models.ukf`) on every navigation sample."""
