"""Safe arithmetic expressions for model files: parsed with :mod:`ast`, checked against a whitelist.

An expression may contain numbers, names, ``+ - * / **``, unary ``+``/``-``, parentheses and the
functions ``sin``, ``cos``, ``tan``, ``sqrt``, ``exp``. Nothing is ever passed to ``eval``: the
parsed tree is checked node by node, and :func:`evaluate` walks it with the arithmetic of whatever
values it is given (floats, or CasADi symbols for the estimator).
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ornitail.core.errors import UserInputError

FUNCTION_NAMES = ("sin", "cos", "tan", "sqrt", "exp")
MATH_FUNCTIONS: dict[str, Callable[[float], float]] = {
    name: getattr(math, name) for name in FUNCTION_NAMES
}

_BINARY_OPERATIONS: dict[type, Callable[[Any, Any], Any]] = {
    ast.Add: lambda left, right: left + right,
    ast.Sub: lambda left, right: left - right,
    ast.Mult: lambda left, right: left * right,
    ast.Div: lambda left, right: left / right,
    ast.Pow: lambda left, right: left**right,
}
_UNARY_OPERATIONS: dict[type, Callable[[Any], Any]] = {
    ast.USub: lambda operand: -operand,
    ast.UAdd: lambda operand: operand,
}


MAX_EXPRESSION_CHARACTERS = 10_000
"""Longest expression accepted, characters."""
MAX_EXPRESSION_DEPTH = 100
"""Deepest nesting of operations and parentheses accepted in an expression."""


@dataclass(frozen=True)
class Expression:
    """A checked arithmetic expression: its source text, parsed tree and the names it uses.

    ``where`` names the file and field it came from, for messages when it cannot be evaluated.
    """

    text: str
    tree: ast.expr
    names: frozenset[str]
    where: str = "expression"

    def evaluate(
        self,
        values: Mapping[str, Any],
        functions: Mapping[str, Callable[[Any], Any]] = MATH_FUNCTIONS,
    ) -> Any:
        """Value of the expression with ``values`` for its names (floats or CasADi symbols).

        Float arithmetic that fails (division by zero, overflow, a function outside its domain)
        raises :class:`UserInputError` naming the expression and the values of its names.
        """
        try:
            return _evaluate_node(self.tree, values, functions)
        except (ZeroDivisionError, OverflowError, ValueError) as error:
            used = ", ".join(
                f"{name} = {values[name]!r}" for name in sorted(self.names) if name in values
            )
            raise UserInputError(
                self.where,
                f"{self.text!r} cannot be evaluated ({_arithmetic_problem(error)})"
                + (f" with {used}" if used else ""),
            ) from None


def _arithmetic_problem(error: Exception) -> str:
    if isinstance(error, ZeroDivisionError):
        return "division by zero"
    if isinstance(error, OverflowError):
        return "the result is too large"
    return f"math domain error: {error}"


def parse_expression(text: str | int | float, where: str) -> Expression:
    """Parse and check one expression; a number is accepted as its own expression.

    Raises
    ------
    UserInputError
        If ``text`` is not a string or number, is not valid syntax, or uses anything outside the
        whitelist (attributes, subscripts, calls of other functions, keywords, strings ...).
    """
    if isinstance(text, bool) or not isinstance(text, str | int | float):
        raise UserInputError(where, f"expected a number or an expression string, got {text!r}")
    source = repr(float(text)) if not isinstance(text, str) else text
    if not isinstance(text, str) and not math.isfinite(float(text)):
        raise UserInputError(where, f"value {text!r} is not a finite number")
    if not source.strip():
        raise UserInputError(where, "empty expression")
    if len(source) > MAX_EXPRESSION_CHARACTERS:
        raise UserInputError(
            where,
            f"expression of {len(source)} characters; at most {MAX_EXPRESSION_CHARACTERS} "
            f"are allowed (starts {source[:40]!r})",
        )
    try:
        tree = ast.parse(source.strip(), mode="eval").body
    except SyntaxError as error:
        raise UserInputError(
            where, f"cannot parse expression {_short(source)}: {error.msg}"
        ) from None
    except (RecursionError, MemoryError):
        raise UserInputError(
            where, f"expression {_short(source)} is nested too deeply to parse"
        ) from None
    names: set[str] = set()
    _check_node(tree, source, where, names)
    return Expression(text=source.strip(), tree=tree, names=frozenset(names), where=where)


def _short(source: str) -> str:
    """``source`` quoted, cut to 60 characters for messages."""
    return repr(source) if len(source) <= 60 else repr(source[:57] + "...")


def _constant_value(node: ast.AST) -> float | None:
    """The value of a checked subtree made of numbers only, else None."""
    if isinstance(node, ast.Constant):
        return float(node.value)
    if isinstance(node, ast.BinOp):
        left, right = _constant_value(node.left), _constant_value(node.right)
        if left is None or right is None:
            return None
        return _BINARY_OPERATIONS[type(node.op)](left, right)
    if isinstance(node, ast.UnaryOp):
        operand = _constant_value(node.operand)
        return None if operand is None else _UNARY_OPERATIONS[type(node.op)](operand)
    if isinstance(node, ast.Call):
        argument = _constant_value(node.args[0])
        return None if argument is None else MATH_FUNCTIONS[node.func.id](argument)
    return None


def _check_constant_part(node: ast.AST, source: str, where: str) -> None:
    """Refuse numbers-only parts that cannot be computed: ``1/0``, ``9**9**9**9``, ``sqrt(-1)``."""
    try:
        value = _constant_value(node)
    except (ZeroDivisionError, OverflowError, ValueError) as error:
        raise UserInputError(
            where, f"{_short(ast.unparse(node))} in {_short(source)}: {_arithmetic_problem(error)}"
        ) from None
    if value is not None and not (isinstance(value, float) and math.isfinite(value)):
        raise UserInputError(
            where, f"{_short(ast.unparse(node))} in {_short(source)} is not a finite number"
        )


def _check_node(node: ast.AST, source: str, where: str, names: set[str], depth: int = 0) -> None:
    if depth > MAX_EXPRESSION_DEPTH:
        raise UserInputError(
            where,
            f"expression {_short(source)} nests deeper than {MAX_EXPRESSION_DEPTH} levels",
        )
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, int | float):
            raise UserInputError(where, f"only numbers may appear as literals in {_short(source)}")
        if not math.isfinite(float(node.value)):
            raise UserInputError(
                where, f"{node.value!r} in {_short(source)} is not a finite number"
            )
    elif isinstance(node, ast.Name):
        if node.id.startswith("_"):
            raise UserInputError(where, f"name {node.id!r} is not allowed in {_short(source)}")
        names.add(node.id)
    elif isinstance(node, ast.BinOp) and type(node.op) in _BINARY_OPERATIONS:
        _check_node(node.left, source, where, names, depth + 1)
        _check_node(node.right, source, where, names, depth + 1)
        _check_constant_part(node, source, where)
    elif isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY_OPERATIONS:
        _check_node(node.operand, source, where, names, depth + 1)
    elif isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTION_NAMES:
            raise UserInputError(
                where,
                f"only the functions {', '.join(FUNCTION_NAMES)} may be called in {source!r}",
            )
        if node.keywords or len(node.args) != 1:
            raise UserInputError(
                where, f"{node.func.id}() takes exactly one argument in {_short(source)}"
            )
        _check_node(node.args[0], source, where, names, depth + 1)
        _check_constant_part(node, source, where)
    else:
        raise UserInputError(
            where,
            f"{type(node).__name__} is not allowed in {_short(source)} "
            "(numbers, names, + - * / **, parentheses and sin cos tan sqrt exp only)",
        )


def _evaluate_node(
    node: ast.expr, values: Mapping[str, Any], functions: Mapping[str, Callable[[Any], Any]]
) -> Any:
    if isinstance(node, ast.Constant):
        return float(node.value)
    if isinstance(node, ast.Name):
        return values[node.id]
    if isinstance(node, ast.BinOp):
        left = _evaluate_node(node.left, values, functions)
        right = _evaluate_node(node.right, values, functions)
        return _BINARY_OPERATIONS[type(node.op)](left, right)
    if isinstance(node, ast.UnaryOp):
        return _UNARY_OPERATIONS[type(node.op)](_evaluate_node(node.operand, values, functions))
    if isinstance(node, ast.Call):
        return functions[node.func.id](_evaluate_node(node.args[0], values, functions))
    raise TypeError(f"unchecked expression node {type(node).__name__}")
