"""Option types for the commands: numbers checked against their plausibility bound
(core.bounds) while the command line is parsed, so a bad value is one usage line (exit 2)
naming the option, before any work or file is touched."""
from __future__ import annotations

import argparse
import math
from typing import Callable

from core import bounds as B
from core.bounds import Bound
from core.identification import prior as P

FRACTION = Bound(0.0, 1.0, "", "a fraction of the poses")
FOLDS = Bound(2, 1000, "", "K-fold validation needs at least two folds")
OUTLIER_K = Bound(0.5, 100.0, "", "a threshold in multiples of the median error")
DEPTH_MM = Bound(1.0, 1e5, "mm", "a depth in front of the cameras")
PAYLOAD_KG = Bound(0.0, 5000.0, "kg", "the mass mounted on the robot's flange")


def _make(bound: Bound, kind: type) -> Callable[[str], float | int]:
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected {'a whole number' if kind is int else 'a number'}, got {text!r}") from None
        if not (math.isfinite(value) and bound.lo <= value <= bound.hi):
            unit = f" {bound.unit}" if bound.unit else ""
            raise argparse.ArgumentTypeError(f"{text}{unit} is outside {bound.lo:g} … {bound.hi:g}{unit} "
                                             f"({bound.reason})")
        return value
    parse.__name__ = kind.__name__       # argparse names the type in its messages
    return parse


def number_in(bound: Bound) -> Callable[[str], float]:
    return _make(bound, float)


def whole_in(bound: Bound) -> Callable[[str], int]:
    return _make(bound, int)


seed = whole_in(B.SEED)
pose_count = whole_in(B.POSE_COUNT)
image_poses = whole_in(Bound(0, B.POSE_COUNT.hi, "", B.POSE_COUNT.reason))
pair_count = whole_in(B.PAIR_COUNT)
candidates = whole_in(B.CANDIDATES)
random_trials = whole_in(B.RANDOM_TRIALS)
folds = whole_in(FOLDS)
noise_grey = number_in(B.NOISE_GREY)
size_mm = number_in(B.SIZE_MM)
depth_mm = number_in(DEPTH_MM)
angle_deg = number_in(B.OPTION_ANGLE_DEG)
huber_k = number_in(B.HUBER_K)
fraction = number_in(FRACTION)
outlier_k = number_in(OUTLIER_K)
payload_kg = number_in(PAYLOAD_KG)
_prior_weight = number_in(P.WEIGHT)


def prior_weight(text: str) -> float | None:
    """`auto` (None: estimated from the measurements) or a weight within its bound."""
    return None if text.strip().lower() == "auto" else _prior_weight(text)


prior_weight.__name__ = "prior weight"


def target_names(text: str) -> list[str]:
    """Comma-separated target names (at least one)."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise argparse.ArgumentTypeError("expected one or more target names separated by commas")
    return names


target_names.__name__ = "target names"
