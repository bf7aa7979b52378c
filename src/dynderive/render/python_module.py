"""The checks every generated Python module passes before anyone can write or import it
(the NumPy and JAX modules of every robot, and the generated pytest files)."""

from __future__ import annotations

import ast
from pathlib import Path
from typing import Any

from ..derivation import Derivation
from .environment import render, template_fault


class CodeGenerationError(ValueError):
    """The generated module would not be what the engine meant (an internal error, unless a
    user's template made it: then ``template_fault`` turns it into bad input).
    ``line``: the line of the generated module at fault, when known."""

    def __init__(self, message: str, line: int | None = None):
        super().__init__(message)
        self.line = line


def render_module(derivation: Derivation, template: str, context: dict[str, Any],
                  template_dir: str | Path | None = None, imports: frozenset[str] | None = None) -> str:
    """A generated Python module's text (the NumPy and JAX modules), checked by
    ``verify_module`` before anyone can write or import it; the docstring must read back the
    robot's title with the built-in templates. A user's template at fault is bad input (exit 2)."""
    text = render("code", template, context, template_dir)
    try:
        verify_module(text, derivation.robot.title if template_dir is None else None, imports or _IMPORTS)
    except CodeGenerationError as exc:
        raise template_fault(exc, exc.line, text, template, template_dir) or exc from None
    return text


#: What the top level of a generated module may hold: its docstring, imports of these
#: modules, constants and functions. Anything else (a call, an ``if``) is not ours.
_TOP_LEVEL = (ast.Import, ast.ImportFrom, ast.Assign, ast.AnnAssign, ast.FunctionDef)
_IMPORTS = {"math", "numpy", "pytest", "__future__"}


def verify_module(text: str, title: str | None = None, imports: frozenset[str] | set[str] = _IMPORTS) -> None:
    """Parse the rendered module and check that it is only what the generator meant: no
    statement at the top level but imports, constants and functions, and (built-in template)
    a docstring that reads back the robot's title exactly, so no free text changed the program.

    Raises ``CodeGenerationError`` (an internal error, exit 1) before anything is written.
    """
    try:
        tree = ast.parse(text)
    except (SyntaxError, ValueError) as exc:
        line = exc.lineno if isinstance(exc, SyntaxError) else None
        raise CodeGenerationError(f"the generated module does not parse: {getattr(exc, 'msg', exc)}", line) from None
    body = tree.body[1:] if ast.get_docstring(tree, clean=False) is not None else tree.body
    for node in body:
        if not isinstance(node, _TOP_LEVEL):
            raise CodeGenerationError(f"unexpected {type(node).__name__} at line {node.lineno} of the generated module",
                                      node.lineno)
        if isinstance(node, ast.Import | ast.ImportFrom):
            names = [node.module or ""] if isinstance(node, ast.ImportFrom) else [a.name for a in node.names]
            if any(n.split(".")[0] not in imports for n in names):
                raise CodeGenerationError(f"unexpected import at line {node.lineno} of the generated module", node.lineno)
    if title is not None and title not in (ast.get_docstring(tree, clean=False) or ""):
        raise CodeGenerationError("the generated module's docstring does not read back the robot's title")


def render_test_module(derivation: Derivation, template: str, template_dir: str | Path | None = None,
                       **context: Any) -> str:
    """A generated pytest file (the NumPy module's checks), parsed before it is returned;
    ``context`` adds to its module name, generator and source."""
    from .._version import __version__

    context |= {"module": f"{derivation.robot.name}_dynamics", "generator": f"dynderive {__version__}",
                "source": Path(derivation.robot.source).name}
    text = render("code", template, context, template_dir)
    try:
        ast.parse(text)
    except (SyntaxError, ValueError) as exc:
        error = CodeGenerationError(f"the generated test module does not parse: {getattr(exc, 'msg', exc)}",
                                    exc.lineno if isinstance(exc, SyntaxError) else None)
        raise template_fault(error, error.line, text, template, template_dir) or error from None
    return text
