"""USV companion: a MAVLink vehicle with the chapter's qLPV/UKF active-model control inside."""

__version__ = "0.1.0"
PRODUCT_NAME = "usv-companion"
