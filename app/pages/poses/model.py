"""The Pose sequence step's model, without Qt: the selection's settings (its options), the
selection it returned (its result, a core.poses.selection.PoseSelectionResult: `.Q` rad/mm,
`.q_file` deg/mm) or, without one, the poses.csv found in the project (`loaded`).

Events: "options", "result" (a selection or None; also when `loaded` changed)."""
from __future__ import annotations

from dataclasses import dataclass

from app.pages.step_model import StepModel
from core.poses.file import PoseList, read_poses
from core.poses.selection import PoseSelectionResult
from core.project import Output

DEMO_COUNT = 30
DEMO_CANDIDATES = 1000


@dataclass(frozen=True)
class PoseOptions:
    """How many poses, by which observability index ("cond", "O1", …), from how many random
    feasible candidates, kept `margin` from every joint limit (° / mm), from `seed`."""

    count: int = DEMO_COUNT
    index: str = "cond"
    candidates: int = DEMO_CANDIDATES
    margin: float = 5.0
    seed: int = 0

    def keywords(self) -> dict:
        """Keyword arguments of app.jobs.poses.run_pose_selection (all but robot, count and lab)."""
        return dict(index=self.index, candidates=self.candidates, margin=self.margin, seed=self.seed)


class PosesModel(StepModel[PoseOptions, PoseSelectionResult]):
    """The selection of this session, or the project's poses.csv (`loaded`) without one."""

    def __init__(self):
        super().__init__(PoseOptions())
        self.loaded: PoseList | None = None

    @property
    def complete(self) -> bool:
        return self.result is not None or self.loaded is not None

    def load_existing(self, project, robot) -> None:
        """A poses.csv already in the project (an earlier session) counts as the selection, unless
        one was made here; RoboCalError (nothing loaded) when it cannot be used."""
        if self.result is not None or project is None or robot is None or not project.has(Output.POSES):
            return
        self.loaded = None
        self.loaded = read_poses(project.path(Output.POSES), robot)

    def selected(self, result: PoseSelectionResult | None) -> None:
        """A new selection (None: forgotten, another project or robot)."""
        self.loaded = None
        self.set_result(result)
