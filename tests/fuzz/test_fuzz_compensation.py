"""Fuzzing the targets file read by `compensate`: exit 1 or 2 with one stderr line naming the
file and no file created, or success where the mutation leaves a valid, reachable file."""
from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.robot.model import robot_path
from tests.fuzz.test_fuzz_commands import assert_one_clear_line, run

FUZZ = settings(derandomize=True, max_examples=80, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

# the educational 6R arm's marker at (0, 10, 20, 0, 30, 0)° and (5, −10, 15, 10, 20, 5)°, base frame
TARGETS = ("name,x,y,z,roll,pitch,yaw,q1,q2,q3,q4,q5,q6\n"
           "a,139.25,0.0,375.45,0.0,-30.0,180.0,0,10,20,0,30,0\n"
           "b,236.08,14.99,279.16,-30.92,-60.88,-144.31,5,-10,15,10,20,5\n")


@FUZZ
@given(line=st.integers(0, 2), column=st.integers(0, 12),
       value=st.one_of(st.text(alphabet=" ,\"#x0123456789.e-+nq\n\r\x00\u2028", max_size=8),
                       st.sampled_from(["nan", "inf", "1e308", "-1e300", "", "1e20", "9" * 400, "-1", "0.5",
                                        "roll", "q7", "name"])))
def test_malformed_targets_for_compensate(tmp_path_factory, line, column, value):
    work = tmp_path_factory.mktemp("targets")
    lines = TARGETS.splitlines()
    cells = lines[line].split(",")
    cells[min(column, len(cells) - 1)] = value
    lines[line] = ",".join(cells)
    targets = work / "targets.csv"
    targets.write_text("\n".join(lines) + "\n")
    code, err = run(["compensate", "--robot", str(robot_path("educational_6r")), "--targets", str(targets),
                     "--position-only", "--out", str(work / "j.csv")], work)
    if code != 0:
        assert_one_clear_line(code, err, [str(targets)])
    else:
        assert (work / "j.csv").is_file()
