"""How `make test` (pytest-xdist, `--dist loadscope`) hands the test modules to its workers:
the longest first, so that no long module starts last while the other workers have nothing
left to do (xdist's own order, most tests first, started the one-minute demo walks last).

- A module's length: its seconds in the last run (setup, call and teardown of its tests, saved
  in pytest's cache: .pytest_cache), else the estimate in SECONDS, else 0.4 s a test.
- Modules that share one expensive session input run on the same worker (SAME_WORKER), so it is
  built once: the in-process demo walk (tests/app/demo_walk.py), the simulated dataset of
  `locate` and `measure` (tests/app/commands/conftest.py).
- Modules that read what a background process made are handed out last (LAST), so that the
  process has had the whole run to end: the demo walked in a fresh process (tests/app/gui_process.py).

Only the order and the grouping change: every test runs, each module on one worker as before.
"""
from __future__ import annotations

from collections import defaultdict

from xdist.scheduler import LoadScopeScheduling

from tests.app import gui_process

CACHE_KEY = "robocal/module_seconds"
SECONDS_PER_TEST = 0.4

#: modules that read the same session-scoped input, scheduled as one unit
SAME_WORKER = {
    "tests/app/test_autopilot.py": "demo walk",
    "tests/app/test_small_screens.py": "demo walk",
    "tests/app/commands/test_locate.py": "6-pose dataset",
    "tests/app/commands/test_measure.py": "6-pose dataset",
}

#: modules handed out after every other (they wait for a process started with the session)
LAST = {gui_process.MODULE}

#: seconds of the long modules in a full run on this 2-core machine, for a run without a cache (CI)
SECONDS = {
    "demo walk": 56.0,
    "tests/app/commands/test_check_port.py": 32.0,
    "tests/app/commands/test_check_files.py": 26.0,
    "tests/app/pages/test_measurement_page.py": 20.0,
    "tests/app/pages/test_stereo_page.py": 19.0,
    "tests/app/pages/test_check_real_cell.py": 17.0,
    "tests/app/test_main_window.py": 16.0,
    "tests/app/pages/test_measurement_page_hardware.py": 16.0,
    "tests/app/pages/test_compensation_page.py": 13.0,
    "tests/app/test_calibration_over_serial.py": 12.0,
    "tests/core/fixtures/test_virtual_fixture.py": 12.0,
    "tests/app/pages/test_marker_page.py": 12.0,
    "tests/app/report/test_render.py": 11.0,
    "tests/core/virtual_lab/test_robustness.py": 11.0,
    "tests/app/pages/test_export_page.py": 11.0,
    "tests/test_docs_commands.py": 9.0,
    "tests/app/pages/test_marker_conditions.py": 9.0,
    "tests/core/virtual_lab/test_dataset.py": 9.0,
}


def scope_of(nodeid: str) -> str:
    """The work unit of a test: its module, or the SAME_WORKER group of its module."""
    module = nodeid.split("::", 1)[0]
    return SAME_WORKER.get(module, module)


class LongestFirstScheduling(LoadScopeScheduling):
    """LoadScopeScheduling whose next work unit is always the longest one left."""

    def __init__(self, config, log=None, seconds: dict | None = None):
        super().__init__(config, log)
        self.seconds = {**SECONDS, **(seconds or {})}

    def _split_scope(self, nodeid: str) -> str:
        return scope_of(nodeid)

    def length(self, scope: str) -> float:
        if scope in LAST:
            return -1.0
        if scope in self.seconds:
            return self.seconds[scope]
        return SECONDS_PER_TEST * len(self.workqueue[scope])

    def _assign_work_unit(self, node) -> None:
        longest = max(self.workqueue, key=self.length)
        self.workqueue.move_to_end(longest, last=False)
        super()._assign_work_unit(node)


class ModuleSeconds:
    """Controller-side: adds up each work unit's seconds in this run and saves them in the cache
    for the next run's order, over the figures saved before: only after a run without failures
    of whole modules (no -k, -m or single tests chosen), whose figures are complete."""

    def __init__(self, config):
        self.config = config
        self.seconds: dict[str, float] = defaultdict(float)

    def pytest_runtest_logreport(self, report):
        self.seconds[scope_of(report.nodeid)] += report.duration

    def pytest_sessionfinish(self, session, exitstatus):
        cache = getattr(self.config, "cache", None)
        option = self.config.option
        partial = option.keyword or option.markexpr or any("::" in a for a in self.config.args)
        if cache is None or exitstatus != 0 or partial or not self.seconds:
            return
        saved = cache.get(CACHE_KEY, None)
        merged = dict(saved) if isinstance(saved, dict) else {}
        merged.update({scope: round(s, 1) for scope, s in self.seconds.items()})
        cache.set(CACHE_KEY, dict(sorted(merged.items())))


def make_scheduler(config, log):
    """The scheduler for `--dist loadscope`; None (xdist's own) for any other --dist."""
    if config.getvalue("dist") != "loadscope":
        return None
    cache = getattr(config, "cache", None)
    saved = cache.get(CACHE_KEY, None) if cache is not None else None
    return LongestFirstScheduling(config, log, saved if isinstance(saved, dict) else None)
