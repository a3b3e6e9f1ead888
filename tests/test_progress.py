"""Long work says what it is doing (stderr, silenced by -q), stops at stated size limits, and a bad
--out is refused before the derivation."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import sympy as sp

from conftest import derived
from symbolic import cli
from symbolic.derivation import analysis
from symbolic.derivation.simplify import compact


def run(*args: str) -> subprocess.CompletedProcess:
    """The command with the cache off: the progress of the work itself is checked, not of reading it back."""
    env = {**os.environ, "SYMBOLIC_NO_CACHE": "1"}
    return subprocess.run([sys.executable, "-m", "symbolic", *args], capture_output=True, text=True, env=env)


@pytest.mark.slow
@pytest.mark.parametrize(
    "command, expected",
    [
        (["derive", "fivebar"], [r"symbolic: fivebar: deriving \(3 coordinates", "symbolic: fivebar: derived in",
                                  r"symbolic: fivebar: compacting D\(Q\)"]),
        (["analyze", "fivebar", "--kinds", "decoupling,balancing"],
         ["symbolic: fivebar: decoupling conditions: 1 in", "symbolic: fivebar: balancing conditions: 2 in"]),
        (["generate", "fivebar", "--out", "{dir}"],
         ["symbolic: fivebar: derived in", "symbolic: fivebar: C source printed in", r"symbolic: fivebar: \d+ CasADi functions in",
          "symbolic: fivebar: report in"]),
    ],
)
def test_progress_on_stderr_and_quiet_with_q(command: list[str], expected: list[str], tmp_path: Path) -> None:
    loud = run(*[part.replace("{dir}", str(tmp_path / "loud")) for part in command])
    quiet = run("-q", *[part.replace("{dir}", str(tmp_path / "quiet")) for part in command])
    assert loud.returncode == 0 and quiet.returncode == 0, loud.stderr + quiet.stderr
    lines = loud.stderr.splitlines()
    for pattern in expected:  # each a regular expression matched at the start of a line
        assert any(re.match(pattern, line) for line in lines), (pattern, loud.stderr)
    assert all(line.startswith("symbolic: ") for line in lines), loud.stderr
    assert quiet.stderr == ""

    def steady(stdout: str) -> str:  # the summary's derivation time varies from run to run
        return re.sub(r"derivation [0-9.]+ s", "derivation _ s", stdout).replace(str(tmp_path / "loud"), str(tmp_path / "quiet"))

    assert steady(quiet.stdout) == steady(loud.stdout)


def _derive_must_not_run(robot):
    raise AssertionError("derive() called before --out was checked")


@pytest.mark.parametrize("case", ["file", "under a file"])
def test_bad_out_is_refused_before_deriving(case: str, tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setattr(cli, "derive", _derive_must_not_run)
    plain = tmp_path / "plain.txt"
    plain.write_text("not a directory\n")
    out = plain if case == "file" else plain / "sub" / "dir"
    assert cli.main(["-q", "generate", "panda", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: --out: output directory {out}") and str(plain) in err
    assert err.count("\n") == 1, err
    assert plain.read_text() == "not a directory\n"


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only directories")
def test_unwritable_out_is_refused_before_deriving(tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setattr(cli, "derive", _derive_must_not_run)
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        assert cli.main(["-q", "generate", "panda", "--out", str(locked / "new")]) == 2
        assert cli.main(["-q", "generate", "panda", "--out", str(locked)]) == 2
    finally:
        locked.chmod(0o700)
    assert "is not writable" in capsys.readouterr().err


def test_good_out_passes_the_check(tmp_path: Path) -> None:
    from symbolic.export import check_output_directory

    check_output_directory(tmp_path)
    check_output_directory(tmp_path / "new" / "nested")
    assert not (tmp_path / "new").exists()  # the check creates nothing


def test_show_prints_large_entries_as_intermediates(monkeypatch, capsys) -> None:
    """With the limit below some of fivebar's entries, those are printed in intermediates whose
    definitions follow; entries under the limit keep their compact form."""
    fivebar = derived("fivebar")
    from symbolic.derivation import simplify

    monkeypatch.setattr(simplify, "SIZE_LIMIT", 40)
    cli.show(fivebar)
    out = capsys.readouterr().out
    lines = out.splitlines()
    definitions = {}
    for line in lines[lines.index("Intermediates of the entries above 40 (compacting them would take minutes):") + 1:]:
        name, _, value = line.strip().partition(" = ")
        definitions[name] = value
    entries = [(f"  D[{i},{j}] = ", fivebar.reduced.D[i, j], fivebar.D[i, j]) for i in range(3) for j in range(i, 3)]
    entries.append(("V_g(Q) = ", fivebar.reduced.potential, fivebar.potential_energy))
    large = []
    for head, reduced, expanded in entries:
        (line,) = [x for x in lines if x.startswith(head)]
        size = sum(1 for _ in sp.preorder_traversal(expanded))
        if size > 40:
            large.append(reduced)
            assert line == f"{head}{sp.sstr(reduced)}    [expanded size {size} > 40: in intermediates, defined below]"
        else:
            assert line == f"{head}{sp.sstr(compact(expanded, fivebar.coordinates))}"
    assert 1 <= len(large) < len(entries)
    program = fivebar.sub.program(large)
    assert definitions == {str(s): sp.sstr(d) for s, d in program}


def test_analysis_lists_what_it_skips(monkeypatch) -> None:
    """Entries above the limit are reported in the summary and the JSON, the rest analysed as before."""
    fivebar = derived("fivebar")
    full = analysis.decoupling(fivebar, kinds=["coriolis", "balancing"])
    monkeypatch.setattr(analysis, "SIZE_LIMIT", 100)
    limited = analysis.decoupling(fivebar, kinds=["coriolis", "balancing"])
    sizes = [sum(1 for _ in sp.preorder_traversal(row)) for row in fivebar.coriolis_vector]
    too_large = [f"coriolis row q{k}" for k, size in enumerate(sizes) if size > 100]
    assert too_large and [s.name for s in limited.skipped] == too_large
    kept = [c for c in full.conditions if not any(c.name.startswith(name + " ") for name in too_large)]
    assert [(c.name, c.expression) for c in limited.conditions] == [(c.name, c.expression) for c in kept]
    data = limited.to_dict()
    assert [s["name"] for s in data["skipped"]] == too_large and all(s["limit"] == 100 for s in data["skipped"])
    text = limited.summary()
    assert f"{len(too_large)} entries too large to analyse" in text.splitlines()[0]
    for name, size in zip(too_large, [s for s in sizes if s > 100]):
        assert f"  {name}: not analysed (expanded size {size}, limit 100)" in text


@pytest.mark.slow
def test_panda_coriolis_rows_are_skipped_not_expanded() -> None:
    panda = derived("panda")
    result = analysis.decoupling(panda, kinds=["coriolis"])
    assert [s.name for s in result.skipped] == [f"coriolis row q{k}" for k in range(1, 8)]
    assert all(s.size > analysis.SIZE_LIMIT for s in result.skipped) and not result.conditions
    assert "coriolis: not analysed" in result.summary()
