"""Derived products: owned by the model, built once, kept on disk by the description's content (issue 20, item 4).

Every test has a cache folder of its own (``SYMBOLIC_CACHE_DIR`` under ``tmp_path``). A read from the
cache is told apart from a build by making the builder fail: a product that comes back while its builder
raises was read.
"""

from __future__ import annotations

import gc
import os
import stat
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import symbolic
from symbolic import cache, export
from symbolic.codegen import exported
from symbolic.derivation import dynamics
from symbolic.derivation.products import Product
from symbolic.description.parameters import ParameterVector
from symbolic.description.robot import digest
from symbolic.errors import ModelError
from symbolic.numeric import base_parameters as base_module

from models import planar_arm

ARM = planar_arm()


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty cache folder of the test's own, the cache on."""
    monkeypatch.setenv("SYMBOLIC_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("SYMBOLIC_NO_CACHE", raising=False)
    return tmp_path / "cache"


def arm(tmp_path: Path, text: str = ARM, name: str = "arm.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def fail(*args, **kwargs):
    raise AssertionError("built again instead of read from the cache")


def entries(folder: Path, kind: str = "") -> list[Path]:
    return sorted((folder / "derived").glob(f"{kind}*.pickle"))


def test_a_cache_hit_gives_the_same_products_and_byte_identical_c(folder: Path, tmp_path: Path, monkeypatch) -> None:
    robot = symbolic.load(arm(tmp_path))
    monkeypatch.setenv("SYMBOLIC_NO_CACHE", "1")
    fresh = symbolic.derive(robot)  # derived without the cache: the reference
    fresh_c = export.render(fresh, ["c"], command="test")
    fresh_base = base_module.model_base_parameters(fresh)
    assert not folder.exists()
    monkeypatch.delenv("SYMBOLIC_NO_CACHE")
    first = symbolic.derive(robot)
    export.render(first, ["c"], command="test")
    base_module.model_base_parameters(first)
    assert [p.name.split("-")[0] for p in entries(folder)] == ["base_parameters", "batched_programs", "derivation",
                                                                "inverse_dynamics_derivatives", "programs", "regressor"]

    monkeypatch.setattr(dynamics, "_derive", fail)
    monkeypatch.setattr(dynamics, "regressor", fail)
    monkeypatch.setattr(base_module, "base_parameters", fail)
    monkeypatch.setattr(exported, "build_program", fail)
    monkeypatch.setattr(exported, "batch_trig", fail)
    warm = symbolic.derive(robot)
    assert warm is not first and warm.robot is robot
    assert warm.D == fresh.D and warm.inverse_dynamics == fresh.inverse_dynamics and warm.gravity == fresh.gravity
    reg, fresh_reg = warm.regressor(), fresh.regressor()
    assert reg.theta == fresh_reg.theta and reg.theta_expressions == fresh_reg.theta_expressions
    assert reg.expand() == fresh_reg.expand()
    base = base_module.model_base_parameters(warm)
    assert base.names == fresh_base.names and base.expressions == fresh_base.expressions
    assert np.array_equal(base.K, fresh_base.K) and np.array_equal(base.values, fresh_base.values)
    assert export.render(warm, ["c"], command="test") == fresh_c  # bytes of every file


def test_products_are_built_once_per_model_and_names_are_unique(folder: Path, tmp_path: Path) -> None:
    model = symbolic.derive(symbolic.load(arm(tmp_path)))
    calls = []
    product = Product("test product", lambda m: calls.append(m.name) or object())
    assert product not in model.products
    value = model.products.get(product)
    assert model.products.get(product) is value and calls == ["arm"] and "test product" in model.products.names()
    with pytest.raises(ValueError, match="two different products are named 'test product'"):
        model.products.get(Product("test product", lambda m: 1))
    assert model.regressor() is model.regressor()
    assert symbolic.numeric_model(model) is symbolic.numeric_model(model)


def test_a_model_and_its_products_are_freed_together(tmp_path: Path, folder: Path) -> None:
    import weakref

    model = symbolic.derive(symbolic.load(arm(tmp_path)))
    symbolic.numeric_model(model)  # holds the model: a cycle through the products, which gc collects
    gone = weakref.ref(model)
    del model
    gc.collect()
    assert gone() is None


def test_a_model_with_beams_has_its_regressor_built_once(folder: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        model = symbolic.derive(symbolic.robots.load("single_flexible_link"))
    reg = model.regressor()
    assert {"rho_link", "EIv_link", "EIw_link"} <= {str(s) for s in reg.theta}
    assert exported.model_regressor(model) is reg and model.regressor() is reg


def test_the_cache_is_keyed_by_content_not_by_path_or_layout(folder: Path, tmp_path: Path, monkeypatch) -> None:
    derivations = []
    real = dynamics._derive
    monkeypatch.setattr(dynamics, "_derive", lambda robot: derivations.append(robot.source) or real(robot))
    first = symbolic.derive(symbolic.load(arm(tmp_path)))
    assert len(derivations) == 1
    # the same content elsewhere, with a comment and blank lines added: read back, naming the new file
    moved = arm(tmp_path, "# moved\n\n" + ARM, "moved.toml")
    again = symbolic.derive(symbolic.load(moved))
    assert len(derivations) == 1 and again.robot.source == str(moved) and again.regressor().robot.source == str(moved)
    # any change of the description misses, even one that leaves D as it was (yy of a planar arm)
    for old, new in [("m2 = 0.8", "m2 = 0.81"), ('com = ["-l2/2"', 'com = ["-l2/3"'), ('yy = "I2"', 'yy = "1.05*I2"')]:
        assert old in ARM
        edited = symbolic.derive(symbolic.load(arm(tmp_path, ARM.replace(old, new), "edited.toml")))
        assert derivations[-1] == str(tmp_path / "edited.toml") and edited is not first
    assert len(derivations) == 4
    assert len(entries(folder, "derivation")) == 4


def test_the_digest_is_the_same_in_every_process() -> None:
    """No Python hash enters the key: two interpreters with other hash seeds agree (and agree with this one)."""
    code = "import symbolic; from symbolic.description.robot import digest; print(digest(symbolic.validate(symbolic.robots.load('panda'))))"
    seen = set()
    for seed in ("1", "2"):
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                              env={**os.environ, "PYTHONHASHSEED": seed})
        seen.add(done.stdout.strip())
    seen.add(digest(symbolic.validate(symbolic.robots.load("panda"))))
    assert len(seen) == 1 and len(seen.pop()) == 64


@pytest.mark.parametrize("damage", ["truncated", "flipped byte", "garbage", "foreign header", "empty", "bad pickle"])
def test_a_corrupt_entry_is_ignored_and_rebuilt(damage: str, folder: Path, tmp_path: Path, monkeypatch) -> None:
    robot = symbolic.load(arm(tmp_path))
    reference = symbolic.derive(robot)
    (entry,) = entries(folder, "derivation")
    raw = entry.read_bytes()
    header_end = raw.index(b"\n", len(cache.MAGIC)) + 1
    payload_start = raw.index(b"\n", header_end) + 1
    if damage == "truncated":
        raw = raw[: len(raw) // 2]
    elif damage == "flipped byte":
        raw = raw[:-10] + bytes([raw[-10] ^ 0xFF]) + raw[-9:]
    elif damage == "garbage":
        raw = os.urandom(len(raw))
    elif damage == "foreign header":
        raw = raw.replace(b'"symbolic": "', b'"symbolic": "9', 1)
    elif damage == "empty":
        raw = b""
    else:  # a well-formed entry whose pickle names a module that does not exist
        import hashlib

        payload = b"\x80\x04\x95\x1a\x00\x00\x00\x00\x00\x00\x00\x8c\x0bno_such_mod\x94\x8c\x01x\x94\x93\x94."
        raw = raw[:header_end] + hashlib.sha256(payload).hexdigest().encode() + b"\n" + payload
    assert raw[payload_start:] != entry.read_bytes()[payload_start:] or damage in ("foreign header",)
    entry.write_bytes(raw)
    derivations = []
    real = dynamics._derive
    monkeypatch.setattr(dynamics, "_derive", lambda r: derivations.append(1) or real(r))
    rebuilt = symbolic.derive(robot)
    assert derivations == [1] and rebuilt.D == reference.D
    assert entry.read_bytes() != raw  # rewritten whole
    monkeypatch.setattr(dynamics, "_derive", fail)
    assert symbolic.derive(robot).D == reference.D  # and read back from now on


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="POSIX permissions")
def test_an_entry_others_may_write_is_not_loaded(folder: Path, tmp_path: Path, monkeypatch) -> None:
    robot = symbolic.load(arm(tmp_path))
    symbolic.derive(robot)
    (entry,) = entries(folder, "derivation")
    assert stat.S_IMODE(entry.stat().st_mode) == 0o600 and stat.S_IMODE((folder / "derived").stat().st_mode) == 0o700
    entry.chmod(0o666)
    derivations = []
    real = dynamics._derive
    monkeypatch.setattr(dynamics, "_derive", lambda r: derivations.append(1) or real(r))
    symbolic.derive(robot)
    assert derivations == [1]


def test_entries_are_not_shared_between_versions(folder: Path, tmp_path: Path, monkeypatch) -> None:
    robot = symbolic.load(arm(tmp_path))
    symbolic.derive(robot)
    (old,) = entries(folder, "derivation")
    for field, value in [("symbolic", "0.0.1"), ("sympy", "0.1"), ("python", "CPython 2.7.18"), ("sources", "0" * 32)]:
        other = {**cache.stamp(), field: value}
        monkeypatch.setattr(cache, "stamp", lambda other=other: other)
        assert cache.entry_path("derivation", digest(robot)) != old
        # even under the old entry's name (a collision), its header names another version: ignored
        assert cache.load("derivation", digest(robot)) is None
        monkeypatch.setattr(cache, "entry_path", lambda kind, key: old)
        assert cache.load("derivation", digest(robot)) is None
        monkeypatch.undo()
        monkeypatch.setenv("SYMBOLIC_CACHE_DIR", str(folder))


def test_no_cache_reads_and_writes_nothing(folder: Path, tmp_path: Path, monkeypatch) -> None:
    robot = symbolic.load(arm(tmp_path))
    symbolic.derive(robot)  # an entry that must not be read
    before = sorted(folder.rglob("*"))
    monkeypatch.setenv("SYMBOLIC_NO_CACHE", "1")
    derivations = []
    real = dynamics._derive
    monkeypatch.setattr(dynamics, "_derive", lambda r: derivations.append(1) or real(r))
    model = symbolic.derive(robot)
    model.regressor()
    base_module.model_base_parameters(model)
    assert derivations == [1] and sorted(folder.rglob("*")) == before
    assert not cache.library_folders()[0].is_relative_to(folder)
    monkeypatch.setenv("SYMBOLIC_NO_CACHE", "0")  # "0" and "" leave it on
    assert not cache.disabled()


def test_the_cache_folder_follows_the_environment(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.delenv("SYMBOLIC_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.folder() == tmp_path / "xdg" / "symbolic"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache.folder() == tmp_path / "home" / ".cache" / "symbolic"
    monkeypatch.setenv("SYMBOLIC_CACHE_DIR", str(tmp_path / "given"))
    assert cache.folder() == tmp_path / "given"
    assert cache.library_folders()[0] == tmp_path / "given" / "libraries"


def test_the_suite_never_writes_to_the_users_cache() -> None:
    """conftest.py gives the session a temporary cache folder (its subprocesses inherit it)."""
    import tempfile

    assert Path(os.environ["SYMBOLIC_CACHE_DIR"]).is_relative_to(tempfile.gettempdir())
    assert cache.folder() == Path(os.environ["SYMBOLIC_CACHE_DIR"])


def synthetic_log(model, path: Path) -> None:
    """τ of the model at its nominal parameters along a smooth two-joint motion, 1 kHz, 3 s."""
    num = symbolic.numeric_model(model)
    t = np.arange(3000) / 1000.0
    w = 2 * np.pi * np.array([[0.7, 1.1]])
    q = 0.8 * np.sin(w * t[:, None]) + np.array([0.3, -0.4])
    qd = 0.8 * w * np.cos(w * t[:, None])
    qdd = -0.8 * w**2 * np.sin(w * t[:, None])
    tau = np.array([num.inverse_dynamics(a, b, c) for a, b, c in zip(q, qd, qdd)])
    rows = np.column_stack([t, q, tau])
    np.savetxt(path, rows, delimiter=",", header="t,q_q1,q_q2,tau_q1,tau_q2", comments="", fmt="%.17g")


def test_a_second_identify_reads_the_derivation_and_prints_the_same(folder: Path, tmp_path: Path) -> None:
    model_file = arm(tmp_path)
    synthetic_log(symbolic.derive(symbolic.load(model_file)), tmp_path / "log.csv")
    for entry in entries(folder):
        entry.unlink()  # the command's first run starts cold

    def identify() -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "symbolic", "identify", str(model_file), str(tmp_path / "log.csv")],
                              capture_output=True, text=True, env={**os.environ, "SYMBOLIC_CACHE_DIR": str(folder)})

    cold, warm = identify(), identify()
    assert cold.returncode == 0 and warm.returncode == 0, cold.stderr + warm.stderr
    assert "derived in" in cold.stderr and "read from the cache" not in cold.stderr
    assert "derivation read from the cache" in warm.stderr and "derived in" not in warm.stderr
    assert "built in" not in warm.stderr  # nor the regressor nor the base parameters
    assert warm.stdout == cold.stdout


def test_parameter_vector_converts_names_symbols_and_arrays() -> None:
    m, l = sp.Symbol("m", real=True), sp.Symbol("l", real=True)
    p = ParameterVector((m, l), [2.0, 0.5], "arm.toml")
    assert p.names == ("m", "l") and len(p) == 2 and p["l"] == 0.5 and p[m] == 2.0 and p.index(l) == 1
    assert p.by_name() == {"m": 2.0, "l": 0.5} and p.by_symbol() == {m: 2.0, l: 0.5}
    assert np.array_equal(np.asarray(p), [2.0, 0.5]) and not p.values.flags.writeable
    changed = p.updated({"l": 0.7, m: 3.0})
    assert changed.by_name() == {"m": 3.0, "l": 0.7} and p.by_name() == {"m": 2.0, "l": 0.5}
    assert np.array_equal(p.coerce(None), [2.0, 0.5]) and np.array_equal(p.coerce([1, 2]), [1.0, 2.0])
    assert p.with_array([4, 5]).by_name() == {"m": 4.0, "l": 5.0}
    with pytest.raises(ModelError) as error:
        p.updated({"mass": 1.0})
    assert str(error.value) == "arm.toml: [parameters]: no parameter 'mass' (the model's: m, l)"
    with pytest.raises(ValueError, match="2 parameter values expected"):
        p.coerce([1.0, 2.0, 3.0])


def test_a_models_parameter_vector_is_its_model_files(tmp_path: Path, folder: Path) -> None:
    model = symbolic.derive(symbolic.load(arm(tmp_path)))
    p = model.parameter_vector
    assert p.symbols == model.parameter_symbols and p.by_symbol() == model.parameters
    assert p.names == ("g", "l1", "l2", "m1", "m2", "I1", "I2", "fv1") and p["m2"] == 0.8


def test_a_warm_simulation_reads_the_plant_and_integrates_the_same(folder: Path, tmp_path: Path, monkeypatch) -> None:
    """The CasADi plant is kept on disk (issue 23 §3): a second model of the same description simulates with
    the plant read back (its builder raises) and gives the same trajectory to the last bit."""
    from symbolic.data import Measurements
    from symbolic.simulation import simulator

    robot = symbolic.load(arm(tmp_path))
    t = np.arange(501) / 500.0
    ref = np.column_stack([0.2 * np.sin(2 * np.pi * t), 0.1 * np.cos(2 * np.pi * t)])
    log = Measurements.from_arrays(t, ["q1", "q2"], np.zeros((len(t), 2)), np.zeros((len(t), 2)), ref=ref)
    table = {"kind": "pd", "kp": [40.0, 20.0], "kd": [4.0, 2.0], "reference": "ref"}
    first = simulator.simulate(symbolic.derive(robot), log, controller=table, initial=(np.zeros(2), np.zeros(2)))
    assert len(entries(folder, "simulation_plant")) == 1
    failing = Product(simulator.plant_product().name, fail, persist=True)
    monkeypatch.setattr(simulator, "plant_product", lambda: failing)
    warm = simulator.simulate(symbolic.derive(robot), log, controller=table, initial=(np.zeros(2), np.zeros(2)))
    assert np.array_equal(warm.simulated.q, first.simulated.q) and np.array_equal(warm.simulated.tau, first.simulated.tau)


def test_base_parameter_bounds_are_read_back_from_the_cache(folder: Path, tmp_path: Path, monkeypatch) -> None:
    """beta_bounds' SymPy work is kept on disk (issue 38): a second model of the same description reads the bounds,
    the same numbers; other names bounded or other parameters known are another entry."""
    from symbolic.identify import known as known_module
    from symbolic.identify.model import model_base

    def bounds(model, names=None, known=frozenset()):
        reg, base = model_base(model)
        return known_module.beta_bounds(model, reg, base, base.names if names is None else names, set(known))

    model = symbolic.derive(symbolic.load(arm(tmp_path)))
    first = bounds(model)
    assert first and len(entries(folder, "base_parameter_bounds")) == 1
    monkeypatch.setattr(known_module, "_beta_bounds", fail)
    again = symbolic.derive(symbolic.load(arm(tmp_path)))
    assert again is not model and bounds(again) == first
    monkeypatch.undo()
    monkeypatch.setenv("SYMBOLIC_CACHE_DIR", str(folder))
    model = symbolic.derive(symbolic.load(arm(tmp_path)))
    some = model_base(model)[1].names[:1]
    assert bounds(model, some) == {k: v for k, v in first.items() if k in some}
    assert len(entries(folder, "base_parameter_bounds")) == 2
