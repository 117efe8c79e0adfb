"""Small form helpers: labelled spin boxes with units and ranges, file pickers."""

from __future__ import annotations

from pathlib import Path

from PySide6 import QtWidgets


def spin_box(
    low: float, high: float, value: float, decimals: int, suffix: str
) -> QtWidgets.QDoubleSpinBox:
    """A spin box limited to ``[low, high]`` showing its unit."""
    box = QtWidgets.QDoubleSpinBox()
    box.setDecimals(decimals)
    box.setRange(low, high)
    box.setValue(value)
    box.setSuffix(f" {suffix}")
    box.setSingleStep(10.0 ** (1 - decimals))
    return box


class FilePicker(QtWidgets.QWidget):
    """A path field with a Browse button."""

    def __init__(
        self, path: Path | str, caption: str, pattern: str, directory: bool = False
    ) -> None:
        super().__init__()
        layout = QtWidgets.QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        self.edit = QtWidgets.QLineEdit(str(path))
        button = QtWidgets.QPushButton("Browse...")
        layout.addWidget(self.edit, 1)
        layout.addWidget(button)
        self._caption, self._pattern, self._directory = caption, pattern, directory
        button.clicked.connect(self._browse)

    @property
    def path(self) -> Path:
        """The chosen path."""
        return Path(self.edit.text().strip())

    def _browse(self) -> None:
        if self._directory:
            chosen = QtWidgets.QFileDialog.getExistingDirectory(self, self._caption, str(self.path))
        else:
            chosen, _ = QtWidgets.QFileDialog.getOpenFileName(
                self, self._caption, str(self.path.parent), self._pattern
            )
        if chosen:
            self.edit.setText(chosen)
