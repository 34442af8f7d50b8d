"""What a kernel becomes when every Warp function it calls is inlined, as NVVM's inliner does on
CUDA: its size in Python statements and the copies of each function it holds, read from the
call tree of the Python sources (no compile, milliseconds).

A call site of a ``wp.func`` is one copy of its body, and of everything that body calls, in
the function compiled around it; a function marked ``inline=False`` is compiled once on its
own (``compiled``) and a call to it costs a call. Branches under ``if wp.static(flag):`` follow
the flag as Warp's code generation does, and a loop Warp unrolls is a copy of its body per
value of its variable, so a dispatcher's ``wp.static(kinds[i].f)(...)`` call in a loop over
the joint types reaches each type's function. Builtins count as statements.

``python -m affine_joint_sim.bench.device_check inlining`` prints the table of every step
kernel variant; ``test/test_inlining.py`` bounds it.
"""

import ast
import inspect
import textwrap
from collections import Counter
from functools import cache
from typing import NamedTuple

from warp._src.context import Function

__all__ = ['Expansion', 'expand', 'compiled', 'copies_of']

MAX_UNROLL = 16     # Warp's default 'max_unroll': longer constant loops stay loops


class Expansion(NamedTuple):
    """A function or kernel's body with every inlined call expanded."""

    statements: int         # Python statements after inlining
    copies: Counter         # function key → copies of it inside


def _is_function(value) -> bool:
    return isinstance(value, Function) and getattr(value, "func", None) is not None


@cache
def _calls(function) -> tuple[int, tuple]:
    """(statements of ``function``'s own body, ((a Warp function it calls, its copies), ...)
    per call site); ``function`` a Warp Function or Kernel. A loop Warp unrolls (``_unrolled``)
    copies its body, once per value of its variable, so that a dispatcher's call of
    ``wp.static(kinds[i].f)`` reaches each kind's function."""
    source = textwrap.dedent(inspect.getsource(function.func))
    tree = ast.parse(source).body[0]
    names = inspect.getclosurevars(function.func)
    scope = {**names.globals, **names.nonlocals}
    statements, called = 0, []

    def static_value(node, bound):
        """The value of ``wp.static(expr)`` (``node``) with the unrolled loops' variables
        ``bound``, or None where ``node`` is no such call or cannot be evaluated."""
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                and node.func.attr == 'static' and len(node.args) == 1):
            try:
                return eval(compile(ast.Expression(node.args[0]), '<static>', 'eval'),
                            {}, {**scope, **bound})
            except (NameError, AttributeError, IndexError, TypeError):
                return None
        return None

    def visit(node, times, bound):
        nonlocal statements
        if isinstance(node, ast.If) and static_value(node.test, bound) is not None:
            for child in (node.body if static_value(node.test, bound) else node.orelse):
                visit(child, times, bound)
            return
        if isinstance(node, ast.stmt):
            statements += times
        if isinstance(node, ast.For):
            values = _unrolled(node, scope)     # (a loop's variable is no constant to it)
            if values is not None:      # one copy of the body per value
                visit(node.iter, times, bound)
                for value in values:
                    for child in node.body:
                        visit(child, times, {**bound, node.target.id: value})
                return
        if isinstance(node, ast.Call):
            value = (scope.get(node.func.id) if isinstance(node.func, ast.Name)
                     else static_value(node.func, bound))
            if _is_function(value):
                called.append((value, times))
        for child in ast.iter_child_nodes(node):
            visit(child, times, bound)

    for statement in tree.body:
        visit(statement, 1, {})
    return statements, tuple(called)


def _unrolled(loop: ast.For, scope: dict):
    """The values of ``loop``'s variable where Warp's code generation unrolls it (a copy of
    its body each), else None: a ``range`` of constants (names in ``scope`` and ``wp.static``
    expressions included) is unrolled when it runs at most MAX_UNROLL times and has no
    ``break`` of its own, or when it holds a ``wp.static`` expression."""
    iterator = loop.iter
    if not (isinstance(iterator, ast.Call) and isinstance(iterator.func, ast.Name)
            and iterator.func.id == 'range' and isinstance(loop.target, ast.Name)):
        return None
    try:
        values = eval(compile(ast.Expression(iterator), '<range>', 'eval'), {},
                      {**scope, 'range': range})
    except (NameError, TypeError, AttributeError):
        return None
    static = any(isinstance(node, ast.Attribute) and node.attr == 'static'
                 for node in ast.walk(loop))
    if static or (len(values) <= MAX_UNROLL and not _breaks(loop.body)):
        return values
    return None


def _breaks(body: list) -> bool:
    """Whether ``body`` breaks out of its own loop (not of a loop nested in it)."""
    return any(isinstance(statement, ast.Break)
               or (isinstance(statement, ast.If)
                   and (_breaks(statement.body) or _breaks(statement.orelse)))
               for statement in body)


def _out_of_line(function, chosen: frozenset) -> bool:
    """Whether ``function`` is compiled on its own: marked ``inline=False``, or in ``chosen``
    (keys: what marking them would give)."""
    return function.inline_hint == 'noinline' or function.key in chosen


@cache
def expand(function, chosen: frozenset = frozenset()) -> Expansion:
    """``function``'s body with its inlined calls expanded (a call to a function compiled on
    its own (``_out_of_line``) stays a call: one statement of the caller, its body not
    copied)."""
    statements, called = _calls(function)
    copies = Counter()
    for callee, times in called:
        copies[callee.key] += times
        if _out_of_line(callee, chosen):
            continue
        inner = expand(callee, chosen)
        statements += times * inner.statements
        copies.update({key: times * n for key, n in inner.copies.items()})
    return Expansion(statements, copies)


def compiled(kernel, chosen: frozenset = frozenset()) -> dict:
    """Each function compiled on its own for ``kernel`` (the kernel itself, then every function
    out of line (``_out_of_line``) it reaches), key → its Expansion."""
    out, todo = {}, [kernel]
    while todo:
        function = todo.pop()
        if function.key in out:
            continue
        out[function.key] = expand(function, chosen)
        todo += [callee for callee in _reached(function, chosen)
                 if _out_of_line(callee, chosen)]
    return out


def _reached(function, chosen: frozenset = frozenset()) -> set:
    """The Warp functions ``function``'s compiled body calls: through inlined calls, down to
    and including those out of line."""
    reached = set()
    for callee, _ in _calls(function)[1]:
        reached.add(callee)
        if not _out_of_line(callee, chosen):
            reached |= _reached(callee, chosen)
    return reached


def copies_of(expansion: Expansion, name: str) -> int:
    """Copies of the Warp function called ``name`` (its Python name) in ``expansion``."""
    return sum(n for key, n in expansion.copies.items() if key.rsplit('__', 1)[-1] == name)
