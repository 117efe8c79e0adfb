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


def test_top_level_keys_are_named_without_brackets():
    top = TomlTable("f.json", "", {"seed": -1}, {"seed"})
    assert top.where() == "f.json" and top.where("seed") == "f.json: seed"
    with pytest.raises(UserInputError, match=r"^f\.json: seed: -1 must be >= 0$"):
        top.integer("seed")
    with pytest.raises(UserInputError, match=r"^f\.json: top level must be a table of keys$"):
        TomlTable("f.json", "", [1, 2], {"seed"})
    with pytest.raises(
        UserInputError, match=r"^f\.json: typo: unknown key; allowed keys are seed$"
    ):
        TomlTable("f.json", "", {"typo": 1}, {"seed"})


def test_lists_of_tables_name_each_table():
    document = {"run": [{"path": "a.csv"}, "b.csv"], "none": []}
    top = TomlTable("f.toml", "", document, {"run", "none"})
    first, second = top.tables("run", {"path"}, text_key="path")
    assert (first.section, second.section) == ("run[1]", "run[2]")
    assert second.where("path") == "f.toml: [run[2]].path"
    assert (first.text("path"), second.text("path")) == ("a.csv", "b.csv")
    assert top.tables("none", {"path"}) == []
    assert top.tables("absent", {"path"}, None) is None
    assert top.tables("absent", {"path"}, []) == []


@pytest.mark.parametrize(
    ("document", "read", "message"),
    [
        (
            {"run": "a.csv"},
            lambda t: t.tables("run", {"path"}),
            r"^f\.toml: \[s\]\.run: 'a\.csv' must be a list of tables$",
        ),
        (
            {"run": [3]},
            lambda t: t.tables("run", {"path"}),
            r"^f\.toml: \[s\.run\[1\]\]: 3 must be a table$",
        ),
        (
            {"run": ["a.csv", 3]},
            lambda t: t.tables("run", {"path"}, text_key="path"),
            r"^f\.toml: \[s\.run\[2\]\]: 3 must be a table or a string \(path\)$",
        ),
        (
            {"run": [{"path": "a", "pth": "b"}]},
            lambda t: t.tables("run", {"path"}),
            r"^f\.toml: \[s\.run\[1\]\]\.pth: unknown key; allowed keys are path$",
        ),
        (
            {"run": [{"path": "a"}, {"when": [2.0, 1.0]}]},
            lambda t: [
                r.interval("when", None, bounds=("start", "end"))
                for r in t.tables("run", {"path", "when"})
            ],
            r"^f\.toml: \[s\.run\[2\]\]\.when: start 2 must be below end 1$",
        ),
        (
            {"run": {"b": 1}},
            lambda t: t.sub_table("run", {"a"}),
            r"^f\.toml: \[s\.run\]\.b: unknown key; allowed keys are a$",
        ),
        ({"run": 3}, lambda t: t.sub_table("run", {"a"}), r"^f\.toml: \[s\.run\]: must be a table"),
        (
            {},
            lambda t: t.sub_table("run", {"a"}),
            r"^f\.toml: \[s\]\.run: required key is missing$",
        ),
    ],
)
def test_list_and_sub_table_mistakes_name_the_table(document, read, message):
    with pytest.raises(UserInputError, match=message):
        read(TomlTable("f.toml", "s", document, {"run"}))


def test_sub_tables_intervals_number_lists_and_strings():
    document = {"planform": {"b_mm": 120}, "when": [1, 2], "c": [1, 2, 3], "hash": "", "rule": 25}
    reader = TomlTable("f.toml", "s", document, set(document))
    planform = reader.sub_table("planform", {"b_mm", "c_mm"})
    assert planform.section == "s.planform" and planform.number("b_mm") == 120.0
    assert planform.where("c_mm") == "f.toml: [s.planform].c_mm"
    assert reader.sub_table("absent", {"b_mm"}, None) is None
    assert reader.interval("when", bounds=("start", "end")) == (1.0, 2.0)
    assert reader.interval("absent", None) is None
    assert reader.numbers("c", 2, "c_0..c_k", or_more=True) == [1.0, 2.0, 3.0]
    with pytest.raises(
        UserInputError, match=r"\[s\]\.when: \[1, 2\] must be 3 or more finite numbers c_k"
    ):
        reader.numbers("when", 3, "c_k", or_more=True)
    with pytest.raises(
        UserInputError, match=r"\[s\]\.c: \[1, 2, 3\] must be 2 finite numbers \[start, end\]"
    ):
        reader.interval("c", bounds=("start", "end"))
    assert reader.text("hash", empty=True) == ""
    assert reader.text("absent", "", empty=True) == ""
    with pytest.raises(UserInputError, match=r"\[s\]\.hash: '' must be a non-empty string"):
        reader.text("hash")
    with pytest.raises(UserInputError, match=r"\[s\]\.rule: 25 must be a string"):
        reader.text("rule", empty=True)
    # a choice names the choices whatever the wrong value's type
    with pytest.raises(UserInputError, match=r"\[s\]\.rule: 25 must be one of a, b"):
        reader.text("rule", choices=("a", "b"))


def test_a_table_of_names_the_file_chooses_takes_any_key():
    document = {
        "constants": {"g": 9.81, "V": {"column": "v"}},
        "names": ["a", "b"],
        "bad": ["a", ""],
    }
    reader = TomlTable("f.toml", "", document, set(document))
    constants = reader.sub_table("constants", None)
    assert list(constants.table) == ["g", "V"] and constants.number("g") == 9.81
    assert constants.sub_table("V", {"column"}).where("column") == "f.toml: [constants.V].column"
    assert reader.texts("names", at_least=1) == ["a", "b"]
    assert reader.texts("absent", None) is None
    with pytest.raises(
        UserInputError, match=r"^f\.toml: bad: \['a', ''\] must be a list of non-empty"
    ):
        reader.texts("bad")
    with pytest.raises(
        UserInputError, match=r"^f\.toml: names: \['a', 'b'\] must be a list of 3 or more non-empty"
    ):
        reader.texts("names", at_least=3)
