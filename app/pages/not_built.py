"""The placeholder of a step that is not built yet: it says so plainly."""
from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFrame, QLabel, QVBoxLayout

from app.pages.base import WizardPage


class NotBuiltPage(WizardPage):
    built = False

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        info = self.step.info
        self.notice = QLabel(f"This step is not built yet (issue {info.issue}).")
        self.notice.setObjectName("notBuiltNotice")
        self.notice.setWordWrap(True)
        heading = QLabel("What it will do")
        heading.setObjectName("sectionHeading")
        self.description = QLabel(info.description)
        self.description.setWordWrap(True)
        self.description.setTextFormat(Qt.TextFormat.RichText)
        self.description.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        meanwhile = QLabel("Meanwhile you can look at the explanation of this step on the right, "
                           "and go on with Next.")
        meanwhile.setWordWrap(True)
        meanwhile.setObjectName("hint")

        box = QFrame()
        box.setObjectName("notBuiltBox")
        inner = QVBoxLayout(box)
        inner.setContentsMargins(20, 18, 20, 18)
        inner.setSpacing(10)
        inner.addWidget(self.notice)
        inner.addWidget(heading)
        inner.addWidget(self.description)
        inner.addWidget(meanwhile)

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 8, 0, 0)
        layout.addWidget(box)
        layout.addStretch(1)

    def text(self) -> str:
        """What the page says (tests, accessibility)."""
        return f"{self.notice.text()}\n{self.description.text()}"

    def is_complete(self) -> bool:
        return False

    def autopilot(self, done) -> None:
        done(True, "not built yet")


class PageLoadErrorPage(NotBuiltPage):
    """Shown instead of a page whose module failed to import or to build: the rest of the
    wizard keeps working, and the error is on screen rather than lost."""

    def __init__(self, state, tasks, *, error: str, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.load_error = error
        self.notice.setText(f"This page could not be loaded: {error}")

    def autopilot(self, done) -> None:
        done(False, f"the {self.title} page could not be loaded: {self.load_error}")
