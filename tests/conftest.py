"""Suite-wide test settings.

- Qt runs offscreen unless told otherwise (QT_QPA_PLATFORM).
- Temporary folders the code under test makes (tempfile, a child process's TMPDIR) go under
  pytest's own temporary folder, so tests write nowhere else.
- Hypothesis is derandomized (its examples follow from each test's source, no example
  database is read or written), so every run, locally and on CI, tries the same examples.
- Virtual labs and trained markers are built once per session (per xdist worker) and handed out
  as copies: the session fixture `built_lab`, tests/app/virtual_inputs.lab_marker (tests/session_cache.py).
- napari style: a GUI test (one that uses qtbot or qapp) fails when it leaves a QThread
  running, a busy TaskRunner, or a visible top-level window behind. Leftovers are cleaned up
  before failing, so one leak does not cascade into the following tests.
- What collection loaded (modules, classes, test functions: ~130 000 objects that live as long
  as the session), and what survives the full collection after each GUI test, is frozen out of
  the garbage collector's view, so the next collections scan only what the following tests make.
- SIFT features and checkerboard corners are computed once per session for each distinct image
  (the virtual lab renders the same images in many tests) and handed out as copies; so are the
  lab's stereo renderings (for each distinct lab, pose and random state), markers trained from an
  image and the marker's locations in a pair, outside the renderer's and the marker's own tests
  and tests marked no_session_cache (tests/session_cache.py).
- With pytest-xdist (`make test` runs `-n <cores + 1> --dist loadscope`), the longest modules are
  handed out first (their seconds in the last run, from pytest's cache) and the modules that
  share the in-process demo walk run on one worker (tests/scheduling.py). The demo walked in a
  fresh process starts in the background at a lower priority as soon as a worker has collected
  its test module, which is handed out last (tests/app/gui_process.py).
- At the end of the session each process deletes what its tests left of Qt (windows, menus,
  graphics items outside a scene, parentless objects) in order, with every module still
  loaded, so PySide has only the application left to delete at the interpreter's exit.
- With pytest-xdist, a worker process that ends abnormally after its
  tests (a crash while Qt tears down at interpreter exit) fails the run, as it would without
  workers: pytest's exit status stays the one CI must see.

Qt is imported only for GUI tests: tests/core never loads it.
"""
from __future__ import annotations

import faulthandler
import gc
import os
import signal
import sys
import tempfile

import pytest
from hypothesis import settings

from tests import scheduling
from tests.app.gui_process import WalkInBackground
from tests.session_cache import (computed_once_per_image, lab_copy, located_once_per_input,
                                 rendered_once_per_input, trained_once_per_image)

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
# Linear algebra on one thread per test process (numpy is loaded after this file): `make test` runs
# one process per core (pytest-xdist), so BLAS threads on top would only oversubscribe the cores.
for _threads in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_threads, "1")

settings.register_profile("robocal", derandomize=True, database=None, print_blob=True)
settings.load_profile("robocal")

GUI_FIXTURES = {"qtbot", "qapp"}


def visible_top_level_windows() -> list:
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance()
    # a shown widget window has a visible native window: without one, the thousands of hidden
    # top-level widgets (every plot's context menus) need not be looked at one by one
    if app is None or not any(window.isVisible() for window in app.topLevelWindows()):
        return []
    return [w for w in app.topLevelWidgets() if w.isVisible() and w.isWindow()
            and w.windowType() not in _popup_types()]


def _popup_types():
    from PySide6.QtCore import Qt
    return (Qt.WindowType.Popup, Qt.WindowType.ToolTip)


def busy_runners() -> list:
    if "app.worker" not in sys.modules:
        return []
    return [r for r in sys.modules["app.worker"].live_runners() if r.busy]


class QThreadTracker:
    """Records every QThread started from Python (QThread.start patched), like napari."""

    def __init__(self, monkeypatch):
        from PySide6.QtCore import QThread

        self.threads: list = []
        original = QThread.start
        tracker = self

        def start(thread, *args, **kwargs):
            tracker.threads.append(thread)
            return original(thread, *args, **kwargs)

        monkeypatch.setattr(QThread, "start", start)

    def running(self) -> list:
        alive = []
        for t in self.threads:
            try:
                if t.isRunning():
                    alive.append(t)
            except RuntimeError:   # the C++ object is gone: not running
                pass
        return alive


def pytest_collection_finish(session):
    gc.collect()
    gc.freeze()


class WorkerExitStatus:
    """Controller-side (pytest-xdist): fails the session when a worker process crashed at exit (a
    signal or a non-zero status). One that xdist itself killed (SIGKILL: it had not ended 10 s
    after its tests, e.g. a test left a thread running, which that test's own check reports) is
    said, not failed: on a busy machine a healthy worker can be that slow to end."""

    def __init__(self):
        self.gateways: list = []

    def pytest_xdist_newgateway(self, gateway):
        self.gateways.append(gateway)

    @pytest.hookimpl(wrapper=True)
    def pytest_sessionfinish(self, session):
        result = yield                       # xdist's own sessionfinish has ended the workers
        crashed, killed = [], []
        for gw in self.gateways:
            popen = getattr(getattr(gw, "_io", None), "popen", None)
            status = None if popen is None else popen.poll()
            if status == -signal.SIGKILL:
                killed.append(gw.id)
            elif status not in (0, None):
                crashed.append(f"{gw.id} (exit status {status})")
        reporter = session.config.pluginmanager.get_plugin("terminalreporter")
        if reporter is not None and (crashed or killed):
            reporter.write_line("")
            if killed:
                reporter.write_line(f"worker(s) {', '.join(killed)} did not end within 10 s and were killed", yellow=True)
            if crashed:
                reporter.write_line("worker process(es) crashed after their tests: " + ", ".join(crashed), red=True)
        if crashed and session.exitstatus == 0:
            session.exitstatus = pytest.ExitCode.TESTS_FAILED
        return result


@pytest.hookimpl(trylast=True)
def pytest_sessionfinish(session):
    """Every process's Qt work ends here, on its main thread, after the session's fixtures are
    torn down: tasks cancelled and every worker pool's threads ended (an idle pool thread lives
    on for 30 s and would otherwise end during the interpreter's exit), the last deferred
    deletions done and the frozen objects collected, so nothing of Qt is left to the exit."""
    if "PySide6.QtWidgets" not in sys.modules:
        return
    from PySide6.QtCore import QEvent, QThreadPool
    from PySide6.QtWidgets import QApplication

    if "app.worker" in sys.modules:
        for runner in sys.modules["app.worker"].live_runners():
            try:
                runner.shutdown(5000)
            except RuntimeError:          # its Qt object went with its window: no threads left
                pass
    QThreadPool.globalInstance().waitForDone(5000)
    app = QApplication.instance()
    if app is not None:
        QApplication.sendPostedEvents(None, QEvent.Type.DeferredDelete)
        QApplication.processEvents()
    gc.unfreeze()
    gc.collect()
    if app is not None:
        _delete_what_qt_has_left(app)


def _delete_what_qt_has_left(app) -> None:
    """Delete, in order, what the session's tests left of Qt: every top-level widget (the
    windows, the plots' parentless context menus) with its children, then the graphics items
    outside any scene, then the objects without a parent that Python owns. Otherwise PySide
    deletes them at the interpreter's exit in no set order, and a process that made hundreds of
    windows can crash there (SIGSEGV with no Python frame) after all its tests passed."""
    import shiboken6
    from PySide6.QtCore import QObject, QThreadPool
    from PySide6.QtWidgets import QGraphicsItem

    # a menu's submenus are top-level windows too, and go with it: only windows without a parent
    # are deleted, each unless another's deletion took it already (shiboken may not know of a
    # window Qt made: Qt's destroyed signal says)
    windows = [w for w in app.topLevelWidgets() if w.parentWidget() is None]
    gone: set[int] = set()
    for w in windows:
        w.destroyed.connect(lambda *_, key=id(w): gone.add(key))
    for w in windows:
        if id(w) not in gone:
            shiboken6.delete(w)
    del windows
    gc.collect()
    # what to delete is chosen before anything is deleted: a deletion takes its children with it
    kept = {id(app), id(app.style()), id(QThreadPool.globalInstance())}
    items, objects = [], []
    for o in gc.get_objects():
        if id(o) in kept or not isinstance(o, (QObject, QGraphicsItem)) or not shiboken6.isValid(o):
            continue
        if isinstance(o, QGraphicsItem) and o.scene() is None and o.parentItem() is None:
            items.append(o)
        elif isinstance(o, QObject) and o.parent() is None and shiboken6.ownedByPython(o):
            objects.append(o)
    for obj in items + objects:
        if shiboken6.isValid(obj):
            shiboken6.delete(obj)
    del items, objects
    gc.collect()


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """A crash while the interpreter exits still prints every thread's Python stack (pytest's
    own fault handler is switched off by then)."""
    faulthandler.enable(file=sys.__stderr__, all_threads=True)


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: over ~20 s alone (a whole demo walk, a fuzzed command line, a chain of "
                                       "commands on rendered images); `make test-quick` leaves them out")
    config.addinivalue_line("markers", "no_session_cache: the virtual lab's renderings, the marker's locations and "
                                       "trainings are computed again, not handed out from the session's (a test of "
                                       "repeatability, or of what happens while a run is under way: each pose takes "
                                       "its real time)")
    if config.pluginmanager.hasplugin("xdist") and not hasattr(config, "workerinput"):
        config.pluginmanager.register(WorkerExitStatus(), "robocal-worker-exit-status")
        config.pluginmanager.register(WalkInBackground(config), "robocal-demo-walk-in-background")
        if config.getvalue("dist") == "loadscope":
            config.pluginmanager.register(scheduling.ModuleSeconds(config), "robocal-module-seconds")


@pytest.hookimpl(tryfirst=True, optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """`--dist loadscope`: the longest modules first (tests/scheduling.py)."""
    return scheduling.make_scheduler(config, log)


@pytest.fixture(scope="session")
def built_lab():
    """built_lab(robot=None, seed=0, noise=0.5, **options): a copy of that VirtualLab, built once."""
    return lab_copy


@pytest.fixture(autouse=True)
def _temporary_files_under_pytest(tmp_path_factory, monkeypatch):
    folder = tmp_path_factory.mktemp("tempfile")
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    monkeypatch.setenv("TMPDIR", str(folder))


@pytest.fixture(autouse=True)
def _images_analysed_once(monkeypatch):
    """SIFT features and checkerboard corners of an image seen before in the session are a copy
    of the first result (tests/session_cache.py)."""
    computed_once_per_image(monkeypatch)


@pytest.fixture(autouse=True)
def _renderings_and_locations_made_once(request, monkeypatch):
    """A stereo pair the virtual lab rendered before in the session, from the same lab, pose,
    options and random state, is a copy of the first rendering; so is the marker located again in
    the same pair with the same marker, rectification and options, and a marker trained again from
    the same image (tests/session_cache.py); not in the renderer's and the marker's own tests
    (tests/core/virtual_lab, tests/core/marker) and tests marked no_session_cache."""
    if request.node.get_closest_marker("no_session_cache"):
        return
    if "tests/core/virtual_lab/" not in request.node.nodeid:
        rendered_once_per_input(monkeypatch)
    if "tests/core/marker/" not in request.node.nodeid:
        located_once_per_input(monkeypatch)
        trained_once_per_image(monkeypatch)


@pytest.fixture(autouse=True)
def _no_qt_leftovers(request, monkeypatch):
    if not GUI_FIXTURES & set(request.fixturenames):
        yield
        return
    request.getfixturevalue("qapp")
    tracker = QThreadTracker(monkeypatch)
    yield
    # runs after qtbot's teardown (autouse fixtures are set up first, torn down last),
    # so widgets registered with qtbot.addWidget are already closed.
    from PySide6.QtCore import QEvent
    from PySide6.QtWidgets import QApplication

    # The test's widgets deleted now, on the GUI thread: pytest-qt's deleteLater, then pages
    # only reference cycles keep (a panel's `page`), which a later garbage collection would
    # otherwise free on whatever thread runs it (a worker), or while the windows are listed below.
    QApplication.sendPostedEvents(None, QEvent.Type.DeferredDelete)
    gc.collect()
    gc.freeze()               # what survived is the session's: the next collection scans only what comes
    QApplication.processEvents()
    problems = []
    runners = busy_runners()
    if runners:
        problems.append(f"{len(runners)} TaskRunner(s) still busy: "
                        + ", ".join(repr(h) for r in runners for h in r.running_tasks()))
        for r in runners:
            r.shutdown(5000)
    threads = tracker.running()
    if threads:
        problems.append(f"{len(threads)} QThread(s) still running")
        for t in threads:
            t.quit()
            t.wait(5000)
    windows = visible_top_level_windows()
    if windows:
        problems.append("top-level window(s) left open: "
                        + ", ".join(f"{type(w).__name__}({w.objectName() or w.windowTitle()!r})"
                                    for w in windows))
        for w in windows:
            w.close()
            w.deleteLater()
        QApplication.processEvents()
    if problems:
        pytest.fail("test left Qt objects behind: " + "; ".join(problems)
                    + " (close windows with qtbot.addWidget, wait for threads and runners)",
                    pytrace=False)
