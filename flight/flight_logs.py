"""Reading flight logs: CSV, Parquet and MATLAB .mat files into a pandas DataFrame.

A .mat log (MATLAB v4 to v7.2) holds either

- as NASA SIDPAC records do, a matrix ``fdata`` (samples x channels) with channel labels
  ``varlab`` such as ``'* alpha      (deg)     '``. Labels become column names ``<name>_<unit>``
  in lower case with spaces, ``/`` and ``-`` turned into ``_`` (``alpha_deg``, ``q_deg_sec``,
  ``qbar_lbf_ft2``); unlabelled channels become ``ch<number>`` (1-based), a repeated name gets
  ``_b``, ``_c``...; or
- channels as numeric vectors: variables of their own, fields of a struct (``log.alpha_deg``;
  a struct array of one element counts as a struct), or fields of a struct inside such a struct
  (``log.imu.q_rad_s``; one level of nesting, deeper is refused). A channel's column is its
  variable or field name; names that occur more than once get their parent's name as a prefix
  (``imu_q``, ``ekf_q``). The longest vectors make the log; shorter ones, scalars, strings and
  matrices are left out.
"""

from __future__ import annotations

import io
import re
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.io
from scipy.io.matlab import mat_struct

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import check_input_file, read_input_text

LOG_SUFFIXES = (".csv", ".parquet", ".pq", ".mat")
MAX_STRUCT_NESTING = 1  # a struct of channels may hold structs of channels, no deeper
_LABEL_PATTERN = re.compile(r"^\*?\s*(?P<name>[^()]*?)\s*(\((?P<unit>[^)]*)\))?\s*$")


def read_flight_log(path: str | Path) -> pd.DataFrame:
    """Read a flight log by its suffix (.csv, .parquet/.pq, .mat); all columns numeric.

    Raises
    ------
    UserInputError
        If the file is missing, of an unknown kind, unreadable, or has non-numeric columns.
    """
    path = Path(path)
    if not path.exists():
        raise UserInputError(str(path), "flight log not found")
    check_input_file(path)  # a regular file of bounded size (core/input_files.py)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        text = read_input_text(path)
        try:
            data = pd.read_csv(io.StringIO(text))
        except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as error:
            message = " ".join(str(error).split())
            raise UserInputError(str(path), f"not a readable CSV file: {message}") from None
    elif suffix in (".parquet", ".pq"):
        data = _read_parquet(path)
    elif suffix == ".mat":
        data = _read_mat(path)
    else:
        raise UserInputError(
            str(path), f"unknown log type {suffix!r} (expected {', '.join(LOG_SUFFIXES)})"
        )
    non_numeric = [
        str(name) for name in data.columns if not pd.api.types.is_numeric_dtype(data[name])
    ]
    if non_numeric:
        raise UserInputError(f"{path}: column {non_numeric[0]}", "is not numeric")
    if data.empty:
        raise UserInputError(str(path), "the log has no samples")
    return data


def _read_parquet(path: Path) -> pd.DataFrame:
    try:
        return pd.read_parquet(path)
    except ImportError:
        raise UserInputError(
            str(path), "reading Parquet needs the pyarrow package (pip install pyarrow)"
        ) from None
    except (OSError, ValueError) as error:
        raise UserInputError(str(path), f"not a readable Parquet file: {error}") from None


def _read_mat(path: Path) -> pd.DataFrame:
    try:
        contents = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)
    except (
        ValueError,
        OSError,
        NotImplementedError,
        IndexError,
        TypeError,
        KeyError,
        EOFError,
        scipy.io.matlab.MatReadError,
    ) as error:  # scipy reports malformed files in many ways
        raise UserInputError(str(path), f"not a readable MATLAB file (v4-v7.2): {error}") from None
    if "fdata" in contents:
        matrix = np.asarray(contents["fdata"], dtype=float)
        if matrix.ndim == 1:  # squeezed from one channel (one sample is too short anyway)
            matrix = matrix[:, None]
        if matrix.ndim != 2:
            raise UserInputError(f"{path}: fdata", "must be a matrix (samples x channels)")
        labels = [str(label) for label in np.ravel(contents.get("varlab", []))]
        return pd.DataFrame(matrix, columns=column_names_from_labels(labels, matrix.shape[1]))
    channels = [
        channel
        for name, value in contents.items()
        if not name.startswith("__")
        for channel in _mat_channels((name,), value, str(path))
    ]
    if not channels:
        raise UserInputError(
            str(path), "no fdata matrix and no numeric vectors (or structs of them) in the file"
        )
    length = max(len(vector) for _, vector in channels)
    longest = [(field, vector) for field, vector in channels if len(vector) == length]
    names = _channel_names([field for field, _ in longest], str(path))
    return pd.DataFrame({name: vector for name, (_, vector) in zip(names, longest, strict=True)})


def _mat_channels(
    field: tuple[str, ...], value: object, where: str
) -> list[tuple[tuple[str, ...], np.ndarray]]:
    """The numeric vectors (field path, values) in a loaded .mat variable or struct field."""
    if (
        isinstance(value, np.ndarray)
        and value.ndim == 1
        and value.size > 1
        and np.issubdtype(value.dtype, np.number)
    ):
        return [(field, value)]
    if (
        isinstance(value, np.ndarray)
        and value.dtype == object
        and any(isinstance(item, mat_struct) for item in value.flat)
    ):
        raise UserInputError(
            f"{where}: {'.'.join(field)}",
            f"is a struct array of {value.size} elements; save one flight's struct (e.g. log(1))",
        )
    if not isinstance(value, mat_struct):
        return []
    if len(field) > MAX_STRUCT_NESTING + 1:
        raise UserInputError(
            f"{where}: {'.'.join(field)}",
            f"structs nest more than {MAX_STRUCT_NESTING} level deep; flatten the log",
        )
    return [
        channel
        for name in value._fieldnames
        for channel in _mat_channels((*field, name), getattr(value, name), where)
    ]


def _channel_names(fields: list[tuple[str, ...]], where: str) -> list[str]:
    """Column names of .mat channels: the field name, prefixed by its parent's where repeated."""
    repeated = Counter(field[-1] for field in fields)
    names = ["_".join(field[-2:]) if repeated[field[-1]] > 1 else field[-1] for field in fields]
    for name, count in Counter(names).items():
        if count > 1:
            clashing = [".".join(f) for f, n in zip(fields, names, strict=True) if n == name]
            raise UserInputError(
                f"{where}: {' and '.join(clashing)}", f"both become column {name}; rename one"
            )
    return names


def column_names_from_labels(labels: Sequence[str], count: int) -> list[str]:
    """Column names for ``count`` channels from SIDPAC-style labels (see the module docstring)."""
    names = []
    for index in range(count):
        label = labels[index] if index < len(labels) else ""
        match = _LABEL_PATTERN.match(label.strip())
        name = match.group("name").strip() if match else ""
        unit = (match.group("unit") or "").strip() if match else ""
        if not name:
            names.append(f"ch{index + 1}")
            continue
        text = f"{name}_{unit}" if unit else name
        names.append(re.sub(r"[\s/\-]+", "_", text).lower())
    seen: dict[str, int] = {}
    unique = []
    for name in names:
        seen[name] = seen.get(name, 0) + 1
        unique.append(name if seen[name] == 1 else f"{name}_{chr(ord('a') + seen[name] - 1)}")
    return unique
