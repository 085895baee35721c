"""Collects benchmark figures and prints each beside its target with PASS/FAIL."""
from __future__ import annotations

import operator
import time
from contextlib import contextmanager
from dataclasses import dataclass, field

_OPS = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}


@dataclass
class Figure:
    group: str
    name: str
    measured: float
    op: str
    target: float
    unit: str
    note: str = ""

    @property
    def passed(self) -> bool:
        return bool(_OPS[self.op](self.measured, self.target))


@dataclass
class Report:
    figures: list[Figure] = field(default_factory=list)
    group: str = ""

    def add(self, name: str, measured: float, op: str, target: float, unit: str = "", note: str = "") -> Figure:
        """Record a figure: e.g. add("corner RMS", 0.03, "<", 0.1, "px")."""
        fig = Figure(self.group, name, float(measured), op, float(target), unit, note)
        self.figures.append(fig)
        print(format_figure(fig), flush=True)
        return fig

    def info(self, name: str, value, unit: str = "") -> None:
        """A figure printed for context, with no target."""
        print(f"  {name:<58} {_fmt(value):>12} {unit:<6} {'':>16}   (info)", flush=True)

    @contextmanager
    def timer(self):
        """with report.timer() as t: ...; t() gives elapsed seconds."""
        start = time.perf_counter()
        end = [None]
        yield lambda: (end[0] or time.perf_counter()) - start
        end[0] = time.perf_counter()

    @property
    def failed(self) -> list[Figure]:
        return [f for f in self.figures if not f.passed]


def _fmt(value) -> str:
    if isinstance(value, (int, float)):
        v = float(value)
        if v != 0 and (abs(v) < 1e-3 or abs(v) >= 1e5):
            return f"{v:.3e}"
        return f"{v:.4g}"
    return str(value)


def format_figure(f: Figure) -> str:
    target = f"{f.op} {_fmt(f.target)} {f.unit}".strip()
    status = "PASS" if f.passed else "FAIL"
    note = f"  {f.note}" if f.note else ""
    return f"  {f.name:<58} {_fmt(f.measured):>12} {f.unit:<6} target {target:<16} {status}{note}"
