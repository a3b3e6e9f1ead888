"""Refresh the benchmark figures that README.md and docs/*.md quote from bench/results/ (issue 33: each fact once).

A document quotes a section of a results file between two comment lines::

    <!-- quote bench/results/diagnose.md "## EMPS (published model, estimation set, cross-test on the pulse set)" -->
    ... written by this script ...
    <!-- end quote -->

The first names the file (from the repository's root) and the section's heading line exactly as the file writes
it; the section runs from that line up to the next heading of the same or a higher level (a file's ``# title``
is the whole file). Between the two lines the script writes the section as a block quote: a first line with the
heading in bold and a link to the file, then the section's lines, its sub-headings in bold so that the quoting
document's outline stays its own. Anything written by hand between the lines is replaced; markers inside fenced
code blocks are left alone. ``make generate`` runs it and ``make check-generated`` fails when it changed a
document; ``tests/test_doc_quotes.py`` fails on a stale block or a missing file or section.

    python bench/quotes.py            # refresh README.md and docs/*.md in place
    python bench/quotes.py --check    # list stale documents, change nothing (exit status 1 if any)
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BEGIN = re.compile(r'^<!-- quote (?P<source>\S+) "(?P<heading>#+ .*)" -->$')
END = "<!-- end quote -->"
HEADING = re.compile(r"^(#{1,6}) +(.*?)(?: +#+)? *$")
FENCE = re.compile(r"^ {0,3}(```|~~~)")


class QuoteError(ValueError):
    """A quote block that cannot be refreshed: unclosed, or naming a missing file or section."""


def documents(root: Path = ROOT) -> list[Path]:
    """The documents that may quote results: README.md and docs/*.md."""
    return [root / "README.md", *sorted((root / "docs").glob("*.md"))]


def heading_level(line: str) -> int:
    """The level of a Markdown heading line (1 for ``#``), 0 for any other line."""
    match = HEADING.match(line)
    return len(match.group(1)) if match else 0


def section(text: str, heading: str, where: str) -> list[str]:
    """The lines of the section that starts at the line ``heading`` of ``text``.

    Parameters
    ----------
    text : str
        A Markdown file's text.
    heading : str
        The heading line, ``#`` marks included, e.g. ``"## Panda, 20 000 samples"``.
    where : str
        The file's name, for the error messages.

    Returns
    -------
    list of str
        From the heading line up to (not including) the next heading of the same or a higher level, trailing
        blank lines dropped. Fenced code is not searched for headings.

    Raises
    ------
    QuoteError
        When ``heading`` is not a heading line of the text, or is one twice.
    """
    lines, level = text.splitlines(), heading_level(heading)
    outside = _outside_fences(lines)
    starts = [i for i, line in enumerate(lines) if line.rstrip() == heading.rstrip() and outside[i]]
    if level == 0 or len(starts) != 1:
        found = [line for i, line in enumerate(lines) if heading_level(line) and outside[i]]
        problem = "is not a heading line" if level == 0 else ("has no section" if not starts else "has two sections")
        raise QuoteError(f"{where} {problem} {heading!r} (its headings: {', '.join(map(repr, found)) or 'none'})")
    end = next((i for i in range(starts[0] + 1, len(lines))
                if outside[i] and 0 < heading_level(lines[i]) <= level), len(lines))
    body = lines[starts[0]:end]
    while body and not body[-1].strip():
        body.pop()
    return body


def _outside_fences(lines: list[str]) -> list[bool]:
    """Whether each line lies outside fenced code blocks (a fence line itself counts as inside)."""
    outside, inside = [], False
    for line in lines:
        fence = FENCE.match(line) is not None
        outside.append(not (inside or fence))
        inside ^= fence
    return outside


def render(source: str, heading: str, document: Path, root: Path = ROOT) -> list[str]:
    """The lines a quote block of ``source``'s section ``heading`` holds in ``document``.

    A block quote: the heading in bold with a link to the file relative to the document, a blank quoted line,
    then the section's lines after its heading, sub-headings in bold.

    Raises
    ------
    QuoteError
        When the file does not exist or has no such section.
    """
    path = root / source
    if not path.is_file():
        raise QuoteError(f"{source}: no such results file")
    lines = section(path.read_text(encoding="utf-8"), heading, source)
    link = Path(os.path.relpath(path, document.parent)).as_posix()
    title = HEADING.match(heading).group(2)  # type: ignore[union-attr]  # section() checked it is a heading
    quoted = [f"> **{title}** ([{source}]({link}))", ">"]
    body = lines[1:]
    while body and not body[0].strip():
        body.pop(0)
    for line, outside in zip(body, _outside_fences(body)):
        match = HEADING.match(line) if outside else None
        line = f"**{match.group(2)}**" if match else line
        quoted.append(f"> {line}" if line.strip() else ">")
    return quoted


def refresh(text: str, document: Path, root: Path = ROOT) -> str:
    """``text`` with every quote block rewritten from its results file.

    Parameters
    ----------
    text : str
        The document's text.
    document : pathlib.Path
        Its path (the links are relative to its folder; the errors name it).
    root : pathlib.Path
        The repository root the blocks' file names start from.

    Raises
    ------
    QuoteError
        Naming the document and line: a block without its end line, a block inside a block, a missing file or
        section.
    """
    lines, out = text.splitlines(), []
    outside = _outside_fences(lines)
    name = _display(document, root)
    i = 0
    while i < len(lines):
        out.append(lines[i])
        begin = BEGIN.match(lines[i]) if outside[i] else None
        if lines[i].startswith("<!-- quote") and outside[i] and begin is None:
            raise QuoteError(f'{name}:{i + 1}: expected <!-- quote bench/results/FILE.md "## HEADING" -->, '
                             f"got {lines[i]!r}")
        if begin is None:
            i += 1
            continue
        end = next((j for j in range(i + 1, len(lines)) if lines[j] == END or BEGIN.match(lines[j])), None)
        if end is None or lines[end] != END:
            raise QuoteError(f"{name}:{i + 1}: the quote block has no {END!r} line before "
                             + ("the next quote block" if end is not None else "the end of the file"))
        try:
            out.extend(render(begin["source"], begin["heading"], document, root))
        except QuoteError as error:
            raise QuoteError(f"{name}:{i + 1}: {error}") from None
        out.append(END)
        i = end + 1
    return "\n".join(out) + ("\n" if text.endswith("\n") else "")


def _display(document: Path, root: Path) -> str:
    try:
        return document.resolve().relative_to(root.resolve()).as_posix()
    except ValueError:
        return str(document)


def main(argv: list[str] | None = None) -> int:
    """Refresh (or with ``--check`` only list) the stale quote blocks of the given documents."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("documents", nargs="*", type=Path, help="default: README.md and docs/*.md")
    parser.add_argument("--check", action="store_true", help="list stale documents; change nothing")
    args = parser.parse_args(argv)
    stale = []
    for document in args.documents or documents():
        text = document.read_text(encoding="utf-8")
        try:
            fresh = refresh(text, document)
        except QuoteError as error:
            print(f"quotes: {error}", file=sys.stderr)
            return 2
        if fresh != text:
            stale.append(_display(document, ROOT))
            if not args.check:
                document.write_text(fresh, encoding="utf-8")
    if stale:
        verb = "stale" if args.check else "refreshed"
        print(f"quotes: {verb}: {', '.join(stale)}", file=sys.stderr)
    return 1 if stale and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
