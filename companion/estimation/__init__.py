"""Active modeling: online estimation of the qLPV model error with a UKF (chapter Eq. 5-11)."""
