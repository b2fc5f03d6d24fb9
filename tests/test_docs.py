"""The documentation says what the code does now, and the README stays a front door.

* the README is at most `README_MAX_LINES` lines;
* the README and every page of docs/ but the journal and the performance page (where the
  measurement history and the current figures live) carry no history: none of `HISTORY`;
* the code's comments and docstrings (app/, web/, vision/, robot/, throwing/, wiithrow/) carry no
  issue numbers, dates or stop markers either (`HISTORY` too): what a change was for belongs in its
  commit message and the journal;
* every constant a page reads from the code (`{{ module.NAME }}`, docs/hooks.py) exists and is a
  literal the hook can read, so that renaming one fails here before the site's build.

The site's strict build (`make docs`, part of `make test`) checks its links, anchors and API
references; this module checks what a build cannot.
"""

from __future__ import annotations

import ast
import importlib.util
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
README_MAX_LINES = 200
#: The pages allowed to hold measurement history and dated figures.
HISTORY_PAGES = ("journal.md", "performance.md")
CODE_FOLDERS = ("app", "web", "vision", "robot", "throwing")
#: What marks a sentence as history rather than a statement of what the code does now.
HISTORY = re.compile(
    "|".join(
        (
            r"\bissues? #?\d+",  # "issue 23", "issues 21"
            r"\(issue\b",  # "(issue 23: ...)"
            r"\b20\d\d-\d\d-\d\d\b",  # a dated figure
            r"\b[Aa] stop (?:later|before|after)\b",  # the project's working sessions ("a stop later")
            r"\b(?:[Tt]he|[Tt]his|[Ll]ast) stop\b(?! (?:the|it|a|an)\b)",  # "this stop's", "the stop before" (not "the stop it")
            r"\bstop \d+\b",  # "stop 31"
            r"\b[Bb]efore this (?:stop|work|change|version)\b",
            r"\b[Tt]he version before\b",
            r"\b[Tt]his branch\b",
            r"\bmain's\b",
            r"\b[Mm]easured again\b",
        )
    )
)


def history_lines(text: str) -> list[str]:
    return [f"{n}: {line.strip()}" for n, line in enumerate(text.splitlines(), 1) if HISTORY.search(line)]


def test_the_readme_is_a_front_door():
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= README_MAX_LINES, (
        f"README.md has {len(lines)} lines (at most {README_MAX_LINES}): move the rest to docs/"
    )


def test_the_readme_carries_no_history():
    found = history_lines((ROOT / "README.md").read_text())
    assert not found, "README.md carries history (docs/journal.md is its place):\n" + "\n".join(found)


def pages() -> list[Path]:
    return sorted(p for p in DOCS.rglob("*.md") if p.relative_to(DOCS).as_posix() not in HISTORY_PAGES)


@pytest.mark.parametrize("page", pages(), ids=lambda p: p.relative_to(DOCS).as_posix())
def test_a_page_but_the_journal_and_performance_carries_no_history(page):
    found = history_lines(page.read_text())
    assert not found, f"docs/{page.relative_to(DOCS)} carries history (docs/journal.md is its place):\n" + "\n".join(
        found
    )


def code_files() -> list[Path]:
    """The code's modules, each once (wiithrow/'s own; its links lead to the folders)."""
    return sorted(
        [*(p for folder in CODE_FOLDERS for p in (ROOT / folder).rglob("*.py")), *(ROOT / "wiithrow").glob("*.py")]
    )


def comments_and_docstrings(path: Path) -> list[tuple[int, str]]:
    """(line, text) of every comment and every docstring of a module, its classes and functions."""
    source = path.read_text()
    found = [
        (token.start[0], token.string)
        for token in tokenize.generate_tokens(io.StringIO(source).readline)
        if token.type == tokenize.COMMENT
    ]
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            doc = ast.get_docstring(node, clean=False)
            if doc is not None:
                first = node.body[0].lineno
                found.extend((first + k, line) for k, line in enumerate(doc.splitlines()))
    return found


def test_the_code_s_comments_and_docstrings_carry_no_history():
    found = [
        f"{path.relative_to(ROOT)}:{line}: {text.strip()}"
        for path in code_files()
        for line, text in comments_and_docstrings(path)
        if HISTORY.search(text)
    ]
    assert not found, "comments and docstrings say what the code does now (history: docs/journal.md):\n" + "\n".join(
        found
    )


def load_hooks():
    spec = importlib.util.spec_from_file_location("docs_hooks", DOCS / "hooks.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_constant_a_page_reads_from_the_code_exists():
    hooks = load_hooks()
    read = 0
    for page in sorted(DOCS.rglob("*.md")):
        for match in hooks.PLACEHOLDER.finditer(page.read_text()):
            body = match.group(1)
            if body.split()[0] in ("cli", "example", "include"):
                continue
            hooks.formatted(hooks.evaluate(body))  # raises DocsPlaceholderError, naming what is wrong
            read += 1
    assert read >= 10, f"only {read} figures are read from the code: the pages type the rest twice?"


def test_the_hook_reads_the_figures_the_code_defines():
    """The figures the README once typed and got wrong are the code's."""
    from wiithrow.app.calibration.robot import DEFAULT_POSES
    from wiithrow.app.throws.release_timing import RELEASE_LATE_BOUND_S

    hooks = load_hooks()
    assert hooks.fill("{{ wiithrow.app.calibration.robot.DEFAULT_POSES }} poses") == f"{DEFAULT_POSES} poses"
    assert hooks.fill("{{ wiithrow.app.throws.release_timing.RELEASE_LATE_BOUND_S * 1000 }} ms") == (
        f"{RELEASE_LATE_BOUND_S * 1000:g} ms"
    )
    with pytest.raises(hooks.DocsPlaceholderError, match="defines no NO_SUCH"):
        hooks.fill("{{ wiithrow.app.calibration.robot.NO_SUCH }}")
    with pytest.raises(hooks.DocsPlaceholderError, match="no module"):
        hooks.fill("{{ wiithrow.app.nowhere.X }}")
