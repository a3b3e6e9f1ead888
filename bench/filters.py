"""The NumPy-only filters of ``symbolic.data.filters`` against the SciPy ones they replace (issue 23 §3).

``symbolic.data.filters`` designed its filters with ``scipy.signal.butter``/``cheby1`` and ran them with
``scipy.signal.sosfilt``; importing ``scipy.signal`` cost about 0.8 s, the largest part of a warm
``symbolic simulate``. It now designs them in NumPy and runs them as a block state-space filter. This
times, on one BLAS thread (``OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1``, set here before NumPy is
imported), each the median of ``--repeat`` runs, old and new alternating:

* ``decimate`` of a 20 000 × 2 000 array by 10 (the diagnosis decimates thousands of regressor columns);
* ``lowpass`` of a 20 000 × 7 array (a 7-joint log's positions, 10 Hz at 1 kHz, order 4);

and the import of ``scipy.signal`` in a fresh process (what the module no longer pays). The old
functions are the module's code before the change (``old_filtfilt`` below, SciPy's ``sosfilt`` and
``sosfilt_zi``). Goal: the new ``decimate`` not slower than the old by more than 10 %::

    python bench/filters.py            # writes bench/results/filters.md
"""

from __future__ import annotations

import os

os.environ["OMP_NUM_THREADS"] = "1"
os.environ["OPENBLAS_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from symbolic.data import filters  # noqa: E402


def old_filtfilt(sos: np.ndarray, x: np.ndarray, padlen: int, axis: int) -> np.ndarray:
    """The module's ``_filtfilt`` before the change: odd extension, ``scipy.signal.sosfilt`` forward and
    backward from rest on the first sample."""
    import scipy.signal

    x = np.moveaxis(x, axis, 0)
    ext = np.concatenate((2 * x[:1] - x[padlen:0:-1], x, 2 * x[-1:] - x[-2 : -(padlen + 2) : -1]), axis=0)
    zi = scipy.signal.sosfilt_zi(sos).reshape((len(sos), 2) + (1,) * (x.ndim - 1))
    y, _ = scipy.signal.sosfilt(sos, ext, axis=0, zi=zi * ext[:1])
    y, _ = scipy.signal.sosfilt(sos, y[::-1], axis=0, zi=zi * y[-1:])
    return np.moveaxis(y[::-1][padlen:-padlen], 0, axis)


def old_decimate(x: np.ndarray, factor: int) -> np.ndarray:
    import scipy.signal

    sos = scipy.signal.cheby1(filters.DECIMATION_ORDER, filters.DECIMATION_RIPPLE, 0.8 / factor, output="sos")
    return old_filtfilt(sos, x, 3 * filters.DECIMATION_ORDER, 0)[filters.kept_indices(len(x), factor)]


def old_lowpass(x: np.ndarray, cutoff: float, rate: float, order: int) -> np.ndarray:
    import scipy.signal

    return old_filtfilt(scipy.signal.butter(order, cutoff / (rate / 2), output="sos"), x, 3 * order, 0)


def timed(run) -> tuple[float, float]:
    """Wall and CPU seconds of one call."""
    wall, cpu = time.perf_counter(), time.process_time()
    run()
    return time.perf_counter() - wall, time.process_time() - cpu


def compare(name: str, old, new, repeat: int) -> dict:
    """Old and new alternating (one run each, ``repeat`` times), after one warm-up run of each; medians of
    the wall and of the CPU times."""
    reference, ours = old(), new()
    olds, news = [], []
    for _ in range(repeat):
        olds.append(timed(old))
        news.append(timed(new))
    difference = float(np.abs(ours - reference).max() / np.abs(reference).max())
    return {"case": name, "difference": difference,
            **{f"{which} {kind}": statistics.median(t[i] for t in runs) for which, runs in (("old", olds), ("new", news))
               for i, kind in enumerate(("wall", "cpu"))}}


def import_cost(repeat: int) -> float:
    """Median wall time of ``import scipy.signal`` in a fresh process (after NumPy)."""
    code = "import numpy, time; t = time.perf_counter(); import scipy.signal; print(time.perf_counter() - t)"
    runs = [float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
            for _ in range(repeat)]
    return statistics.median(runs)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--output", type=Path, default=ROOT / "bench" / "results" / "filters.md")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    load_before = os.getloadavg()[0]
    wide = rng.normal(size=(20_000, 2_000)).cumsum(axis=0)
    joints = rng.normal(size=(20_000, 7)).cumsum(axis=0)
    rows = [compare("decimate 20 000 × 2 000 by 10", lambda: old_decimate(wide, 10),
                    lambda: filters.decimate(wide, 10), args.repeat),
            compare("lowpass 20 000 × 7, 10 Hz at 1 kHz, order 4", lambda: old_lowpass(joints, 10.0, 1000.0, 4),
                    lambda: filters.lowpass(joints, 10.0, 1000.0, 4), args.repeat)]
    scipy_import = import_cost(args.repeat)
    load_after = os.getloadavg()[0]
    lines = ["# Zero-phase filters: NumPy block state space against scipy.signal.sosfilt", "",
             f"`bench/filters.py` (issue 23 §3): medians of {args.repeat} runs each, old and new alternating, "
             f"one BLAS thread, on {platform.machine()}, Python {platform.python_version()}, NumPy "
             f"{np.__version__}; a 2-core machine shared with other work (load average {load_before:.1f} before, "
             f"{load_after:.1f} after). Old: the module before the change (SciPy's `cheby1`/`butter` and "
             "`sosfilt`); new: `symbolic.data.filters` (NumPy only). Difference: the largest |new − old| over "
             "the largest |old|. Wall time is what a user waits for; CPU time (one thread) repeats better on a "
             "shared machine.", "",
             "| case | old wall (s) | new wall (s) | new / old | old CPU (s) | new CPU (s) | new / old | difference |",
             "|---|---|---|---|---|---|---|---|"]
    for row in rows:
        lines.append(f"| {row['case']} | {row['old wall']:.4f} | {row['new wall']:.4f} | "
                     f"**{row['new wall'] / row['old wall']:.2f}** | {row['old cpu']:.4f} | {row['new cpu']:.4f} | "
                     f"{row['new cpu'] / row['old cpu']:.2f} | {row['difference']:.1e} |")
    lines += ["", f"`import scipy.signal` in a fresh process, which the module no longer pays: {scipy_import:.2f} s "
              f"(median of {args.repeat}).", ""]
    args.output.write_text("\n".join(lines))
    print("\n".join(lines))
    ratio = rows[0]["new wall"] / rows[0]["old wall"]
    return 0 if ratio <= 1.1 else 1


if __name__ == "__main__":
    sys.exit(main())
