"""Show the window on the X display of $DISPLAY (a virtual one in the tests) and report its size as JSON.

Run as ``python window_on_screen.py WIDTH HEIGHT PNG``: the window is made to fill a WIDTH x HEIGHT
screen through Qt's xcb platform (what a real desktop uses, libxcb-cursor0 and all), given a second of redraws,
then grabbed into PNG. Prints {"screen": [w, h], "window": [w, h], "minimum": [w, h]}.
"""

import json
import os
import sys
import tempfile
import time

os.environ["QT_QPA_PLATFORM"] = "xcb"
os.environ.setdefault("PYQTGRAPH_QT_LIB", "PySide6")

from PySide6 import QtWidgets  # noqa: E402

from ornitail.gui.main_window import MainWindow  # noqa: E402
from ornitail.gui.rig_session import RigSession  # noqa: E402

application = QtWidgets.QApplication([])
window = MainWindow(RigSession(tempfile.mkdtemp()))
window.setGeometry(
    application.primaryScreen().availableGeometry()
)  # maximised (Xvfb has no window manager)
window.show()
end = time.monotonic() + 1.0
while time.monotonic() < end:
    application.processEvents()
    time.sleep(0.01)
window.grab().save(sys.argv[3])
screen = application.primaryScreen().size()
hint = window.minimumSizeHint()
print(
    json.dumps(
        {
            "screen": [screen.width(), screen.height()],
            "window": [window.frameGeometry().width(), window.frameGeometry().height()],
            "minimum": [hint.width(), hint.height()],
        }
    )
)
window.close()
