"""Shared look of the live plots: thin pens, fixed time axis, y range updated a few times a second.

Redrawing an axis costs more than drawing a curve, so the time axis is fixed, axes are cached as pixmaps (no grid
lines, which would make every curve update repaint them) and the y range only follows the data twice a second (and
at once when data leave it), instead of auto-ranging at every frame.
"""

from __future__ import annotations

import time

import numpy as np
import pyqtgraph as pg

COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b")
TAILED_COLOR = "#1f77b4"
TAILLESS_COLOR = "#ff7f0e"
Y_RANGE_INTERVAL_S = 0.5
MAX_POINTS_PER_CURVE = 1500


def live_plot(
    layout: pg.GraphicsLayoutWidget,
    row: int,
    title: str,
    unit_label: str,
    window_s: float,
    col: int = 0,
    colspan: int = 1,
) -> pg.PlotItem:
    """A plot of the last ``window_s`` seconds in ``layout`` at ``row``, ``col`` (``colspan`` columns wide),
    legend and labelled y axis."""
    plot = layout.addPlot(row=row, col=col, colspan=colspan, title=title)
    plot.setLabel("left", unit_label)
    plot.getAxis("left").enableAutoSIPrefix(
        False
    )  # the unit is the label's: no "(x0.001)" rescaling
    plot.setLabel("bottom", "time", units="s")
    for name in ("left", "bottom"):  # axes repaint from a pixmap unless their range changed
        plot.getAxis(name).setCacheMode(pg.QtWidgets.QGraphicsItem.CacheMode.DeviceCoordinateCache)
    plot.setXRange(-window_s, 0.0, padding=0.0)
    plot.enableAutoRange(x=False, y=False)
    plot.setMouseEnabled(x=False, y=True)
    plot.addLegend(offset=(5, 5))
    return plot


def curve(plot: pg.PlotItem, index: int, name: str) -> pg.PlotDataItem:
    """A thin curve in the ``index``-th colour."""
    return plot.plot(
        [], [], pen=pg.mkPen(COLORS[index % len(COLORS)], width=1), name=name, skipFiniteCheck=True
    )


def thinned(rows: int) -> slice:
    """A stride that keeps at most ``MAX_POINTS_PER_CURVE`` of ``rows`` points (the screen shows no more)."""
    return slice(None, None, max(1, rows // MAX_POINTS_PER_CURVE))


class YRangeFollower:
    """Moves a plot's y range to its data at most every ``Y_RANGE_INTERVAL_S``, or at once when data leave it."""

    def __init__(self, plot: pg.PlotItem) -> None:
        self.plot = plot
        self._last_s = 0.0
        self._range = (0.0, 0.0)

    def follow(self, *series: np.ndarray) -> None:
        """Fit the y range to ``series`` (with 10 % margin) when due."""
        finite = [values[np.isfinite(values)] for values in series if len(values)]
        finite = [values for values in finite if len(values)]
        if not finite:
            return
        low = min(float(values.min()) for values in finite)
        high = max(float(values.max()) for values in finite)
        now = time.monotonic()
        outside = low < self._range[0] or high > self._range[1]
        if not outside and now - self._last_s < Y_RANGE_INTERVAL_S:
            return
        margin = max(0.1 * (high - low), 1e-9)
        self._range = (low - margin, high + margin)
        self._last_s = now
        self.plot.setYRange(*self._range, padding=0.0)
