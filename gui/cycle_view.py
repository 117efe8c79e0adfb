"""Cycle view tab: phase-averaged X, Z and M over the flap cycle, mean and 2 sigma band, tailed and tailless.

Updated once per new flap cycle from the newest seconds of display data (phase averaging by
:func:`ornitail.balance.phase_loads.phase_averaged_loads`). The curve of the current tail state is live; the
other state's last average stays on the plot, so tailed and tailless of the configuration can be compared.
"""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6 import QtWidgets

from ornitail.balance.phase_loads import PhaseAveragedLoads, phase_averaged_loads
from ornitail.core.errors import UserInputError
from ornitail.gui.live_data import LiveData
from ornitail.gui.plot_style import TAILED_COLOR, TAILLESS_COLOR

CYCLE_WINDOW_S = 2.0
PHASE_BINS = 40
PLOTTED_LOADS = (("x_n", "X (N)"), ("z_n", "Z (N)"), ("m_n_m", "M (N m)"))


class _BandCurves:
    """Mean curve and a filled 2 sigma band of one load for one tail state."""

    def __init__(self, plot: pg.PlotItem, color: str, name: str) -> None:
        self.mean = plot.plot([], [], pen=pg.mkPen(color, width=2), name=name)
        self.upper = pg.PlotDataItem([], [], pen=pg.mkPen(color, width=0.5))
        self.lower = pg.PlotDataItem([], [], pen=pg.mkPen(color, width=0.5))
        brush = pg.mkColor(color)
        brush.setAlpha(50)
        self.band = pg.FillBetweenItem(self.upper, self.lower, brush=brush)
        plot.addItem(self.upper)
        plot.addItem(self.lower)
        plot.addItem(self.band)

    def show(self, phase: np.ndarray, mean: np.ndarray, spread: np.ndarray) -> None:
        self.mean.setData(phase, mean)
        self.upper.setData(phase, mean + 2 * spread)
        self.lower.setData(phase, mean - 2 * spread)

    def clear(self) -> None:
        for item in (self.mean, self.upper, self.lower):
            item.setData([], [])


class CycleView(QtWidgets.QWidget):
    """Phase-averaged loads of the newest cycles; :meth:`refresh` is called by the redraw timer."""

    def __init__(self, data: LiveData, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.data = data
        layout = QtWidgets.QVBoxLayout(self)
        self.status = QtWidgets.QLabel("no flapping cycles yet")
        self.status.setObjectName("cycleStatus")
        layout.addWidget(self.status)
        plots = pg.GraphicsLayoutWidget()
        layout.addWidget(plots)
        self.curves: dict[bool, list[_BandCurves]] = {True: [], False: []}
        for row, (_, label) in enumerate(PLOTTED_LOADS):
            plot = plots.addPlot(row=row, col=0)
            plot.setLabel("left", label)
            plot.setLabel("bottom", "phase of the flap cycle (0 = Hall edge)")
            plot.showGrid(x=True, y=True, alpha=0.2)
            plot.addLegend(offset=(5, 5))
            self.curves[True].append(_BandCurves(plot, TAILED_COLOR, "tailed, mean and 2 sigma"))
            self.curves[False].append(
                _BandCurves(plot, TAILLESS_COLOR, "tailless, mean and 2 sigma")
            )
        self.latest: dict[bool, PhaseAveragedLoads] = {}
        self._rows_at_last_update = 0
        self.updates = 0

    def clear(self) -> None:
        """Forget both tail states (a new configuration)."""
        self.latest.clear()
        for curves in self.curves.values():
            for item in curves:
                item.clear()

    def draw(self) -> None:
        """Show the latest average of each tail state."""
        for tailed, loads in self.latest.items():
            for item, (name, _) in zip(self.curves[tailed], PLOTTED_LOADS, strict=True):
                item.show(loads.phase, *loads.load(name))

    def showEvent(self, event) -> None:  # noqa: N802 - Qt override
        """Draw at once when the tab is shown."""
        super().showEvent(event)
        self.draw()

    def refresh(self) -> None:
        """Recompute once a new flap cycle's worth of rows has arrived."""
        readings = self.data.session.readings
        frequency_hz = readings.flapping_frequency_hz
        if not frequency_hz > 0.5 or not np.isfinite(self.data.display_rate_hz):
            return
        rows_per_cycle = self.data.display_rate_hz / frequency_hz
        if self.data.rows_received - self._rows_at_last_update < rows_per_cycle:
            return
        self._rows_at_last_update = self.data.rows_received
        volts = self.data.volts(CYCLE_WINDOW_S)
        tare = self.data.session.tare_volts
        calibration = self.data.session.calibration
        if calibration is None or len(volts) < 2 * rows_per_cycle:
            return
        try:
            loads = phase_averaged_loads(
                volts[:, :6],
                volts[:, 8],
                self.data.display_rate_hz,
                tare if tare is not None else np.zeros(6),
                calibration,
                n_bins=PHASE_BINS,
            )
        except (UserInputError, ValueError) as error:
            self.status.setText(f"cycle view waiting: {error}")
            return
        tailed = self.data.session.tail_attached
        self.latest[tailed] = loads
        self.updates += 1
        if self.isVisible():
            self.draw()
        tare_note = "" if tare is not None else ", no tare yet"
        self.status.setText(
            f"{'tailed' if tailed else 'tailless'}: {loads.cycle_count} cycles at "
            f"{loads.flapping_frequency_hz:.2f} Hz (last {CYCLE_WINDOW_S:g} s{tare_note})"
        )
