"""The Identification step's model, without Qt: the options of the identification (what the
Options panel chose), the run it returned (the step's result: app.jobs.identification's
IdentificationRun), the digests of the measurements it was made from, and where the measurements
come from (`MeasurementsSource`, told by `read_source`).

Events: "options", "result" (an IdentificationRun, or None when cleared)."""
from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

from app.jobs.identification import IdentificationRun
from app.pages.identification.texts import NO_PROJECT, measurements_html, missing_html, unusable_html
from app.pages.step_model import StepModel
from core.errors import RoboCalError
from core.identification.file import write_calibrated_model
from core.identification.prior import PriorOptions
from core.measurement.file import read_measurements
from core.measurement.synthetic import synthetic_description
from core.project import Output
from core.provenance import changed_inputs, changed_since, record_inputs


@dataclass(frozen=True)
class IdentificationOptions:
    """identify()'s options: Huber's k (None: least squares), the held-out fraction or the number
    of folds (None: no validation), the parameters kept at nominal (canonical names), a prior
    toward nominal, the marker orientations, the deflection terms ("off", "auto", "on") and the
    payload mounted while measuring (kg, None: not given)."""

    huber: float | None = None
    holdout: float | None = 0.25
    kfold: int | None = None
    fixed: tuple[str, ...] = ()
    prior: PriorOptions | None = None
    orientation: bool = False
    compliance: str = "off"
    payload_kg: float | None = None

    def keywords(self) -> dict:
        """The options as run_identification's keyword arguments."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values["fixed"] = list(self.fixed)
        return values


@dataclass(frozen=True)
class MeasurementsSource:
    """The measurements line (rich text), whether ideal virtual-lab measurements are offered, and
    whether measurements.csv exists and reads for the robot."""

    html: str
    offer_ideal: bool = False
    ready: bool = False


def read_source(project, robot, virtual: bool) -> MeasurementsSource:
    """The project's measurements.csv as the page describes it."""
    if project is None or robot is None:
        return MeasurementsSource(NO_PROJECT)
    path = project.path(Output.MEASUREMENTS)
    if not path.is_file():
        return MeasurementsSource(missing_html(path, virtual), offer_ideal=virtual)
    try:
        meas = read_measurements(path, robot)
    except RoboCalError as exc:
        return MeasurementsSource(unusable_html(exc.message))
    return MeasurementsSource(measurements_html(path, meas, synthetic_description(path)), ready=True)


def inputs(project) -> dict[str, Path]:
    """The project files an identification is made from, by name."""
    if project is None:
        return {}
    path = project.path(Output.MEASUREMENTS)
    return {path.name: path}


class IdentificationModel(StepModel[IdentificationOptions, IdentificationRun]):
    """Options, the run, and what it was made from; `saved_path` once calibrated.json is written."""

    def __init__(self):
        super().__init__(IdentificationOptions())
        self.made_from: dict[str, str | None] | None = None    # digests of the inputs of `result`
        self.saved_path: Path | None = None

    def identified(self, run: IdentificationRun | None, made_from: dict[str, str | None] | None) -> None:
        """A new run (None: forgotten, another project or robot), not saved yet."""
        self.made_from, self.saved_path = made_from, None
        self.set_result(run)

    def changed_inputs(self, project) -> list[str]:
        """The inputs changed since this session's run (or the project's calibrated.json) was made
        from them: [] when up to date or nothing is known."""
        if project is None:
            return []
        if self.result is not None:
            return changed_since(self.made_from, inputs(project))
        return changed_inputs(project.path(Output.CALIBRATED), inputs(project))

    def save(self, project) -> Path:
        """Write calibrated.json into the project (atomically) with the digests of its inputs;
        RoboCalError when it cannot be written."""
        path = project.path(Output.CALIBRATED)
        write_calibrated_model(self.result.result, path)
        if self.made_from is not None:
            record_inputs(path, self.made_from, hashed=True)
        self.saved_path = path
        return path
