"""The desktop window at the tunnel (``ornitail gui``): PySide6 widgets and pyqtgraph plots over the library.

pyqtgraph prefers PyQt6 when several Qt bindings are installed; ornitail's GUI uses PySide6 only.
"""

import os

os.environ.setdefault("PYQTGRAPH_QT_LIB", "PySide6")
