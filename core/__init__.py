"""RoboCal's algorithms and data (numpy / scipy / OpenCV / pyserial; never Qt).

Two settings for the whole process, made when `core` is first imported:

- One BLAS thread. The matrices here are small (at most a few thousand rows by a few dozen
  columns), where a multi-threaded BLAS only adds contention: measured on 2 busy cores, a
  900 × 33 QR took 0.46 ms median with 5–25 ms spikes on OpenBLAS's threads, 0.21 ms steadily
  on one. The environment sets it for the BLAS libraries loaded from now on (numpy's, scipy's
  own copy), threadpoolctl for any loaded already.
- Freed image memory is kept for the next image (glibc's allocator, Linux). An image's working
  arrays (1280 × 1024 float32: 5 MB each; ray maps and SIFT's scale space more) are otherwise
  mapped from the system and given back at every image, and each new page is a page fault:
  12 marker pairs rendered and searched by SIFT took 638 000 page faults and 3.3 s with glibc's
  defaults, 61 000 and 2.3 s with these settings (`make bench`, virtual_lab). Blocks under
  32 MB come from the heap, and up to 256 MB freed at its top stays there. A MALLOC_*_ or
  GLIBC_TUNABLES variable in the environment leaves glibc's defaults alone, for whoever tunes
  the allocator themselves.
"""
import ctypes
import os
import sys

for _name in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

from threadpoolctl import threadpool_limits  # noqa: E402  (after the environment is set)

threadpool_limits(limits=1, user_api="blas")

_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3     # mallopt's parameter numbers (malloc.h)


def _keep_freed_image_memory() -> None:
    if not sys.platform.startswith("linux"):
        return
    if "GLIBC_TUNABLES" in os.environ or any(k.startswith("MALLOC_") for k in os.environ):
        return
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):            # no C library with mallopt: its defaults
        return
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt(_M_MMAP_THRESHOLD, 32 << 20)
    mallopt(_M_TRIM_THRESHOLD, 256 << 20)


_keep_freed_image_memory()
