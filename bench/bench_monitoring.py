"""Monitoring a calibrated cell on the virtual lab: false alarms, detection, diagnosis, re-identification;
then through rendered images as a real cell measures (run_through_images): the check through image
files against the lab path, re-identification after each change kind, an 8-pose check over sim-robot.

Ideal lab measurements (the true robot + Gaussian noise σ = 0.05 mm per axis, 3D σ = σ·√3), the
educational 6R arm calibrated from 50 poses; several calibrations (measurement seeds) so that the
rates include the calibration's own scatter. Checks at α = 1 % unless said.
"""
from __future__ import annotations

import math

import numpy as np

from core.identification.solver import identify
from core.errors import RoboCalError
from core.monitoring.check import check_limits, run_check
from core.monitoring.check_poses import select_check_poses
from core.monitoring.diagnosis import diagnose
from core.monitoring.reidentify import propose_poses, reidentify
from core.monitoring.uncertainty import calibration_uncertainty
from core.measurement.file import Measurements
from core.identification.fit import error_stats
from core.kinematics.jacobian import predict_points
from core.virtual_lab.changes import apply_change
from core.virtual_lab.ideal_measurements import ideal_lab_measurements, ideal_measure
from core.virtual_lab.lab import VirtualLab, lab_options
from core.virtual_lab.synthetic import simulate_measurements

SIGMA = 0.05
CALIBRATIONS = 6
REID_DRAWS = 5      # check noise and full recalibration poses per calibration


def _calibrated(lab, seed):
    res = identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=SIGMA, seed=seed))
    model = res.model.copy()
    model.calibration = res.calibration_section()
    return model, calibration_uncertainty(model)


def run(report) -> None:
    lab = VirtualLab.create(seed=0)
    true = lab.true_robot
    opts = lab_options(lab)
    opts.pop("robot")
    cells = []
    for s in range(CALIBRATIONS):
        model, unc = _calibrated(lab, 100 + s)
        Q5 = select_check_poses(model, 5, candidates=600, **opts).Q
        Q8 = select_check_poses(model, 8, candidates=600, **opts).Q
        cells.append((model, unc, Q5, check_limits(model, unc, Q5, ["marker"] * 5, 0.01),
                      Q8, check_limits(model, unc, Q8, ["marker"] * 8, 0.01)))

    # false alarms: no change
    alarms = total = 0
    for s, (model, unc, Q5, L5, _, _) in enumerate(cells):
        for k in range(300):
            r = run_check(model, unc, Q5, ideal_measure(lab, sigma_mm=SIGMA, seed=10_000 * s + k), limits=L5)
            alarms += not r.within
            total += 1
    report.add("false alarms, no change, 5 check poses (α 1 %)", 100 * alarms / total, "<=", 1.5, "%",
               f"{total} checks over {CALIBRATIONS} calibrations; nominal 1 %")

    # smallest tool change detected with 95 % probability (5 check poses)
    smallest = math.inf
    for size in (0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.7):
        hits = n = 0
        for s, (model, unc, Q5, L5, _, _) in enumerate(cells):
            for k in range(40):
                lab.true_robot = true
                apply_change(lab, f"tool:{size}", seed=1000 * s + k)
                r = run_check(model, unc, Q5, ideal_measure(lab, sigma_mm=SIGMA, seed=7 + k), limits=L5)
                hits += not r.within
                n += 1
        lab.true_robot = true
        report.info(f"tool change {size:g} mm detected", f"{100 * hits / n:.1f} %")
        if hits / n >= 0.95:
            smallest = size
            break
    report.add("smallest tool change detected with 95 % (5 check poses)", smallest / (SIGMA * math.sqrt(3)), "<=",
               3.0, "× 3D σ", f"{smallest:g} mm; 3D σ {SIGMA * math.sqrt(3):.3f} mm")

    # diagnosis per kind (8 check poses)
    kinds = {"tool:1.5": ("tool", -1), "base:2": ("base", -1), "joint1:0.3": ("joint", 0),
             "joint2:0.3": ("joint", 1), "joint3:0.3": ("joint", 2), "joint4:0.3": ("joint", 3),
             "joint5:0.3": ("joint", 4), "link3:1": ("several", -1)}
    for spec, (kind, joint) in kinds.items():
        right = n = 0
        for s, (model, unc, _, _, Q8, L8) in enumerate(cells):
            for k in range(15):
                lab.true_robot = true
                apply_change(lab, spec, seed=1000 * s + k)
                r = run_check(model, unc, Q8, ideal_measure(lab, sigma_mm=SIGMA, seed=500 + k), limits=L8)
                n += 1
                if r.within:
                    continue
                d = diagnose(model, unc, r)
                right += d.kind == kind and (joint < 0 or d.chosen.joint == joint)
        lab.true_robot = true
        report.add(f"diagnosis right: {spec}", 100 * right / n, ">=", 95.0, "%", f"{n} trials, 8 check poses")

    # re-identification after a tool swap vs a full recalibration (held-out poses). One draw of a
    # full recalibration's held-out error scatters by ±25 % (50 random poses), and so does the
    # previous calibration each re-identification keeps: the ratio of single draws fails 1.2 even
    # for the previous calibration with the exact new tool. So both errors are pooled (RMS) over
    # every cell and several draws of the check's noise and of the full recalibration's poses.
    reid_sq, full_sq, ratios, fractions, proposed = [], [], [], [], []
    refused = 0
    for s, (model, unc, _, _, Q8, L8) in enumerate(cells):
        lab.true_robot = true
        apply_change(lab, "tool:2", seed=s)
        held = ideal_lab_measurements(lab, 40, sigma_mm=0.0, seed=950 + s)
        for j in range(REID_DRAWS):
            r = run_check(model, unc, Q8, ideal_measure(lab, sigma_mm=SIGMA, seed=s + 1000 * j), limits=L8)
            d = diagnose(model, unc, r)
            meas, proposed_poses = _check_and_proposed_points(lab, model, unc, d, r, opts, rng=s + 1000 * j)
            try:
                re = error_stats(reidentify(model, unc, d.parameters, meas).model, held).rms_mm
            except RoboCalError:        # the nested test refuses a pure change at its α (1 %) by design
                refused += 1
                continue
            full = error_stats(identify(lab.nominal_robot, ideal_lab_measurements(
                lab, 50, sigma_mm=SIGMA, seed=900 + s + 1000 * j)).model, held).rms_mm
            reid_sq.append(re ** 2)
            full_sq.append(full ** 2)
            ratios.append(re / full)
            fractions.append(meas.n_poses / 50)
            proposed.append(proposed_poses)
    lab.true_robot = true
    report.add("re-identified tool swap: held-out error / full recalibration's",
               math.sqrt(np.mean(reid_sq) / np.mean(full_sq)), "<=", 1.2, "",
               f"RMS over {len(ratios)} trials ({CALIBRATIONS} calibrations × {REID_DRAWS}); single trials "
               f"{min(ratios):.2f}–{max(ratios):.2f}; {min(proposed)}–{max(proposed)} proposed poses + 8 check poses")
    report.add("re-identification poses / full recalibration's", 100 * max(fractions), "<=", 20.0, "%",
               "proposed + check poses, against 50; the most of any trial")
    if refused:
        report.info("  tool swaps the re-identification refused (left out above)", f"{refused} of {len(ratios) + refused}")
    _tool_swaps_refused(report, lab, cells, opts)
    run_through_images(report)


def _check_and_proposed_points(lab, model, unc, diagnosis, check, opts, *, rng) -> tuple[Measurements, int]:
    """The check's points and those measured (ideally, σ = SIGMA) at the poses proposed for the
    re-identification of the diagnosed change: (measurements, how many poses were proposed)."""
    proposal = propose_poses(model, unc, diagnosis.parameters, check.Q, candidates=600, **opts)
    new = simulate_measurements(lab.true_robot, len(proposal.Q), Q=proposal.Q, sigma_mm=SIGMA,
                                targets=["marker"], rng=rng)
    Q = np.vstack([new.Q, check.Q])
    return Measurements(pose=np.arange(len(Q)), target=["marker"] * len(Q), q_file=model.q_to_file(Q),
                        xyz=np.vstack([new.xyz, [p.measured for p in check.points]]), Q=Q), len(proposal.Q)


REFUSAL_DRAWS = 40      # check noise draws per calibration


def _tool_swaps_refused(report, lab, cells, opts) -> None:
    """How often the re-identification refuses a pure tool swap: its test that only the tool
    changed refuses at α = 1 % by design; REFUSAL_DRAWS checks per calibration, each diagnosed,
    its poses proposed and measured, then re-identified."""
    true = lab.true_robot
    refused = trials = 0
    for s, (model, unc, _, _, Q8, L8) in enumerate(cells):
        lab.true_robot = true
        apply_change(lab, "tool:2", seed=s)
        for j in range(REFUSAL_DRAWS):
            seed = s + 1000 * j + 77
            r = run_check(model, unc, Q8, ideal_measure(lab, sigma_mm=SIGMA, seed=seed), limits=L8)
            d = diagnose(model, unc, r)
            if d.kind != "tool":
                continue
            meas, _ = _check_and_proposed_points(lab, model, unc, d, r, opts, rng=seed)
            trials += 1
            try:
                reidentify(model, unc, d.parameters, meas)
            except RoboCalError:
                refused += 1
    lab.true_robot = true
    report.add("re-identification of a tool swap refused", 100 * refused / trials, "<=", 2.5, "%",
               f"{refused} of {trials} tool swaps diagnosed as such; its test refuses at α 1 % "
               f"(2.5 % leaves room for the binomial scatter of {trials} trials)")


# -- through rendered images: the file path, re-identification, a check over sim-robot ---------------------------
FILE_TRIALS = 200         # per scenario
FILE_DRAWS = 2            # draws of each change (its direction) per scenario
FILE_NOISE = 2            # renders of each check pose's pair per draw: 2^8 combinations per draw
IMAGE_POSES = 40          # poses of the calibration through images, and of a full recalibration
SCENARIOS = {"none": None, "tool": "tool:1.5", "base": "base:2", "joint zero": "joint2:0.3"}
REID_CHAINS = (("tool:0.5", "base:0.5", "joint2:0.05", "tool:3", "base:3", "joint3:0.5"),   # one after the other
               ("tool:1.5", "joint5:0.2", "tool:2.5", "base:1.5"))          # again from the first calibration


def _image_cell(tmp):
    """The lab (seed 0), its true stereo calibration and trained marker as files, a locator, and the
    arm calibrated from IMAGE_POSES poses measured through rendered images (25 % held out, as the
    README's chain), written to tmp/calibrated.json."""
    from core.identification.file import write_calibrated_model
    from core.marker.location import MarkerLocator
    from core.marker.training import train_marker
    from core.stereo.rectification import StereoRectification
    from app.lab import image_measure

    lab = VirtualLab.create(seed=0, noise=0.5)
    locator = MarkerLocator(train_marker(lab.render_training_image(), outer_size=lab.marker.outer_size),
                            StereoRectification.from_rig(lab.rig))
    meas = _through_images(lab, locator, lab.random_visible_poses(IMAGE_POSES, np.random.default_rng(31)), seed=32)
    write_calibrated_model(identify(lab.nominal_robot, meas, holdout=0.25), tmp / "calibrated.json")
    return lab, locator, tmp / "calibrated.json", image_measure


def _through_images(lab, locator, Q, *, seed):
    from app.lab import image_measure
    measure = image_measure(lab, locator.locate, seed=seed)
    rows = [(q, p) for q in Q for p in [measure(q)] if p is not None]
    Qm = np.array([q for q, _ in rows])
    return Measurements(pose=np.arange(len(rows)), target=[lab.target] * len(rows),
                        q_file=lab.nominal_robot.q_to_file(Qm), xyz=np.array([p for _, p in rows]), Q=Qm)


class _LocatedOnce:
    """A MarkerLocator that locates each distinct pair of images once: its answer is kept under
    the pair's pixels (SHA-1 of both images' bytes), so a pair read back from files whose pixels
    equal a pair located before gets that location, and any pair differing in one byte is
    located anew. Locating (~1 s a pair here) is a deterministic function of the pixels."""

    def __init__(self, locator):
        self.locator = locator
        self.rect = locator.rect
        self.located: dict[bytes, object] = {}
        self.runs = 0

    def locate(self, left, right):
        import hashlib
        key = hashlib.sha1(np.ascontiguousarray(left).tobytes() + np.ascontiguousarray(right).tobytes()).digest()
        if key not in self.located:
            self.located[key] = self.locator.locate(left, right)
            self.runs += 1
        return self.located[key]


def _file_path_verdicts(report, lab, locator, calibrated, tmp) -> None:
    """Per scenario, FILE_DRAWS draws of the change (its direction) and FILE_NOISE renders of each
    check pose's pair per draw (image noise and light), each rendered pair written once as two PNG
    files. A trial takes one render per check pose (FILE_TRIALS distinct combinations, out of
    FILE_NOISE^8 per draw): the lab path checks the rendered pairs in memory; the file path makes
    the trial's folder (left/NN.png, right/NN.png: hard links to the written files) and, with the
    joints file written once, runs `check --images`'s code on them: pairs found and read from the
    files, located, judged, diagnosed. Each distinct pair is located once (_LocatedOnce), in memory for the lab path; a
    pair read from files reuses it only when its pixels are the same bytes."""
    import itertools
    import os
    import time
    import cv2
    from app.jobs import check as job
    from app.jobs.check_sources import image_files
    from core.measurement.point import located_point
    from core.poses.file import write_poses

    opts = lab_options(lab)
    cell = job.setup(calibrated, lab_options=opts)
    joints = write_poses(tmp / "check_poses.csv", cell.model.q_to_file(cell.Q))
    once = _LocatedOnce(locator)
    true = lab.true_robot
    t0 = time.perf_counter()
    seconds_rendering = 0.0
    anew = 0
    for name, spec in SCENARIOS.items():
        same = alarms = 0
        renders = []                # [draw][pose][noise] -> (pair, (left file, right file))
        t = time.perf_counter()
        for d in range(FILE_DRAWS):
            lab.true_robot = true
            if spec:
                apply_change(lab, spec, seed=d)
            rng = np.random.default_rng(1000 + d)
            draw = []
            for j, q in enumerate(cell.Q):
                pose = []
                for n in range(FILE_NOISE):
                    pair = lab.render_marker_pair(q, rng)
                    files = tuple(tmp / "rendered" / f"{name}-{d}-{j}-{n}-{side}.png" for side in ("left", "right"))
                    files[0].parent.mkdir(exist_ok=True)
                    for f, img in zip(files, pair):
                        cv2.imwrite(str(f), img, [cv2.IMWRITE_PNG_COMPRESSION, 1])
                    once.locate(*pair)                  # the lab path's location, made once
                    pose.append((pair, files))
                draw.append(pose)
            renders.append(draw)
        lab.true_robot = true
        seconds_rendering += time.perf_counter() - t
        located = once.runs
        per_draw = -(-FILE_TRIALS // FILE_DRAWS)
        combos = [c for d in range(FILE_DRAWS) for c in itertools.islice(
            (c for c in _shuffled_products(len(cell.Q), FILE_NOISE, seed=d)), per_draw)]
        for k in range(FILE_TRIALS):
            d = k // per_draw
            chosen = [renders[d][j][n] for j, n in enumerate(combos[k])]
            folder = tmp / f"{name}-{k}"
            for side, i in (("left", 0), ("right", 1)):
                (folder / side).mkdir(parents=True)
                for j, (_, files) in enumerate(chosen):
                    os.link(files[i], folder / side / f"{j:02d}.png")
            memory = iter(pair for pair, _ in chosen)

            def lab_measure(q):                # as app.lab.image_measure: the point with its covariance
                return located_point(once.locate(*next(memory)))
            on_lab, d_lab = job.check(cell, lab_measure)
            files = image_files(cell.model, joints, folder, once)
            on_files = run_check(cell.model, cell.unc, cell.Q, files.measure, limits=cell.limits)
            d_files = diagnose(cell.model, cell.unc, on_files) if not on_files.within else None
            same += (on_lab.within == on_files.within
                     and (d_lab is None) == (d_files is None)
                     and (d_lab is None or (d_lab.kind, d_lab.chosen.joint) == (d_files.kind, d_files.chosen.joint)))
            alarms += not on_files.within
        anew += once.runs - located
        report.add(f"check through image files = lab path, same verdict and diagnosis: {name} "
                   f"({FILE_TRIALS} trials)", 100 * same / FILE_TRIALS, ">=", 99.0, "%",
                   f"out of limits in {alarms} of {FILE_TRIALS}; 8 check poses; {FILE_DRAWS} change draws × "
                   f"{FILE_NOISE} renders of each pose")
    total = time.perf_counter() - t0
    report.info("  pairs rendered, written and located", once.runs - anew, "pairs")
    report.info("  pairs read from files, located", FILE_TRIALS * len(SCENARIOS) * len(cell.Q), "pairs")
    report.info("    of them with pixels not those rendered (located anew)", anew, "pairs")
    report.info("  time: rendering, writing and locating the pairs", seconds_rendering, "s")
    report.info("  time per trial (read the files, check and diagnose twice)",
                (total - seconds_rendering) / (FILE_TRIALS * len(SCENARIOS)), "s")


def _shuffled_products(poses: int, renders: int, *, seed: int):
    """Distinct choices of one render per pose (tuples of `poses` indices below `renders`), in a seeded random order."""
    rng = np.random.default_rng(seed)
    seen = set()
    total = renders ** poses
    while len(seen) < total:
        c = tuple(int(v) for v in rng.integers(0, renders, poses))
        if c not in seen:
            seen.add(c)
            yield c


def _reidentification_through_images(report, lab, locator, calibrated, tmp) -> None:
    """A cell that changes, one after the other, each of REID_CHAINS' changes (each chain from the
    first calibration), each after its own calibration through images: at each, the check, its
    diagnosis and the proposed poses measured through images and re-identified with the cell's
    calibration as prior; then a full recalibration of the changed robot through images of the
    same kind (IMAGE_POSES poses, 25 % held out), which is the calibration the next change is
    checked and re-identified against. So every re-identification has its own prior (a different
    calibration, as luck drew it) and the ratio re-identified / full recalibration is pooled over
    as many calibrations as changes. Both held-out errors on the same 40 poses, against the true
    marker of the changed robot."""
    import shutil
    from app.jobs import check as job
    from core.errors import RoboCalError
    from core.identification.file import write_calibrated_model
    from core.robot.file import read_robot

    true = lab.true_robot
    held_Q = lab.random_visible_poses(40, np.random.default_rng(77))

    def held_out(robot):
        return Measurements(pose=np.arange(40), target=[lab.target] * 40, q_file=lab.nominal_robot.q_to_file(held_Q),
                            xyz=predict_points(robot, held_Q, [lab.target] * 40), Q=held_Q)

    rows = []           # (kind, spec, re-identified mm, full mm, prior's own mm before the change, poses, new)
    check_err, calibration_err, notes = [], [], []
    for c, chain in enumerate(REID_CHAINS):
        lab.true_robot = true
        prior_path = calibrated
        for i, spec in enumerate(chain):
            kind = "joint zero" if spec.startswith("joint") else spec.split(":")[0]
            before = error_stats(read_robot(prior_path), held_out(lab.true_robot)).rms_mm
            path = tmp / f"reid-{c}-{i}.json"
            shutil.copy(prior_path, path)
            cell, result, diagnosis = job.check_project(path, lab, change=spec, images=(locator.trained, locator.rect),
                                                        seed=40 + i)
            changed = lab_copy_truth(lab, spec)
            truth = predict_points(changed.true_robot, result.Q, [lab.target] * len(result.Q))
            check_err += [p.measured - t for p, t in zip(result.points, truth)]
            held = held_out(changed.true_robot)
            full_meas = _through_images(changed, locator, changed.random_visible_poses(
                IMAGE_POSES, np.random.default_rng(60 + i)), seed=61 + i)
            full_result = identify(lab.nominal_robot, full_meas, holdout=0.25)
            calibration_err += list(full_meas.xyz - predict_points(changed.true_robot, full_meas.Q, full_meas.target))
            full = error_stats(full_result.model, held).rms_mm
            prior_path = write_calibrated_model(full_result, tmp / f"calibrated-{c}-{i + 1}.json")   # the next prior
            if diagnosis is None or not diagnosis.explained:
                notes.append(f"{spec}: {'within limits' if diagnosis is None else 'unexplained'}")
            else:
                try:
                    update = job.reidentify_on_lab(cell, result, diagnosis, lab, spec, path,
                                                   images=(locator.trained, locator.rect), lab_options=lab_options(lab),
                                                   seed=50 + i)
                    re = error_stats(update.reidentification.model, held).rms_mm
                    rows.append((kind, spec, re, full, before, len(update.proposed) + len(result.points),
                                 len(update.proposed)))
                except RoboCalError as exc:
                    notes.append(f"{spec}: refused ({exc.problem[:60]})")
            lab.true_robot = changed.true_robot              # the cell as it is now, for the next change
    lab.true_robot = true
    for kind in dict.fromkeys(k for k, *_ in rows):
        mine = [r for r in rows if r[0] == kind]
        ratio = math.sqrt(sum(r[2] ** 2 for r in mine) / sum(r[3] ** 2 for r in mine))
        report.add(f"re-identified {kind} through images: held-out error / full recalibration's", ratio, "<=", 1.2, "",
                   f"RMS over {len(mine)} changes, each with its own calibration as prior: " + "; ".join(
                       f"{r[1]}: {r[2]:.4f} vs {r[3]:.4f} mm (prior's own {r[4]:.4f}), {r[6]} proposed + "
                       f"{r[5] - r[6]} check poses" for r in mine))
    if rows:
        ratios = np.array([r[2] / r[3] for r in rows])
        report.add("re-identified, all changes through images: held-out error / full recalibration's",
                   math.sqrt(sum(r[2] ** 2 for r in rows) / sum(r[3] ** 2 for r in rows)), "<=", 1.2, "",
                   f"RMS over {len(rows)} changes and calibrations; single changes median {np.median(ratios):.2f}, "
                   f"worst {ratios.max():.2f}")
        report.info("  the priors' own held-out error / the full recalibrations' (RMS)",
                    math.sqrt(sum(r[4] ** 2 for r in rows) / sum(r[3] ** 2 for r in rows)), "")
        report.info("  poses used (proposed + check), fewest – most",
                    f"{min(r[5] for r in rows)} – {max(r[5] for r in rows)}")
    for where, errors in (("the check poses", check_err), ("the full recalibrations' poses", calibration_err)):
        e = np.array(errors)
        report.info(f"  image error at {where} (located − true), RMS 3D", float(np.sqrt(np.mean(np.sum(e ** 2, 1)))),
                    "mm")
    report.info("  changes the diagnosis left unexplained (full calibration advised)",
                f"{sum(n.endswith(': unexplained') for n in notes)} of {sum(len(c) for c in REID_CHAINS)}")
    if notes:
        report.info("  not re-identified", "; ".join(notes))


def lab_copy_truth(lab, spec):
    """A copy of the lab with `spec` applied as the check saw it (app.jobs.check.lab_measure's change)."""
    import copy
    from app.jobs.check import CHANGE_SEED
    changed = copy.copy(lab)
    apply_change(changed, spec, seed=CHANGE_SEED)
    return changed


def _check_over_sim_robot(report, lab, locator, calibrated, tmp) -> None:
    """An 8-pose check driven over sim-robot on a real pty at realistic speed, cameras two image
    folders holding the pairs rendered at the check poses: the time beyond motion + capture."""
    import time
    import cv2
    from app.jobs import check as job
    from app.jobs.check_sources import connected_cell
    from core.robot.controller_sim import ControllerSim

    cell = job.setup(calibrated, lab_options=lab_options(lab))
    rng = np.random.default_rng(3)
    folder = tmp / "cams"
    for side in ("left", "right"):
        (folder / side).mkdir(parents=True)
    for j, q in enumerate(cell.Q):
        left, right = lab.render_marker_pair(q, rng)
        cv2.imwrite(str(folder / "left" / f"{j:02d}.png"), left)
        cv2.imwrite(str(folder / "right" / f"{j:02d}.png"), right)
    with ControllerSim(lab.true_robot, time_scale=1.0) as sim:
        poses = connected_cell(cell.model, cell.Q, sim.port, "robocal_v1", (str(folder / "left"), str(folder / "right")),
                               locator)
        with poses:
            t = time.perf_counter()
            result = run_check(cell.model, cell.unc, cell.Q, poses.measure, limits=cell.limits, log=tmp / "c.csv")
            total = time.perf_counter() - t
        motion = sim.motion_seconds
    assert len(result.points) == 8
    # capture = grab + read of the two image files, timed apart on the same files
    from core.measurement.capture import open_stereo
    with open_stereo(str(folder / "left"), str(folder / "right")) as cams:
        t = time.perf_counter()
        for _ in range(8):
            cams.capture()
        capture = time.perf_counter() - t
    report.info("8-pose check over sim-robot (speed 25 %, real pty): total", total, "s")
    report.info("  motion time alone (simulator)", motion, "s")
    report.info("  capture time (two image folders)", capture, "s")
    report.add("8-pose check over sim-robot: time beyond motion + capture", 100 * (total - motion - capture) /
               (motion + capture), "<=", 10.0, "%", f"{result.verdict()[:40]}…; locating the marker counts as overhead")


def run_through_images(report) -> None:
    import tempfile
    from pathlib import Path
    with tempfile.TemporaryDirectory(prefix="robocal-bench-") as tmp:
        tmp = Path(tmp)
        lab, locator, calibrated, _ = _image_cell(tmp)
        _check_over_sim_robot(report, lab, locator, calibrated, tmp)
        _reidentification_through_images(report, lab, locator, calibrated, tmp)
        _file_path_verdicts(report, lab, locator, calibrated, tmp)
