"""The study's published tables, shipped as package data in ``vehicle/data/`` (Rijks et al., AIAA 2018-0524).

- ``tails.csv``: the 14 tail planforms (Table 2), mm, with the published S (cm^2) and AR;
- ``fuselages.csv``: the fuselages' tail positions x_h (Table 1), mm;
- ``study_table3_steady_states_xh57.csv``: measured and predicted steady states at x_h = 57 mm (Table 3);
- ``study_table4_derivatives_xh98.csv``: identified derivatives at x_h = 98 mm in the study's frame (Table 4).

Lines starting with ``#`` carry each file's citation and are skipped. Readers that turn rows into geometry,
trend observations or simulator checks live with their users; this module only reads.
"""

from __future__ import annotations

import csv
from importlib import resources

STUDY_TAILS_TABLE = "tails.csv"
STUDY_FUSELAGES_TABLE = "fuselages.csv"
STUDY_TABLE_3 = "study_table3_steady_states_xh57.csv"
STUDY_TABLE_4 = "study_table4_derivatives_xh98.csv"

STUDY_SIGN_FLIPPED_DERIVATIVES = ("Mu", "Mw", "Xq", "Zq")
"""Table 4 derivatives whose published sign is flipped into ornitail's frame (docs/frames.md)."""


def study_table_rows(name: str) -> list[dict[str, str]]:
    """Rows of one shipped study table (``name`` as in ``vehicle/data/``), as strings keyed by column."""
    text = resources.files("ornitail.vehicle").joinpath(f"data/{name}").read_text()
    return list(csv.DictReader(line for line in text.splitlines() if not line.startswith("#")))
