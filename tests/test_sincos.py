"""The batched sine/cosine of the generated C (templates/sincos.c.j2) against 200-bit references.

Every generated function that needs trigonometry calls NAME_sincos once for all its angles. The
kernel must be as accurate as libm: under 1 ulp from the exact value. It is checked here against
mpmath at 200 bits on random angles, tiny angles, and every double within 3 ulp of a multiple of
pi/2 in the fast path's range (where the argument reduction cancels most), compiled the ways a
controller project would (-O2, -O3, -march=native with FMA contraction allowed, and the libm switch).
On x86-64 without -march, the kernel carries a second copy compiled for AVX2 and FMA and picks it at
run time; both copies are checked (the SYMBOLIC_NO_DISPATCH build keeps to the baseline copy).
"""

from __future__ import annotations

import ctypes
import math
import platform
import shutil
import subprocess
from pathlib import Path

import mpmath
import numpy as np
import pytest

from c_library import STRICT, compile_shared
from symbolic.codegen.templates import render

WRAPPER = """#include <math.h>
{kernel}
void batch(int n, const double *x, double *s, double *c) {{ t_sincos(n, x, s, c); }}
"""

GNU99 = ["-std=gnu99", "-Wall", "-Wextra", "-Werror", "-O3"]  # GNU C: contraction into FMA allowed
BUILDS = {
    "strict -O2": [*STRICT],
    "strict -O3": [*STRICT[:-1], "-O3"],
    "strict -O3 SYMBOLIC_NO_DISPATCH": [*STRICT[:-1], "-O3", "-DSYMBOLIC_NO_DISPATCH"],
    "gnu99 -O3": GNU99,
    "gnu99 -O3 -march=native": [*GNU99, "-march=native"],
    "strict -O3 -march=native": [*STRICT[:-1], "-O3", "-march=native"],
    "libm (SYMBOLIC_LIBM_SINCOS)": [*STRICT, "-DSYMBOLIC_LIBM_SINCOS"],
}


def build(directory: Path, flags: list[str]):
    """The kernel compiled with ``flags`` into ``directory`` (created if needed) as a batch function."""
    directory.mkdir(parents=True, exist_ok=True)
    source = directory / "sincos.c"
    source.write_text(WRAPPER.format(kernel=render("sincos.c.j2", name="t")))
    lib = ctypes.CDLL(str(compile_shared(source, directory / "libsincos.so", flags)))
    pointer = ctypes.POINTER(ctypes.c_double)

    def batch(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.ascontiguousarray(x, dtype=float)
        s, c = np.empty_like(x), np.empty_like(x)
        lib.batch(x.size, x.ctypes.data_as(pointer), s.ctypes.data_as(pointer), c.ctypes.data_as(pointer))
        return s, c

    return batch


def libm(x: np.ndarray) -> tuple[list[float], list[float]]:
    """libm's sin and cos of each angle (math.sin is libm's; numpy may use its own SIMD code)."""
    return [math.sin(v) for v in x], [math.cos(v) for v in x]


def ulp_error(computed: float, exact: mpmath.mpf) -> float:
    """|computed − exact| in units of the last place of the double nearest to exact."""
    nearest = float(exact)
    unit = math.ulp(nearest) if nearest != 0.0 else 5e-324
    return float(abs(mpmath.mpf(computed) - exact) / unit)


def near_multiples_of_half_pi(limit: int = 509, spread: int = 3) -> np.ndarray:
    """Every double within ``spread`` ulp of n*pi/2, |n| <= limit (509*pi/2 = 799.5: the fast path's range)."""
    values = []
    with mpmath.workprec(200):
        for n in range(-limit, limit + 1):
            centre = float(n * mpmath.pi / 2)
            values.append(centre)
            for direction in (-math.inf, math.inf):
                x = centre
                for _ in range(spread):
                    x = math.nextafter(x, direction)
                    values.append(x)
    return np.array(values)


def angles() -> np.ndarray:
    rng = np.random.default_rng(7)
    return np.concatenate([
        rng.uniform(-7, 7, 3000),
        rng.uniform(-800, 800, 2000),
        10 ** rng.uniform(-30, 0, 300) * rng.choice([-1, 1], 300),
        near_multiples_of_half_pi(),
        [0.0, 5e-324, -1e-310, math.pi / 4, -math.pi / 4, 3 * math.pi / 4, 799.999999, -800.0, 800.0],
    ])


def test_accuracy_set_stays_on_the_fast_path() -> None:
    """One angle beyond 800 rad would send the whole batch to libm and the accuracy test would test libm."""
    assert np.abs(angles()).max() <= 800.0


@pytest.fixture(scope="module")
def reference() -> tuple[np.ndarray, list, list]:
    x = angles()
    with mpmath.workprec(200):
        sines = [mpmath.sin(mpmath.mpf(v)) for v in x]
        cosines = [mpmath.cos(mpmath.mpf(v)) for v in x]
    return x, sines, cosines


@pytest.mark.parametrize("flags", BUILDS.values(), ids=BUILDS.keys())
def test_error_is_under_one_ulp(flags, reference, tmp_path: Path) -> None:
    x, sines, cosines = reference
    s, c = build(tmp_path, flags)(x)
    worst_sin = max(ulp_error(v, e) for v, e in zip(s, sines))
    worst_cos = max(ulp_error(v, e) for v, e in zip(c, cosines))
    assert worst_sin < 1.0 and worst_cos < 1.0, (worst_sin, worst_cos)


def test_signed_zero_and_batches_of_any_length(tmp_path: Path) -> None:
    batch = build(tmp_path, BUILDS["strict -O3"])
    s, c = batch(np.array([-0.0, 0.0]))
    assert math.copysign(1.0, s[0]) == -1.0 and math.copysign(1.0, s[1]) == 1.0 and (c == 1.0).all()
    x = np.linspace(-3, 3, 13)
    for n in range(1, 14):  # vector loops with and without a scalar remainder
        s, c = batch(x[:n])
        # both within 1 ulp of the exact value, so within 2 ulp of libm
        np.testing.assert_allclose(s, [math.sin(v) for v in x[:n]], rtol=4.5e-16, atol=1e-300)
        np.testing.assert_allclose(c, [math.cos(v) for v in x[:n]], rtol=4.5e-16, atol=1e-300)


def test_large_or_non_finite_angles_take_libm_for_the_whole_batch(tmp_path: Path) -> None:
    """Beyond |x| = 800 the two-part reduction is no longer exact: the batch falls back to libm."""
    batch = build(tmp_path, BUILDS["strict -O3"])
    x = np.array([0.3, 1.0e6, -2.5e300, 800.0000001, 1.2])
    s, c = batch(x)
    assert (s.tolist(), c.tolist()) == libm(x)
    s, c = batch(np.array([0.3, math.inf, math.nan]))
    assert np.isnan(s[1:]).all() and np.isnan(c[1:]).all()
    assert s[0] == math.sin(0.3) and c[0] == math.cos(0.3)


@pytest.mark.parametrize("build_name", ["strict -O3", "strict -O3 SYMBOLIC_NO_DISPATCH"])
def test_one_out_of_range_angle_anywhere_in_the_batch_is_noticed(build_name: str, tmp_path: Path) -> None:
    """The range check is folded into the vector loop: every lane and the scalar remainder must report."""
    batch = build(tmp_path, BUILDS[build_name])
    for n in range(1, 10):
        for position in range(n):
            for bad in (800.0000000000001, -1.0e4, math.inf, -math.nan):
                x = np.linspace(-3.0, 3.0, n)
                x[position] = bad
                s, c = batch(x)
                finite = np.isfinite(x)
                assert (s[finite].tolist(), c[finite].tolist()) == libm(x[finite]), (n, position, bad)


def cpu_has(*flags: str) -> bool:
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return False
    words = set(text.split())
    return all(f in words for f in flags)


X86_64 = platform.machine() in ("x86_64", "AMD64")


@pytest.mark.skipif(not (X86_64 and shutil.which("objdump")), reason="x86-64 with binutils' objdump only")
def test_portable_build_carries_an_avx2_copy_and_the_switch_removes_it(tmp_path: Path) -> None:
    """-O3 without -march targets SSE2; the AVX2 copy shows as 256-bit (ymm) instructions."""
    for flags, expected in ((BUILDS["strict -O3"], True), (BUILDS["strict -O3 SYMBOLIC_NO_DISPATCH"], False)):
        directory = tmp_path / str(expected)
        build(directory, flags)
        listing = subprocess.run(["objdump", "-d", str(directory / "libsincos.so")], capture_output=True, text=True, check=True)
        assert ("%ymm" in listing.stdout) == expected, flags


@pytest.mark.skipif(not (X86_64 and cpu_has("avx2", "fma")), reason="needs an x86-64 processor with AVX2 and FMA")
def test_the_avx2_copy_is_taken_at_run_time(reference, tmp_path: Path) -> None:
    """The AVX2 copy's fused multiply-adds round differently from the SSE2 copy on some angles.

    Identical results would mean the dispatch never chose the AVX2 copy on a processor that has it.
    """
    x = reference[0]
    dispatched = build(tmp_path / "a", GNU99)(x)
    baseline = build(tmp_path / "b", [*GNU99, "-DSYMBOLIC_NO_DISPATCH"])(x)
    differing = sum(int((u != v).sum()) for u, v in zip(dispatched, baseline))
    assert differing > 0


def test_in_range_angles_stay_on_the_fast_path(reference, tmp_path: Path) -> None:
    """The kernel rounds differently from libm on some angles; all-equal results would mean a range
    check that sends every batch to libm (the accuracy tests would then be testing libm)."""
    x = reference[0]
    s, c = build(tmp_path, BUILDS["strict -O3 SYMBOLIC_NO_DISPATCH"])(x)
    libm_s, libm_c = libm(x)
    differing = int((s != libm_s).sum() + (c != libm_c).sum())
    assert differing > 0
