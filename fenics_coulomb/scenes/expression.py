"""Safe arithmetic expressions in x1, x2 for gap profiles given in scene files (no ``eval`` of user text).

The text is parsed with :mod:`ast` and only numbers, the variables ``x1``, ``x2``, the constants ``pi``
and ``e``, the operators + − * / ** and unary ±, and calls of the whitelisted NumPy functions below are
accepted; anything else (attribute access, names such as ``__import__``, subscripts, lambdas,
comprehensions, keyword or starred arguments) is rejected with an :class:`InputError` naming it. The accepted
tree is evaluated by a small interpreter on NumPy arrays.

Every function has a fixed arity and is called with exactly that many positional arguments, so NumPy's
positional ``out`` argument (``sin(1, x1)`` would write sin(1) into the mesh coordinates x1) can never be
reached; a call with another number of arguments is rejected naming the function. The interpreter also
evaluates on read-only copies of x1, x2, so nothing it computes can write into its inputs.
"""

from __future__ import annotations

import ast
import operator
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError

__all__ = ["FUNCTIONS", "CONSTANTS", "VARIABLES", "BINARY", "UNARY", "MAX_LENGTH", "MAX_DEPTH",
           "parse_point_expression", "parse_gap_expression"]

Array = npt.NDArray[np.float64]

#: The whitelisted functions and their arity (number of positional arguments, no more, no fewer).
FUNCTIONS: dict[str, tuple[Callable[..., Array], int]] = {
    "sin": (np.sin, 1), "cos": (np.cos, 1), "tan": (np.tan, 1), "exp": (np.exp, 1), "log": (np.log, 1),
    "sqrt": (np.sqrt, 1), "abs": (np.abs, 1), "tanh": (np.tanh, 1), "arctan": (np.arctan, 1),
    "arctan2": (np.arctan2, 2), "max": (np.maximum, 2), "min": (np.minimum, 2), "hypot": (np.hypot, 2),
}
CONSTANTS = {"pi": np.float64(np.pi), "e": np.float64(np.e)}
VARIABLES = ("x1", "x2")
BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
          ast.Pow: operator.pow}
UNARY: dict[type[ast.unaryop], Callable[[Any], Any]] = {ast.UAdd: operator.pos, ast.USub: operator.neg}
MAX_LENGTH = 2000
#: Deepest accepted nesting of the expression tree (the interpreter recurses once per level).
MAX_DEPTH = 100


def _check(node: ast.AST, text: str, variables: tuple[str, ...] = VARIABLES, what: str = "gap expression") -> None:
    """Raise InputError unless every node of the tree is allowed."""
    callees = {id(sub.func) for sub in ast.walk(node) if isinstance(sub, ast.Call)}
    for sub in ast.walk(node):
        if isinstance(sub, ast.Expression | ast.Load):
            continue
        if isinstance(sub, ast.Constant):
            if isinstance(sub.value, bool) or not isinstance(sub.value, int | float):
                raise InputError(f"{what} {text!r}: constant {sub.value!r} is not a number")
        elif isinstance(sub, ast.Name):
            if sub.id not in variables and sub.id not in CONSTANTS and sub.id not in FUNCTIONS:
                raise InputError(
                    f"{what} {text!r}: unknown name {sub.id!r} "
                    f"(allowed: {', '.join(variables)}, {', '.join(CONSTANTS)}, {', '.join(sorted(FUNCTIONS))})"
                )
            if sub.id in FUNCTIONS and id(sub) not in callees:
                raise InputError(f"{what} {text!r}: function {sub.id!r} must be called, e.g. {sub.id}(x1)")
        elif isinstance(sub, ast.Call):
            if not isinstance(sub.func, ast.Name) or sub.func.id not in FUNCTIONS:
                raise InputError(f"{what} {text!r}: only calls of {sorted(FUNCTIONS)} are allowed")
            if sub.keywords:
                raise InputError(f"{what} {text!r}: keyword arguments are not allowed")
            arity = FUNCTIONS[sub.func.id][1]
            if len(sub.args) != arity:
                raise InputError(
                    f"{what} {text!r}: {sub.func.id}() takes exactly {arity} argument"
                    f"{'s' if arity > 1 else ''}, got {len(sub.args)}"
                )
        elif isinstance(sub, ast.BinOp):
            if type(sub.op) not in BINARY:
                raise InputError(f"{what} {text!r}: operator {type(sub.op).__name__} is not allowed")
        elif isinstance(sub, ast.UnaryOp):
            if type(sub.op) not in UNARY:
                raise InputError(f"{what} {text!r}: operator {type(sub.op).__name__} is not allowed")
        elif not isinstance(sub, ast.operator | ast.unaryop):
            raise InputError(f"{what} {text!r}: {type(sub).__name__} is not allowed")


def _evaluate(node: ast.AST, env: dict[str, Array | float]) -> Array | float:
    if isinstance(node, ast.Expression):
        return _evaluate(node.body, env)
    if isinstance(node, ast.Constant):
        assert isinstance(node.value, int | float)  # guaranteed by _check
        return np.float64(node.value)  # NumPy semantics: 1/0 is inf, (-1)**0.5 is nan, never an exception
    if isinstance(node, ast.Name):
        return env[node.id] if node.id in env else CONSTANTS[node.id]
    if isinstance(node, ast.BinOp):
        return BINARY[type(node.op)](_evaluate(node.left, env), _evaluate(node.right, env))
    if isinstance(node, ast.UnaryOp):
        return UNARY[type(node.op)](_evaluate(node.operand, env))
    if isinstance(node, ast.Call):
        assert isinstance(node.func, ast.Name)
        function, arity = FUNCTIONS[node.func.id]
        args = [_evaluate(a, env) for a in node.args]
        if len(args) != arity:  # unreachable after _check; never let a surplus argument become ``out``
            raise InputError(f"{node.func.id}() takes exactly {arity} argument(s), got {len(args)}")
        return function(*args)
    raise InputError(f"{type(node).__name__} is not allowed")  # unreachable after _check


def _depth(node: ast.AST) -> int:
    """Depth of the tree (iteratively, so a deep tree cannot exhaust the interpreter's stack here)."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        current, level = stack.pop()
        deepest = max(deepest, level)
        stack.extend((child, level + 1) for child in ast.iter_child_nodes(current))
    return deepest
def _parse(text: str, variables: tuple[str, ...], what: str) -> ast.Expression:
    """The checked syntax tree of ``text`` (InputError naming ``what`` otherwise)."""
    if not isinstance(text, str) or not text.strip():
        raise InputError(f"{what} {text!r}: must be a non-empty string")
    if len(text) > MAX_LENGTH:
        raise InputError(f"{what} is longer than {MAX_LENGTH} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as err:
        raise InputError(f"{what} {text!r} does not parse: {err.msg}") from None
    _check(tree, text, variables, what)
    if _depth(tree) > MAX_DEPTH:
        raise InputError(f"{what} {text!r} is nested deeper than {MAX_DEPTH} levels")
    return tree


def parse_point_expression(text: str, what: str = "expression") -> Callable[[Array], Array]:
    """Compile an expression in x1, x2, x3 into a vectorized function of points x (shape (3, m) → (m,)).

    Raises:
        InputError: as :func:`parse_gap_expression`, naming ``what``.
    """
    tree = _parse(text, ("x1", "x2", "x3"), what)

    def value(x: Array) -> Array:
        x = np.asarray(x, dtype=np.float64)
        with np.errstate(all="ignore"):
            out = _evaluate(tree, {"x1": x[0], "x2": x[1], "x3": x[2]})
        return np.broadcast_to(np.asarray(out, dtype=np.float64), x[0].shape).copy()

    value.__name__ = text.strip()
    return value


def parse_gap_expression(text: str) -> Callable[[Array, Array], Array]:
    """Compile a gap expression d(x1, x2) into a vectorized function.

    Args:
        text: e.g. ``"0.01 + 0.005*(sin(2*pi*x1) + cos(2*pi*x2))"``.

    Raises:
        InputError: for text that does not parse or uses anything outside the whitelist.
    """
    tree = _parse(text, VARIABLES, "gap expression")

    def gap(x1: Array, x2: Array) -> Array:
        env: dict[str, Array | float] = {}
        for name, x in (("x1", x1), ("x2", x2)):
            copy = np.array(x, dtype=np.float64)  # a copy, read-only: the caller's arrays are never written
            copy.flags.writeable = False
            env[name] = copy
        with np.errstate(all="ignore"):
            value = _evaluate(tree, env)
        return np.broadcast_to(np.asarray(value, dtype=np.float64), np.shape(x1)).copy()

    gap.__name__ = text.strip()
    return gap
