"""Whitelisted arithmetic expressions in x, for a scene's initial data.

A scene is data: its expressions are parsed with :mod:`ast` into a tree that holds numbers, ``x``,
parameter names, ``+ - * / **``, parentheses, the functions sin cos tan exp log sqrt abs and the
constant pi, and nothing else. The tree is made once into nested Python functions that evaluate it
with NumPy, its transcendental functions and powers by the C library's (:func:`_libm`: the same
bits on every machine); the parts in x of a source evaluated at every step are kept while the
parameters they read stay put. Nothing a user wrote is ever passed to ``eval`` or ``exec``.
"""

from __future__ import annotations

import ast
import difflib
import math
from collections.abc import Callable, Mapping

import numpy as np

def _libm(function: Callable[..., float], numpy_function) -> Callable[..., np.ndarray]:
    """``function`` of :mod:`math` (the C library's) on every element of its arguments, which
    broadcast as NumPy's do. NumPy's own transcendental functions are not one arithmetic: on a
    processor with AVX-512 they are SVML's, rounded otherwise than the C library's (an ulp here
    and there, which an ill-conditioned run carries to 1e-13 of its history), so a scene's data
    would depend on the machine. Where ``function`` raises (a pole, a domain or an overflow),
    the element is ``numpy_function``'s (nan or ±inf, the same on every machine)."""

    def element(*args: float) -> float:
        try:
            return function(*args)
        except (ValueError, OverflowError, ZeroDivisionError):
            return float(numpy_function(*(np.float64(a) for a in args)))

    def apply(*arrays):
        if not any(isinstance(a, np.ndarray) for a in arrays):  # scalars: the same call, bare
            return np.float64(element(*(float(a) for a in arrays)))
        shaped = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in arrays))
        columns = [a.ravel().tolist() for a in shaped]
        out = np.fromiter(map(element, *columns), np.float64, shaped[0].size)
        return out.reshape(shaped[0].shape) if shaped[0].ndim else np.float64(out[0])

    return apply


FUNCTIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "sin": _libm(math.sin, np.sin),
    "cos": _libm(math.cos, np.cos),
    "tan": _libm(math.tan, np.tan),
    "exp": _libm(math.exp, np.exp),
    "log": _libm(math.log, np.log),
    "sqrt": np.sqrt,  # correctly rounded (IEEE 754) on every machine, as are + - * /
    "abs": np.abs,
}
CONSTANTS = {"pi": np.pi}
MAX_LENGTH = 1000
MAX_DEPTH = 64  # nesting of operations; deeper trees are refused, not recursed into

_BINARY = {
    ast.Add: np.add,
    ast.Sub: np.subtract,
    ast.Mult: np.multiply,
    ast.Div: np.divide,
    ast.Pow: _libm(math.pow, np.power),
}
_UNARY = {ast.USub: np.negative, ast.UAdd: np.positive}


class ExpressionError(ValueError):
    """An expression that is not in the whitelisted grammar."""


def shorten(text: str, width: int = 60) -> str:
    """Text as it is quoted in a one-line error message."""
    return text if len(text) <= width else text[: width - 1] + "…"


def _nearest(name: str, allowed) -> str:
    close = difflib.get_close_matches(name, list(allowed), n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


class Expression:
    """A parsed expression f(x; parameters), evaluated on NumPy arrays.

    Args:
        text: the expression, e.g. ``"theta_A*(cos(2*pi*x) - sin(pi*x/2))"``.
        names: the parameter names it may use besides ``x`` and ``pi``.
    """

    def __init__(self, text: str, names):
        if not isinstance(text, str):
            raise ExpressionError("must be a string expression in x")
        if len(text) > MAX_LENGTH:
            raise ExpressionError(f"is longer than {MAX_LENGTH} characters")
        if "#" in text:
            raise ExpressionError("contains '#'; expressions have no comments")
        self.text = text
        self.names = frozenset(names)
        try:
            tree = ast.parse(text.strip(), mode="eval")
        except SyntaxError as err:
            raise ExpressionError(f"is not a valid expression ({err.msg})") from None
        except (RecursionError, MemoryError, ValueError):
            raise ExpressionError("is not a valid expression (nested too deeply)") from None
        self._check(tree.body, 0)
        self._tree = tree.body
        self._x: np.ndarray | None = None
        self._kept: dict[ast.AST, tuple[tuple, np.ndarray]] = {}
        self._evaluate = None

    def __getstate__(self):  # the evaluator and the kept values are this process's
        return {**self.__dict__, "_x": None, "_kept": {}, "_evaluate": None}

    def _compiled(self, node: ast.AST):
        """(``node``'s evaluator: a function of the names' values, the names it reads). A
        subtree in x keeps its value and is evaluated again only when a parameter it reads
        changes: a source's parts in x alone are evaluated once a run, by the same arithmetic."""
        if isinstance(node, ast.Constant):
            value = np.float64(float(node.value))
            return (lambda values: value), frozenset()
        if isinstance(node, ast.Name):
            name = node.id
            return (lambda values: values[name]), frozenset([name])
        if isinstance(node, ast.BinOp):
            (left, a), (right, b) = self._compiled(node.left), self._compiled(node.right)
            op = _BINARY[type(node.op)]
            evaluate, used = (lambda values: op(left(values), right(values))), a | b
        elif isinstance(node, ast.UnaryOp):
            (operand, used), op = self._compiled(node.operand), _UNARY[type(node.op)]
            evaluate = lambda values: op(operand(values))  # noqa: E731
        else:
            (argument, used), function = self._compiled(node.args[0]), FUNCTIONS[node.func.id]
            evaluate = lambda values: function(argument(values))  # noqa: E731
        if "x" not in used:
            return evaluate, used
        names, kept = tuple(sorted(used - {"x", *CONSTANTS})), self._kept

        def again(values):
            key = tuple(values[name] for name in names)
            last = kept.get(node)
            if last is None or last[0] != key:
                last = kept[node] = (key, evaluate(values))
            return last[1]

        return again, used

    def _check(self, node: ast.AST, depth: int) -> None:
        allowed = sorted({"x", *CONSTANTS, *self.names})
        if depth > MAX_DEPTH:
            raise ExpressionError(f"is nested more than {MAX_DEPTH} deep")
        depth += 1
        if isinstance(node, ast.Constant):
            if type(node.value) not in (int, float):
                raise ExpressionError(f"has a literal {node.value!r}; only numbers are allowed")
            try:
                float(node.value)
            except OverflowError:
                number = shorten(str(node.value), 20)
                raise ExpressionError(f"has a number too large for a float ({number})") from None
        elif isinstance(node, ast.Name):
            if node.id not in allowed:
                raise ExpressionError(
                    f"uses unknown name '{node.id}'{_nearest(node.id, allowed)}; "
                    f"allowed names: {', '.join(allowed)}"
                )
        elif isinstance(node, ast.BinOp):
            if type(node.op) not in _BINARY:
                raise ExpressionError("uses an operator other than + - * / **")
            self._check(node.left, depth)
            self._check(node.right, depth)
        elif isinstance(node, ast.UnaryOp):
            if type(node.op) not in _UNARY:
                raise ExpressionError("uses a unary operator other than + and -")
            self._check(node.operand, depth)
        elif isinstance(node, ast.Call):
            name = node.func.id if isinstance(node.func, ast.Name) else None
            if name not in FUNCTIONS:
                shown = name if name else ast.unparse(node.func)
                raise ExpressionError(
                    f"calls '{shown}'{_nearest(shown, FUNCTIONS)}; "
                    f"allowed functions: {', '.join(FUNCTIONS)}"
                )
            if len(node.args) != 1 or node.keywords:
                raise ExpressionError(f"calls {name} with other than one argument")
            self._check(node.args[0], depth)
        else:
            raise ExpressionError(
                f"contains '{shorten(ast.unparse(node), 30)}'; allowed: numbers, x, parameter "
                "names, + - * / **, parentheses, sin cos tan exp log sqrt abs, pi"
            )

    def __call__(self, x: np.ndarray, parameters: Mapping[str, float]) -> np.ndarray:
        """Evaluate at the points x (a 1D array) with the given parameter values."""
        x = np.asarray(x, dtype=np.float64)
        if self._evaluate is None:
            self._evaluate = self._compiled(self._tree)[0]
        if self._x is None or not np.array_equal(self._x, x):
            self._x = x.copy()
            self._kept.clear()
        values = {"x": x, **CONSTANTS, **{k: np.float64(v) for k, v in parameters.items()}}
        with np.errstate(all="ignore"):
            result = self._evaluate(values)
        return np.broadcast_to(np.asarray(result, dtype=np.float64), x.shape).copy()
