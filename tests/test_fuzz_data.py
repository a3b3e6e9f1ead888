"""Fuzzing data files (CSV, NPZ) and experiment files through the command line (issue 22, "Done when").

Hypothesis builds logs for the EMPS axis — plausible ones (a two-sine motion and its forces, so that many
reach the least squares and the search) and hostile ones (empty, constant, huge, tiny, NaN, repeated or
millisecond time, misnamed, truncated, pickled or lying ``.npy`` headers, numeric header lines) — and
experiment files mapping them (random ``[signals]`` expressions, ``[constants]``, ``[window]``,
``[identification]`` and ``[controller]`` values, extreme numbers among them). Each is run through
:func:`symbolic.cli.main` in this process under a deadline (tests/deadline.py), and must end in one of two
ways: exit 0 with every printed number finite (no ``nan``/``inf`` in the output, no ``not_finite`` in the
JSON), or exit 2 with one error line and no traceback.

The default profiles are small (about a minute in all); the ``slow`` tests run the same with many more
examples.
"""

from __future__ import annotations

import json
import re
import struct
import warnings
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from deadline import within
from symbolic import cli
from test_fuzz_model_files import toml_document

NON_FINITE = re.compile(r"(?<![\w.])-?(nan|inf|NaN|Infinity)(?![\w])")
"""A non-finite number as Python, NumPy or JSON print it (not inside a word such as 'information')."""

FUZZ = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                                      HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much])

RATES = st.sampled_from([500.0, 1000.0, 200.0, 50.0, 1e-3, 1.0, 3e9, 1e12])
LENGTHS = st.sampled_from([0, 1, 2, 3, 30, 150, 400, 700])
SHAPES = ("sine", "sine", "sine", "zeros", "constant", "noise", "ramp", "huge", "tiny", "nan", "inf", "steps", "big")
TIMES = ("uniform", "uniform", "uniform", "ms", "jitter", "repeat", "decreasing", "nan", "offset", "dense")


def signal(shape: str, t: np.ndarray, seed: int) -> np.ndarray:
    """A signal of the given kind on the time stamps ``t`` (plausible: "sine"; the others hostile)."""
    rng = np.random.default_rng(seed)
    n = len(t)
    u = np.arange(n) / 500.0
    base = 0.1 * np.sin(2 * np.pi * 0.5 * u) + 0.05 * np.sin(2 * np.pi * 1.7 * u + seed % 7)
    values = {
        "sine": base,
        "zeros": np.zeros(n),
        "constant": np.full(n, 3.25),
        "noise": rng.normal(size=n),
        "ramp": np.linspace(-1.0, 1.0, n),
        "huge": 1e300 * np.sign(base + 1e-9),
        "tiny": 1e-300 * base,
        "steps": np.repeat(rng.normal(size=max(1, n // 10 + 1)), 10)[:n],
        "big": 1e29 * base,
    }
    if shape in values:
        return values[shape]
    out = base.copy()
    if n:
        out[rng.integers(0, n)] = np.nan if shape == "nan" else np.inf
    return out


def force_of(q: np.ndarray) -> np.ndarray:
    """EMPS-like forces of a position signal sampled at 500 Hz (M q̈ + Fv q̇ + Fc sign q̇ + offset)."""
    if len(q) < 3:
        return np.zeros(len(q))
    with np.errstate(all="ignore"):  # a hostile q (nan, inf, 1e308) gives nan or inf forces: wanted here
        qd = np.gradient(q, 1 / 500.0)
        qdd = np.gradient(qd, 1 / 500.0)
        return 95 * qdd + 200 * qd + 20 * np.sign(qd) - 3


def times(kind: str, n: int, rate: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    if kind == "ms":
        return t * 1e3
    if kind == "jitter":
        return t + rng.uniform(0, 0.4 / rate, n)
    if kind == "repeat" and n > 2:
        t[n // 2] = t[n // 2 - 1]
    if kind == "decreasing":
        return t[::-1].copy()
    if kind == "nan" and n:
        t[rng.integers(0, n)] = np.nan
    if kind == "offset":
        return t + 1e9
    if kind == "dense":
        return t * 1e-12
    return t


PLAUSIBLE_SHAPES = ("sine", "sine", "sine", "zeros", "constant", "noise", "huge", "tiny", "big", "steps")


@st.composite
def logs(draw, plausible: bool | None = None) -> dict[str, np.ndarray]:
    """Columns of a log: t, q_q and tau_q (or u_q) of one of many kinds, and optional others. A plausible log
    (two times in three) is long enough, uniformly sampled and complete, so that it reaches the treatment and
    the least squares; its numbers may still be hostile."""
    if plausible is None:
        plausible = draw(st.integers(0, 2)) > 0
    seed = draw(st.integers(0, 2**16))
    if plausible:
        n, rate = draw(st.sampled_from([400, 700, 1500])), draw(st.sampled_from([500.0, 1000.0, 200.0]))
        t = times(draw(st.sampled_from(["uniform"] * 6 + ["ms", "jitter", "offset"])), n, rate, seed)
        q = signal(draw(st.sampled_from(["sine"] * 4 + ["ramp", "steps", "constant", "big"])), t, seed)
    else:
        n, rate = draw(LENGTHS), draw(RATES)
        t = times(draw(st.sampled_from(TIMES)), n, rate, seed)
        q = signal(draw(st.sampled_from(SHAPES)), t, seed)
    plausible_force = draw(st.integers(0, 2)) > 0 if plausible else draw(st.booleans())
    tau = force_of(q) + np.random.default_rng(seed).normal(0, 0.5, n) if plausible_force else \
        signal(draw(st.sampled_from(PLAUSIBLE_SHAPES if plausible else SHAPES)), t, seed + 1)
    columns = {"t": t, "q_q": q, draw(st.sampled_from(["tau_q"] * 4 + ["u_q"])): tau}
    extras = ["qd_q", "ref_q", "qdd_q", "extra"] + ([] if plausible else ["q_other", "tau_other"])
    for name in draw(st.lists(st.sampled_from(extras), max_size=2, unique=True)):
        columns[name] = signal(draw(st.sampled_from(PLAUSIBLE_SHAPES if plausible else SHAPES)), t, seed + 2)
    if not plausible and draw(st.integers(0, 4)) == 0:  # one column of another length
        name = draw(st.sampled_from(sorted(columns)))
        columns[name] = columns[name][: max(0, n - 1)]
    if not plausible and draw(st.integers(0, 4)) == 0:  # one column missing
        columns.pop(draw(st.sampled_from(sorted(columns))))
    return columns


def number(value: float) -> str:
    return repr(float(value)) if np.isfinite(value) else str(value)


@st.composite
def csv_texts(draw) -> str:
    """A CSV file of a log, sometimes malformed: no header, numeric or duplicate names, comments, bad fields."""
    plausible = draw(st.integers(0, 2)) > 0
    columns = draw(logs(plausible))
    names = list(columns)
    length = max((len(v) for v in columns.values()), default=0)
    rows = [[number(columns[k][i]) if i < len(columns[k]) else "" for k in names] for i in range(length)]
    header = "names" if plausible else draw(st.sampled_from(["names", "none", "numbers", "duplicate", "comment", "bom"]))
    lines = []
    if header == "comment" or (plausible and draw(st.integers(0, 3)) == 0):
        lines.append("# logged by a fuzzer")
    if header in ("names", "comment", "bom"):
        lines.append(("\ufeff" if header == "bom" else "") + ",".join(names))
    elif header == "numbers":
        lines.append(",".join("-0.000000" for _ in names))
    elif header == "duplicate":
        lines.append(",".join(names[:1] * len(names)))
    for row in rows:
        if not plausible and rows and draw(st.integers(0, 40)) == 0:
            row = [*row[:-1], draw(st.sampled_from(["abc", "", "1e999", "0x10", "1,2", " ", "nan", "--1"]))]
        lines.append(",".join(row))
    if not plausible and draw(st.integers(0, 5)) == 0:
        lines.append(draw(st.sampled_from(["", ",,,", "1", "end"])))
    return "\n".join(lines) + "\n"


def npy_header(shape: tuple[int, ...], descr: str = "<f8", fortran: bool = False) -> bytes:
    text = "{'descr': '%s', 'fortran_order': %s, 'shape': %r, }" % (descr, fortran, shape)
    text += " " * (63 - (10 + len(text)) % 64) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(text)) + text.encode()


@st.composite
def npz_bytes(draw, folder: Path) -> Path:
    """An .npz archive of a log: arrays as they are, some reshaped or retyped, some members with a lying header."""
    plausible = draw(st.integers(0, 2)) > 0
    columns = draw(logs(plausible))
    path = folder / "log.npz"
    arrays: dict[str, Any] = {}
    forms = ["as is", "as is", "column", "row", "float32"] + ([] if plausible else ["int", "bool", "scalar", "matrix",
                                                                                     "complex", "text"])
    for name, values in columns.items():
        form = draw(st.sampled_from(forms))
        with np.errstate(over="ignore"):  # hostile on purpose: 1e300 as float32 is inf (every form is built)
            arrays[name] = {"as is": values, "column": values[:, None], "row": values[None, :],
                            "int": np.nan_to_num(values).clip(-1e18, 1e18).astype(np.int64),
                            "float32": values.astype(np.float32), "bool": values > 0,
                            "scalar": np.float64(values[0]) if len(values) else np.float64(1.0),
                            "matrix": np.resize(values, (3, max(1, len(values) // 3))) if len(values) else values,
                            "complex": values.astype(complex), "text": values.astype(str)}[form]
    if draw(st.integers(0, 4)) == 0:
        arrays["gtau"] = np.array(draw(st.sampled_from([35.15, 0.0, 1e300, -1.0, np.nan])))
    save = np.savez_compressed if draw(st.booleans()) else np.savez
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        save(path, **arrays)
    trick = "none" if plausible else draw(st.sampled_from(["none", "claims", "truncated", "not npy", "garbage", "fortran"]))
    if trick != "none":
        with zipfile.ZipFile(path, "a") as archive:
            name = draw(st.sampled_from(["t", "q_q", "tau_q", "x"]))
            body = {"claims": npy_header((2**40,)) + bytes(64), "truncated": npy_header((10**6,)) + bytes(80),
                    "not npy": b"plain text", "garbage": b"\x93NUMPY\x09\x00garbage",
                    "fortran": npy_header((2, 3), fortran=True) + np.arange(6.0).tobytes()}[trick]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a duplicate member name: the later one is what a reader sees
                archive.writestr(f"{name}.npy" if trick != "not npy" else f"{name}.txt", body)
    return path


EXPRESSIONS = st.sampled_from([
    "q_q", "2*q_q", "q_q/0", "q_q**2", "sin(q_q)", "exp(q_q*1e3)", "log(q_q)", "sqrt(q_q)", "q_q + c", "c*tau_q",
    "tau_q", "-tau_q", "t", "t*1e-3", "t*1e3", "t + 1e20", "1", "0", "c", "q_q**16", "tau_q*1e29", "abs(q_q)",
    "sign(tau_q)", "atan2(q_q, t)", "q_q + ", "__import__('os')", "missing", "t/(t-t)", "tau_q**0.5",
])
NUMBERS = st.one_of(st.sampled_from([0, 1, 2, 4, 10, 16, 17, 200, -1, 2**62, 2**63 - 1, 0.5, 20.0, 1e-300, 1e300,
                                     1e308, 1e-3, 499.9, 500.0, float("nan"), float("inf"), -float("inf")]),
                    st.floats(allow_nan=True, allow_infinity=True), st.integers(-(2**63), 2**63 - 1))
ODD = st.one_of(NUMBERS, st.booleans(), st.text(max_size=5), st.lists(NUMBERS, max_size=3))


CONTROLLERS = st.sampled_from([
    {"kind": "torque"},
    {"kind": "pd", "kp": [2000.0], "kd": [300.0], "reference": ["0.1*sin(t)"]},
    {"kind": "cascade", "kp": [160.0], "kv": [240.0], "gain": [35.15], "reference": ["0"], "saturation": [10.0],
     "velocity_filter": [0.5, 0.5]},
    {"kind": "pid", "kp": [1e3], "kd": [50.0], "ki": [10.0], "reference": ["0"]},
    {"kind": "state_feedback", "inputs": ["q"], "states": ["q_q", "qd_q"], "K": [[1000.0, 50.0]]},
])
CONTROLLER_KEYS = ["kind", "kp", "kd", "ki", "kv", "gain", "saturation", "quantisation", "velocity_filter", "reference",
                   "coordinates", "K", "inputs", "states", "kpp"]


@st.composite
def experiments(draw, data: str, columns: tuple[str, ...] = ("t", "q_q", "tau_q")) -> dict[str, Any]:
    """An experiment file's contents for the data file ``data`` with ``columns``: a plausible file mapping them
    with up to three changes, each a plausible or a hostile value of one key or table."""
    signals = {name: name for name in columns if name in ("t", "q_q", "tau_q", "u_q", "ref_q")}
    if "u_q" in signals and draw(st.booleans()):
        signals.pop("u_q")
        signals["tau_q"] = "35.15*u_q"
    spec: dict[str, Any] = {"data": data, "model": "emps", "signals": signals}
    for change in draw(st.lists(st.sampled_from(["signal", "signal", "constants", "rate", "window", "resample",
                                                 "identification", "identification", "identification", "controller",
                                                 "controller", "model", "unknown"]), max_size=3)):
        if change == "signal":
            name = draw(st.sampled_from(["t", "q_q", "tau_q", "tau_q", "ref_q", "qd_q", "extra", "q_x", "1bad", "rate"]))
            if draw(st.integers(0, 5)) == 0:
                spec["signals"].pop(name, None)
            else:
                spec["signals"][name] = draw(EXPRESSIONS | NUMBERS)
        elif change == "constants":
            spec["constants"] = {"c": draw(NUMBERS), **({"q_q": 1.0} if draw(st.integers(0, 9)) == 0 else {})}
        elif change == "rate":
            spec["rate"] = draw(NUMBERS)
            if draw(st.booleans()):
                spec["signals"].pop("t", None)
        elif change == "window":
            spec["window"] = draw(st.fixed_dictionaries({}, optional={"start": NUMBERS, "stop": NUMBERS, "middle": NUMBERS}))
        elif change == "resample":
            spec["resample"] = draw(st.booleans() | NUMBERS)
        elif change == "identification":
            keys = ["bandwidth", "cutoff", "order", "decimation", "border", "filter_positions", "held_force", "orders"]
            table = spec["identification"] = spec.get("identification") if isinstance(spec.get("identification"), dict) else {}
            table[draw(st.sampled_from(keys))] = draw(NUMBERS | ODD | st.sampled_from([[0, 49], [3, 2**62], True]))
        elif change == "controller":
            table = dict(draw(CONTROLLERS))
            if draw(st.booleans()):
                table[draw(st.sampled_from(CONTROLLER_KEYS))] = draw(ODD | st.lists(NUMBERS, min_size=1, max_size=1)
                                                                     | st.lists(st.lists(NUMBERS, max_size=2), max_size=2))
            spec["controller"] = table
        elif change == "model":
            spec["model"] = draw(st.sampled_from(["panda", "nosuch", "../x.toml", ""]) | ODD)
        else:
            spec[draw(st.sampled_from(["colums", "signal", "extra", "identification"]))] = draw(ODD)
    return spec


def check(argv: list[str], seconds: float, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """Run the command line on ``argv`` under a deadline and check how it ended (module docstring)."""
    with within(seconds, " ".join(argv)), warnings.catch_warnings(record=True):
        # hostile numbers make the commands warn (units; NumPy's overflow on values near 1e308): recorded and
        # dropped, as what is checked here is how each command ends (a result or one refusal)
        warnings.simplefilter("always")
        status = cli.main(["-q", *argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err, err[-3000:]
    assert status in (0, 2), (status, err[-3000:])
    if status == 2:
        lines = [line for line in err.splitlines() if not line.startswith(("warning: ", "symbolic: "))]
        assert len(lines) == 1 and lines[0].startswith("error: "), err
        event(f"{argv[0]} refused: {re.sub(r'^error: [^:]*: ', '', lines[0])[:38]}")  # --hypothesis-show-statistics
    else:
        event(f"{argv[0]} answered")
    if status == 0:
        found = NON_FINITE.search(out)
        assert not found, out[max(0, found.start() - 1500):found.end() + 500]
        if "--json" in argv:
            assert "not_finite" not in json.loads(out), json.loads(out)["not_finite"]
    return status, out, err


@pytest.fixture
def quiet_cli(monkeypatch: pytest.MonkeyPatch) -> None:
    """:func:`symbolic.cli.main` changes the warning filters and format: undone after the test."""
    monkeypatch.setattr(warnings, "formatwarning", warnings.formatwarning)
    monkeypatch.setattr(warnings, "filters", list(warnings.filters))


def identify_data_file(tmp_path_factory: pytest.TempPathFactory, capsys, data: st.DataObject) -> None:
    folder = tmp_path_factory.mktemp("fuzz")
    if data.draw(st.booleans()):
        path = folder / "log.csv"
        path.write_text(data.draw(csv_texts()), encoding="utf-8")
    else:
        path = data.draw(npz_bytes(folder))
    json_flag = ["--json"] if data.draw(st.booleans()) else []
    check(["identify", "emps", str(path), *json_flag], 60.0, capsys)


def identify_experiment(tmp_path_factory: pytest.TempPathFactory, capsys, data: st.DataObject) -> None:
    folder = tmp_path_factory.mktemp("fuzz")
    log = folder / "log.csv"
    columns = data.draw(logs(plausible=data.draw(st.integers(0, 3)) > 0))
    names = list(columns)
    rows = zip(*(columns[k] for k in names))
    log.write_text(",".join(names) + "\n" + "".join(",".join(map(number, row)) + "\n" for row in rows), encoding="utf-8")
    spec = data.draw(experiments("log.csv", tuple(names)))
    experiment = folder / "run.toml"
    experiment.write_text(toml_document(spec), encoding="utf-8")
    command = data.draw(st.sampled_from(["identify", "identify", "identify", "simulate"]))
    check([command, "emps", str(experiment)], 120.0, capsys)


@settings(FUZZ, max_examples=40)
@given(data=st.data())
def test_data_files_identify_or_are_refused(tmp_path_factory, capsys, quiet_cli, data) -> None:
    identify_data_file(tmp_path_factory, capsys, data)


@settings(FUZZ, max_examples=40)
@given(data=st.data())
def test_experiment_files_identify_or_are_refused(tmp_path_factory, capsys, quiet_cli, data) -> None:
    identify_experiment(tmp_path_factory, capsys, data)


@settings(FUZZ, max_examples=6)
@given(data=st.data())
def test_data_files_diagnose_or_are_refused(tmp_path_factory, capsys, quiet_cli, data) -> None:
    folder = tmp_path_factory.mktemp("fuzz")
    path = folder / "log.csv"
    path.write_text(data.draw(csv_texts()), encoding="utf-8")
    check(["diagnose", "emps", str(path), "--out", str(folder / "out"), "--effects", "offset,spring"], 180.0, capsys)


@pytest.mark.slow
@settings(FUZZ, max_examples=400)
@given(data=st.data())
def test_many_data_files_identify_or_are_refused(tmp_path_factory, capsys, quiet_cli, data) -> None:
    identify_data_file(tmp_path_factory, capsys, data)


@pytest.mark.slow
@settings(FUZZ, max_examples=400)
@given(data=st.data())
def test_many_experiment_files_identify_or_are_refused(tmp_path_factory, capsys, quiet_cli, data) -> None:
    identify_experiment(tmp_path_factory, capsys, data)


@pytest.mark.slow
@settings(FUZZ, max_examples=40)
@given(data=st.data())
def test_experiment_files_diagnose_or_are_refused(tmp_path_factory, capsys, quiet_cli, data) -> None:
    """diagnose, on the inverse or the simulated path, of experiment files (a few seconds each)."""
    folder = tmp_path_factory.mktemp("fuzz")
    columns = data.draw(logs(plausible=True))
    names = list(columns)
    (folder / "log.csv").write_text(",".join(names) + "\n" + "".join(",".join(map(number, row)) + "\n"
                                                                      for row in zip(*(columns[k] for k in names))))
    spec = data.draw(experiments("log.csv", tuple(names)))
    experiment = folder / "run.toml"
    experiment.write_text(toml_document(spec), encoding="utf-8")
    simulate = ["--simulate"] if data.draw(st.booleans()) else []
    check(["diagnose", "emps", str(experiment), "--out", str(folder / "out"), "--effects", "offset,spring", *simulate],
          300.0, capsys)
