"""The Marker page's studies in the virtual lab, a helper the page holds (not a base class): the
comparison of candidate markers, one pair under chosen imaging conditions and the robustness
sweep, each on a worker with the options of the model; what they give goes to the model (the
Compare markers and Conditions tabs draw from its events)."""
from __future__ import annotations

from typing import Callable

from app.html import number
from app.jobs.marker import Comparison, run_comparison
from app.jobs.marker_conditions import ConditionsPair, conditions_pair, run_sweep
from app.lab import RobustnessTable, VirtualLab
from app.pages.marker.model import MarkerModel
from app.pages.page_task import PageTask
from core.marker.location import MarkerLocator


class LabStudies:
    """`say(text, ok)` is the page's status line, `show_tab(name)` brings a tab forward
    ("compare", "conditions"), `ready_locator()` the marker's locator (None: the status line
    says what is missing)."""

    def __init__(self, state, model: MarkerModel, task: PageTask, *, say: Callable[[str, bool | None], None],
                 show_tab: Callable[[str], None], ready_locator: Callable[[], MarkerLocator | None]):
        self.state, self.model, self.task = state, model, task
        self._say = say
        self._show_tab = show_tab
        self._ready_locator = ready_locator
        self._conditions_count = 0

    def _in_lab(self, why: str) -> bool:
        """The virtual lab with a robot, else the status line says `why` it is needed."""
        if not self.state.virtual or self.state.robot is None:
            self._say(why, False)
            return False
        return True

    # -- comparison -------------------------------------------------------------------------
    def compare(self) -> bool:
        if not self._in_lab("The marker comparison renders its views in the virtual lab."):
            return False
        self._show_tab("compare")
        return self.task.with_lab(lambda lab: self.task.start(
            run_comparison, lab, self.model.options.comparison.views, int(self.state.seed),
            on_done=self._compared, label="Comparing markers", status="Comparing the candidate markers…"))

    def _compared(self, comparison: Comparison) -> None:
        self.model.set_comparison(comparison)
        result = comparison.result
        best = next(p for p in result.patterns if p.key == result.recommended)
        self._say(f"✓ Compared {len(result.patterns)} patterns over {result.views} views: "
                  f"{best.name} detected best ({100 * best.detection_rate:.0f} %).", True)

    # -- imaging conditions -------------------------------------------------------------------
    def _conditions_locator(self) -> MarkerLocator | None:
        """The locator, when the marker may be rendered under conditions (virtual lab only)."""
        if not self._in_lab("Imaging conditions are rendered in the virtual lab."):
            return None
        return self._ready_locator()

    def show_conditions(self, then=None) -> bool:
        """One marker pair under the chosen light, occlusion and tilt, located."""
        locator = self._conditions_locator()
        if locator is None:
            return False
        conditions = self.model.options.conditions.conditions
        self._show_tab("conditions")

        def go(lab: VirtualLab) -> bool:
            self._conditions_count += 1
            return self.task.start(conditions_pair, lab, locator, conditions, self._conditions_count,
                                   int(self.state.seed), on_done=self._conditions_shown, label="Conditions",
                                   then=then, status="Rendering the marker under these conditions and locating it…")

        return self.task.with_lab(go)

    def _conditions_shown(self, pair: ConditionsPair) -> None:
        self.model.set_conditions_pair(pair)
        loc = pair.location
        if loc.ok:
            self._say(f"✓ Located {number(pair.error, 3, 'mm')} from the true position.", True)
        else:
            self._say(f"Not located under these conditions: {loc.reason}", False)

    def sweep(self, then=None) -> bool:
        """Detection rate and 3D error over light levels, occlusions and tilts."""
        locator = self._conditions_locator()
        if locator is None:
            return False
        options = self.model.options.conditions
        pairs, side = options.sweep_pairs, options.conditions.side
        self._show_tab("conditions")
        return self.task.with_lab(lambda lab: self.task.start(
            run_sweep, lab, locator, pairs, int(self.state.seed), side, on_done=self._swept, label="Conditions sweep",
            then=then, status=f"Sweeping light, occlusion and tilt, {pairs} pairs per value…"))

    def _swept(self, table: RobustnessTable) -> None:
        self.model.set_sweep(table)
        if table.wrong:
            self._say(f"✗ {table.wrong} marker(s) accepted more than {table.wrong_mm:g} mm from the truth: "
                      "the locator's checks let a wrong point through.", False)
        else:
            self._say(f"✓ Swept {len(table.rows)} conditions × {table.pairs} pairs: no marker accepted more "
                      f"than {table.wrong_mm:g} mm off. See where detection drops.", True)
