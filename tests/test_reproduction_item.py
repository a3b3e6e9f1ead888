"""The reproduction table's judging rules (symbolic.reproduction.item) and the CLI around them."""

from __future__ import annotations

import json

import pytest

from symbolic.cli import main
from symbolic.reproduction.item import compare, not_reproducible, printed_tolerance, relative_difference
from symbolic.reproduction.render import markdown


def test_printed_tolerance_is_half_the_last_printed_digit() -> None:
    assert printed_tolerance("36.727") == pytest.approx(0.0005 / 36.727, rel=1e-12)
    assert printed_tolerance("1.2e-3") == pytest.approx(0.05e-3 / 1.2e-3, rel=1e-12)
    assert printed_tolerance("70") == pytest.approx(0.5 / 70, rel=1e-12)
    # the worst element of a list decides; printed zeros carry no relative precision
    assert printed_tolerance(["0", "14.4", "99.2"]) == pytest.approx(0.05 / 14.4, rel=1e-12)


def test_statuses() -> None:
    ok = compare("madill", "(4.10) x", "69.5", 69.52, "Hz", how="test")
    assert ok.status == "matches" and ok.relative_difference == pytest.approx(0.02 / 69.5, rel=1e-12)
    off = compare("madill", "(4.10) x", "69.5", 69.56, "Hz", how="test")
    assert off.status == "differs"
    fixed = compare("milne", "Table 4", ["1.0", "2.0"], [1.01, 2.0], "", how="t", correcting="the sign of (18)")
    assert fixed.status == "matches after correcting the sign of (18)"
    missing = not_reproducible("janot", "Table 4 Fv", "1.5", "N s/m", why="the data are not published")
    assert missing.status.startswith("not reproducible: ") and missing.ours is None
    unprinted = not_reproducible("janot", "(19) K_tot", None, "Nm/rad", why="no value printed", ours=1.0)
    assert unprinted.published is None and unprinted.ours == 1.0 and unprinted.relative_difference is None
    assert "| — | 1 | Nm/rad |" in markdown([unprinted])
    with pytest.raises(ValueError, match="source"):
        compare("nobody", "x", "1", 1.0, "", how="")
    with pytest.raises(ValueError, match="numbers"):
        relative_difference((1.0, 2.0), (1.0,))


def test_markdown_lists_every_item_and_how() -> None:
    items = [compare("madill", "(5.11) a|b", "222.3", 222.31, "rad/s", how="by the beam roots")]
    text = markdown(items)
    assert "| 1 | madill | (5.11) a\\|b | 222.3 | 222.31 | rad/s |" in text and "by the beam roots" in text


def test_cli_refuses_unknown_sources(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["-q", "reproduce", "--sources", "madill,nobody"]) == 2
    assert "nobody" in capsys.readouterr().err


def test_cli_json_has_the_contract_fields(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["-q", "reproduce", "--json", "--sources", "janot"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert set(payload) == {"items"}
    for item in payload["items"]:
        assert {"source", "item", "published", "ours", "unit", "relative_difference", "status"} <= set(item)
