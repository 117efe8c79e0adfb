"""The shared TOML table reader: every mistake is one line naming file, table and key."""

import math

import pytest

from ornitail.core.errors import UserInputError
from ornitail.core.toml_table import TomlTable

TABLE = {
    "rate": 10.0,
    "count": 3,
    "name": "S3",
    "on": True,
    "pair": [1.0, 2.0],
    "bad": float("nan"),
}
KEYS = set(TABLE) | {"absent"}


def table():
    return TomlTable("f.toml", "t", TABLE, KEYS)


def test_reads_typed_values():
    reader = table()
    assert reader.number("rate", positive=True) == 10.0
    assert reader.integer("count", minimum=1, maximum=5) == 3
    assert reader.text("name", choices=("S1", "S3")) == "S3"
    assert reader.boolean("on") is True
    assert reader.interval("pair") == (1.0, 2.0)
    assert reader.number("absent", 4.5) == 4.5


@pytest.mark.parametrize(
    ("read", "message"),
    [
        (lambda r: r.number("bad"), r"f.toml: \[t\]\.bad: nan must be a finite number"),
        (lambda r: r.number("rate", minimum=20), r"\[t\]\.rate: 10.0 must be >= 20"),
        (lambda r: r.integer("count", minimum=4), r"\[t\]\.count: 3 must be >= 4"),
        (lambda r: r.integer("count", minimum=0, maximum=2), r"\[t\]\.count: 3 must be in 0..2"),
        (lambda r: r.integer("rate"), r"\[t\]\.rate: 10.0 must be a whole number"),
        (lambda r: r.text("name", choices=("S1",)), r"\[t\]\.name: 'S3' must be one of S1"),
        (lambda r: r.boolean("count"), r"\[t\]\.count: 3 must be true or false"),
        (
            lambda r: r.numbers("pair", 3, "[x, y, z]"),
            r"\[t\]\.pair: .* must be 3 finite numbers \[x, y, z\]",
        ),
        (lambda r: r.number("absent"), r"\[t\]\.absent: required key is missing"),
        (lambda r: r.file("name"), r"\[t\]\.name: file 'S3' not found"),
    ],
)
def test_mistakes_name_file_table_and_key(read, message):
    with pytest.raises(UserInputError, match=message):
        read(table())


def test_unknown_keys_and_non_tables_are_refused():
    with pytest.raises(UserInputError, match=r"\[t\]\.typo: unknown key; allowed keys are a, b"):
        TomlTable("f.toml", "t", {"a": 1, "typo": 2}, {"a", "b"})
    with pytest.raises(UserInputError, match=r"f.toml: \[t\]: must be a table"):
        TomlTable("f.toml", "t", [1, 2], {"a"})
    assert math.isfinite(TomlTable("f.toml", "t", {"a": 1}, {"a"}).number("a"))


@pytest.mark.parametrize(
    "read",
    [
        lambda r: r.get("absent"),
        lambda r: r.text("absent"),
        lambda r: r.number("absent"),
        lambda r: r.integer("absent"),
        lambda r: r.boolean("absent"),
        lambda r: r.numbers("absent", 2, "[a, b]"),
    ],
)
def test_a_key_without_default_is_required(read):
    with pytest.raises(UserInputError, match=r"f\.toml: \[t\]\.absent: required key is missing"):
        read(table())


def test_none_is_a_default_like_any_other():
    # an optional key reads as None when absent; falsy defaults are defaults too (the old sentinel was None)
    reader = table()
    assert reader.get("absent", None) is None
    assert reader.text("absent", None) is None
    assert reader.number("absent", None) is None
    assert reader.integer("absent", None) is None
    assert reader.boolean("absent", None) is None
    assert reader.numbers("absent", 2, "[a, b]", None) is None
    assert reader.number("absent", 0.0) == 0.0
    assert reader.boolean("absent", False) is False
    assert reader.number("rate", None) == 10.0  # a present key is read and checked as before
    with pytest.raises(UserInputError, match="finite"):
        reader.number("bad", None)
