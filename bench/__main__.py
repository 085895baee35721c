"""Run every benchmark module bench/bench_*.py (each defines run(report)); print a summary.

Usage: python -m bench [NAME ...]   (NAME matches part of a module name)
Exit code 1 if any figure misses its target.
"""
from __future__ import annotations

import importlib
import sys
from pathlib import Path

from bench.report import Report

# The wizard's order: the virtual lab (renderer accuracy, simulate speed) first.
ORDER = ["virtual_lab", "stereo_calibration", "marker", "robustness", "orientation", "pose_selection", "hardware",
         "identification", "real_robot", "compliance", "end_to_end", "monitoring", "compensation", "compensation_map",
         "tools", "fixtures", "teaching"]


def _rank(name: str) -> tuple[int, str]:
    short = name.removeprefix("bench_")
    return (ORDER.index(short) if short in ORDER else len(ORDER), short)


def main(argv: list[str]) -> int:
    names = sorted((p.stem for p in Path(__file__).parent.glob("bench_*.py")), key=_rank)
    if argv:
        names = [n for n in names if any(a in n for a in argv)]
    report = Report()
    for name in names:
        module = importlib.import_module(f"bench.{name}")
        report.group = name.removeprefix("bench_")
        print(f"\n== {report.group}: {(module.__doc__ or '').strip().splitlines()[0]}", flush=True)
        module.run(report)
    failed = report.failed
    print(f"\n{len(report.figures) - len(failed)} of {len(report.figures)} figures meet their targets.")
    for f in failed:
        print(f"  FAIL {f.group}: {f.name}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
