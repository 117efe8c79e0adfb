"""Messages in the window: a log line for everything, a message box for user mistakes and instrument errors."""

from __future__ import annotations

from datetime import datetime

from PySide6 import QtCore, QtWidgets

MAX_LOG_LINES = 2000


class MessageLog(QtWidgets.QPlainTextEdit):
    """A read-only log of timestamped lines; :meth:`show_problem` also opens a (non-blocking) message box."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setReadOnly(True)
        self.setMaximumBlockCount(MAX_LOG_LINES)
        self.setObjectName("messageLog")
        self.problems: list[str] = []

    def add(self, text: str) -> None:
        """Append one line."""
        self.appendPlainText(f"{datetime.now():%H:%M:%S}  {text}")

    def show_problem(self, title: str, text: str) -> None:
        """Log ``text`` and show it in a message box that does not block the redraw."""
        self.add(f"{title}: {text}")
        self.problems.append(text)
        box = QtWidgets.QMessageBox(
            QtWidgets.QMessageBox.Icon.Warning, title, text, parent=self.window()
        )
        box.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        box.open()
