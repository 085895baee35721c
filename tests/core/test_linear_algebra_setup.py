"""One BLAS thread in every RoboCal process (core/__init__.py), and the QR used by the solver."""
import subprocess
import sys

import numpy as np

from core.kinematics.identifiability import qr_r


def test_blas_runs_on_one_thread_whatever_was_imported_first():
    code = ("import numpy, core, scipy.linalg; from threadpoolctl import threadpool_info; "
            "print(max(i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "1"


def test_qr_r_gives_the_least_squares_solution_and_the_singular_values():
    rng = np.random.default_rng(0)
    A, b = rng.normal(size=(300, 12)), rng.normal(size=300)
    R, c = qr_r(A, b)
    np.testing.assert_allclose(np.linalg.solve(R, c), np.linalg.lstsq(A, b, rcond=None)[0], atol=1e-12)
    wide = rng.normal(size=(5, 9))
    np.testing.assert_allclose(np.linalg.svd(qr_r(wide)[0], compute_uv=False),
                               np.linalg.svd(wide, compute_uv=False), atol=1e-12)
