"""Output folders get exactly the command's own files (symbolic/export/output.py, docs/contracts.md "Output
folders") and the output carries no machine path.

The kill tests run `symbolic generate` (or only its write phase, forked) with the write phase slowed by the
test hook SYMBOLIC_TEST_WRITE_DELAY, interrupt it with SIGINT or SIGKILL at seeded random moments of that
phase, and check that after the recovery the next run does first the folder holds exactly the previous set
or exactly the new one (bytes), with the user's own files kept; after a following normal run no temporary
file may remain.
"""

from __future__ import annotations

import logging
import os
import random
import signal
import subprocess
import sys
import shutil
import threading
import time
import warnings
from pathlib import Path

import pytest

import symbolic
import symbolic.cli
import symbolic.export as export
from symbolic.export import output

ROOT = Path(__file__).resolve().parents[1]
MODEL = (ROOT / "tests" / "golden" / "double_pendulum.toml").read_text()
# a second version of the model: link 2 twice as far out changes D, C, g and every function using them
MODEL_B = MODEL.replace('a = "l2"', 'a = "2*l2"')
FOREIGN = {"notes.txt": b"the user's own file\n", "sub/keep.txt": b"kept in a subdirectory\n"}


def snapshot(directory: Path) -> dict[str, bytes]:
    return {p.relative_to(directory).as_posix(): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


def put(directory: Path, files: dict[str, bytes]) -> None:
    for name, content in files.items():
        (directory / name).parent.mkdir(parents=True, exist_ok=True)
        (directory / name).write_bytes(content)


def synthetic(tag: str, count: int = 14) -> dict[str, bytes]:
    return {f"arm_{i:02d}.c": f"{tag} {i}\n".encode() * (i + 1) for i in range(count)}


# -- banners ---------------------------------------------------------------------------------


def test_banners_carry_no_machine_path(tmp_path: Path, monkeypatch) -> None:
    """The same model file given by two absolute paths, written to two directories, gives the same bytes."""
    monkeypatch.setattr(warnings, "formatwarning", warnings.formatwarning)  # cli.main replaces it
    monkeypatch.setattr(warnings, "filters", list(warnings.filters))
    outputs = []
    for place in ("first/deep/er", "second"):
        model = tmp_path / place / "pendulum.toml"
        model.parent.mkdir(parents=True)
        model.write_text(MODEL)
        out = tmp_path / place / "out"
        assert symbolic.cli.main(["-q", "generate", str(model), "--out", str(out), "--targets", "c,report,casadi"]) == 0
        outputs.append(snapshot(out))
    monkeypatch.chdir(tmp_path / "second")
    assert symbolic.cli.main(["-q", "generate", "pendulum.toml", "--out", "relative"]) == 0
    outputs.append(snapshot(tmp_path / "second" / "relative"))
    assert outputs[0] == outputs[1] == outputs[2]
    for name, content in outputs[0].items():
        assert str(tmp_path).encode() not in content and b"/first/" not in content, name
    head = outputs[0]["double_pendulum.c"].splitlines()[0].decode()
    assert head.endswith("regenerate with: symbolic generate pendulum.toml --out <dir> */"), head


def test_banner_names_chosen_targets_and_builtin_robots() -> None:
    assert export.regenerate_command("/home/someone/models/arm.toml", ["c"]) == "symbolic generate arm.toml --out <dir> --targets c"
    assert export.regenerate_command("fivebar", ["report", "casadi", "c"]) == "symbolic generate fivebar --out <dir>"
    assert export.regenerate_command("fivebar", ["report", "c"]) == "symbolic generate fivebar --out <dir> --targets c,report"


# -- the set is replaced as a whole ------------------------------------------------------------


INTERNAL = {output.MANIFEST}


def ours(directory: Path) -> dict[str, bytes]:
    """The snapshot without the writer's manifest."""
    return {k: v for k, v in snapshot(directory).items() if k not in INTERNAL}


def test_other_files_are_kept_and_stale_files_of_the_previous_set_removed(tmp_path: Path) -> None:
    out = tmp_path / "out"
    export.write_files(synthetic("old"), out)
    put(out, FOREIGN)
    os.symlink("notes.txt", out / "link")
    export.write_files(synthetic("new", 10), out)
    assert ours(out) == synthetic("new", 10) | FOREIGN | {"link": FOREIGN["notes.txt"]}
    assert os.readlink(out / "link") == "notes.txt"
    assert sorted(os.listdir(tmp_path)) == ["out"]
    assert not [n for n in os.listdir(out) if output.PARTIAL in n or n == output.JOURNAL]


def test_a_stale_file_changed_since_it_was_written_is_kept(tmp_path: Path, caplog) -> None:
    """issue 22 item 4: the stale effect_*.png of an earlier diagnosis go; one the user edited stays."""
    out = tmp_path / "out"
    export.write_files({"report.md": b"a", "effect_1.png": b"1", "effect_2.png": b"2", "effect_3.png": b"3"}, out)
    (out / "effect_3.png").write_bytes(b"annotated by hand")
    with caplog.at_level(logging.WARNING, logger="symbolic.export.output"):
        export.write_files({"report.md": b"b", "effect_1.png": b"one"}, out)
    assert ours(out) == {"report.md": b"b", "effect_1.png": b"one", "effect_3.png": b"annotated by hand"}
    assert "effect_3.png was written by an earlier run and changed since: kept" in caplog.text


def test_owned_directory_keeps_only_the_new_set_but_never_its_folders(tmp_path: Path) -> None:
    out = tmp_path / "out"
    export.write_files(synthetic("old"), out)
    put(out, FOREIGN)
    export.write_files(synthetic("new", 3), out, owned=True)
    assert snapshot(out) == synthetic("new", 3) | {"sub/keep.txt": FOREIGN["sub/keep.txt"]}
    assert sorted(os.listdir(tmp_path)) == ["out"]


def test_directory_mode_and_symlinked_output_are_kept(tmp_path: Path) -> None:
    real = tmp_path / "real"
    real.mkdir()
    os.chmod(real, 0o750)
    os.symlink("real", tmp_path / "out")
    export.write_files(synthetic("new"), tmp_path / "out")
    assert (tmp_path / "out").is_symlink() and ours(real) == synthetic("new")
    assert real.stat().st_mode & 0o777 == 0o750
    assert sorted(os.listdir(tmp_path)) == ["out", "real"]


def test_a_replaced_file_keeps_its_mode(tmp_path: Path) -> None:
    out = tmp_path / "out"
    export.write_files({"a.c": b"1"}, out)
    os.chmod(out / "a.c", 0o640)
    export.write_files({"a.c": b"2"}, out)
    assert (out / "a.c").read_bytes() == b"2" and (out / "a.c").stat().st_mode & 0o777 == 0o640


def test_leftovers_of_interrupted_runs_are_removed(tmp_path: Path) -> None:
    """Temporary files of this version and earlier ones (.NAME.XXXXXXXX.tmp), and 0.1's sibling folders."""
    out = tmp_path / "out"
    export.write_files(synthetic("old"), out)
    put(out, FOREIGN)
    (out / ".arm_03.c.k2j4_9xz.tmp").write_bytes(b"half")  # tempfile.mkstemp's name in earlier versions
    (out / f".arm_04.c{output.PARTIAL}0a1b2c3d").write_bytes(b"half")
    (tmp_path / ".out.symbolic-staging-00ff00ff").mkdir()
    (tmp_path / ".out.symbolic-staging-00ff00ff" / "arm_00.c").write_bytes(b"half")
    (tmp_path / ".other.symbolic-staging-00ff00ff").mkdir()  # another folder's: not ours to remove now
    export.write_files(synthetic("new"), out)
    assert ours(out) == synthetic("new") | FOREIGN
    assert sorted(os.listdir(tmp_path)) == [".other.symbolic-staging-00ff00ff", "out"]


def test_a_run_that_died_after_its_journal_is_completed_by_the_next(tmp_path: Path, monkeypatch) -> None:
    out = tmp_path / "out"
    export.write_files(synthetic("old"), out)
    put(out, FOREIGN)

    def die(directory, journal, pace):
        raise KeyboardInterrupt  # after the journal, before any rename

    monkeypatch.setattr(output, "_roll_forward", die)
    with pytest.raises(KeyboardInterrupt):
        export.write_files(synthetic("new", 5), out)
    monkeypatch.undo()
    assert ours(out) == synthetic("old") | FOREIGN | {output.JOURNAL: (out / output.JOURNAL).read_bytes()} | {
        k: v for k, v in snapshot(out).items() if output.PARTIAL in k}
    output.recover(out)
    assert ours(out) == synthetic("new", 5) | FOREIGN


def test_files_created_during_the_run_are_kept_even_in_sub_folders(tmp_path: Path, monkeypatch) -> None:
    """issue 22 item 3: files another process writes into DIR or a sub-folder during a run stay."""
    out = tmp_path / "out"
    export.write_files(synthetic("old"), out)
    put(out, FOREIGN)
    write = output._write_file

    def write_and_meddle(path: Path, content: bytes, like=None) -> None:
        write(path, content, like)
        if path.name.startswith(".arm_05.c"):  # while the new set is staged, someone adds files
            (out / "late.txt").write_bytes(b"late")
            (out / "sub" / "late.txt").write_bytes(b"late too")

    monkeypatch.setattr(output, "_write_file", write_and_meddle)
    export.write_files(synthetic("new"), out)
    assert ours(out) == synthetic("new") | FOREIGN | {"late.txt": b"late", "sub/late.txt": b"late too"}


def test_a_folder_with_the_name_of_an_output_file_is_refused_before_anything_changes(tmp_path: Path) -> None:
    out = tmp_path / "out"
    export.write_files({"a.c": b"1", "b.c": b"1"}, out)
    (out / "report.md").mkdir()
    with pytest.raises(export.ExportError, match="report.md"):
        export.write_files({"a.c": b"2", "report.md": b"2"}, out)
    assert ours(out) == {"a.c": b"1", "b.c": b"1"}
    assert not [n for n in os.listdir(out) if output.PARTIAL in n]


def test_reader_sees_complete_files_at_every_moment(tmp_path: Path, monkeypatch) -> None:
    """A reader while sets are replaced sees, file by file, the old content or the new, never a part."""
    out = tmp_path / "out"
    sets = [synthetic("old"), synthetic("new")]
    export.write_files(sets[0], out)
    monkeypatch.setenv(output.DELAY_VARIABLE, "0.002")
    done = threading.Event()
    seen: set[int] = set()

    def reader() -> None:
        while not done.is_set():
            for name in sets[0]:
                content = (out / name).read_bytes()
                assert content in (sets[0][name], sets[1][name]), name
                seen.add(int(content == sets[1][name]))

    thread = threading.Thread(target=reader)
    thread.start()
    try:
        k, deadline = 0, time.monotonic() + 60.0
        while (k < 6 or seen != {0, 1}) and time.monotonic() < deadline:
            export.write_files(sets[(k + 1) % 2], out)
            k += 1
    finally:
        done.set()
        thread.join()
    assert seen == {0, 1}


# -- what the command does not own (issue 22 items 1 and 2) -----------------------------------------


def _mount_tmpfs(where: Path) -> bool:
    if os.geteuid() != 0 or not shutil.which("mount"):
        return False
    return subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(where)], capture_output=True).returncode == 0


def test_a_mount_and_another_users_folder_inside_out_are_left_alone(tmp_path: Path) -> None:
    out = tmp_path / "out"
    (out / "mnt").mkdir(parents=True)
    if not _mount_tmpfs(out / "mnt"):
        pytest.skip("needs root and mount(8) to mount a tmpfs (CI runs as root)")
    try:
        (out / "mnt" / "data.bin").write_bytes(b"on another file system")
        (out / "theirs").mkdir()
        (out / "theirs" / "f.txt").write_bytes(b"theirs")
        os.chown(out / "theirs", 12345, 12345)
        os.chmod(out, 0o751)
        before = {p: (os.lstat(out / p).st_uid, os.lstat(out / p).st_mode) for p in ("", "theirs", "mnt")}
        for k in range(2):
            export.write_files(synthetic(f"v{k}"), out)
        assert (out / "mnt" / "data.bin").read_bytes() == b"on another file system"
        assert (out / "theirs" / "f.txt").read_bytes() == b"theirs"
        assert {p: (os.lstat(out / p).st_uid, os.lstat(out / p).st_mode) for p in before} == before
    finally:
        subprocess.run(["umount", str(out / "mnt")], check=False)


@pytest.mark.parametrize("out, message", [("", "--out is empty"), (".", "contains the working folder"),
                                          ("..", "contains the working folder")])
def test_an_empty_out_or_one_holding_the_working_folder_is_refused(tmp_path: Path, out: str, message: str) -> None:
    work = tmp_path / "work"
    work.mkdir()
    (work / "mine.txt").write_text("mine")
    result = subprocess.run([sys.executable, "-m", "symbolic", "-q", "generate", "emps", "--out", out],
                            capture_output=True, text=True, cwd=work)
    assert result.returncode == 2 and message in result.stderr and "Traceback" not in result.stderr
    assert sorted(os.listdir(work)) == ["mine.txt"] and sorted(os.listdir(tmp_path)) == ["work"]


def test_a_dead_writers_temporary_file_is_removed_by_the_next_write(tmp_path: Path) -> None:
    """issue 22 item 5: `identify --out FILE` killed during its write left .FILE.XXXX.tmp for ever."""
    import fcntl

    from symbolic.writing import PARTIAL, replacing

    target = tmp_path / "arm.toml"
    dead = tmp_path / f".arm.toml{PARTIAL}deadbeef"
    dead.write_text("half")  # nobody holds it: its writer died
    alive = tmp_path / f".arm.toml{PARTIAL}0a1b2c3d"
    alive.write_text("being written")
    with open(alive) as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)  # a concurrent writer, still at work
        with replacing(target) as temporary:
            temporary.write_text("complete")
        assert sorted(os.listdir(tmp_path)) == [alive.name, "arm.toml"]
    assert target.read_text() == "complete"


# -- interrupted `symbolic generate` ------------------------------------------------------------


def generate(model: Path, out: Path, delay: float = 0.0) -> subprocess.Popen:
    env = {**os.environ, output.DELAY_VARIABLE: str(delay)}
    return subprocess.Popen([sys.executable, "-m", "symbolic", "-q", "generate", str(model), "--out", str(out)],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


class Forked:
    """A child process running only the write phase of `symbolic generate` (write_files), slowed."""

    def __init__(self, files: dict[str, bytes], out: Path, delay: float) -> None:
        self.pid = os.fork()
        if self.pid == 0:
            status = 1
            try:
                os.environ[output.DELAY_VARIABLE] = str(delay)
                export.write_files(files, out)
                status = 0
            except KeyboardInterrupt:
                status = 130
            finally:
                os._exit(status)
        self.returncode: int | None = None

    def poll(self) -> int | None:
        if self.returncode is None:
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            self.returncode = None if pid == 0 else os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self) -> int:
        while self.poll() is None:
            time.sleep(0.001)
        return self.returncode


def temporary_names(out: Path) -> set[str]:
    return {name for name in os.listdir(out) if output.PARTIAL in name}


def write_phase(launch, out: Path):
    """Launch a run; return it and the moment its first temporary file appeared (its write phase began)."""
    before = temporary_names(out)
    process = launch()
    while not temporary_names(out) - before:
        assert process.poll() is None, "the run ended before its write phase"
        time.sleep(0.001)
    return process, time.monotonic()


@pytest.fixture(scope="module")
def versions(tmp_path_factory) -> tuple[list[Path], list[dict[str, bytes]]]:
    """The model files of two versions of one model and their complete output sets (normal CLI runs)."""
    base = tmp_path_factory.mktemp("versions")
    models, sets = [], []
    for version, text in (("a", MODEL), ("b", MODEL_B)):
        (base / version).mkdir()
        models.append(base / version / "double_pendulum.toml")
        models[-1].write_text(text)
        assert generate(models[-1], base / f"reference_{version}").wait() == 0
        sets.append(ours(base / f"reference_{version}"))
    assert sum(sets[0][k] != sets[1][k] for k in sets[0]) >= 10  # most files differ between the versions
    return models, sets


def interrupted(launch, out: Path, phase: float, sets, k: int, rng: random.Random) -> int:
    """Interrupt a run at a uniformly random moment of its write phase, recover as the next run would, and
    return which set ``out`` holds."""
    how = signal.SIGINT if rng.random() < 0.5 else signal.SIGKILL
    process, begin = write_phase(launch, out)
    time.sleep(max(0.0, begin + rng.uniform(0, phase) - time.monotonic()))
    os.kill(process.pid, how)
    process.wait()
    output.recover(out)
    now = {k: v for k, v in ours(out).items() if output.PARTIAL not in k}
    assert now in (sets[0] | FOREIGN, sets[1] | FOREIGN), f"interruption {k} ({how.name}): a mixture of the two sets"
    return 0 if now == sets[0] | FOREIGN else 1


@pytest.mark.slow
def test_interrupted_generate_leaves_the_old_or_the_new_set(tmp_path: Path, versions) -> None:
    """`symbolic generate` interrupted by SIGINT or SIGKILL at random moments of its (slowed) write phase."""
    models, sets = versions
    out = tmp_path / "out"
    out.mkdir()
    put(out, sets[0] | FOREIGN)
    delay = 0.02
    process, begin = write_phase(lambda: generate(models[1], out, delay), out)  # uninterrupted: the phase's length
    assert process.wait() == 0
    phase = time.monotonic() - begin
    assert ours(out) == sets[1] | FOREIGN
    rng, state = random.Random(15), 1
    for k in range(6):
        model = models[1 - state]
        state = interrupted(lambda: generate(model, out, delay), out, phase, sets, k, rng)
    assert generate(models[0], out).wait() == 0
    assert ours(out) == sets[0] | FOREIGN
    assert sorted(os.listdir(tmp_path)) == ["out"]
    assert [p.name for p in out.rglob("*") if p.name.startswith(".")] == [output.MANIFEST]


@pytest.mark.slow
def test_write_phase_interrupted_at_many_moments(tmp_path: Path, versions) -> None:
    """The same, many more times and cheaper: each run is a forked child doing only the write phase
    of the two sets rendered once."""
    _, sets = versions
    out = tmp_path / "out"
    out.mkdir()
    put(out, sets[0] | FOREIGN)
    delay = 0.004
    phases = []
    for k in range(3):  # uninterrupted runs: the phase's length (median, as the machine may be busy)
        process, begin = write_phase(lambda: Forked(sets[(k + 1) % 2], out, delay), out)
        assert process.wait() == 0
        phases.append(time.monotonic() - begin)
    phase = sorted(phases)[1]
    rng, state, outcomes = random.Random(15), 1, []
    for k in range(80):
        target = 1 - state
        state = interrupted(lambda: Forked(sets[target], out, delay), out, phase, sets, k, rng)
        outcomes.append(state == target)
    # interruptions landed both before and after the journal (which comes at about half of the phase)
    assert 2 <= sum(outcomes) <= 78, (phases, outcomes)
    export.write_files(sets[0], out)
    assert ours(out) == sets[0] | FOREIGN
    assert sorted(os.listdir(tmp_path)) == ["out"]
