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


@dataclass(frozen=True)
class Expression:
    """A checked arithmetic expression: its source text, parsed tree and the names it uses."""

    text: str
    tree: ast.expr
    names: frozenset[str]

    def evaluate(
        self,
        values: Mapping[str, Any],
        functions: Mapping[str, Callable[[Any], Any]] = MATH_FUNCTIONS,
    ) -> Any:
        """Value of the expression with ``values`` for its names (floats or CasADi symbols)."""
        return _evaluate_node(self.tree, values, functions)


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
    try:
        tree = ast.parse(source.strip(), mode="eval").body
    except SyntaxError as error:
        raise UserInputError(where, f"cannot parse expression {source!r}: {error.msg}") from None
    names: set[str] = set()
    _check_node(tree, source, where, names)
    return Expression(text=source.strip(), tree=tree, names=frozenset(names))


def _check_node(node: ast.AST, source: str, where: str, names: set[str]) -> None:
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, int | float):
            raise UserInputError(where, f"only numbers may appear as literals in {source!r}")
    elif isinstance(node, ast.Name):
        if node.id.startswith("_"):
            raise UserInputError(where, f"name {node.id!r} is not allowed in {source!r}")
        names.add(node.id)
    elif isinstance(node, ast.BinOp) and type(node.op) in _BINARY_OPERATIONS:
        _check_node(node.left, source, where, names)
        _check_node(node.right, source, where, names)
    elif isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY_OPERATIONS:
        _check_node(node.operand, source, where, names)
    elif isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTION_NAMES:
            raise UserInputError(
                where,
                f"only the functions {', '.join(FUNCTION_NAMES)} may be called in {source!r}",
            )
        if node.keywords or len(node.args) != 1:
            raise UserInputError(
                where, f"{node.func.id}() takes exactly one argument in {source!r}"
            )
        _check_node(node.args[0], source, where, names)
    else:
        raise UserInputError(
            where,
            f"{type(node).__name__} is not allowed in {source!r} "
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
