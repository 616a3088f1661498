"""USV companion: a MAVLink vehicle with the chapter's qLPV/UKF active-model control inside.

One BLAS thread per process (unless the user's environment says otherwise), set here, before
anything imports numpy: the companion's matrices are small (at most a few tens of columns), so
a second BLAS thread gains nothing, and on a busy machine its spinning threads make them slow.
Measured on 2 cores under load: the SVD of a 21600 x 21 Jacobian in ``usv identify`` took
0.40-0.55 s with OpenBLAS's default two threads and 0.05 s with one (same result to 1e-8).
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

__version__ = "0.1.0"
PRODUCT_NAME = "usv-companion"
