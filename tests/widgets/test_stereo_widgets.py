"""The widgets of the stereo calibration page, alone: error bars with the draggable
threshold, coverage bars, thumbnail strip, residual scatter, image view, value table."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from core.thumbnails import compose_pair_thumbnail
from widgets.coverage_bars import GOOD, LOW, CoverageBars
from widgets.error_bar_chart import ErrorBarChart
from widgets.image_view import ImageView
from widgets.residual_scatter import ResidualScatter
from widgets.thumbnail_strip import ThumbnailStrip, to_qimage
from widgets.value_table import ValueTable, format_std, format_value


def test_error_bars_threshold_selects_pairs_above_it(qtbot):
    chart = ErrorBarChart()
    qtbot.addWidget(chart)
    chart.set_errors([1, 2, 4], [0.1, 0.5, 0.2], [0.12, 0.3, 0.45], flagged=[False, True, False],
                     auto_threshold=0.4)
    assert chart.selected() == [] and chart.threshold() > 0.5
    assert chart.auto_line.isVisible() and chart.line.isVisible()
    assert "0.400" in chart.auto_line.label.toPlainText()
    with qtbot.waitSignal(chart.selectionChanged) as blocker:
        chart.set_threshold(0.35)
    assert blocker.args == [[1, 2]] and chart.selected() == [1, 2]
    assert "0.350" in chart.line.label.toPlainText()
    chart.set_threshold(0.47)
    assert chart.selected() == [1]
    assert list(chart.series()["flagged"]) == [False, True, False]
    assert chart.getPlotItem().getAxis("bottom").labelText == "pair"
    assert "RMS reprojection error (px)" in chart.getPlotItem().getAxis("left").labelText
    chart.clear_errors()
    assert chart.selected() == [] and not chart.line.isVisible()
    with pytest.raises(ValueError):
        chart.set_errors([1, 2], [0.1], [0.1, 0.2])


def test_coverage_bars_colour_by_threshold(qtbot):
    bars = CoverageBars(threshold=0.6)
    qtbot.addWidget(bars)
    bars.set_values({"X": 0.3, "Y": 1.4, "size": 0.6})
    assert bars.values() == {"X": 0.3, "Y": 1.0, "size": 0.6, "skew": 0.0}
    assert LOW in bars.bars["X"].styleSheet() and GOOD in bars.bars["size"].styleSheet()
    assert bars.value_labels["Y"].text() == "1.00" and bars.bars["X"].value() == 300


def test_pair_thumbnail_and_strip(qtbot):
    img = np.full((512, 640), 128, np.uint8)
    corners = np.stack(np.meshgrid(np.arange(9) * 20 + 200.0, np.arange(6) * 20 + 200.0), -1).reshape(-1, 2)
    thumb = compose_pair_thumbnail(img, None, corners, None, (9, 6), width=100)
    assert thumb.shape == (80, 204, 3) and thumb.dtype == np.uint8
    assert len(np.unique(thumb.reshape(-1, 3), axis=0)) > 5          # corners drawn in colour
    assert not to_qimage(thumb).isNull()
    strip = ThumbnailStrip()
    qtbot.addWidget(strip)
    strip.add("a", thumb, "1 ✓")
    strip.add("b", thumb, "2 ✗", badge="board not found", tooltip="why")
    assert strip.keys() == ["a", "b"] and strip.badge("b") == "board not found"
    strip.update("b", badge=None, caption="2 ✓")
    assert strip.badge("b") is None and strip.caption("b") == "2 ✓"
    with pytest.raises(KeyError):
        strip.add("a", thumb, "again")
    strip.select_key("b")
    assert strip.selected_keys() == ["b"]
    strip.remove("a")
    assert strip.keys() == ["b"]
    strip.clear_all()
    assert strip.keys() == []


def test_residual_scatter_equal_axes_centred(qtbot):
    plot = ResidualScatter()
    qtbot.addWidget(plot)
    plot.resize(500, 400)
    plot.set_residuals(np.array([[0.1, -0.2], [0.3, 0.0]]), np.array([[np.nan, 1.0], [-0.1, 0.05]]))
    assert plot.counts() == (2, 1)
    (x0, x1), (y0, y1) = plot.getPlotItem().viewRange()
    assert x0 < 0 < x1 and y0 < 0 < y1
    plot.set_highlight([[0.1, -0.2]], None, "pair 3")
    assert "pair 3" in [label.text for _, label in plot.legend.items]
    plot.set_highlight(None, None)
    assert "pair 3" not in [label.text for _, label in plot.legend.items]


def test_image_view_overlays_are_updated_not_recreated(qtbot):
    view = ImageView()
    qtbot.addWidget(view)
    view.add_lines("rows")
    view.add_points("dots")
    view.set_image(np.zeros((100, 200), np.uint8))
    assert view.image_shape() == (100, 200)
    assert view.image_item.levels is not None and list(view.image_item.levels) == [0, 255]
    item = view.overlays["rows"]
    view.set_horizontal_lines("rows", [10, 50], 0, 200)
    x, y = item.getData()
    assert list(y) == [10, 10, 50, 50] and list(x) == [0, 200, 0, 200]
    view.set_points("dots", [[1, 2], [3, 4]])
    assert view.overlays["rows"] is item and len(view.overlays["dots"].data) == 2
    with pytest.raises(KeyError):
        view.add_points("dots")


@dataclass
class Row:
    group: str
    name: str
    value: float
    std: float
    unit: str
    fixed: bool = False


def test_value_table_digits_follow_the_std(qtbot):
    table = ValueTable(group_names={"left": "Left camera"}, display_names={"fx": "fx (focal length)"})
    qtbot.addWidget(table)
    table.set_rows([Row("left", "fx", 1504.9812, 0.113, "px"), Row("left", "cx", 640.0, 0.0, "px", True)])
    assert [table.cell_text(0, c) for c in range(5)] == ["Left camera", "fx (focal length)", "1504.98", "± 0.11", "px"]
    assert table.cell_text(1, 0) == "" and table.cell_text(1, 3) == "fixed"
    assert table.find("left", "cx") == 1 and table.find("right", "cx") == -1
    assert format_value(0.000238, 3.8e-5) == "0.000238" and format_std(3.8e-5) == "± 0.000038"
