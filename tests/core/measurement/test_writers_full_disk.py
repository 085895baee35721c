"""The measurements and rejects writers on a disk that fills up: each row is on disk as soon as
it is appended, a failed write is one clear message naming the file, and closing afterwards is
quiet. The disk is really full for the writer: a child process with a file size limit
(RLIMIT_FSIZE), where a write past the limit fails with EFBIG as a write past a full disk does
with ENOSPC."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from core.measurement.file import read_measurements
from core.measurement.run import read_rejects

ROOT = Path(__file__).resolve().parents[3]
LIMIT = 1500                     # bytes: the tag, the header and a few rows

CHILD = """
import json, os, resource, signal, sys
from core.errors import RoboCalError
from core.measurement.file import MeasurementWriter
from core.measurement.run import RejectsWriter

kind, path, limit = sys.argv[1], sys.argv[2], int(sys.argv[3])
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
w = RejectsWriter(path, 6) if kind == "rejects" else MeasurementWriter(path, 6, sigmas=True)
sizes, message = [os.path.getsize(path)], None
try:
    for pose in range(1000):
        if kind == "rejects":
            w.append(pose, "marker", [1.5] * 6, "marker not found in the left image")
        else:
            w.append(pose, "marker", [1.5] * 6, [100.0, 200.0, 300.0], [0.01, 0.01, 0.02])
        sizes.append(os.path.getsize(path))
except RoboCalError as exc:
    message = exc.message
w.close()
print(json.dumps({"sizes": sizes, "message": message}))
"""


@pytest.mark.parametrize("kind", ["rejects", "measurements"])
def test_a_full_disk_is_one_message_and_a_quiet_close(tmp_path, kind):
    path = tmp_path / f"m.{kind}.csv"
    proc = subprocess.run([sys.executable, "-c", CHILD, kind, str(path), str(LIMIT)], capture_output=True,
                          text=True, timeout=60, env={"PYTHONPATH": str(ROOT), "PYTHONDONTWRITEBYTECODE": "1"})
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr      # close() raised nothing
    out = json.loads(proc.stdout)
    assert out["message"] == f"{path}: cannot write the file (File too large). Check the disk space and permissions."
    sizes = out["sizes"]
    rows = len(sizes) - 1
    assert rows >= 3 and sizes[-1] <= LIMIT
    data = path.read_bytes()
    ends = [i + 1 for i, b in enumerate(data) if b == ord("\n")]
    assert all(size in ends for size in sizes)        # after every append the file ended with that row
    complete = tmp_path / "complete.csv"
    complete.write_bytes(data[:sizes[-1]])
    found = len(read_rejects(complete)) if kind == "rejects" else read_measurements(complete).n_points
    assert found == rows
