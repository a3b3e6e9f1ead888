"""Compile generated C with gcc and call it through ctypes (test helper)."""

from __future__ import annotations

import ctypes
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path

import numpy as np

STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2"]


def gcc() -> str:
    path = shutil.which("gcc")
    if path is None:
        raise RuntimeError("gcc is required for the C export tests")
    return path


def compile_shared(source: Path, out: Path, flags: Sequence[str] = tuple(STRICT)) -> Path:
    """A shared library from one C file (``flags`` replace the strict defaults)."""
    subprocess.run([gcc(), *flags, "-fPIC", "-shared", "-o", str(out), str(source), "-lm"], check=True, capture_output=True, text=True)
    return out


class CModel:
    """ctypes wrapper of a generated model library."""

    def __init__(self, library: Path, name: str, n: int, n_p: int) -> None:
        self.lib = ctypes.CDLL(str(library))
        self.name, self.n, self.n_p = name, n, n_p
        self.defaults = np.ctypeslib.as_array((ctypes.c_double * n_p).in_dll(self.lib, f"{name}_parameter_defaults")).copy()

    def _call(self, function: str, inputs, size: int) -> np.ndarray:
        args = [np.ascontiguousarray(x, dtype=float) for x in inputs]
        out = np.zeros(size)
        pointer = ctypes.POINTER(ctypes.c_double)
        fn = getattr(self.lib, f"{self.name}_{function}")
        fn.restype = ctypes.c_int if function == "forward_dynamics" else None
        status = fn(*[a.ctypes.data_as(pointer) for a in args], out.ctypes.data_as(pointer))
        if function == "forward_dynamics":
            self.status = status
        return out

    def inertia(self, q, p):
        return self._call("inertia", [q, p], self.n * self.n).reshape(self.n, self.n)

    def coriolis(self, q, qd, p):
        return self._call("coriolis", [q, qd, p], self.n)

    def coriolis_matrix(self, q, qd, p):
        return self._call("coriolis_matrix", [q, qd, p], self.n * self.n).reshape(self.n, self.n)

    def gravity(self, q, p):
        return self._call("gravity", [q, p], self.n)

    def stiffness(self, q, p):
        return self._call("stiffness", [q, p], self.n)

    def friction(self, q, qd, p):
        return self._call("friction", [q, qd, p], self.n)

    def applied(self, q, qd, p):
        return self._call("applied", [q, qd, p], self.n)

    def inverse_dynamics(self, q, qd, qdd, p):
        return self._call("inverse_dynamics", [q, qd, qdd, p], self.n)

    def forward_dynamics(self, q, qd, tau, p):
        qdd = self._call("forward_dynamics", [q, qd, tau, p], self.n)
        return qdd, self.status
