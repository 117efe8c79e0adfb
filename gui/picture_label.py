"""A picture (PNG bytes or file) shown scaled to its scroll area's width, keeping its aspect ratio."""

from __future__ import annotations

from pathlib import Path

from PySide6 import QtCore, QtGui, QtWidgets


class PictureView(QtWidgets.QScrollArea):
    """Shows one picture at the view's width (scrolls vertically when taller); a text when there is none."""

    def __init__(self, empty_text: str, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.label = QtWidgets.QLabel(empty_text)
        self.label.setAlignment(
            QtCore.Qt.AlignmentFlag.AlignTop | QtCore.Qt.AlignmentFlag.AlignLeft
        )
        self.setWidget(self.label)
        self.setWidgetResizable(True)
        self.pixmap: QtGui.QPixmap | None = None

    def show_png(self, png: bytes) -> None:
        """Show PNG bytes."""
        pixmap = QtGui.QPixmap()
        pixmap.loadFromData(png, "PNG")
        self._show(pixmap)

    def show_file(self, path: Path) -> None:
        """Show a picture file."""
        self._show(QtGui.QPixmap(str(path)))

    def clear(self, text: str) -> None:
        """Show ``text`` instead of a picture."""
        self.pixmap = None
        self.label.setPixmap(QtGui.QPixmap())
        self.label.setText(text)

    def _show(self, pixmap: QtGui.QPixmap) -> None:
        self.pixmap = pixmap
        self._fit()

    def resizeEvent(self, event: QtGui.QResizeEvent) -> None:  # noqa: N802 - Qt override
        super().resizeEvent(event)
        self._fit()

    def _fit(self) -> None:
        if self.pixmap is None or self.pixmap.isNull():
            return
        width = max(100, self.viewport().width() - 4)
        self.label.setPixmap(
            self.pixmap.scaledToWidth(width, QtCore.Qt.TransformationMode.SmoothTransformation)
        )
