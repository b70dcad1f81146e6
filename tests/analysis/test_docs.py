"""The README and the pages under docs/: the README stays a short front door whose first
commands are the two a new user and CI run, every relative link and image resolves to a file,
every #anchor to a heading of its target (GitHub's slug rule), no page points at documents
a user does not have, and the pages run the installed `kinolab` from the PATH."""

import os
import re
from pathlib import Path
from urllib.parse import unquote

import pytest

SOURCE_DIR = Path(os.environ.get("KINOLAB_SOURCE_DIR", Path(__file__).resolve().parents[2]))
README = SOURCE_DIR / "README.md"
MAX_README_LINES = 260

# The pages that run the build tree's kinolab on purpose, and why; every other page runs the
# installed `kinolab` from the PATH.
BUILD_TREE_COMMAND = {
    "docs/README.md": "what to run when kinolab is built but not installed",
    "docs/adding_a_planner.md": "a new plugin is in the build tree's kinolab before an install",
}

FENCE = re.compile(r"^ {0,3}(`{3,}|~{3,})")
HEADING = re.compile(r"^ {0,3}(#{1,6})[ \t]+(.*?)(?:[ \t]+#+)?[ \t]*$")
# A code span may run over a line break but not over a blank line.
CODE_SPAN = re.compile(r"(`+)((?:(?!\n[ \t]*\n).)+?)(?<!`)\1(?!`)", re.S)
LINK = re.compile(r"!?\[((?:[^\[\]]|\[[^\[\]]*\])*)\]\(\s*<?([^)\s>]*)>?(?:\s+\"[^\"]*\")?\s*\)")
EXTERNAL = re.compile(r"^(?:[a-z][a-z0-9+.-]*:|//)", re.I)


def markdown_files():
    return [README] + sorted((SOURCE_DIR / "docs").rglob("*.md"))


def prose_lines(text: str):
    """The lines of `text` with fenced code blocks blanked (line numbers kept)."""
    lines = text.split("\n")
    fence = None
    out = []
    for line in lines:
        match = FENCE.match(line)
        if fence is None and match:
            fence = match.group(1)
            out.append("")
        elif fence is not None:
            if match and match.group(1)[0] == fence[0] and len(match.group(1)) >= len(fence) \
                    and line.strip() == match.group(1):
                fence = None
            out.append("")
        else:
            out.append(line)
    return out


def prose(text: str) -> str:
    """`text` without fenced code blocks and with code spans replaced by a placeholder."""
    return CODE_SPAN.sub(lambda m: "code" + "\n" * m.group(0).count("\n"),
                         "\n".join(prose_lines(text)))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading's text."""
    text = re.sub(r"!?\[((?:[^\[\]]|\[[^\[\]]*\])*)\]\([^)]*\)", r"\1", heading)  # links: text
    text = re.sub(r"<[^>]+>", "", text)                                             # inline HTML
    text = text.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set:
    found = set()
    counts = {}
    for line in prose_lines(path.read_text(encoding="utf-8")):
        match = HEADING.match(line)
        if not match:
            continue
        base = slug(match.group(2))
        n = counts.get(base, 0)
        counts[base] = n + 1
        found.add(base if n == 0 else f"{base}-{n}")
    return found


def links(path: Path):
    """(line number, target) of every link and image outside code."""
    text = prose(path.read_text(encoding="utf-8"))
    for match in LINK.finditer(text):
        yield text.count("\n", 0, match.start()) + 1, match.group(2)


def test_readme_is_short():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= MAX_README_LINES, f"README.md has {len(lines)} lines"


def test_readme_first_commands():
    text = README.read_text(encoding="utf-8")
    block = re.search(r"^```sh[ \t]*\n(.*?)^```[ \t]*$", text, re.S | re.M)
    assert block, "README.md has no sh code block"
    commands = [line.split("#", 1)[0].strip() for line in block.group(1).splitlines()]
    assert [c for c in commands if c] == ["bash scripts/demo.sh", "bash scripts/test.sh"]


def test_slug_rule():
    assert slug("Ecosystem: Python, the 3D viewer and Planner Arena") == \
        "ecosystem-python-the-3d-viewer-and-planner-arena"
    assert slug("The paper's Table II at its scale") == "the-papers-table-ii-at-its-scale"
    assert slug("The `kinolab` command") == "the-kinolab-command"
    assert slug("Hybrid A\\*: `hybrid_astar`") == "hybrid-a-hybrid_astar"
    assert slug("See [the docs](docs/README.md)") == "see-the-docs"


def test_helpers_skip_code():
    text = "a [x](one.md)\n```sh\n[y](two.md)\n```\n`[z](three.md)` and\n![i](img.png#a)\n"
    lines = prose(text)
    targets = [m.group(2) for m in LINK.finditer(lines)]
    assert targets == ["one.md", "img.png#a"]


@pytest.mark.parametrize("path", markdown_files(), ids=lambda p: str(p.relative_to(SOURCE_DIR)))
def test_links_resolve(path: Path):
    problems = []
    for line, target in links(path):
        if not target or EXTERNAL.match(target):
            continue
        file_part, _, anchor = target.partition("#")
        destination = (path.parent / unquote(file_part)).resolve() if file_part else path
        where = f"{path.relative_to(SOURCE_DIR)}:{line}: {target}"
        if not destination.exists():
            problems.append(f"{where}: no such file")
            continue
        if anchor:
            if destination.is_dir() or destination.suffix.lower() != ".md":
                problems.append(f"{where}: an anchor into a file that is not Markdown")
            elif unquote(anchor).lower() not in anchors(destination):
                problems.append(f"{where}: no heading with anchor #{anchor}")
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("path", markdown_files(), ids=lambda p: str(p.relative_to(SOURCE_DIR)))
def test_no_private_documents(path: Path):
    text = path.read_text(encoding="utf-8")
    mentioned = [name for name in ("DESIGN.md", "STYLE.md") if name in text]
    assert not mentioned, f"{path.relative_to(SOURCE_DIR)} mentions {', '.join(mentioned)}"


@pytest.mark.parametrize("path", markdown_files(), ids=lambda p: str(p.relative_to(SOURCE_DIR)))
def test_commands_run_kinolab_from_the_path(path: Path):
    name = str(path.relative_to(SOURCE_DIR))
    text = path.read_text(encoding="utf-8")
    lines = [number for number, line in enumerate(text.split("\n"), 1)
             if "build/framework/kinolab" in line]
    assert not lines or name in BUILD_TREE_COMMAND, \
        f"{name}:{lines[0]}: runs build/framework/kinolab; use `kinolab` from the PATH"
