"""What the documentation shows or points to is in the repository: every relative link and
image of the README, ``docs/`` and ``benchmarks/`` Markdown files names a committed file (and
an anchor that its headings make), every repository path the README, ``docs/*.md`` and
``benchmarks/RESULTS.md`` name in backticks exists, and every record under ``benchmarks/records/``
that a document, a benchmark or a shipped controller's provenance names - inside a command too -
is there.

A picture that was rendered but never committed (``*.png`` is ignored outside ``docs/``) shows
as a broken image on GitHub and nowhere else: the author's own checkout has it.  So files are
looked up among those git tracks, not on the disk."""

from __future__ import annotations

import fnmatch
import itertools
import re
import subprocess
from pathlib import Path, PurePosixPath

import pytest

ROOT = Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^(```|~~~).*?^\1", re.S | re.M)
INLINE_CODE = re.compile(r"`([^`\n]+)`")
LINK = re.compile(r"!?\[[^\]\n]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
REFERENCE = re.compile(r"^[ \t]{0,3}\[[^\]]+\]:[ \t]*<?(\S+?)>?(?:\s.*)?$", re.M)
HTML_SOURCE = re.compile(r"<(?:img|a|source)\b[^>]*?\b(?:src|href)=\"([^\"]+)\"", re.I)
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$", re.M)
# a path into the records, anywhere in a line (`--measure benchmarks/records/x/polished.json`), with
# `{a,b}` alternatives and `*` globs; not one inside another path (`/tmp/benchmarks/records`)
RECORD_PATH = re.compile(r"(?<![\w./-])benchmarks/records(?:/(?:[\w.*-]|\{[^}\s]*\})+)*/?")
PLACEHOLDER = re.compile(r"[A-Z][A-Z_]*|<[^>]*>|\.\.\.")  # `runs/NAME`, `<run>`, `...`


def tracked() -> set[str]:
    """The repository's files as git tracks them (index included), POSIX paths from ROOT;
    every file on the disk where git is not there (an unpacked source archive)."""
    try:
        out = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-z"], capture_output=True, check=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        skip = {"runs", "build", "dist", "__pycache__"}
        return {p.relative_to(ROOT).as_posix() for p in ROOT.rglob("*") if p.is_file()
                and not any(part.startswith(".") or part in skip for part in p.relative_to(ROOT).parts)}
    return set(filter(None, out.stdout.decode().split("\0")))


FILES = tracked()
FOLDERS = {str(parent) for f in FILES for parent in PurePosixPath(f).parents if str(parent) != "."}
TOP_FOLDERS = {f.split("/")[0] for f in FOLDERS}
DOCUMENTS = sorted(f for f in FILES
                   if f.endswith(".md") and (f == "README.md" or f.startswith(("docs/", "benchmarks/"))))
# where backticked paths are claims about this repository (docs/research/ quotes other projects' files)
PATH_DOCUMENTS = ["README.md", "benchmarks/RESULTS.md", *sorted(f for f in FILES if re.fullmatch(r"docs/[^/]+\.md", f))]


# what cites records: the documents, the benchmarks, the shipped controllers (their provenance
# names the run they came from) and the records' own READMEs; tests that read a record fail alone
RECORD_CITERS = sorted({*PATH_DOCUMENTS, *(f for f in FILES if re.fullmatch(
    r"benchmarks/[^/]+\.(md|py)|configs/controllers/[^/]+\.json|benchmarks/records/(.+/)?README\.md", f))})


def read(document: str) -> str:
    return (ROOT / document).read_text(encoding="utf-8")


def prose(text: str) -> str:
    """``text`` without fenced code blocks (lines kept, for line numbers)."""
    return FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), text)


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, markup and punctuation dropped, spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link in a heading: its text
    return re.sub(r"[^\w\- ]", "", text.strip().lower()).replace(" ", "-")


def anchors(document: str) -> set[str]:
    """The anchors a Markdown file's headings make (a repeated heading gets -1, -2, ...)."""
    seen: dict[str, int] = {}
    out = set()
    for heading in HEADING.findall(prose(read(document))):
        base = slug(heading)
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return out


def targets(markdown: str) -> list[tuple[int, str]]:
    """(line, target) of every link, image, reference definition and HTML src/href outside code."""
    text = prose(markdown)
    text = INLINE_CODE.sub(lambda m: "x" * len(m.group(0)), text)  # `[a](b)` in code is not a link
    found = []
    for pattern in (LINK, REFERENCE, HTML_SOURCE):
        for m in pattern.finditer(text):
            found.append((text.count("\n", 0, m.start()) + 1, m.group(1)))
    return sorted(found)


def broken(document: str, target: str) -> str | None:
    """Why ``target``, linked from ``document``, does not resolve; None if it does (or is
    not a path in this repository: a URL, a mail address)."""
    if re.match(r"^[a-z][a-z0-9+.\-]*:", target, re.I) or target.startswith("//"):
        return None
    path, _, anchor = target.partition("#")
    if path:
        resolved = PurePosixPath(document).parent / path.split("?")[0]
        parts: list[str] = []
        for part in resolved.parts:  # normalise "a/../b" without touching the disk
            if part == "..":
                if not parts:
                    return "points outside the repository"
                parts.pop()
            elif part != ".":
                parts.append(part)
        name = "/".join(parts)
        if name not in FILES and name not in FOLDERS:
            on_disk = (ROOT / name).exists()
            return f"{name} is not in the repository" + (" (on this disk: untracked or ignored)" if on_disk else "")
    else:
        name = document
    if anchor and name.endswith(".md") and anchor not in anchors(name):
        return f"{name} has no heading whose anchor is #{anchor}"
    return None


def record_citations(text: str) -> list[tuple[int, str]]:
    """(line, path) of every path into ``benchmarks/records`` that ``text`` names, fenced code and
    commands included: `{a,b}` expanded, a trailing full stop or comma dropped, and a path cut
    before its first placeholder component (`runs/NAME` names the folder `runs`)."""
    found = []
    for m in RECORD_PATH.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        parts = re.split(r"(\{[^}]*\})", m.group(0).rstrip("/.,"))
        choices = [p[1:-1].split(",") if p.startswith("{") else [p] for p in parts]
        for path in map("".join, itertools.product(*choices)):
            kept = list(itertools.takewhile(lambda part: not PLACEHOLDER.fullmatch(part), path.split("/")))
            found.append((line, "/".join(kept).rstrip("/.")))
    return found


def missing_record(path: str) -> bool:
    """Whether the repository lacks ``path`` (a glob: matches nothing)."""
    if "*" in path:
        return not any(fnmatch.fnmatch(f, path) or fnmatch.fnmatch(f, path + "/*") for f in FILES)
    return path not in FILES and path not in FOLDERS


def dangling_records(document: str, text: str) -> list[str]:
    return [f"{document}:{line}: {path} is not in the repository"
            for line, path in record_citations(text) if missing_record(path)]


def test_the_documents_are_found():
    """The checks below look at something: the README and the files it links are found."""
    assert "README.md" in DOCUMENTS and "benchmarks/RESULTS.md" in DOCUMENTS and "docs/servo_model.md" in DOCUMENTS
    assert any(target.endswith(".png") for _, target in targets(read("README.md")))


@pytest.mark.parametrize("document", DOCUMENTS)
def test_every_link_and_image_resolves(document):
    problems = [f"{document}:{line}: ({target}) {why}" for line, target in targets(read(document))
                if (why := broken(document, target))]
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("document", PATH_DOCUMENTS)
def test_every_repository_path_named_in_backticks_exists(document):
    """`docs/x.png`, `benchmarks/records/...`: a path under one of the repository's own
    top-level folders is a claim that it is here (placeholders with <>, * or {} aside)."""
    text = prose(read(document))
    problems = []
    for m in INLINE_CODE.finditer(text):
        path = m.group(1).strip().rstrip("/")
        if not re.fullmatch(r"[\w.\-]+(/[\w.\-]+)+", path) or path.split("/")[0] not in TOP_FOLDERS:
            continue
        if path not in FILES and path not in FOLDERS:
            problems.append(f"{document}:{text.count(chr(10), 0, m.start()) + 1}: `{path}` is not in the repository")
    assert not problems, "\n".join(problems)


def test_the_record_citers_are_found():
    """The check below reads what cites records: RESULTS, a benchmark, a shipped controller."""
    assert {"benchmarks/RESULTS.md", "benchmarks/sysid.py", "configs/controllers/human_male_50.json",
            "benchmarks/records/README.md"} <= set(RECORD_CITERS)
    assert len(record_citations(read("benchmarks/RESULTS.md"))) > 100


@pytest.mark.parametrize("document", RECORD_CITERS)
def test_every_record_cited_is_in_the_repository(document):
    """A record that RESULTS, the README, docs, a benchmark or a controller's provenance names
    (in a command, a table or a sentence) was not dropped or left uncommitted."""
    problems = dangling_records(document, read(document))
    assert not problems, "\n".join(problems)


def test_the_record_checker_sees_what_it_must():
    """Paths inside commands, `{a,b}`, globs and placeholders; a missing record is named."""
    text = ("`biped eval benchmarks/records/polish-straight5/polished.json --json` and\n"
            "`benchmarks/records/issue16/human-walk/human_stepping_{male_50,female_5}-seed1/`.\n"
            "`cp -r benchmarks/records/runs/NAME runs/`, benchmarks/records/tolerance/shipped_*.json,"
            " /tmp/benchmarks/records/x, benchmarks/records/configs/.\n")
    assert record_citations(text) == [
        (1, "benchmarks/records/polish-straight5/polished.json"),
        (2, "benchmarks/records/issue16/human-walk/human_stepping_male_50-seed1"),
        (2, "benchmarks/records/issue16/human-walk/human_stepping_female_5-seed1"),
        (3, "benchmarks/records/runs"), (3, "benchmarks/records/tolerance/shipped_*.json"),
        (3, "benchmarks/records/configs")]
    assert dangling_records("doc.md", text) == []
    gone = "see benchmarks/records/runs/no-such-run/ and benchmarks/records/tolerance/none_*.json"
    assert dangling_records("doc.md", gone) == [
        "doc.md:1: benchmarks/records/runs/no-such-run is not in the repository",
        "doc.md:1: benchmarks/records/tolerance/none_*.json is not in the repository"]


def test_the_checker_sees_what_it_must():
    """The checker itself: a missing picture, a missing anchor, and links it must leave alone."""
    assert broken("README.md", "docs/no_such_picture.png") == "docs/no_such_picture.png is not in the repository"
    assert broken("README.md", "#no-such-section") == "README.md has no heading whose anchor is #no-such-section"
    assert broken("docs/servo_model.md", "../README.md#install") is None
    assert broken("README.md", "https://example.org/x.png") is None
    assert broken("README.md", "../outside.md") == "points outside the repository"
    assert slug("The firmware's D term") == "the-firmwares-d-term"
    assert slug("NEAT (`evolve/neat/`)") == "neat-evolveneat"
    sample = "![a](docs/a.png) `[b](c.md)`\n```\n[d](e.md)\n```\n[f]: docs/g.png\n<img src=\"h.png\">\n"
    assert targets(sample) == [(1, "docs/a.png"), (5, "docs/g.png"), (6, "h.png")]
