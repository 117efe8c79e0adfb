"""Checks of the numeric columns of a table a user gives (tunnel or steady-state table)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import check_input_file


def csv_header(path: str | Path) -> set[str]:
    """Column names of a readable ``.csv`` file; empty for anything else (wrong suffix, unreadable)."""
    path = Path(path)
    if path.suffix.lower() != ".csv":
        return set()
    try:
        check_input_file(path)  # a regular file of bounded size, else not a table
        return set(pd.read_csv(path, nrows=0).columns)
    except (
        UserInputError,
        pd.errors.ParserError,
        pd.errors.EmptyDataError,
        UnicodeDecodeError,
        OSError,
    ):
        return set()


def finite_column(path: str | Path, table: pd.DataFrame, column: str) -> np.ndarray:
    """``table[column]`` as floats; a cell that is not a finite number stops with one line naming
    the file, the column, the cell as written and its data row (1-based, header not counted)."""
    values = pd.to_numeric(table[column], errors="coerce").to_numpy(float)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise UserInputError(
            f"{path}: column {column}",
            f"value {str(table[column].iloc[bad[0]])!r} in data row {table.index[bad[0]] + 1} "
            "is not a finite number",
        )
    return values
