"""The benchmark figures in README.md and docs/*.md are quoted from bench/results/, never copied (issue 33).

Every ``<!-- quote FILE "HEADING" -->`` … ``<!-- end quote -->`` block must hold exactly what bench/quotes.py
writes from that section of the results file (``make generate`` refreshes them), and must name a file and a
section that exist. The rest checks the mechanism itself on small files.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location("bench_quotes", ROOT / "bench" / "quotes.py")
quotes = importlib.util.module_from_spec(_SPEC)
sys.modules.setdefault("bench_quotes", quotes)
_SPEC.loader.exec_module(quotes)

RESULTS = """# Title

Intro line.

## First

Alpha | 1.0 s

### Detail

Beta 2.0 s

## Second

```
## not a heading
```
Gamma
"""


@pytest.mark.parametrize("document", quotes.documents(), ids=lambda path: path.name)
def test_quote_blocks_hold_their_sections(document: Path) -> None:
    text = document.read_text(encoding="utf-8")
    fresh = quotes.refresh(text, document)  # raises on a missing file or section, naming the line
    if fresh != text:
        old, new = text.splitlines(), fresh.splitlines()
        line = next((i for i, (a, b) in enumerate(zip(old, new)) if a != b), min(len(old), len(new)))
        pytest.fail(f"{document.relative_to(ROOT)}:{line + 1}: a quote block differs from its results section "
                    "(run `python bench/quotes.py` or `make generate`, then commit)")


def test_the_docs_quote_the_benchmarks() -> None:
    """The speed passages quote their figures (a block each at least in these documents)."""
    for name in ("workflow.md", "fleet.md", "simulation.md", "data.md", "architecture.md"):
        text = (ROOT / "docs" / name).read_text(encoding="utf-8")
        assert any(quotes.BEGIN.match(line) for line in text.splitlines()), f"docs/{name} quotes no results"


def results_tree(tmp_path: Path, results: str = RESULTS) -> Path:
    (tmp_path / "bench" / "results").mkdir(parents=True)
    (tmp_path / "bench" / "results" / "x.md").write_text(results, encoding="utf-8")
    (tmp_path / "docs").mkdir()
    return tmp_path / "docs" / "d.md"


def block(heading: str, *body: str) -> str:
    return "\n".join(["Prose.", "", f'<!-- quote bench/results/x.md "{heading}" -->', *body, "<!-- end quote -->",
                      "", "More prose.", ""])


def test_a_section_runs_to_the_next_heading_of_its_level(tmp_path: Path) -> None:
    document = results_tree(tmp_path)
    fresh = quotes.refresh(block("## First", "stale 0.5 s"), document, tmp_path)
    assert fresh == block("## First", "> **First** ([bench/results/x.md](../bench/results/x.md))", ">",
                          "> Alpha | 1.0 s", ">", "> **Detail**", ">", "> Beta 2.0 s")
    assert quotes.refresh(fresh, document, tmp_path) == fresh


def test_the_title_is_the_whole_file_and_fenced_lines_are_no_headings(tmp_path: Path) -> None:
    document = results_tree(tmp_path)
    whole = quotes.refresh(block("# Title"), document, tmp_path).splitlines()
    assert whole[3] == "> **Title** ([bench/results/x.md](../bench/results/x.md))"
    assert "> ## not a heading" in whole and "> Gamma" in whole and "> **Second**" in whole
    second = quotes.refresh(block("## Second"), document, tmp_path)
    assert "> Gamma" in second


def test_a_block_in_a_fence_is_text(tmp_path: Path) -> None:
    document = results_tree(tmp_path)
    text = "```\n" + block("## Missing", "anything") + "```\n"
    assert quotes.refresh(text, document, tmp_path) == text


@pytest.mark.parametrize(("text", "message"), [
    (block("## Third"), "docs/d.md:3: bench/results/x.md has no section '## Third' (its headings: '# Title', "
                        "'## First', '### Detail', '## Second')"),
    (block("## First").replace("x.md", "y.md"), "docs/d.md:3: bench/results/y.md: no such results file"),
    (block("First"), "docs/d.md:3: expected <!-- quote bench/results/FILE.md \"## HEADING\" -->"),
    (block("## First").replace("<!-- end quote -->", ""), "docs/d.md:3: the quote block has no '<!-- end quote -->'"
                                                          " line before the end of the file"),
    (block("## First").replace("<!-- end quote -->", "") + block("## Second"), "before the next quote block"),
])
def test_a_bad_block_is_named(tmp_path: Path, text: str, message: str) -> None:
    document = results_tree(tmp_path)
    with pytest.raises(quotes.QuoteError) as error:
        quotes.refresh(text, document, tmp_path)
    assert message in str(error.value)


def test_a_heading_twice_is_refused(tmp_path: Path) -> None:
    document = results_tree(tmp_path, RESULTS + "\n## First\n\nagain\n")
    with pytest.raises(quotes.QuoteError, match="has two sections '## First'"):
        quotes.refresh(block("## First"), document, tmp_path)


def test_the_command_checks_and_refreshes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    document = tmp_path / "d.md"
    stale = block("# Cache: a second `symbolic identify panda LOG`", "> a copied 5.5×").replace("x.md", "cache.md")
    document.write_text(stale, encoding="utf-8")
    assert quotes.main(["--check", str(document)]) == 1
    assert document.read_text(encoding="utf-8") == stale
    assert "stale" in capsys.readouterr().err
    assert quotes.main([str(document)]) == 0
    assert quotes.main(["--check", str(document)]) == 0
    fresh = document.read_text(encoding="utf-8")
    assert "> | cache | work starts (the log is opened) | total |" in fresh
    document.write_text(block("## Nothing").replace("x.md", "cache.md"), encoding="utf-8")
    assert quotes.main(["--check", str(document)]) == 2
    assert "has no section '## Nothing'" in capsys.readouterr().err
