"""The Marker page's Conditions tab: one pair under chosen light, occlusion and tilt, and the
robustness sweep with its table and plots (pytest-qt, virtual lab)."""
from __future__ import annotations

import pytest
from PySide6.QtCore import Qt

from app.jobs.marker import save_trained
from app.pages.marker.page import TAB_CONDITIONS, MarkerPage
from app.worker import TaskRunner
from tests.app.virtual_inputs import lab_marker, lab_state, make_lab


@pytest.fixture(scope="module")
def lab():
    return make_lab()


@pytest.fixture
def page(qtbot, lab, boxes):
    state = lab_state(lab)
    save_trained(state.project, lab_marker(lab))          # the page loads the project's marker
    p = MarkerPage(state, TaskRunner())
    qtbot.addWidget(p)
    p.resize(1000, 800)
    p.show()
    p.on_enter()
    yield p
    p.task.runner.shutdown()
    p.state.close()


def wait(qtbot, page, timeout=120000):
    qtbot.waitUntil(lambda: not page.task.busy, timeout=timeout)


def test_show_a_pair_under_chosen_conditions(qtbot, page, lab, boxes):
    panel = page.conditions_panel
    assert page.model.result.trained is not None and panel.show_button.isEnabled() and panel.sweep_button.isEnabled()
    panel.light_slider.setValue(30)
    assert panel.light_label.text() == "0.30×"
    panel.occlusion_spin.setValue(5)
    panel.tilt_spin.setValue(40)
    c = panel.conditions()
    assert (c.light, c.occlusion, c.side, c.tilt) == (0.3, 0.05, "corner", 40.0)
    qtbot.mouseClick(panel.show_button, Qt.MouseButton.LeftButton)
    wait(qtbot, page)
    assert page.tabs.currentIndex() == TAB_CONDITIONS
    assert "located" in panel.pair_text.text() and "not located" not in panel.pair_text.text()
    assert "tilt 40°" in panel.pair_text.text() and page.status.text().startswith("✓ Located")
    assert panel.pair_view.image_shape() == (lab.rig.left.height, lab.rig.left.width)
    assert len(panel.pair_view.overlays["reference"].data) == 1
    # a dim image: the mean grey level of the shown pair is far below the normal light's
    dim = panel.pair_view.image_item.image.mean()
    panel.light_slider.setValue(100)
    panel.occlusion_spin.setValue(80)                       # most of the marker covered
    panel.tilt_spin.setValue(panel.tilt_spin.minimum())     # "random ≤ 30°"
    assert panel.tilt_spin.text() == "random ≤ 30°" and panel.conditions().tilt is None
    qtbot.mouseClick(panel.show_button, Qt.MouseButton.LeftButton)
    wait(qtbot, page)
    assert "not located" in panel.pair_text.text() and len(panel.pair_view.overlays["reference"].data) == 0
    assert panel.pair_view.image_item.image.mean() > 2.0 * dim
    assert boxes == []


def test_sweep_fills_the_table_and_the_plots(qtbot, page, boxes, tmp_path):
    panel = page.conditions_panel
    panel.pairs_spin.setValue(1)
    qtbot.mouseClick(panel.sweep_button, Qt.MouseButton.LeftButton)
    assert page.task.busy and not panel.sweep_button.isEnabled()
    wait(qtbot, page)
    table = panel.result
    assert table is not None and table.pairs == 1 and table.wrong == 0
    assert panel.table.rowCount() == len(table.rows) == 19
    assert panel.table.item(0, 0).text() == "light 1×" and panel.table.item(0, 2).text() == "100 %"
    assert page.status.text().startswith("✓ Swept 19 conditions")
    x, y = panel.plot.rate.getData()
    assert list(x) == [1.0, 0.7, 0.5, 0.3, 0.2, 0.1] and y[0] == 100.0
    panel.axis_combo.setCurrentIndex(2)                     # plot against the tilt
    x, y = panel.plot.rate.getData()
    assert list(x) == [0.0, 20.0, 40.0, 50.0, 60.0, 70.0, 75.0]
    assert "tilt" in panel.plot.error_plot.getAxis("bottom").labelText
    assert panel.plot.error_plot.getAxis("left").labelText == "3D error (mm)"
    panel.axis_combo.setCurrentIndex(1)                     # occlusion, in %
    x, _ = panel.plot.rate.getData()
    assert list(x) == [0.0, 10.0, 20.0, 30.0, 40.0, 50.0]
    assert page.grab().save(str(tmp_path / "conditions.png"))
    assert boxes == []
