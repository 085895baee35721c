"""RoboCal's algorithms and data (numpy / scipy / OpenCV / pyserial; never Qt).

The matrices here are small (at most a few thousand rows by a few dozen columns), where a
multi-threaded BLAS only adds contention: measured on 2 busy cores, a 900 × 33 QR took
0.46 ms median with 5–25 ms spikes on OpenBLAS's threads, 0.21 ms steadily on one. So a
RoboCal process uses one BLAS thread: the environment sets it for the BLAS libraries loaded
from now on (numpy's, scipy's own copy), threadpoolctl for any loaded already.
"""
import os

for _name in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

from threadpoolctl import threadpool_limits  # noqa: E402  (after the environment is set)

threadpool_limits(limits=1, user_api="blas")
