"""The documentation site's build hook (mkdocs.yml, `hooks:`): what a page says that the code defines
is read from the code when the site is built, never typed twice.

A page writes, anywhere in its Markdown (code blocks included):

* `{{ wiithrow.app.calibration.robot.DEFAULT_POSES }}`: a constant, read from the module's source
  (a literal assignment at its top level: nothing is imported, so the site builds fast and a
  constant of `tests.conftest` costs no browser); arithmetic over constants and numbers is allowed,
  `{{ 1000 / tests.conftest.FRAME_PERIOD_MS }}`, `{{ wiithrow.app.throws.release_timing.RELEASE_LATE_BOUND_S * 1000 }}`;
* `{{ cli demo }}`: `wiithrow demo --help` as the installed parser prints it (`build_parser`), in
  a fenced block: the command-line reference is the parsers' own text;
* `{{ example 01 }}`: the numbered example `examples/01_*.py`'s source, in a fenced block;
* `{{ include CHANGELOG.md }}`: a file of the repository's root, from its `<!-- body -->` line
  on (its own title left out), its links into `docs/` made the site's.

A placeholder that names nothing, or a constant that is not a number, a string or a tuple of them,
fails the build (`mkdocs build --strict` turns the logged error into a failure; the hook raises
besides, so a plain build fails too).
"""

from __future__ import annotations

import ast
import operator
import os
import re
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
#: `{{ ... }}`, not across lines.
PLACEHOLDER = re.compile(r"\{\{\s*([^{}\n]+?)\s*\}\}")
#: The width `cli` renders `--help` at (argparse reads COLUMNS): what the site's code blocks show unscrolled.
HELP_COLUMNS = 80
#: The folders a dotted `wiithrow.X...` name lives in: the repository's own (`wiithrow/` links them).
PACKAGE_ROOTS = {"wiithrow": ROOT, "tests": ROOT / "tests"}
_OPERATORS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv}


class DocsPlaceholderError(ValueError):
    """A placeholder the hook cannot fill: the page and what is wrong."""


def module_file(dotted: str) -> Path:
    """The source file of a module named `wiithrow.a.b` (or `tests.x`), without importing it."""
    head, *rest = dotted.split(".")
    if head not in PACKAGE_ROOTS:
        raise DocsPlaceholderError(f"{dotted}: only wiithrow.* and tests.* modules are read")
    base = PACKAGE_ROOTS[head].joinpath(*rest)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    raise DocsPlaceholderError(f"no module {dotted} ({base.relative_to(ROOT)}.py)")


def constant(dotted: str) -> Any:
    """The value of a module-level constant `module.NAME`, from the module's source (literal only)."""
    module, _, name = dotted.rpartition(".")
    tree = ast.parse(module_file(module).read_text())
    for node in tree.body:
        targets = (
            node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
        )
        value = node.value if isinstance(node, ast.Assign | ast.AnnAssign) else None
        if value is not None and any(isinstance(t, ast.Name) and t.id == name for t in targets):
            try:
                return ast.literal_eval(value)
            except ValueError:
                raise DocsPlaceholderError(
                    f"{dotted} is not a literal: write its value where the docs can read it"
                ) from None
    raise DocsPlaceholderError(f"{module} defines no {name}")


def evaluate(expression: str) -> Any:
    """A constant, or + - * / over constants and numbers."""

    def walk(node: ast.AST) -> Any:
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, int | float):
            return node.value
        if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](walk(node.left), walk(node.right))
        if isinstance(node, ast.Attribute | ast.Name):
            return constant(ast.unparse(node))
        raise DocsPlaceholderError(f"{{{{ {expression} }}}}: only constants, numbers and + - * /")

    try:
        return walk(ast.parse(expression, mode="eval"))
    except SyntaxError:
        raise DocsPlaceholderError(
            f"{{{{ {expression} }}}} is neither a constant nor `cli NAME` nor `example NN`"
        ) from None


def formatted(value: Any) -> str:
    """A number as a person writes it (60, 0.01, 1.5); a string as is; a tuple as (a, b)."""
    if isinstance(value, bool):
        raise DocsPlaceholderError(f"{value!r}: a flag is not a figure")
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() else f"{value:.6g}"
    if isinstance(value, int | str):
        return str(value)
    if isinstance(value, tuple):
        return "(" + ", ".join(formatted(v) for v in value) + ")"
    raise DocsPlaceholderError(f"{value!r}: not a number, a string or a tuple of them")


def command_help(name: str) -> str:
    """`wiithrow NAME --help`, as the command line prints it, in a fenced block."""
    import argparse

    from wiithrow.app.cli.main import COMMAND_MODULES, build_parser

    if name not in COMMAND_MODULES:
        raise DocsPlaceholderError(f"no command {name!r} (wiithrow.app.cli.main.COMMAND_MODULES)")
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(HELP_COLUMNS)
    try:
        parser = build_parser(name)
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        text = sub.choices[name].format_help()
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old
    return f"```text\n{text.rstrip()}\n```"


def example_source(number: str) -> str:
    """The numbered example's source, in a fenced block."""
    found = sorted((ROOT / "examples").glob(f"{number}_*.py"))
    if len(found) != 1:
        raise DocsPlaceholderError(f"example {number}: {len(found)} files examples/{number}_*.py")
    return f'```python title="examples/{found[0].name}"\n{found[0].read_text().rstrip()}\n```'


#: Where an included file's body starts (the line after it).
BODY_MARK = "<!-- body -->"


def included(name: str) -> str:
    """A root file's body (module docstring), its `](docs/...)` links relative to the site's root page."""
    path = ROOT / name
    if path.parent != ROOT or not path.is_file():
        raise DocsPlaceholderError(f"include {name}: not a file of the repository's root")
    text = path.read_text()
    if BODY_MARK not in text:
        return f"```text\n{text.rstrip()}\n```"
    return text.split(BODY_MARK, 1)[1].strip().replace("](docs/", "](")


def fill(markdown: str) -> str:
    """Every placeholder of a page, filled (module docstring)."""

    def one(match: re.Match[str]) -> str:
        body = match.group(1)
        if body.startswith("cli "):
            return command_help(body.removeprefix("cli ").strip())
        if body.startswith("example "):
            return example_source(body.removeprefix("example ").strip())
        if body.startswith("include "):
            return included(body.removeprefix("include ").strip())
        return formatted(evaluate(body))

    return PLACEHOLDER.sub(one, markdown)


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    """MkDocs' hook: fill the page's placeholders; one that cannot be filled names its page and fails the build."""
    try:
        return fill(markdown)
    except DocsPlaceholderError as exc:
        raise DocsPlaceholderError(f"{page.file.src_uri}: {exc}") from None
