"""The model files' expression parser: arithmetic is evaluated, everything else refused."""

import math

import casadi
import pytest

from ornitail.core.errors import UserInputError
from ornitail.flight.expressions import parse_expression
from ornitail.flight.model_functions import CASADI_FUNCTIONS


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("Mq/Iyy", -2.0 / 4.0),
        ("Xq/m - w0", 3.0 / 0.5 - (-0.25)),
        ("-g*cos(theta0)", -9.81 * math.cos(0.4)),
        ("(1 + Mq)**2", 1.0),
        ("sqrt(m) * sin(theta0) + -Mq", math.sqrt(0.5) * math.sin(0.4) + 2.0),
        ("2.5e-3", 2.5e-3),
        (7, 7.0),
    ],
)
def test_arithmetic_is_evaluated_like_python(text, expected):
    values = {"Mq": -2.0, "Iyy": 4.0, "Xq": 3.0, "m": 0.5, "w0": -0.25, "g": 9.81, "theta0": 0.4}
    expression = parse_expression(text, "test")
    assert expression.evaluate(values) == pytest.approx(expected, rel=1e-15)


def test_the_same_tree_gives_casadi_expressions_with_the_same_value():
    expression = parse_expression("Xq/m - g*cos(theta0)", "test")
    assert expression.names == {"Xq", "m", "g", "theta0"}
    symbols = {name: casadi.SX.sym(name) for name in expression.names}
    function = casadi.Function(
        "f", list(symbols.values()), [expression.evaluate(symbols, CASADI_FUNCTIONS)]
    )
    numeric = dict(zip(symbols, (3.0, 0.5, 9.81, 0.4), strict=True))
    assert float(function(*numeric.values())) == pytest.approx(expression.evaluate(numeric))


@pytest.mark.parametrize(
    "text",
    [
        "__import__('os').system('echo owned')",
        "__import__",
        "a.b",
        "x[0]",
        "lambda: 1",
        "open(1)",
        "sin(x, y)",
        "sin(x=1)",
        "1 if a else 2",
        "'text'",
        "a == b",
        "a % b",
        "a // b",
        "True",
        "",
        "1 +",
        "[1, 2]",
        "(a, b)",
    ],
)
def test_anything_but_arithmetic_is_refused_with_the_field_named(text):
    with pytest.raises(UserInputError) as error:
        parse_expression(text, "m.toml: [matrices].A[1][1]")
    assert error.value.where == "m.toml: [matrices].A[1][1]"


@pytest.mark.parametrize("value", [math.nan, math.inf, True, None, [1]])
def test_non_finite_or_non_numeric_literals_are_refused(value):
    with pytest.raises(UserInputError):
        parse_expression(value, "field")
