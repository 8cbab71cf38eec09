"""Shape limits of the backend's sources: a function reads in one screen, a module holds one concept.

The Python side of the limits eslint's `max-lines-per-function` and `max-lines` hold for the TypeScript
sources. A function counts every line from its `def` to its last line (its decorators excluded); a module
counts the lines that hold code, as eslint does with `skipBlankLines` and `skipComments`: blank lines,
`#` comments and docstrings (Python's doc comments) are not counted.
"""

from __future__ import annotations

import ast
import io
import tokenize
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

MAX_FUNCTION_LINES = 80
MAX_MODULE_LINES = 400

_NOT_CODE = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT,
             tokenize.ENDMARKER}
_DOCUMENTED = (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)


def _modules() -> list[Path]:
    return sorted(SRC.rglob("*.py"))


def _docstring_lines(tree: ast.Module) -> set[int]:
    """The lines of every module, class and function docstring."""
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, _DOCUMENTED) and node.body:
            first = node.body[0]
            if (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
                    and isinstance(first.value.value, str) and first.end_lineno is not None):
                lines.update(range(first.lineno, first.end_lineno + 1))
    return lines


def code_lines(text: str) -> int:
    """How many lines of `text` hold code: blank lines, comments and docstrings excluded."""
    code: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type not in _NOT_CODE:
            code.update(range(tok.start[0], tok.end[0] + 1))
    return len(code - _docstring_lines(ast.parse(text)))


def long_functions(text: str, where: str) -> list[str]:
    """Each function of `text` longer than the limit, as `where:line name (lines)`."""
    found = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.end_lineno is not None:
            length = node.end_lineno - node.lineno + 1
            if length > MAX_FUNCTION_LINES:
                found.append(f"{where}:{node.lineno} {node.name} ({length} lines)")
    return found


def test_no_function_is_longer_than_the_limit() -> None:
    """Every function of the backend's sources fits in the limit; the failure names each one that does not."""
    found = [f for p in _modules() for f in long_functions(p.read_text(), str(p.relative_to(SRC)))]
    assert not found, f"functions over {MAX_FUNCTION_LINES} lines, cut into named steps:\n" + "\n".join(found)


def test_no_module_is_longer_than_the_limit() -> None:
    """Every module of the backend's sources fits in the limit; the failure names each one that does not."""
    found = [f"{p.relative_to(SRC)} ({n} lines of code)" for p in _modules()
             if (n := code_lines(p.read_text())) > MAX_MODULE_LINES]
    assert not found, f"modules over {MAX_MODULE_LINES} lines of code, cut by concept:\n" + "\n".join(found)


def test_the_checks_count_what_they_claim() -> None:
    """A long function is named with its length, decorators aside; docstrings and comments are not code."""
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    text = (f'"""Doc.\n\nMore."""\n\n# note\n@decorator\ndef long():\n{body}\n\n\n'
            'def short():\n    """Doc."""\n')
    assert long_functions(text, "m.py") == [f"m.py:7 long ({MAX_FUNCTION_LINES + 1} lines)"]
    assert code_lines(text) == 1 + 1 + MAX_FUNCTION_LINES + 1
