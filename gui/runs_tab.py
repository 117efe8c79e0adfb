"""Runs tab: the catalog of recordings; one run's set points and raw signals; processing with derivatives,
intervals and the processed figures."""

from __future__ import annotations

import math
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from PySide6 import QtWidgets

from ornitail.acquisition.catalog import (
    CATALOG_FILE_NAME,
    CatalogEntry,
    RunCatalog,
    catalog_entry_from_run_metadata,
)
from ornitail.acquisition.recording_layout import RUNS_FOLDER_NAME
from ornitail.acquisition.run_documents import RunStop
from ornitail.balance.process_runs import process_runs
from ornitail.core.normal_quantiles import NORMAL_QUANTILE_95
from ornitail.gui.background_job import BackgroundJobs
from ornitail.gui.picture_label import PictureView
from ornitail.gui.run_browser import RunBrowser

RUN_COLUMNS = (
    "run id",
    "status",
    "tail",
    "x_h (mm)",
    "tailed",
    "plan",
    "set points",
    "lost samples",
)


def _catalog_row(run: CatalogEntry) -> tuple[str, ...]:
    x_h = "-" if run.x_h_m is None else f"{run.x_h_m * 1000:g}"
    lost = run.lost_samples  # counted once, as `ornitail runs` counts them
    return (
        run.run_id,
        run.exit_status,
        run.tail_id or "-",
        x_h,
        "yes" if run.tailed else "no",
        run.plan_name,
        str(run.set_point_count),
        str(lost),
    )


def derivative_rows(configuration: dict[str, Any]) -> list[tuple[str, str, str, str]]:
    """(name, value, 95 % interval, unit) of every estimable derivative of one processed configuration."""
    rows = []
    for name, item in configuration.get("derivatives", {}).get("derivatives", {}).items():
        value, sigma = item["value"], item["sigma"]
        if value is None or not math.isfinite(value):
            continue
        interval = (
            "-"
            if sigma is None or not math.isfinite(sigma)
            else (
                f"[{value - NORMAL_QUANTILE_95 * sigma:.4g}, {value + NORMAL_QUANTILE_95 * sigma:.4g}]"
            )
        )
        rows.append((name, f"{value:.4g}", interval, item["unit"]))
    return rows


class RunsTab(QtWidgets.QWidget):
    """Catalog table, Open (set points of one run) and Process (the selected runs) buttons."""

    def __init__(self, data_root: Path, on_problem: Callable[[str, str], None]) -> None:
        super().__init__()
        self.data_root = Path(data_root)
        self.jobs = BackgroundJobs(on_problem, self)
        self.runs: list[CatalogEntry] = []
        self.last_result: dict[str, Any] | None = None
        layout = QtWidgets.QVBoxLayout(self)
        self.where = QtWidgets.QLabel(f"catalog of {self.data_root}")
        layout.addWidget(self.where)
        self.table = QtWidgets.QTableWidget(0, len(RUN_COLUMNS))
        self.table.setHorizontalHeaderLabels(RUN_COLUMNS)
        self.table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.horizontalHeader().setStretchLastSection(True)
        layout.addWidget(self.table, 2)
        buttons = QtWidgets.QHBoxLayout()
        self.reload_button = QtWidgets.QPushButton("Reload")
        self.open_button = QtWidgets.QPushButton("Open run")
        self.process_button = QtWidgets.QPushButton("Process selected runs")
        for button in (self.reload_button, self.open_button, self.process_button):
            buttons.addWidget(button)
        layout.addLayout(buttons)
        self.details = QtWidgets.QPlainTextEdit()
        self.details.setReadOnly(True)
        self.derivatives = QtWidgets.QTableWidget(0, 4)
        self.derivatives.setHorizontalHeaderLabels(("derivative", "value", "95 % interval", "unit"))
        self.derivatives.horizontalHeader().setStretchLastSection(True)
        self.browser = RunBrowser(on_problem)
        self.figure_choice = QtWidgets.QComboBox()
        self.figure_choice.currentIndexChanged.connect(self._show_figure)
        self.figure = PictureView("process runs to see their figures")
        figures = QtWidgets.QWidget()
        figures_layout = QtWidgets.QVBoxLayout(figures)
        figures_layout.addWidget(self.figure_choice)
        figures_layout.addWidget(self.figure, 1)
        processed = QtWidgets.QSplitter()
        processed.addWidget(self.details)
        processed.addWidget(self.derivatives)
        self.views = QtWidgets.QTabWidget()
        self.views.addTab(self.browser, "Set points and signals")
        self.views.addTab(processed, "Processed")
        self.views.addTab(figures, "Processed figures")
        layout.addWidget(self.views, 3)
        self.reload_button.clicked.connect(self.reload)
        self.open_button.clicked.connect(self.open_selected)
        self.process_button.clicked.connect(self.process_selected)
        self.reload()

    def reload(self) -> None:
        """Read the catalog again (newest run first)."""
        self._show(self._catalog_runs())

    def run_stopped(self, stop: RunStop) -> None:
        """Read the catalog again, listing the run ``stop`` ended as its stop record says (the catalog may take
        the stop record a moment later)."""
        runs = {run.run_id: run for run in self._catalog_runs()}
        if stop.run_metadata:
            runs[stop.run_id] = catalog_entry_from_run_metadata(
                dict(stop.run_metadata), f"{RUNS_FOLDER_NAME}/{stop.run_id}"
            )
        self._show(list(runs.values()))

    def _catalog_runs(self) -> list[CatalogEntry]:
        if not (self.data_root / CATALOG_FILE_NAME).exists():
            return []
        return RunCatalog(self.data_root).find_runs()

    def _show(self, runs: list[CatalogEntry]) -> None:
        self.runs = sorted(runs, key=lambda run: run.start_time_utc, reverse=True)
        self.table.setRowCount(len(self.runs))
        for row, run in enumerate(self.runs):
            for column, text in enumerate(_catalog_row(run)):
                self.table.setItem(row, column, QtWidgets.QTableWidgetItem(text))
        self.table.resizeColumnsToContents()

    def selected_runs(self) -> list[CatalogEntry]:
        """The runs whose rows are selected, in catalog order."""
        rows = sorted({index.row() for index in self.table.selectionModel().selectedRows()})
        return [self.runs[row] for row in rows]

    def open_selected(self) -> None:
        """Show the first selected run's set points and raw signals (read in the background)."""
        runs = self.selected_runs()
        if not runs:
            return
        self.views.setCurrentWidget(self.browser)
        self.browser.open(self.data_root / runs[0].run_directory)

    def process_selected(self) -> None:
        """Process the selected runs in the background; show derivatives with 95 % intervals."""
        runs = self.selected_runs()
        if not runs:
            self.details.setPlainText(
                "select the runs of one configuration (tailed and tailless) first"
            )
            return
        directories = [self.data_root / run.run_directory for run in runs]
        out = self.data_root / "processed" / f"{datetime.now(UTC):%Y%m%dT%H%M%SZ}"
        self.details.setPlainText(f"processing {len(directories)} run(s) into {out} ...")
        self.views.setCurrentIndex(1)
        self.jobs.run(process_runs, self.show_processed, directories, out)

    def show_processed(self, result: dict[str, Any]) -> None:
        """Tail statements, warnings and the derivative table of the processed runs."""
        self.last_result = result
        lines = [f"cycle averages: {result['table_csv']}"] + list(result["warnings"])
        rows = []
        for configuration in result["configurations"]:
            lines.append(f"configuration {configuration['configuration']}")
            statements = [
                configuration.get("drift_statement", ""),
                configuration.get("derivatives", {}).get("repeatability_statement", ""),
            ] + configuration.get("tail_statements", [])
            lines += [f"  {text}" for text in statements if text]
            rows += derivative_rows(configuration)
        self.details.setPlainText("\n".join(lines))
        self.derivatives.setRowCount(len(rows))
        for row, values in enumerate(rows):
            for column, text in enumerate(values):
                self.derivatives.setItem(row, column, QtWidgets.QTableWidgetItem(text))
        self.derivatives.resizeColumnsToContents()
        self.figure_choice.clear()
        for path in result["written"]:
            if path.endswith(".png"):
                self.figure_choice.addItem(Path(path).stem, path)

    def _show_figure(self, index: int) -> None:
        path = self.figure_choice.itemData(index)
        if path is not None:
            self.figure.show_file(Path(path))

    def latest_derivatives_files(self) -> list[str]:
        """Derivative JSON files of the last processing (for the design tab's trends)."""
        if self.last_result is None:
            return []
        return [path for path in self.last_result["written"] if path.endswith("-derivatives.json")]
