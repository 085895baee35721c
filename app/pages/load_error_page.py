"""Shown instead of a page that failed to build: the rest of the wizard keeps working, and the
error is on screen rather than lost."""
from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFrame, QLabel, QVBoxLayout

from app.pages.base import WizardPage


class PageLoadErrorPage(WizardPage):
    def __init__(self, state, tasks, *, error: str, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.load_error = error
        info = self.step.info
        self.notice = QLabel(f"This page could not be loaded: {error}")
        self.notice.setObjectName("loadErrorNotice")
        self.notice.setWordWrap(True)
        heading = QLabel("What this step does")
        heading.setObjectName("sectionHeading")
        self.description = QLabel(info.description)
        self.description.setWordWrap(True)
        self.description.setTextFormat(Qt.TextFormat.RichText)
        box = QFrame()
        box.setObjectName("loadErrorBox")
        inner = QVBoxLayout(box)
        inner.setContentsMargins(20, 18, 20, 18)
        inner.setSpacing(10)
        inner.addWidget(self.notice)
        inner.addWidget(heading)
        inner.addWidget(self.description)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 8, 0, 0)
        layout.addWidget(box)
        layout.addStretch(1)

    def text(self) -> str:
        """What the page says (tests, accessibility)."""
        return f"{self.notice.text()}\n{self.description.text()}"

    def autopilot(self, done) -> None:
        done(False, f"the {self.title} page could not be loaded: {self.load_error}")
