"""Design tab: steady-state and damping targets in; the proposed tail drawn with its predicted steady state,
poles and damping (``ornitail design propose`` in a window; trends from the study tables, optionally joined by the
tunnel derivatives of the last processing in the Runs tab)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pyqtgraph as pg
from PySide6 import QtWidgets

from ornitail.design.drawing import base_tail_outline_mm, planform_outline_mm
from ornitail.design.proposal import OBJECTIVES, Proposal, propose
from ornitail.design.proposal_report import (
    design_targets,
    proposal_result,
    render_proposal,
)
from ornitail.design.trend_sources import trend_model_from_sources
from ornitail.gui.background_job import BackgroundJobs
from ornitail.gui.form_widgets import spin_box
from ornitail.gui.plot_style import TAILED_COLOR, TAILLESS_COLOR
from ornitail.gui.runs_tab import RunsTab


def propose_tail(
    targets_args: tuple, objective: str, tunnels: tuple[str, ...]
) -> tuple[Proposal, dict]:
    """Fit trends (study tables plus ``tunnels``) and propose a tail; returns the proposal and its summary."""
    targets = design_targets(*targets_args)
    trend_model = trend_model_from_sources(True, (), tunnels, (), "linear")
    proposal = propose(trend_model, targets, objective=objective)
    return proposal, proposal_result(proposal, trend_model)


class _OptionalTarget:
    """A checkbox, a value and a tolerance spin box."""

    def __init__(
        self,
        form: QtWidgets.QFormLayout,
        name: str,
        value: float,
        tolerance: float,
        low: float,
        high: float,
        unit: str,
        checked: bool,
    ) -> None:
        self.enabled = QtWidgets.QCheckBox(name)
        self.enabled.setChecked(checked)
        self.value = spin_box(low, high, value, 2, unit)
        self.tolerance = spin_box(0.0, high, tolerance, 2, unit)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(self.value)
        row.addWidget(QtWidgets.QLabel("+/-"))
        row.addWidget(self.tolerance)
        form.addRow(self.enabled, row)

    def chosen(self) -> tuple[float | None, float]:
        return (self.value.value() if self.enabled.isChecked() else None), self.tolerance.value()


class DesignTab(QtWidgets.QWidget):
    """Targets form, Propose button, planform drawing, pole map and the predicted numbers."""

    def __init__(self, runs_tab: RunsTab, on_problem: Callable[[str, str], None]) -> None:
        super().__init__()
        self.runs_tab = runs_tab
        self.jobs = BackgroundJobs(on_problem, self)
        self.result: dict[str, Any] | None = None
        layout = QtWidgets.QHBoxLayout(self)
        form_widget = QtWidgets.QWidget()
        form = QtWidgets.QFormLayout(form_widget)
        self.theta = _OptionalTarget(form, "theta_ss", 22.0, 0.5, 1.0, 89.0, "deg", True)
        self.velocity = _OptionalTarget(form, "V_ss", 0.8, 0.1, 0.1, 10.0, "m/s", False)
        self.frequency = _OptionalTarget(form, "f_ss", 13.5, 0.5, 1.0, 30.0, "Hz", False)
        self.zeta_enabled = QtWidgets.QCheckBox("damping ratio at least")
        self.zeta_enabled.setChecked(True)
        self.zeta = spin_box(0.01, 0.98, 0.25, 2, "")
        form.addRow(self.zeta_enabled, self.zeta)
        self.objective = QtWidgets.QComboBox()
        self.objective.addItems(list(OBJECTIVES))
        form.addRow("objective", self.objective)
        self.use_tunnel = QtWidgets.QCheckBox("add tunnel derivatives of the last processing")
        form.addRow(self.use_tunnel)
        self.propose_button = QtWidgets.QPushButton("Propose tail")
        form.addRow(self.propose_button)
        self.summary = QtWidgets.QPlainTextEdit()
        self.summary.setReadOnly(True)
        form.addRow(self.summary)
        layout.addWidget(form_widget, 1)
        plots = pg.GraphicsLayoutWidget()
        self.planform = plots.addPlot(
            row=0, col=0, title="Proposed tail (blue) over the base tail (orange)"
        )
        self.planform.setAspectLocked(True)
        self.planform.setLabel("bottom", "y (mm)")
        self.planform.setLabel("left", "x from the leading edge (mm)")
        self.planform.invertY(True)
        self.poles = plots.addPlot(row=1, col=0, title="Poles of the longitudinal model")
        self.poles.setLabel("bottom", "real (1/s)")
        self.poles.setLabel("left", "imaginary (rad/s)")
        self.poles.showGrid(x=True, y=True, alpha=0.3)
        layout.addWidget(plots, 1)
        self.propose_button.clicked.connect(self.start_proposal)

    def start_proposal(self) -> None:
        """Propose in the background from the form's targets."""
        theta, theta_tol = self.theta.chosen()
        velocity, velocity_tol = self.velocity.chosen()
        frequency, frequency_tol = self.frequency.chosen()
        zeta = self.zeta.value() if self.zeta_enabled.isChecked() else None
        args = (theta, theta_tol, velocity, velocity_tol, frequency, frequency_tol, zeta, None, 0.0)
        tunnels = (
            tuple(self.runs_tab.latest_derivatives_files()) if self.use_tunnel.isChecked() else ()
        )
        self.summary.setPlainText("proposing ...")
        self.jobs.run(propose_tail, self.show_proposal, args, self.objective.currentText(), tunnels)

    def show_proposal(self, outcome: tuple[Proposal, dict]) -> None:
        """Draw the planform and poles; print steady state, damping and intervals."""
        proposal, result = outcome
        self.result = result
        self.summary.setPlainText(render_proposal(result))
        self.planform.clear()
        base = base_tail_outline_mm()
        self.planform.plot(base[:, 0], base[:, 1], pen=pg.mkPen(TAILLESS_COLOR, width=2))
        outline = planform_outline_mm(proposal.geometry)
        self.planform.plot(outline[:, 0], outline[:, 1], pen=pg.mkPen(TAILED_COLOR, width=2))
        self.poles.clear()
        poles = np.array([[p["real"], p["imag"]] for p in result["poles"]])
        self.poles.plot(
            poles[:, 0],
            poles[:, 1],
            pen=None,
            symbol="x",
            symbolSize=12,
            symbolPen=pg.mkPen(TAILED_COLOR, width=2),
        )
