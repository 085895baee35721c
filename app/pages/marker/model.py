"""The Marker step's model, plain Python (no Qt): what the technician chose in the panels (the
options: training, verification, comparison, imaging conditions) and what the step produced
(the training image, the trained marker, the live pair, the verification, the comparison, the
conditions pair and sweep), with the stereo rectification the marker is located with.

The panels follow the model's events and the page sets it from what its jobs return:

    model.on("live", live_panel.draw)                  # a panel redraws from the model
    model.choose(verification=panel.options())         # a panel says what was chosen
    page.task.start(run_verification, ..., model.options.verification.poses, on_done=model.set_verification)

Events (each listener gets the value shown): "options" (MarkerOptions), "image" (TrainingImage:
a new image, not trained yet), "trained" (MarkerResult: the trained marker, None after another
project, with its image), "live" (LiveResult | None), "verification" (VerificationResult | None),
"verification_so_far" (VerificationResult: the poses measured so far, while it runs),
"verified" (bool), "comparison" (Comparison), "conditions_pair" (ConditionsPair), "sweep"
(RobustnessTable), "stereo" (StereoSource), and "result" (MarkerResult) after any result change.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from app.jobs.marker import Comparison, LiveResult, TrainingImage, VerificationResult
from app.jobs.marker_conditions import ConditionsPair
from app.lab import ImagingConditions, RobustnessTable
from app.pages.measurement_inputs import StereoSource
from app.pages.step_model import StepModel
from core.marker.location import LocatorOptions, MarkerLocator
from core.marker.training import DEFAULT_OUTER_SIZE, TrainedMarker


@dataclass(frozen=True)
class TrainingOptions:
    """The side of the marker's outer black square (mm) and the crop rectangle (x0, y0, x1, y1)
    px of the training image trained on (None: the whole image)."""

    outer_size: float = DEFAULT_OUTER_SIZE
    crop: tuple[int, int, int, int] | None = None


@dataclass(frozen=True)
class VerificationOptions:
    poses: int = 20                   # random robot poses where both cameras see the marker


@dataclass(frozen=True)
class ComparisonOptions:
    views: int = 20                   # random views each candidate pattern is detected in


@dataclass(frozen=True)
class ConditionsOptions:
    """One pair's light, occlusion (and its side) and tilt; the sweep's pairs per value (its
    occluder on the same side)."""

    conditions: ImagingConditions = ImagingConditions()
    sweep_pairs: int = 8


@dataclass(frozen=True)
class MarkerOptions:
    training: TrainingOptions = TrainingOptions()
    verification: VerificationOptions = VerificationOptions()
    comparison: ComparisonOptions = ComparisonOptions()
    conditions: ConditionsOptions = ConditionsOptions()


@dataclass(frozen=True, eq=False)
class MarkerResult:
    """What the step has: the training image, the trained marker (trained on the crop at
    `offset` px of that image, saved as `saved_path`), and what locating it gave."""

    training_image: TrainingImage | None = None
    trained: TrainedMarker | None = None
    offset: np.ndarray = field(default_factory=lambda: np.zeros(2))
    saved_path: Path | None = None              # the project's marker.npz
    verified: bool = False                      # located at least once (marker_verification.json)
    live: LiveResult | None = None
    verification: VerificationResult | None = None
    comparison: Comparison | None = None
    conditions_pair: ConditionsPair | None = None
    sweep: RobustnessTable | None = None


class MarkerModel(StepModel[MarkerOptions, MarkerResult]):
    """The Marker step's options and result, and the stereo source its locator uses."""

    def __init__(self, options: MarkerOptions | None = None):
        super().__init__(options or MarkerOptions())
        self.result: MarkerResult = MarkerResult()
        self.stereo = StereoSource(None, "", "no stereo calibration")
        self._locator: MarkerLocator | None = None

    def choose(self, **parts) -> None:
        """One panel's options changed, e.g. `choose(verification=VerificationOptions(10))`."""
        self.set_options(replace(self.options, **parts))

    def _update(self, event: str, value, **changes) -> None:
        self.set_result(replace(self.result, **changes))
        self.emit(event, value)

    # -- training ---------------------------------------------------------------------------
    def set_training_image(self, image: TrainingImage) -> None:
        """A new training image, to train (the marker trained before stays until then)."""
        self._update("image", image, training_image=image)

    def set_trained(self, trained: TrainedMarker | None, offset=(0.0, 0.0), path: Path | None = None,
                    image: TrainingImage | None = None) -> None:
        """The trained marker (None: none), trained on `image` (default: the current one)."""
        self._locator = None
        self.set_result(replace(self.result, trained=trained, offset=np.asarray(offset, dtype=float),
                                saved_path=path,
                                training_image=self.result.training_image if image is None else image))
        self.emit("trained", self.result)

    def forget(self) -> None:
        """Another project or robot: no training image, no marker, nothing located."""
        self.set_result(replace(self.result, training_image=None))
        self.set_trained(None)
        self.clear_located()

    # -- locating ---------------------------------------------------------------------------
    def clear_located(self) -> None:
        """Forget the live pair and the verification (another marker or project)."""
        self._update("verified", False, verified=False, live=None, verification=None)
        self.emit("live", None)
        self.emit("verification", None)

    def set_verified(self, verified: bool) -> None:
        self._update("verified", verified, verified=verified)

    def set_live(self, live: LiveResult) -> None:
        self._update("live", live, live=live)

    def set_verification(self, verification: VerificationResult) -> None:
        self._update("verification", verification, verification=verification)

    def set_comparison(self, comparison: Comparison) -> None:
        self._update("comparison", comparison, comparison=comparison)

    def set_conditions_pair(self, pair: ConditionsPair) -> None:
        self._update("conditions_pair", pair, conditions_pair=pair)

    def set_sweep(self, table: RobustnessTable) -> None:
        self._update("sweep", table, sweep=table)

    # -- stereo -----------------------------------------------------------------------------
    def set_stereo(self, source: StereoSource) -> None:
        """Where the rectification comes from; another source makes a new locator."""
        if source.kind != self.stereo.kind or source.label != self.stereo.label:
            self._locator = None
        self.stereo = source
        self.emit("stereo", source)

    @property
    def ready(self) -> bool:
        """A trained marker and a stereo rectification: the marker can be located."""
        return self.result.trained is not None and self.stereo.rect is not None

    def locator(self) -> MarkerLocator | None:
        """The locator of the trained marker with this rectification (None until ready)."""
        if self._locator is None and self.ready:
            self._locator = MarkerLocator(self.result.trained, self.stereo.rect, LocatorOptions())
        return self._locator
