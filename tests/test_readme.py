"""The README's commands, run as a new user runs them, print what the README says they print.

A new user clones the repository beside a folder ``shared`` holding the measured data (``../shared``, as
docs/data.md describes), installs it and types the README's commands in the clone, with no environment
variable of ours set. This test does the same:

* the clone: the repository's tracked files (``git ls-files``, with the working tree's content, so that an
  edit is tested before it is committed; nothing untracked) copied into ``tmp/main``, beside a symbolic link
  ``tmp/shared`` to the real ``../shared`` (skipped, saying so, when that folder or its EMPS data is absent);
* the install: ``PYTHONPATH`` is the clone, which stands for ``pip install -e .`` there (the clone's
  package and ``symbolic`` command are the ones run; an install per test run would take minutes);
* the environment: ``SYMBOLIC_DATA_PATH`` removed (the examples must find the data by their own paths);
  ``SYMBOLIC_CACHE_DIR`` stays the suite's own folder (tests/conftest.py: never the user's cache);
* every command of a ``sh`` block and every ``$`` line of a console block is run in the clone with bash, in
  README order, except those of :data:`EXCLUDED` (each with its reason); a console block's printed lines must
  appear in the command's output in order, exactly — every number as printed. ``...`` alone stands for
  lines left out, a line ending in ``...`` for its beginning, and a parenthesised "(... omitted here)" line
  for lines the README leaves out.

Like docs/reproduction.md (``make check-generated``), the README's numbers are thereby checked, not copied.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from shared_data import EMPS_FILES

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"

EXCLUDED = {
    "python3 -m venv .venv && . .venv/bin/activate && python3 -m pip install -e '.[dev]'":
        "the install itself: the test runs inside it, and a second one downloads 1.6 GB (PYTHONPATH stands for it)",
    'symbolic derive fivebar && python3 -m pytest -n 2 -m "not slow"':
        "runs this suite (minutes); `symbolic derive fivebar` is run from the console block below it",
}
"""README commands not run, each with the reason (by the command's text without its trailing comment)."""


@dataclass
class Command:
    """A README command and the lines the README shows it printing (none for a ``sh`` block)."""

    text: str
    line: int
    expected: list[str] = field(default_factory=list)


def commands(readme: str) -> list[Command]:
    """The commands of the README's ``sh`` blocks and console blocks (``$`` lines), in order."""
    found: list[Command] = []
    block: str | None = None
    printing: Command | None = None  # the console command whose output the next lines are
    for number, line in enumerate(readme.splitlines(), 1):
        if line.startswith("```"):
            block, printing = (line[3:].strip() if block is None else None), None
        elif block == "sh" and line.strip() and not line.lstrip().startswith("#"):
            found.append(Command(without_comment(line), number))
        elif block == "" and line.startswith("$ "):
            printing = Command(without_comment(line[2:]), number)
            found.append(printing)
        elif printing is not None:
            printing.expected.append(line)
    return found


def without_comment(line: str) -> str:
    """The command without a trailing ``  # comment`` (none of the README's commands quotes a ``#``)."""
    return re.sub(r"\s+#\s.*$", "", line).strip()


def shown_in(expected: list[str], printed: str) -> str | None:
    """``None`` when the README's lines ``expected`` appear in ``printed`` in order (with the README's ways of
    leaving lines out); else the first line that does not, for the failure message."""
    lines = [line.rstrip() for line in printed.splitlines()]
    at = 0
    for wanted in (w.rstrip() for w in expected):
        if not wanted.strip() or wanted.strip() == "..." or re.fullmatch(r"\s*\(.*omitted here\)", wanted):
            continue
        prefix = wanted.endswith("...")
        stem = wanted[:-3] if prefix else wanted
        for k in range(at, len(lines)):
            if (lines[k].startswith(stem) if prefix else lines[k] == stem):
                at = k + 1
                break
        else:
            return wanted
    return None


def test_the_readme_commands_are_found_and_the_exclusions_are_current() -> None:
    """The parser sees the README's commands (so the test below runs something), and every exclusion still
    names a README command (so the list cannot go stale)."""
    found = commands((ROOT / "README.md").read_text(encoding="utf-8"))
    texts = [c.text for c in found]
    assert sorted(set(EXCLUDED) - set(texts)) == []
    run = [c for c in found if c.text not in EXCLUDED]
    assert any(c.text.startswith("symbolic identify emps") for c in run), texts
    assert all(c.expected for c in run if c.text.startswith("symbolic ")), [c.text for c in run if not c.expected]


def test_the_shipped_emps_experiments_find_the_data_beside_a_clone(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """The shipped experiment files' ``data`` reach ``shared/data/emps`` beside the checkout, without
    SYMBOLIC_DATA_PATH (they pointed one folder too high, and only the variable made them work)."""
    from symbolic.data.experiment import resolve_data
    from symbolic.data.files import read_toml

    monkeypatch.delenv("SYMBOLIC_DATA_PATH", raising=False)
    robots = tmp_path / "main" / "symbolic" / "robots"
    robots.mkdir(parents=True)
    emps = tmp_path / "shared" / "data" / "emps"
    emps.mkdir(parents=True)
    for name in EMPS_FILES:
        (emps / name).write_bytes(b"")
    for example in ("emps_estimation", "emps_pulses"):
        shipped = ROOT / "symbolic" / "robots" / f"{example}.experiment.toml"
        copy = robots / shipped.name
        shutil.copyfile(shipped, copy)
        name = read_toml(copy, "experiment")["data"]
        assert resolve_data(name, copy) == (emps / Path(name).name).resolve()


def test_a_data_file_found_nowhere_names_both_places_looked_at(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """As an installed package's examples are (not beside ``shared``): the error names the path looked at,
    absolute, and the variable's folders."""
    from symbolic.data import DataError
    from symbolic.data.experiment import resolve_data

    shipped = ROOT / "symbolic" / "robots" / "emps_estimation.experiment.toml"
    copy = tmp_path / "site-packages" / "symbolic" / "robots" / shipped.name
    copy.parent.mkdir(parents=True)
    shutil.copyfile(shipped, copy)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SYMBOLIC_DATA_PATH", str(tmp_path / "nowhere"))
    with pytest.raises(DataError) as raised:
        resolve_data("../../../shared/data/emps/DATA_EMPS.mat", Path("site-packages/symbolic/robots") / shipped.name)
    message = str(raised.value)
    assert f"looked at {tmp_path / 'shared' / 'data' / 'emps' / 'DATA_EMPS.mat'}" in message
    assert f"SYMBOLIC_DATA_PATH: {tmp_path / 'nowhere'}" in message and "DATA_EMPS.mat" in message


def clone(target: Path) -> Path:
    """The repository's tracked files, with the working tree's content, copied into ``target``."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("the README test needs the repository's git metadata (git ls-files) to copy what a clone holds")
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    for name in filter(None, listed.decode().split("\0")):
        source = ROOT / name
        if source.is_file():  # a file deleted in the working tree is not in the clone either
            (target / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target / name)
    return target


@pytest.mark.slow
def test_the_readme_commands_print_what_the_readme_shows(tmp_path: Path) -> None:
    missing = [name for name in EMPS_FILES if not (SHARED / "data" / "emps" / name).is_file()]
    if missing:
        pytest.skip(f"the README's EMPS examples need {', '.join(missing)} in {SHARED / 'data' / 'emps'} "
                    "(the folder shared beside the checkout, as a new user's)")
    main = clone(tmp_path / "main")
    (tmp_path / "shared").symlink_to(SHARED, target_is_directory=True)
    environment = {k: v for k, v in os.environ.items() if k not in ("SYMBOLIC_DATA_PATH", "PYTHONPATH")}
    environment["PYTHONPATH"] = str(main)
    environment["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), environment.get("PATH", "")])
    if shutil.which("symbolic", path=environment["PATH"]) is None:
        pytest.skip("no `symbolic` command beside this Python (pip install -e '.[dev]' makes it)")
    where = subprocess.run(["python3", "-c", "import symbolic; print(symbolic.__file__)"], cwd=main,
                           env=environment, capture_output=True, text=True)
    assert where.stdout.strip() == str(main / "symbolic" / "__init__.py"), where  # the clone's package runs
    for command in commands((main / "README.md").read_text(encoding="utf-8")):
        if command.text in EXCLUDED:
            continue
        result = subprocess.run(["bash", "-c", command.text], cwd=main, env=environment, capture_output=True,
                                text=True, timeout=300)
        where = f"README.md line {command.line}: {command.text}"
        assert result.returncode == 0, f"{where}\nexit {result.returncode}\n{result.stderr[-2000:]}"
        differs = shown_in(command.expected, result.stdout)
        assert differs is None, f"{where}\nthe README shows\n  {differs}\nthe command printed\n{result.stdout}"


def test_a_warning_of_the_package_fails_the_suite_and_a_models_warning_is_shown() -> None:
    """`python3 -m pytest` (the README's second command) shows real warnings only: pyproject.toml turns a
    warning attributed to the package's code into an error, the tests' own known ones are filtered where they
    arise, and the ModelWarning the package gives users on purpose stays a warning."""
    import warnings

    from symbolic.errors import ModelWarning

    with pytest.raises(RuntimeWarning):  # as NumPy's "overflow encountered" in a symbolic.* module would be
        warnings.warn_explicit("overflow", RuntimeWarning, "where.py", 1, module="symbolic.workflow.where")
    with warnings.catch_warnings(record=True) as caught:
        warnings.warn_explicit("units", ModelWarning, "units.py", 1, module="symbolic.data.units")
        warnings.warn_explicit("elsewhere", RuntimeWarning, "other.py", 1, module="numpy.lib")
    assert [str(w.message) for w in caught] == ["units", "elsewhere"]


def test_the_install_size_and_test_time_are_measurements_with_their_command_and_date() -> None:
    """The figures of the README's first block (1.1 GB and "8–12 min" were copied, not measured): each is given
    again in the paragraph below it, next to the command that measures it and the date of the measurement."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block, after = readme.split("```sh\n", 1)[1].split("```", 1)
    paragraph = after.split("\n\n", 2)[1]
    size = re.search(r"install \(([\d.]+ GB)\)", block)
    minutes = re.search(r"run the tests \(gcc; (\d+) min", block)
    assert size and minutes, block
    assert re.search(rf"`du -sh \.venv` after the `\[dev\]` install gave {re.escape(size.group(1))} \([^)]*\d{{4}}-\d\d-\d\d\)",
                     paragraph), paragraph
    assert re.search(rf"`time python3 -m pytest[^`]*` took\s+{minutes.group(1)} min", paragraph), paragraph
