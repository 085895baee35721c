"""Freed image memory is kept for the next image in a RoboCal process (core/__init__.py): a
second image-sized array reuses the pages of the first instead of faulting in new ones, unless
the environment tunes glibc's allocator itself."""
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator (Linux) only")

# 20 image-sized float32 arrays (1280 × 1024 × 4 = 5 MB each, 1280 pages) made, filled and freed
# one after another; prints the minor page faults they took
COUNT_FAULTS = """
import resource, numpy
{imports}
def faults(): return resource.getrusage(resource.RUSAGE_SELF).ru_minflt
numpy.full((1024, 1280), 1.0, numpy.float32)
before = faults()
for _ in range(20):
    numpy.full((1024, 1280), 1.0, numpy.float32)
print(faults() - before)
"""


def page_faults(imports: str, **env) -> int:
    environ = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_") and k != "GLIBC_TUNABLES"}
    out = subprocess.run([sys.executable, "-c", COUNT_FAULTS.format(imports=imports)], capture_output=True,
                         text=True, check=True, env={**environ, **env})
    return int(out.stdout)


# Each array spans at least 3 pages even where the kernel maps 2 MB pages (numpy asks for them),
# so an array in new memory takes at least 3 faults: 60 for the 20 arrays.
NEW_PAGES = 60


def test_image_arrays_reuse_freed_pages_after_core_is_imported():
    assert page_faults("") >= NEW_PAGES                      # glibc's defaults: new pages for each array
    assert page_faults("import core") <= 3                  # RoboCal's: the freed pages again


def test_an_allocator_tuned_in_the_environment_is_left_alone():
    assert page_faults("import core", MALLOC_ARENA_MAX="2") >= NEW_PAGES
