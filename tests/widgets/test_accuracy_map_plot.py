"""The accuracy map plot: arrows from each target toward where the marker landed, magnified by one
round factor for both models, legends with units, the histogram's bins on a logarithmic axis
holding every error, and a cleared plot."""
from __future__ import annotations

import numpy as np

from core.compensation.accuracy_map import AccuracyMap
from widgets.accuracy_map_plot import AccuracyMapPlot, _magnification


def make_map() -> AccuracyMap:
    rng = np.random.default_rng(0)
    targets = np.column_stack([rng.uniform(0, 200, 12), rng.uniform(-100, 100, 12), np.full(12, 600.0)])
    before = targets + rng.normal(0, 4.0, (12, 3))
    after = targets + rng.normal(0, 0.05, (12, 3))
    after[11] = np.nan                              # one landing not measured
    q = np.zeros((12, 6))
    return AccuracyMap(targets, before, after, q, q, np.eye(4), "virtual lab", [""] * 12)


def test_round_magnification():
    assert _magnification(200.0, 10.0) == 5.0 and _magnification(200.0, 0.5) == 100.0
    assert _magnification(200.0, 0.0) == 1.0


def test_draws_arrows_histogram_and_legends(qtbot):
    plot = AccuracyMapPlot()
    qtbot.addWidget(plot)
    amap = make_map()
    plot.set_map(amap)
    m = plot.magnification
    x, y = plot.before_lines.getData()
    assert len(x) == 2 * 11                                     # a line per target measured both ways
    ends = np.column_stack([x[1::2], y[1::2]]) - np.column_stack([x[0::2], y[0::2]])
    np.testing.assert_allclose(ends, m * amap.vectors_before[amap.both, :2], atol=1e-9)
    labels = [label.text for _, label in plot.vector_legend.items]
    assert labels == ["target", f"nominal model, error ×{m:g}", f"calibrated model, error ×{m:g}"]
    hist = [label.text for _, label in plot.hist_legend.items]
    assert hist[0].endswith(f"{amap.rms_before_mm:.2f} mm") and hist[1].endswith(f"{amap.rms_after_mm:.3f} mm")
    assert plot.before_hist.yData.sum() == 11 and plot.after_hist.yData.sum() == 11
    assert "mm" in plot.histogram.getPlotItem().getAxis("bottom").labelText
    assert "mm" in plot.vectors.getPlotItem().getAxis("left").labelText
    assert f"{amap.improvement:.0f}×" in plot.vectors.getPlotItem().titleLabel.text
    plot.set_map(None)
    assert plot.before_lines.getData()[0] is None or len(plot.before_lines.getData()[0]) == 0
    assert "no accuracy map" in plot.vectors.getPlotItem().titleLabel.text
