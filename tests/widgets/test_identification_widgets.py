"""The identification widgets on their own: formatting, log/linear axes, bins, bad input."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from widgets.convergence_plot import ConvergencePlot
from widgets.correlation_view import CorrelationView
from widgets.parameter_table import ParameterTable, format_std, format_value
from widgets.plot_theme import ReadableAxis
from widgets.residual_plots import ResidualBarChart, ResidualHistogram


def row(name, unit="mm", nominal=1.0, identified=1.5, std=0.01, identifiable=True, status="identified",
        explanation="", group="joint", initial=None):
    return SimpleNamespace(name=name, unit=unit, nominal=nominal, identified=identified, std=std,
                           identifiable=identifiable, status=status, explanation=explanation, group=group,
                           initial=nominal if initial is None else initial)


def test_number_formats():
    assert format_value(1.23456, "mm") == "1.235" and format_value(90.0, "deg") == "90.0000"
    assert format_value(-0.0001, "mm") == "0.000" and format_value(None, "mm") == "—"
    assert format_std(0.01234) == "± 0.012" and format_std(1.234) == "± 1.2" and format_std(None) == "—"


def test_parameter_table_greys_and_explains(qtbot):
    table = ParameterTable()
    qtbot.addWidget(table)
    table.set_rows([row("J1.a"), row("J1.theta", unit="deg", identifiable=False, std=None,
                                     status="not identifiable", explanation="absorbed by base.ry"),
                    row("base.x", nominal=0.0, initial=60.0, identified=61.0, group="base")])
    assert table.rowCount() == 3 and not table.is_greyed(0) and table.is_greyed(1)
    assert table.cell_text(0, 5) == "+0.500" and table.cell_text(1, 4) == "—"
    assert "absorbed by base.ry" in table.item(1, 0).toolTip() and table.explanation(0) == ""
    assert table.cell_text(2, 2) == "60.000" and table.cell_text(2, 5) == "+1.000"   # base: vs registered
    assert "registration" in table.item(2, 2).toolTip()
    table.set_rows([])
    assert table.rowCount() == 0


def test_bar_chart_log_and_linear(qtbot):
    bars = ResidualBarChart()
    qtbot.addWidget(bars)
    bars.set_errors([0, 1, 2], [2.0, 4.0, 3.0], [0.05, 0.1, 0.02])
    opts = bars.before_bars.opts
    assert np.allclose(np.asarray(opts["y0"]) + np.asarray(opts["height"]), np.log10([2.0, 4.0, 3.0]))
    bars.set_log(False)
    assert np.allclose(bars.before_bars.opts["height"], [2.0, 4.0, 3.0])
    assert np.allclose(bars.series()["after"], [0.05, 0.1, 0.02])
    with pytest.raises(ValueError):
        bars.set_errors([0, 1], [1.0], None)


def test_histogram_counts_every_point(qtbot):
    hist = ResidualHistogram()
    qtbot.addWidget(hist)
    rng = np.random.default_rng(0)
    before, after = rng.uniform(1, 8, 40), rng.uniform(0.01, 0.2, 40)
    hist.set_errors(before, after)
    assert hist.counts["before"].sum() == 40 and hist.counts["after"].sum() == 40
    assert hist.edges[0] <= after.min() and hist.edges[-1] >= before.max()
    hist.set_log(False)
    assert hist.edges[0] == 0.0 and hist.counts["after"].sum() == 40
    hist.set_errors(None, None)
    assert len(hist.edges) == 0


def test_convergence_marks_stages(qtbot):
    plot = ConvergencePlot()
    qtbot.addWidget(plot)
    plot.set_history([0, 1, 2, 3], [100.0, 1.0, 0.5, 0.0], ["fit", "fit", "refine", "refine"])
    assert len(plot._markers) == 1 and plot.y[-1] > 0        # a zero cost still fits the log axis


def test_correlation_view(qtbot):
    view = CorrelationView()
    qtbot.addWidget(view)
    m = np.array([[1.0, 0.95, 0.0], [0.95, 1.0, -0.2], [0.0, -0.2, 1.0]])
    view.set_matrix(m, ["a", "b", "c"])
    assert view.strong_pairs() == [("a", "b", 0.95)]
    assert "a–b +0.95" in view.info.text()
    assert view.hover_text(1, 2) == "b (2) × c (3): correlation -0.200" and view.hover_text(5, 0) == ""
    with pytest.raises(ValueError):
        view.set_matrix(np.eye(2), ["a", "b", "c"])


def test_log_axis_labels_only_1_2_5(qapp):
    axis = ReadableAxis("bottom")
    values = np.log10([0.01, 0.02, 0.03, 0.05, 0.1, 0.7])
    assert axis.logTickStrings(list(values), 1.0, 1.0) == ["0.01", "0.02", "", "0.05", "0.1", ""]
