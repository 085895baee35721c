"""core.provenance: the inputs an output was made from, and whether they changed since."""
from __future__ import annotations

import os

from core import provenance


def test_unchanged_inputs_are_not_called_changed(tmp_path):
    stereo = tmp_path / "stereo.yaml"
    stereo.write_text("baseline: 120\n")
    marker = tmp_path / "marker.npz"
    marker.write_bytes(b"trained")
    provenance.record_inputs(marker, {"stereo.yaml": stereo})
    assert provenance.inputs_file(marker) == tmp_path / "marker.inputs.json"
    assert provenance.changed_inputs(marker, {"stereo.yaml": stereo}) == []


def test_a_rewritten_input_is_changed_even_with_the_same_size_and_time(tmp_path):
    stereo = tmp_path / "stereo.yaml"
    stereo.write_text("baseline: 120\n")
    marker = tmp_path / "marker.npz"
    marker.write_bytes(b"trained")
    provenance.record_inputs(marker, {"stereo.yaml": stereo})
    st = stereo.stat()
    stereo.write_text("baseline: 121\n")                       # same size
    os.utime(stereo, ns=(st.st_atime_ns, st.st_mtime_ns + 1))   # a later time: hashed again
    assert provenance.changed_inputs(marker, {"stereo.yaml": stereo}) == ["stereo.yaml"]
    stereo.write_text("baseline: 120\n")                        # back to what the marker was made from
    assert provenance.changed_inputs(marker, {"stereo.yaml": stereo}) == []


def test_a_deleted_or_new_input_counts_and_no_record_says_nothing(tmp_path):
    poses, meas = tmp_path / "poses.csv", tmp_path / "measurements.csv"
    meas.write_text("q1,x\n0,1\n")
    out = tmp_path / "calibrated.json"
    out.write_text("{}")
    assert provenance.changed_inputs(out, {"measurements.csv": meas}) == []      # no side file yet
    provenance.record_inputs(out, {"measurements.csv": meas, "poses.csv": poses})
    assert provenance.recorded_inputs(out)["poses.csv"] is None
    poses.write_text("q1\n0\n")
    meas.unlink()
    assert provenance.changed_inputs(out, {"measurements.csv": meas, "poses.csv": poses}) == [
        "measurements.csv", "poses.csv"]


def test_digests_taken_before_the_work_are_recorded_as_given(tmp_path):
    meas = tmp_path / "measurements.csv"
    meas.write_text("q1,x\n0,1\n")
    before = provenance.fingerprint({"measurements.csv": meas})
    meas.write_text("q1,x\n0,2\n")                # changed while the output was being made
    out = tmp_path / "calibrated.json"
    out.write_text("{}")
    provenance.record_inputs(out, before, hashed=True)
    assert provenance.changed_inputs(out, {"measurements.csv": meas}) == ["measurements.csv"]
    (tmp_path / "calibrated.inputs.json").write_text("not json")
    assert provenance.changed_inputs(out, {"measurements.csv": meas}) == []


def test_a_forgotten_record_says_nothing_again(tmp_path):
    meas = tmp_path / "measurements.csv"
    meas.write_text("q1,x\n0,1\n")
    out = tmp_path / "calibrated.json"
    out.write_text("{}")
    provenance.record_inputs(out, {"measurements.csv": meas})
    meas.write_text("q1,x\n0,2\n")
    assert provenance.changed_inputs(out, {"measurements.csv": meas}) == ["measurements.csv"]
    provenance.forget_inputs(out)
    provenance.forget_inputs(out)                 # twice: nothing to remove is fine
    assert not provenance.inputs_file(out).exists()
    assert provenance.changed_inputs(out, {"measurements.csv": meas}) == []
