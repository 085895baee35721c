"""Teaching guide: every exercise of docs/teaching-guide.md once on the virtual lab, with what each step shows.

The command-line exercises are the guide's own ```sh code blocks, parsed from the Markdown and
run literally, all of them and in order, through app.cli.main in a fresh temporary folder; the
wizard exercises run the same core functions the pages call. Each step prints the figure a
student should observe; the PASS/FAIL lines check the observation the guide asks about.
Set ROBOCAL_BENCH_AUTOPILOT=0 to skip the classroom demo (a whole wizard run, a few minutes).
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from app.cli import main as cli
from core.identification.solver import identify
from core.marker.correspondence import StereoRectification, window_sweep
from core.marker.location import MarkerLocator
from core.marker.training import train_marker
from core.poses.file import read_poses
from core.virtual_lab.lab import VirtualLab
from core.virtual_lab.marker_comparison import compare_markers
from core.virtual_lab.synthetic import simulate_measurements

ROOT = Path(__file__).resolve().parents[1]
SEED = 7


def _run(argv: list[str]) -> dict:
    """`robocal <argv>` in-process; its --json output (exit code 0 required)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = cli(argv)
    if code != 0:
        raise RuntimeError(f"robocal {' '.join(argv)} exited {code}")
    text = out.getvalue()
    return json.loads(text[text.index("{"):]) if "--json" in argv else {}


def run(report) -> None:
    with tempfile.TemporaryDirectory(prefix="robocal-teaching-") as tmp:
        cwd = os.getcwd()
        os.chdir(tmp)
        try:
            _demo(report)
            _stereo(report)
            _marker(report)
            _poses(report)
            _command_line(report)
        finally:
            os.chdir(cwd)


def _demo(report) -> None:
    """Session step 1: `robocal gui --demo --autopilot` exits 0 when the whole calibration finished."""
    if os.environ.get("ROBOCAL_BENCH_AUTOPILOT", "1") == "0":
        report.info("1. demo (autopilot): skipped (ROBOCAL_BENCH_AUTOPILOT=0)", "")
        return
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", PYTHONPATH=str(ROOT), HOME=os.getcwd())
    done = subprocess.run([sys.executable, "-m", "app.cli", "gui", "--demo", "--autopilot"], env=env,
                          capture_output=True, text=True, timeout=1800)
    steps = [line for line in done.stdout.splitlines() + done.stderr.splitlines() if line.startswith("[")]
    report.info("1. demo: last autopilot line", steps[-1][:70] if steps else "(none)")
    report.add("1. demo: `robocal gui --demo --autopilot` exit code", float(done.returncode), "<=", 0.0)


def _stereo(report) -> None:
    """Session step 2: 8 pairs (cross-validation runs), then 20 more."""
    _run(["simulate", "--out", "boards", "--seed", str(SEED), "--pairs", "28", "--poses", "0"])
    common = ["stereo-calibrate", "--left", "boards/checkerboard/left", "--right", "boards/checkerboard/right",
              "--board", "9x6", "--square", "25", "--json"]
    six = _run(common + ["--out", "s6.yaml", "--exclude", ",".join(str(i) for i in range(7, 29))])
    eight = _run(common + ["--out", "s8.yaml", "--exclude", ",".join(str(i) for i in range(9, 29)),
                           "--export-json", "s8.json"])
    full = _run(common + ["--out", "s28.yaml", "--export-json", "s28.json"])
    report.info("2. stereo, 6 pairs: cross-validation", "skipped" if six["cross_validation_px"] is None
                else six["cross_validation_px"], "px")
    report.add("2. stereo, 6 pairs: cross-validation figure given (1 = yes)",
               float(six["cross_validation_px"] is not None), "<=", 0.0)
    report.info("2. stereo, 8 pairs: reprojection RMS / cross-validation",
                f"{eight['rms_stereo']:.3f} / {eight['cross_validation_px']:.3f}", "px")
    report.info("2. stereo, 28 pairs: reprojection RMS / cross-validation",
                f"{full['rms_stereo']:.3f} / {full['cross_validation_px']:.3f}", "px")
    report.add("2. stereo, 8 pairs: cross-validation figure given (1 = yes)",
               float(eight["cross_validation_px"] is not None), ">=", 1.0)
    s8, s28 = _sigma("s8.json", "cx"), _sigma("s28.json", "cx")
    report.info("2. stereo: σ of the left c_x, 8 -> 28 pairs", f"{s8:.3f} -> {s28:.3f}", "px")
    report.add("2. stereo: σ(c_x) with 28 pairs / with 8", s28 / s8, "<", 1.0)


def _sigma(path: str, name: str) -> float:
    """σ of the left camera's parameter `name` from a stereo-calibrate --export-json file."""
    rows = json.loads(Path(path).read_text())["parameters"]
    return float(next(r["std"] for r in rows if r["group"] == "left" and r["name"] == name))


def _marker(report) -> None:
    """Session step 3: Compare markers (Fig. 11), then a live pair and its SSD window sweep (Fig. 17)."""
    lab = VirtualLab.create(seed=0)
    comparison = compare_markers(views=12, seed=0, lab=lab)
    for p in comparison.patterns:
        report.info(f"3. compare markers: {p.name[:28]} detected", 100.0 * p.detection_rate, "%")
    best = max(p.detection_rate for p in comparison.patterns)
    worst = min(p.detection_rate for p in comparison.patterns)
    report.info("3. compare markers: recommended", comparison.recommended)
    report.add("3. compare markers: best minus worst detection rate", 100.0 * (best - worst), ">=", 50.0, "%")
    trained = train_marker(lab.render_training_image())
    rect = StereoRectification.from_rig(lab.rig)
    rng = np.random.default_rng(3)
    q = lab.random_visible_poses(1, rng)[0]
    left, right = lab.render_marker_pair(q, rng)                       # "Next pose"
    loc = MarkerLocator(trained, rect).locate(left, right)
    report.add("3. live pair located (1 = yes)", float(loc.ok), ">=", 1.0)
    report.info("3. live pair: 3D error against the truth", float(np.linalg.norm(loc.point - lab.marker_position(q))),
                "mm")
    sweep = window_sweep(rect, left, right, loc.left_rectified)
    d_true = loc.disparity_edges
    for size in (5, 15, 37):
        k = int(np.flatnonzero(sweep.sizes == size)[0])
        report.info(f"3. SSD window {size}x{size}: minimum / disparity error / reliability",
                    f"{sweep.minima[k]:.1f} grey²/px / {sweep.disparities[k] - d_true:+.2f} px / "
                    f"{sweep.reliabilities[k]:.2f}")
    report.info("3. SSD: window sizes giving a wrong match (> 1 px off)",
                int(np.sum(np.abs(sweep.disparities - d_true) > 1.0)))
    k5, k37 = (int(np.flatnonzero(sweep.sizes == s)[0]) for s in (5, 37))
    report.add("3. SSD: minimum of the 37x37 window / of the 5x5 (grows with the window)",
               float(sweep.minima[k37] / sweep.minima[k5]), ">", 1.0)


def _poses(report) -> None:
    """Session step 4: 30 poses by κ, O1, O5 against random; 10 poses and what they leave poorly determined."""
    for index in ("cond", "O1", "O5"):
        r = _run(["select-poses", "--virtual-lab", "--count", "30", "--candidates", "1000", "--random-trials", "30",
                  "--index", index, "--out", f"poses_{index}.csv", "--json"])
        key = "condition_number" if index == "cond" else index
        ratio = r["indices"][key] / r["random_median"][key]
        report.info(f"4. 30 poses by {index}: selected / random median of {index}", ratio)
        better = ratio if index == "cond" else 1.0 / ratio        # < 1: the selection beats random poses
        report.add(f"4. 30 poses by {index}: {'selected / random' if index == 'cond' else 'random / selected'}",
                   better, "<", 1.0)
    lab = VirtualLab.create(seed=0)
    sigmas = {}
    for count in (10, 30):
        if count == 10:
            _run(["select-poses", "--virtual-lab", "--count", "10", "--candidates", "1000", "--random-trials", "30",
                  "--out", "poses_10.csv", "--json"])
        Q = lab.nominal_robot.q_from_file(read_poses(f"poses_{'cond' if count == 30 else 10}.csv").q_file)
        meas = simulate_measurements(lab.true_robot, len(Q), sigma_mm=0.05, Q=Q, targets=[lab.target],
                                     rng=np.random.default_rng(1))
        result = identify(lab.nominal_robot, meas)
        poor = [e.name for e in result.identifiability.excluded if e.status.startswith("not determined")]
        rows = [r for r in result.parameters if r.std is not None and r.group == "joint"]
        worst = max(rows, key=lambda r: r.std / (5.0 if r.unit == "mm" else 1.0))   # against 5 mm / 1°
        sigmas[count] = {r.name: r.std for r in rows}
        report.info(f"4. {count} poses: kept at nominal as poorly determined", ", ".join(poor) or "none")
        report.info(f"4. {count} poses: largest joint σ", f"{worst.name} ± {worst.std:.3g} {worst.unit}")
    common = set(sigmas[10]) & set(sigmas[30])
    grown = np.median([sigmas[10][n] / sigmas[30][n] for n in common])
    report.add("4. median σ of a joint parameter, 10 poses / 30 poses", float(grown), ">", 1.0)


GUIDE = ROOT / "docs" / "teaching-guide.md"
FENCE = re.compile(r"```sh\n(.*?)```", re.S)
#: exit codes that are results, not failures: `check` exits 3 when the check is out of its limits
RESULT_CODES = {"check": {0, 3}}


def guide_commands(path: Path = GUIDE) -> list[str]:
    """Every `robocal …` line of the guide's ```sh blocks, in order, as written."""
    lines = []
    for block in FENCE.findall(path.read_text(encoding="utf-8")):
        lines += [ln.strip() for ln in block.replace("\\\n", " ").splitlines() if ln.strip().startswith("robocal ")]
    return lines


def _literal(line: str) -> tuple[int, str, str]:
    """Run one guide line as written (in-process); (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli(shlex.split(line)[1:])
    return code, out.getvalue(), err.getvalue()


def _command_line(report) -> None:
    """Every code block of the teaching guide, literally and in order, then what each exercise shows."""
    lines = guide_commands()
    passed, by_command = 0, {}
    for k, line in enumerate(lines, 1):
        with report.timer() as t:
            code, _, err = _literal(line)
        command = shlex.split(line)[1]
        ok = code in RESULT_CODES.get(command, {0})
        passed += ok
        runs = by_command.setdefault(command, [0, 0])
        runs[0] += ok
        runs[1] += 1
        report.info(f"guide {k:2d}: {line[8:70]}", f"exit {code} ({t():.0f} s)"
                    + ("" if ok else f": {err.strip().splitlines()[-1][:120] if err.strip() else ''}"))
    report.info("guide commands that run, per command", ", ".join(f"{c} {a}/{n}" for c, (a, n) in by_command.items()))
    report.add("guide commands that run as written (of all)", passed / len(lines), ">=", 1.0,
               note=f"{passed} of {len(lines)}")
    _observations(report)


def _json(argv: list[str]) -> dict:
    try:
        return _run(argv + ["--json"])
    except (RuntimeError, ValueError) as exc:
        return {"error": str(exc)}


def _validation(path: str) -> tuple[float, float]:
    v = json.loads(Path(path).read_text())["calibration"]["statistics"]["validation"]
    return v["before"]["rms_mm"], v["after"]["rms_mm"]


def _point_sigma(path: str) -> float:
    from core.measurement.file import read_measurements
    return float(np.median(np.linalg.norm(read_measurements(path).sigma, axis=1)))


def _observations(report) -> None:
    """The figures each exercise asks students to compare, from the files the guide wrote."""
    if not Path("lab/calibrated.json").is_file():
        return
    before, after = _validation("lab/calibrated.json")
    report.info("whole run: held-out RMS, nominal -> calibrated", f"{before:.3f} -> {after:.4f}", "mm")
    report.add("whole run: held-out RMS calibrated / nominal", after / before, "<", 0.2)
    stats = json.loads(Path("lab/calibrated.json").read_text())["calibration"]["statistics"]
    report.info("whole run: σ̂ of the fit (× the points' own σ)", stats["sigma_hat"])
    grades = {name: _json(["grade", f"{name}/calibrated.json", "--lab-seed", str(SEED), "--stereo", "lab/stereo.yaml"])
              for name in ("lab", "chosen", "few", "many", "quiet", "noisy") if Path(f"{name}/calibrated.json").is_file()}
    for name, g in grades.items():
        if "marks" in g:
            f = g["fresh_poses"]
            report.info(f"grade {name}: marks, fresh RMS aligned / camera frame",
                        f"{g['marks']}/{g['out_of']}, {f['rms_mm']:.4f} / {f['camera_frame_rms_mm']:.3f}", "mm")
    if "marks" in grades.get("lab", {}):
        report.add("grade lab: parameters within tolerance / compared", grades["lab"]["marks"] / grades["lab"]["out_of"],
                   ">=", 1.0)
    report.add("report: hand-in PDF written (1 = yes)", float(Path("lab/report.pdf").is_file()), ">=", 1.0)
    for a, b in (("chosen", "lab"), ("many", "few")):
        if Path(f"{a}/calibrated.json").is_file() and Path(f"{b}/calibrated.json").is_file():
            report.info(f"held-out RMS after, {a} / {b}", f"{_validation(a + '/calibrated.json')[1]:.4f} / "
                        f"{_validation(b + '/calibrated.json')[1]:.4f}", "mm")
    if all("marks" in grades.get(n, {}) for n in ("quiet", "noisy")):
        s0, s3 = _point_sigma("quiet/measurements.csv"), _point_sigma("noisy/measurements.csv")
        r0, r3 = (grades[n]["fresh_poses"]["camera_frame_rms_mm"] for n in ("quiet", "noisy"))
        report.info("noise 0 -> 3 grey levels: median point σ", f"{s0:.4f} -> {s3:.4f}", "mm")
        report.info("noise 0 -> 3 grey levels: fresh-pose RMS in the camera frame", f"{r0:.3f} -> {r3:.3f}", "mm")
        report.add("noise: point σ, noise 3 / noise 0", s3 / s0, ">", 2.0)
        report.add("noise: fresh-pose RMS (camera frame), noise 3 / noise 0", r3 / r0, "<", 1.5)
    if Path("lab/orientation_rz.json").is_file():
        rows = {r["name"]: r for r in json.loads(Path("lab/orientation_rz.json").read_text())["calibration"]["parameters"]}
        report.add("orientation + fixed marker.rz: J6.theta identified (1 = yes)",
                   float(rows["J6.theta"]["std"] is not None), ">=", 1.0)
