"""Reading small numeric CSV tables with named columns (calibration points, tunnel tables).

Format: a header line naming the columns, then one row of numbers per line. Lines that start
with ``#`` and blank lines are ignored, so a file may carry its own description. Extra columns
are allowed and ignored. Every required value must be a finite number; errors name the file,
the line number and the column.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import decode_text, read_input_bytes


def read_numeric_csv_columns(
    path: str | Path, required_columns: tuple[str, ...], minimum_rows: int = 1
) -> tuple[dict[str, np.ndarray], list[int], bytes]:
    """Return ``(columns, line_numbers, raw_bytes)`` of a numeric CSV file.

    ``columns`` maps each required column name to a float array; ``line_numbers[i]`` is the
    1-based line of data row ``i`` in the file (for error messages); ``raw_bytes`` are the file's
    bytes (for its content hash).
    """
    path = Path(path)
    source = str(path)
    data = read_input_bytes(path)
    text = decode_text(data, source)
    numbered_lines = [
        (number, line)
        for number, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not numbered_lines:
        raise UserInputError(source, "file has no header line")
    header_number, header_line = numbered_lines[0]
    header = [name.strip() for name in next(csv.reader(io.StringIO(header_line)))]
    missing = [name for name in required_columns if name not in header]
    if missing:
        raise UserInputError(
            f"{source}: line {header_number}",
            f"missing column(s) {', '.join(missing)}; header is {','.join(header)}",
        )
    indices = {name: header.index(name) for name in required_columns}
    values: dict[str, list[float]] = {name: [] for name in required_columns}
    line_numbers: list[int] = []
    for number, line in numbered_lines[1:]:
        fields = [item.strip() for item in next(csv.reader(io.StringIO(line)))]
        if len(fields) != len(header):
            raise UserInputError(
                f"{source}: line {number}", f"expected {len(header)} fields, got {len(fields)}"
            )
        for name, index in indices.items():
            where = f"{source}: line {number}, column {name}"
            try:
                value = float(fields[index])
            except ValueError:
                raise UserInputError(where, f"{fields[index]!r} is not a number") from None
            if not math.isfinite(value):
                raise UserInputError(where, f"{fields[index]!r} is not a finite number")
            values[name].append(value)
        line_numbers.append(number)
    if len(line_numbers) < minimum_rows:
        raise UserInputError(
            source, f"needs at least {minimum_rows} data rows, found {len(line_numbers)}"
        )
    return {name: np.array(items) for name, items in values.items()}, line_numbers, data
