"""The documents: a README that starts with the animator, and docs/ pages that hold the rest.

Checks README.md and every docs/**/*.md: the README is short and names the two commands; no
document shows a path of one machine; every relative link (and #anchor) leads to a file (and
heading) in the tree; no paragraph is written twice; docs/design.md names every file of the add-on
and of the native library. Plain text checks: no quatcurve module or Blender needed.
"""

import re
import unicodedata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
DESIGN = DOCS / "design.md"

README_MAX_LINES = 300
# Absolute paths of one machine's checkouts and home folders (a document shows paths relative to
# the repository, `~/...`, or placeholders such as OUT/).
MACHINE_PATH = re.compile(r"(?<![\w.~])/(?:work|root|home)/")
# [text](target) and ![alt](target); the target ends at whitespace or the closing parenthesis.
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^\s*(```|~~~)")
# Paragraphs shorter than this may repeat (a heading, "From a script:", a short command).
PARAGRAPH_MIN_CHARS = 80


def documents():
    return [README] + sorted(DOCS.rglob("*.md"))


def rel(path):
    return path.relative_to(ROOT).as_posix()


def prose_lines(text):
    """The lines outside fenced code blocks, with their 1-based numbers."""
    inside = False
    for number, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            inside = not inside
            continue
        if not inside:
            yield number, line


def strip_code_spans(line):
    return re.sub(r"`[^`]*`", "", line)


def links(path):
    """(line number, target) of every Markdown link in the prose of `path`."""
    for number, line in prose_lines(path.read_text(encoding="utf-8")):
        for match in LINK.finditer(strip_code_spans(line)):
            yield number, match.group(1)


def slug(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"`([^`]*)`", r"\1", heading.strip()).lower()
    text = "".join(c for c in text if c in " -_" or unicodedata.category(c)[0] in "LN")
    return text.replace(" ", "-")


def anchors(path):
    found, seen = set(), {}
    for _, line in prose_lines(path.read_text(encoding="utf-8")):
        match = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if match:
            base = slug(match.group(1))
            count = seen.get(base, 0)
            seen[base] = count + 1
            found.add(base if count == 0 else "%s-%d" % (base, count))
    return found


def paragraphs(path):
    """(first line number, normalized text) of each prose paragraph of `path`."""
    block, start = [], None
    for number, line in list(prose_lines(path.read_text(encoding="utf-8"))) + [(None, "")]:
        if line.strip():
            if not block:
                start = number
            block.append(line.strip())
        elif block:
            yield start, " ".join(" ".join(block).split())
            block = []


def test_readme_is_short_and_names_the_two_commands():
    text = README.read_text(encoding="utf-8")
    lines = text.count("\n") + (0 if text.endswith("\n") else 1)
    assert lines <= README_MAX_LINES, "README.md has %d lines (at most %d)" % (lines, README_MAX_LINES)
    for command in ("build_scripts/demo.sh", "build_scripts/test.sh"):
        assert command in text, "README.md does not name %s" % command


def test_docs_folder_has_an_index():
    assert (DOCS / "README.md").is_file() or (DOCS / "index.md").is_file()


@pytest.mark.parametrize("path", documents(), ids=rel)
def test_no_absolute_path_of_a_machine(path):
    shown = ["%s:%d: %s" % (rel(path), number, line.strip())
             for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
             if MACHINE_PATH.search(line)]
    assert shown == []


@pytest.mark.parametrize("path", documents(), ids=rel)
def test_relative_links_resolve(path):
    broken = []
    for number, target in links(path):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):  # https:, mailto:, …
            continue
        file_part, _, anchor = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        where = "%s:%d: %s" % (rel(path), number, target)
        if file_part.startswith("/"):
            broken.append(where + " (absolute)")
        elif not dest.exists():
            broken.append(where + " (no such file)")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            broken.append(where + " (no such heading)")
    assert broken == []


def test_no_paragraph_twice():
    first, repeated = {}, []
    for path in documents():
        for number, text in paragraphs(path):
            if len(text) < PARAGRAPH_MIN_CHARS:
                continue
            where = "%s:%d" % (rel(path), number)
            if text in first:
                repeated.append("%s repeats %s: %s…" % (where, first[text], text[:60]))
            else:
                first[text] = where
    assert repeated == []


def shipped_files():
    """Every source file of the add-on and of the native library (not built modules or caches)."""
    found = []
    for folder in (ROOT / "addon" / "quatcurve_blender", ROOT / "native"):
        for path in sorted(folder.rglob("*")):
            if (path.is_file() and "__pycache__" not in path.parts
                    and path.suffix not in (".so", ".pyd", ".pyc", ".dll", ".dylib")):
                found.append(path)
    return found


def test_design_doc_lists_every_file():
    text = DESIGN.read_text(encoding="utf-8")
    missing = [rel(path) for path in shipped_files() if "`%s`" % path.name not in text]
    assert missing == [], "docs/design.md does not list: %s" % ", ".join(missing)


def test_checks_catch_what_they_look_for(tmp_path):
    """The helpers above find a machine path, a broken link, a missing heading and a repeat."""
    assert MACHINE_PATH.search("saved /work/main/out/a.blend")
    assert MACHINE_PATH.search("/root/.cache/x") and MACHINE_PATH.search("see /home/me/x")
    assert not MACHINE_PATH.search("~/.cache/quatcurve/bpy-4.5.15 and out/work/x and ../work/y")
    page = tmp_path / "page.md"
    page.write_text("# A page\n\n## Report (JSON)\n\nSee [x](missing.md), ![i](images/x.png) and "
                    "[h](#report-json) and [w](https://example.org).\n\n```\n[not](a-link.md)\n```\n",
                    encoding="utf-8")
    assert [t for _, t in links(page)] == ["missing.md", "images/x.png", "#report-json",
                                         "https://example.org"]
    assert anchors(page) == {"a-page", "report-json"}
    assert slug("`--help`") == "--help" and slug("Fit, Live and ease") == "fit-live-and-ease"
    long = "A paragraph long enough to be checked for repeats, " * 3
    page.write_text("%s\n\n# Heading\n\n%s\n" % (long, long.replace(" ", "\n", 3)), encoding="utf-8")
    texts = [t for _, t in paragraphs(page)]
    assert texts[0] == texts[2] and texts[1] == "# Heading"
