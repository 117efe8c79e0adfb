"""Screenshots of each tab of the window on the simulated rig, for the README and docs/gui.md. Run under a virtual
display of the screen size wanted, once per size:

    xvfb-run -a -s "-screen 0 1366x768x24" .venv/bin/python docs/screenshots/make_screenshots.py docs/screenshots
    xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/python docs/screenshots/make_screenshots.py docs/screenshots

The window fills the screen, as maximised on a tunnel PC; the pictures are named ``<tab>-<width>x<height>.png``. It
records a tailless and a tailed manual point (tare first), runs a short sweep plan, processes the sweep's runs,
opens one run's signals and proposes a tail, all in real time on the simulated rig (about three minutes).
"""

import os
import pathlib
import sys
import tempfile
import time

os.environ.setdefault("PYQTGRAPH_QT_LIB", "PySide6")
from PySide6 import QtWidgets

from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.gui.main_window import MainWindow
from ornitail.gui.rig_session import RigSession

out = pathlib.Path(sys.argv[1])
app = QtWidgets.QApplication([])
screen = app.primaryScreen().size()
size = f"{screen.width()}x{screen.height()}"
root = pathlib.Path(tempfile.mkdtemp())
w = MainWindow(RigSession(root))
w.setGeometry(
    app.primaryScreen().availableGeometry()
)  # the whole screen (no window manager to maximise)
w.show()


def spin(sec):
    end = time.time() + sec
    while time.time() < end:
        app.processEvents()
        time.sleep(0.005)


s = w.session
s.connect(DEFAULT_RIG_FILE, 1.0)
spin(3)
s.set_pitch_deg(25)
for tailed in (False, True):  # a tailless, then a tailed point: the cycle view overlays both
    s.start_recording("S3", 98.0, tailed)
    spin(6)
    s.tare(1.0)
    spin(4)
    s.set_tunnel_velocity(0.8)
    s.set_flapping_frequency(13.5)
    spin(6)
    s.record_point(2.0)
    spin(3)
    s.stop_recording()
    spin(1)
w.tabs.setCurrentWidget(w.live_view)
spin(2)
w.grab().save(str(out / f"live-{size}.png"))
w.tabs.setCurrentWidget(w.cycle_view)
spin(2)
w.grab().save(str(out / f"cycle-{size}.png"))
plan = pathlib.Path(tempfile.mkdtemp()) / "short.toml"
plan.write_text((pathlib.Path(__file__).parent / "short_plan.toml").read_text())
w.sweep_panel.plan_file.edit.setText(str(plan))
w.sweep_panel.run_button.click()
while s.sweep_running or w.sweep_panel.last_result is None:
    spin(0.5)
w.runs_tab.reload()
spin(1)
w.tabs.setCurrentWidget(w.runs_tab)
w.runs_tab.table.setSelectionMode(QtWidgets.QAbstractItemView.SelectionMode.MultiSelection)
for row, run in enumerate(w.runs_tab.runs):
    if run.plan_name == "short":
        w.runs_tab.table.selectRow(row)
w.runs_tab.process_selected()
while w.runs_tab.jobs.busy:
    spin(0.5)
spin(1)
w.runs_tab.views.setCurrentIndex(2)  # the processed figures
spin(1)
w.grab().save(str(out / f"runs-{size}.png"))
w.runs_tab.table.clearSelection()
w.runs_tab.table.selectRow(0)
w.runs_tab.open_selected()
while w.runs_tab.browser.jobs.busy:
    spin(0.5)
w.runs_tab.browser.table.selectRow(3)
spin(0.5)
while w.runs_tab.browser.jobs.busy:
    spin(0.5)
spin(1)
w.grab().save(str(out / f"signals-{size}.png"))
w.tabs.setCurrentWidget(w.design_tab)
w.design_tab.start_proposal()
while w.design_tab.jobs.busy:
    spin(0.5)
spin(1)
w.grab().save(str(out / f"design-{size}.png"))
w.close()
