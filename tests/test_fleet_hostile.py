"""Hostile and mistaken inputs to ``symbolic campaign`` (docs/fleet.md): a log that is a link to another file, a
data file whose content would be copied into the results, a scheduler that accepts connections and never
answers, addresses Dask cannot parse, Ctrl-C on a local cluster, a log listed twice under two names, a
misspelt ``[task] fix``, a file named ``cache`` in the output folder. Each is refused in one line, or is a
row of the results, before anything is written; nothing quotes more than a short excerpt of a file.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from symbolic import cli, fleet
from symbolic.data import DataError, files
from symbolic.errors import ClusterError, ExportError
from symbolic.fleet import campaign as campaigns

ROOT = Path(__file__).resolve().parents[1]
needs_dask = pytest.mark.skipif(not fleet.available(), reason="dask.distributed is not installed")

CAMPAIGN = '''[task]
kind = "identify"
[[robot]]
id = "r1"
model = "emps"
logs = "logs/**/*.csv"
time = { from = "name", pattern = '(\\d{8})', format = "%Y%m%d" }
'''
LOG = "t,q_q,tau_q\n0,0,0\n0.001,0.1,1\n"
SECRET = "secret-0123456789-abcdefghijklmnopqrstuvwxyz-SECRET"


def plant(folder: Path, text: str = CAMPAIGN) -> Path:
    """A campaign file and one plain log in ``folder``."""
    (folder / "logs").mkdir(parents=True, exist_ok=True)
    (folder / "logs" / "a_20240301.csv").write_text(LOG)
    path = folder / "plant.toml"
    path.write_text(text)
    return path


def secret(folder: Path) -> Path:
    """A file the campaign's user may read but never named as a log: its content must not reach any output."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "private.csv"
    path.write_text(f"{SECRET}\n{SECRET},{SECRET}\n")
    return path


def written(out: Path) -> str:
    return "".join(p.read_text(errors="replace") for p in out.rglob("*") if p.is_file())


# --- links among the logs and the content errors quote ---------------------------------------------------------------

def test_a_log_that_is_a_link_is_a_row_named_as_the_campaign_names_it_and_is_never_read(tmp_path: Path) -> None:
    folder = tmp_path / "plant"
    path = plant(folder)
    private = secret(tmp_path / "elsewhere")
    (folder / "logs" / "b_20240302.csv").symlink_to(private)  # a link planted among the logs
    (folder / "logs" / "sub").symlink_to(private.parent, target_is_directory=True)  # a folder a wildcard reaches
    (private.parent / "c_20240303.csv").write_text(f"{SECRET}\n1\n")
    out = tmp_path / "out"
    outcome = fleet.run(campaigns.load(path), out, workers=0, figures=False)
    errors = {r["log"]: r["error"] for r in outcome.rows}
    assert errors["logs/b_20240302.csv"] == ("logs/b_20240302.csv: is a symbolic link: not read (a campaign reads only "
                                             "logs that are files, not links; name the file itself)")
    assert errors["logs/sub/c_20240303.csv"].startswith("logs/sub/c_20240303.csv: is reached through the symbolic "
                                                        "link 'sub': not read")
    assert "symbolic link" not in errors["logs/a_20240301.csv"]
    assert SECRET[:10] not in written(out) and "elsewhere" not in written(out)


def test_a_listed_log_that_is_a_link_is_refused_and_a_linked_folder_the_campaign_names_is_read(tmp_path: Path) -> None:
    folder = tmp_path / "plant"
    real = tmp_path / "mounted"  # the plant's log folder, mounted elsewhere and linked: the user's own choice
    real.mkdir()
    (real / "a_20240301.csv").write_text(LOG)
    folder.mkdir()
    (folder / "logs").symlink_to(real, target_is_directory=True)
    (real / "b.csv").symlink_to(secret(tmp_path / "elsewhere"))
    text = CAMPAIGN.replace('logs = "logs/**/*.csv"\ntime = { from = "name", pattern = \'(\\d{8})\', format = "%Y%m%d" }',
                            '[[robot.log]]\nfile = "logs/a_20240301.csv"\ntime = 2024-03-01\n'
                            '[[robot.log]]\nfile = "logs/b.csv"\ntime = 2024-03-02')
    (folder / "plant.toml").write_text(text)
    robot, = campaigns.load(folder / "plant.toml").robots
    assert [(log.name, log.refused) for log in robot.logs] == [
        ("logs/a_20240301.csv", None), ("logs/b.csv", f"is a symbolic link: {campaigns.NOT_READ}")]


@pytest.mark.parametrize("text, quoted", [
    (f"t,q_q,{'x' * 200}\n0,0,0\n0,0,abc\n", "line 3 column 'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx'… (200 characters)"),
    (f"t,q_q,tau_q\n0,0,0\n0,0,{'y' * 300}\n", "cannot read 'yyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyy'… (300 characters)"),
    ("t,q_q,tau_q\n0,0,\x1b[2J\x07\n", r"cannot read '\x1b[2J\x07' as a number"),
    (f"{'1,' * 60}1\n", "the first line '1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,'… (121 characters) is numbers"),
    (f"t,{'z' * 100},{'z' * 100}\n", "column name 'zzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzz'… (100 characters) appears twice"),
])
def test_a_data_file_error_quotes_a_short_escaped_excerpt_of_the_file(tmp_path: Path, text: str, quoted: str) -> None:
    path = tmp_path / "log.csv"
    path.write_text(text)
    with pytest.raises(DataError) as raised:
        files.read(path)
    message = str(raised.value)
    assert quoted in message and message.isprintable(), message
    assert not any(text[k:k + 61] in message for k in range(len(text) - 60)), message  # at most 60 characters of it


def test_a_length_mismatch_names_a_bounded_list_of_the_columns(tmp_path: Path) -> None:
    path = tmp_path / "log.csv"
    path.write_text(",".join(["t", *[f"c{k}_{'w' * 50}" for k in range(100)]]) + "\n0,1\n")
    with pytest.raises(DataError, match=r"length mismatch: 2 fields, the header has 101 \(t, 'c0_w+'…") as raised:
        files.read(path)
    assert len(str(raised.value)) < 700 and "and 89 more" in str(raised.value)


# --- the scheduler: addresses, a port that never answers, nothing written before it is reached -----------------------

@needs_dask
@pytest.mark.parametrize("address, problem", [("nonsense://x:1", "unknown scheme 'nonsense'"),
                                              ("http://127.0.0.1:18799", "unknown scheme 'http'"),
                                              ("tcp://127.0.0.1", "no port"),
                                              ("inproc://x", "unknown scheme 'inproc'"),
                                              ("tcp://127.0.0.1:70000", "port 70000 out of range"),
                                              ("tcp://a b:1", "not an address")])
def test_an_address_dask_cannot_parse_is_one_line_and_nothing_is_written(address, problem, tmp_path, capsys) -> None:
    path = plant(tmp_path)
    out = tmp_path / "out"
    assert cli.main(["-q", "campaign", str(path), "--out", str(out), "--scheduler", address]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: --scheduler ") and problem in err, err
    assert "expected tcp://HOST:PORT (or tls://, ws://, wss://" in err
    assert not out.exists()


@pytest.fixture
def silent_port():
    """A TCP port that accepts connections and never answers (not a Dask scheduler)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    accepted = []

    def accept() -> None:
        try:
            while True:
                accepted.append(server.accept()[0])
        except OSError:  # the listening socket closed: the test is over
            pass

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    server.close()
    for connection in accepted:
        connection.close()


@needs_dask
def test_a_scheduler_that_never_answers_is_an_error_within_the_connect_timeout(silent_port, tmp_path, capsys) -> None:
    path = plant(tmp_path)
    out = tmp_path / "out"
    started = time.monotonic()
    with pytest.raises(ClusterError, match=r"--scheduler tcp://127\.0\.0\.1:\d+: no Dask scheduler answered within "
                                           r"0\.5 s"):
        fleet.run(campaigns.load(path), out, scheduler=silent_port, connect_timeout=0.5)
    assert time.monotonic() - started < 8
    assert not out.exists()  # not even the cache's file digests: nothing before the cluster is reached
    assert cli.main(["-q", "campaign", str(path), "--out", str(out), "--scheduler", silent_port,
                     "--connect-timeout", "0.5"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no Dask scheduler answered within 0.5 s" in err and not out.exists()


@needs_dask
def test_the_connect_timeout_is_in_the_help_and_checked(capsys) -> None:
    with pytest.raises(SystemExit):
        cli.main(["campaign", "--help"])
    assert "(default 10)" in " ".join(capsys.readouterr().out.split())
    assert cli.main(["campaign", "plant.toml", "--out", "out", "--connect-timeout", "0"]) == 2
    assert "--connect-timeout 0: expected a positive number of seconds" in capsys.readouterr().err


# --- Ctrl-C on a local cluster ----------------------------------------------------------------------------------------

@needs_dask
@pytest.mark.slow
def test_ctrl_c_on_a_local_cluster_exits_130_with_one_line(tmp_path: Path) -> None:
    """The terminal sends SIGINT to every process of the group, the workers included: only the command speaks."""
    import fleet_cases

    path = fleet_cases.fleet(tmp_path / "fleet", logs=2, robots=1, seconds=30.0, kind="diagnose")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    process = subprocess.Popen([sys.executable, "-m", "symbolic", "campaign", str(path), "--out", str(tmp_path / "out"),
                                "--workers", "2"], env=env, cwd=tmp_path, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        lines = []
        while "starting a local cluster" not in (lines or [""])[-1]:
            lines.append(process.stderr.readline())
            assert lines[-1], "".join(lines)
        time.sleep(0.5)  # while the cluster starts: Dask's processes printed their tracebacks then
        os.killpg(process.pid, signal.SIGINT)
        rest = process.stderr.read()
        assert process.wait(timeout=60) == 130
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    assert "Traceback" not in rest and rest.strip() == "interrupted", rest


# --- the campaign file ---------------------------------------------------------------------------------------------

def test_the_same_log_under_two_names_is_listed_twice(tmp_path: Path) -> None:
    text = CAMPAIGN.replace('logs = "logs/**/*.csv"\ntime = { from = "name", pattern = \'(\\d{8})\', format = "%Y%m%d" }',
                            '[[robot.log]]\nfile = "logs/a_20240301.csv"\ntime = 2024-03-01\n'
                            '[[robot.log]]\nfile = "logs/../logs/./a_20240301.csv"\ntime = 2024-03-08')
    path = plant(tmp_path, text)
    with pytest.raises(DataError, match=r"\[\[robot\]\] 'r1' logs: 'logs/a_20240301.csv' is listed twice \(as "
                                        r"'.*logs/\.\./logs/a_20240301\.csv' and '.*logs/a_20240301\.csv'\)"):
        campaigns.load(path)


@pytest.mark.parametrize("change, key", [(('kind = "identify"', 'kind = "identify"\nfix = ["Fcc"]'), "[task] fix"),
                                         (('model = "emps"', 'model = "emps"\n[robot.task]\nkind = "diagnose"\n'
                                                             'fix = ["M", "ofset"]'), "[[robot]] 'r1' task fix")])
def test_a_misspelt_fixed_parameter_is_refused_before_any_work(change, key, tmp_path: Path) -> None:
    text = CAMPAIGN.replace(*change)
    if "[robot.task]" in text:  # the robot's own table after its keys
        text = text.replace('\n[robot.task]\nkind = "diagnose"\nfix = ["M", "ofset"]', "") + \
            '[robot.task]\nkind = "diagnose"\nfix = ["M", "ofset"]\n'
    path = plant(tmp_path, text)
    with pytest.raises(DataError) as raised:
        campaigns.load(path)
    message = str(raised.value)
    wrong, near = ("Fcc", "Fc") if "Fcc" in text else ("ofset", "offset")
    assert message.startswith(f"{path}: {key}: unknown parameter(s) {wrong} of the model 'emps' (its parameters: "
                              f"M, Fv, Fc, offset, gtau); did you mean '{near}'?"), message


# --- the output folder --------------------------------------------------------------------------------------------------

def test_a_file_named_cache_in_the_output_folder_is_a_precise_error(tmp_path: Path, capsys) -> None:
    path = plant(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "cache").write_text("mine")
    with pytest.raises(ExportError, match="cache is not a folder: a campaign keeps its results between runs in the "
                                          "folder cache/ of its output folder"):
        fleet.run(campaigns.load(path), out, workers=0)
    assert cli.main(["-q", "campaign", str(path), "--out", str(out), "--workers", "0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Errno" not in err and "cache is not a folder" in err
    assert [p.name for p in out.iterdir()] == ["cache"] and (out / "cache").read_text() == "mine"
