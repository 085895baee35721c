"""Expensive, deterministic test inputs and results built once per test session (with
pytest-xdist: once per worker process) and handed out as deep copies: virtual labs (~0.3 s), trained
markers (~0.6 s), and the SIFT features and checkerboard corners of an image (~0.1 s each); and
memoised for each distinct input: the lab's stereo renderings, markers trained from an image and
the marker located in a pair.

A test gets the same object a fresh build would give it, and cannot change what another test
gets: labs are changed in place by tests (`apply_change` moves the true robot, `lab.target`, a
rig replaced), so the built original is never handed out. tests/conftest.py exposes labs as the
session fixture `built_lab` and installs the image caches for every test;
tests/app/virtual_inputs.lab_marker hands out trained markers.
"""
from __future__ import annotations

import copy
import hashlib
import os
import pickle
import threading
import weakref
from collections import OrderedDict

_built: dict = {}
_originals: dict = {}                # (owner, name) -> what owner.name was before this module replaced it


def _unpatched(owner, name: str):
    """`owner.name` as it was before this module first replaced it for a test."""
    return _originals.setdefault((owner, name), getattr(owner, name))


def shared_copy(key, build):
    """A deep copy of `build()`, which runs once per session for each `key`."""
    if key not in _built:
        _built[key] = build()
    return copy.deepcopy(_built[key])


def _robot_key(robot) -> str:
    """The robot's digest: the same model read from a file or given as a RobotModel, the same key."""
    from core.robot.file import read_robot
    from core.robot.model import robot_path
    from core.virtual_lab.lab import DEFAULT_ROBOT

    if robot is None:
        robot = robot_path(DEFAULT_ROBOT)
    if isinstance(robot, (str, os.PathLike)):
        robot = read_robot(robot)
    return hashlib.sha1(pickle.dumps(robot)).hexdigest()


def lab_copy(robot=None, seed: int = 0, noise: float = 0.5, **options):
    """A copy of `VirtualLab.create(robot, seed=seed, noise=noise, **options)` (robot: None for the
    educational 6R arm, a robot file or a RobotModel)."""
    from core.virtual_lab.lab import VirtualLab

    create = _unpatched(VirtualLab, "create")
    key = ("lab", _robot_key(robot), int(seed), float(noise), tuple(sorted(options.items())))
    return shared_copy(key, lambda: create(robot, seed=seed, noise=noise, **options))


def create_labs_once(monkeypatch) -> None:
    """For the duration of a test, VirtualLab.create (the wizard's lab on its worker thread, the
    commands' --lab options, `robocal simulate`) hands out copies of labs built once per session.
    A lab given a rig, board or marker object is built as before."""
    from core.virtual_lab.lab import VirtualLab

    original = _unpatched(VirtualLab, "create")

    def create(cls, robot=None, seed=0, noise=0.5, *more, **options):
        if more or any(not isinstance(v, (bool, int, float, str, type(None))) for v in options.values()):
            return original(robot, seed, noise, *more, **options)
        return lab_copy(robot, seed, noise, **options)

    monkeypatch.setattr(VirtualLab, "create", classmethod(create))


def trained_marker_copy(lab):
    """A copy of the lab's marker trained on its rendered training image at its true outer size
    (the image follows from the lab's seed, noise and marker description only)."""
    from core.marker.training import train_marker

    key = ("marker", int(lab.seed), float(lab.noise), hashlib.sha1(pickle.dumps(lab.marker)).hexdigest())
    return shared_copy(key, lambda: train_marker(lab.render_training_image(), outer_size=lab.marker.outer_size))


class KeptResults:
    """Results by key, at most `limit` of them (the least recently used is forgotten first), safe
    to use from the worker threads that compute in parallel."""

    def __init__(self, limit: int):
        self.limit = limit
        self._kept: OrderedDict = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key):
        """The result kept for `key`, or None."""
        with self._lock:
            found = self._kept.get(key)
            if found is not None:
                self._kept.move_to_end(key)
            return found

    def keep(self, key, result) -> None:
        with self._lock:
            self._kept[key] = result
            while len(self._kept) > self.limit:
                self._kept.popitem(last=False)


_pixel_results = KeptResults(4000)   # about 1 GB of SIFT features and corners at most per process


def _pixel_key(name: str, image, args, kwargs) -> tuple:
    import numpy as np

    image = np.ascontiguousarray(image)
    return (name, image.shape, image.dtype.str, hashlib.sha1(image).hexdigest(), repr(args),
            repr(sorted(kwargs.items())))


def computed_once_per_image(monkeypatch) -> None:
    """For the duration of a test, SIFT features (core.marker.detection.sift_features) and
    checkerboard corners (core.stereo.detection.detect_corners), both functions of the pixels and
    their options only, are computed once per session for each distinct image and option (the
    rendered images of the virtual lab repeat from test to test), and handed out as copies."""
    from core.marker import detection as marker_detection
    from core.stereo import detection as board_detection
    from core.stereo import screening

    for module, name, users in ((marker_detection, "sift_features", (marker_detection,)),
                                (board_detection, "detect_corners", (board_detection, screening))):
        original = _unpatched(module, name)

        def cached(image, *args, _name=name, _original=original, **kwargs):
            key = _pixel_key(_name, image, args, kwargs)
            result = _pixel_results.get(key)
            if result is None:
                result = _original(image, *args, **kwargs)
                _pixel_results.keep(key, result)
            return copy.deepcopy(result)

        for user in users:
            monkeypatch.setattr(user, name, cached)


_trained = KeptResults(200)


def trained_once_per_image(monkeypatch) -> None:
    """For the duration of a test, a marker trained from an image (core.marker.training.train_marker,
    a function of the pixels, the outline and the options: ~0.5 s) is trained once per session for
    each distinct image and option and handed out as a copy, wherever the wizard, a command or a
    test trains it; a call that reports progress or can be cancelled is always computed."""
    import numpy as np

    import app.jobs.marker
    import core.marker
    import core.virtual_lab.marker_comparison
    from core.marker import training

    original = _unpatched(training, "train_marker")

    def cached(image, outline=None, *, progress=None, cancelled=None, **options):
        if progress is not None or cancelled is not None:
            return original(image, outline, progress=progress, cancelled=cancelled, **options)
        key = _pixel_key("train_marker", image, (None if outline is None else np.asarray(outline).tolist(),), options)
        kept = _trained.get(key)
        if kept is None:
            kept = original(image, outline, **options)
            _trained.keep(key, kept)
        return copy.deepcopy(kept)

    for user in (training, core.marker, app.jobs.marker, core.virtual_lab.marker_comparison):
        monkeypatch.setattr(user, "train_marker", cached)


_renders = KeptResults(300)          # (left, right, rng state after the render): ~0.8 GB per process at most
_digest_lock = threading.Lock()
_room_digests: dict = {}             # id(room) -> (weak reference, digest): a room is never changed in place


def _digest_once(digests: dict, thing, make) -> str:
    """make(thing), remembered for as long as `thing` lives (by identity, without keeping it alive)."""
    with _digest_lock:
        known = digests.get(id(thing))
        if known is not None and known[0]() is thing:
            return known[1]
    digest = make(thing)
    with _digest_lock:
        digests[id(thing)] = (weakref.ref(thing), digest)
    return digest


def _room_digest(room) -> str:
    return _digest_once(_room_digests, room, lambda r: hashlib.sha1(pickle.dumps(r)).hexdigest())


def _render_key(name: str, lab, args, kwargs, rng) -> tuple | None:
    """Everything a lab's rendering depends on, or None where the result is not repeatable (no
    generator or seed given: fresh entropy)."""
    import numpy as np

    if rng is None:
        return None
    rng_key = (rng.bit_generator.state if isinstance(rng, np.random.Generator) else rng)
    scene = (lab.rig, lab.true_robot, lab.board, lab.marker, lab.noise, lab.target, lab._right_from_left)
    return (name, hashlib.sha1(pickle.dumps((scene, args, sorted(kwargs.items()), rng_key))).hexdigest(),
            _room_digest(lab.room))


def rendered_once_per_input(monkeypatch) -> None:
    """For the duration of a test, the virtual lab's stereo renderings (render_checkerboard_pair,
    render_marker_pair, render_marker_at: functions of the lab's rig, true robot, board, marker,
    room and noise, the pose and options, and the random generator's state) are rendered once per
    session for each distinct input and handed out as copies; the caller's generator is left in the
    state the rendering would have left it in. Renderings without a generator or seed are not kept."""
    import numpy as np

    from core.virtual_lab.lab import VirtualLab

    for name in ("render_checkerboard_pair", "render_marker_pair", "render_marker_at"):
        original = _unpatched(VirtualLab, name)

        def cached(lab, pose, rng=None, *args, _name=name, _original=original, **kwargs):
            key = _render_key(_name, lab, args, kwargs, rng)
            if key is None:
                return _original(lab, pose, rng, *args, **kwargs)
            key = key + (hashlib.sha1(np.ascontiguousarray(pose, dtype=float)).hexdigest(),)
            kept = _renders.get(key)
            if kept is None:
                generator = rng if isinstance(rng, np.random.Generator) else None
                left, right = _original(lab, pose, rng, *args, **kwargs)
                _renders.keep(key, (left.copy(), right.copy(), generator and generator.bit_generator.state))
                return left, right
            if isinstance(rng, np.random.Generator):
                rng.bit_generator.state = kept[2]
            return kept[0].copy(), kept[1].copy()

        monkeypatch.setattr(VirtualLab, name, cached)


_locations = KeptResults(2000)       # MarkerLocation by images, marker, rectification and options
_locator_digests: dict = {}          # id(locator) -> (weak reference, digest of its marker and rectification)


def _add_array(digest, array) -> None:
    """Feed an array's shape, type and bytes to a hashlib digest."""
    import numpy as np

    array = np.ascontiguousarray(array)
    digest.update(repr((array.shape, array.dtype.str)).encode())
    digest.update(array)


def _trained_digest(trained) -> str:
    """The digest of what a trained marker's file holds (every field but where it was read from),
    from the arrays' bytes (0.6 ms): its compressed file (TrainedMarker.to_bytes) took 80 ms to write."""
    import dataclasses

    import numpy as np

    digest = hashlib.sha1()
    for f in dataclasses.fields(trained):
        if f.name in ("source", "_kp_cache"):
            continue
        value = getattr(trained, f.name)
        digest.update(f.name.encode())
        if isinstance(value, np.ndarray):
            _add_array(digest, value)
        else:
            digest.update(repr(value).encode())
    return digest.hexdigest()


def _locator_digest(locator) -> str:
    return _digest_once(_locator_digests, locator,
                        lambda loc: hashlib.sha1(pickle.dumps((_trained_digest(loc.trained), loc.rect))).hexdigest())


def located_once_per_input(monkeypatch) -> None:
    """For the duration of a test, MarkerLocator.locate of a stereo pair (a function of the two
    images, the trained marker, the rectification, the options and the predicted homographies)
    is computed once per session for each distinct input and handed out as a copy; a call that
    reports progress or can be cancelled is always computed."""
    from core.marker.location import MarkerLocator

    original = _unpatched(MarkerLocator, "locate")

    def cached(locator, left, right, *, predicted=None, progress=None, cancelled=None):
        if progress is not None or cancelled is not None:
            return original(locator, left, right, predicted=predicted, progress=progress, cancelled=cancelled)
        images = hashlib.sha1()
        for image in (left, right):
            _add_array(images, image)
        key = (_locator_digest(locator), images.hexdigest(),
               hashlib.sha1(pickle.dumps((locator.options, predicted))).hexdigest())
        kept = _locations.get(key)
        if kept is None:
            kept = original(locator, left, right, predicted=predicted)
            _locations.keep(key, kept)
        return copy.deepcopy(kept)

    monkeypatch.setattr(MarkerLocator, "locate", cached)
