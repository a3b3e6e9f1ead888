"""Physically consistent identification as a small problem: the closest feasible parameters in the metric
of the least-squares fit (issue 23 §1; what it returns and when to use it: docs/data.md, "Physically consistent
parameters (`identify --consistent`)").

The weighted rows of the fit are summarised by their QR factor (:class:`Summary`, (1)), so the estimate
(2) of :func:`fit` has b residuals (b base parameters) whatever the number of samples. Each body's feasible
set — its pseudo-inertia positive definite (:func:`symbolic.identify.pseudo_inertia.pseudo_inertia`, (4); Wensing, Kim & Slotine 2018) — is
parameterized exactly by log-Cholesky coordinates (:func:`log_cholesky`, (5)–(6); Rucker & Wensing 2022) in
the form of the model file (:class:`BodyPlan`, (7); :func:`plan_bodies`); :func:`fit` solves (2) in two passes,
the second Newton's method with the exact Hessian (:func:`_newton`, (8)–(9)). Each numbered equation is stated
in the docstring of the function that implements it.

SciPy is imported inside :func:`fit` only (identification without ``--consistent`` never needs it).
"""

from __future__ import annotations

import functools
import itertools
import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from symbolic.identify.pseudo_inertia import AXES, INERTIA_KEYS
from symbolic.numeric.blas import one_blas_thread

log = logging.getLogger(__name__)

PROGRESS_AFTER = 2.0
"""Seconds of fitting after which progress is reported (logging INFO: stderr under the command line)."""
PENALTY_WEIGHT = 1e4
"""Weight of the penalty residuals of the bodies (7) cannot parameterize exactly, relative to ‖z‖ per
unit of the body's inertia scale."""
ANCHOR_WEIGHT = 1e-4
"""Weight of the pull towards the start in the first pass, relative to ρ (or 1e-6·‖y_w‖ where larger)
per typical size of each coordinate of φ: it holds the directions the data leave free (they would
otherwise drift, e^{d} overflowing); the second pass has none."""
FIRST_PASS_FTOL = 1e-3
"""The first pass ends when a step gains less than this fraction of ‖R·β − z‖²: run longer, it creeps towards
an answer on the boundary (some coordinates of (7) going to −∞), hundreds of evaluations for what the second
pass does in tens."""
MAX_EVALUATIONS = 500
"""Evaluations of the first pass at most."""
MAX_ITERATIONS = 200
"""Newton iterations of the second pass at most."""
POLISH_ITERATIONS = 30
"""Newton iterations at most after the interior-point solve of the convex form (:func:`_newton_polish`)."""
STALL_CHI2, STALL_ITERATIONS = 0.01, 10
"""The second pass also stops, unconverged, when χ² = 2·cost/σ² fell by less than STALL_CHI2 over the last
STALL_ITERATIONS iterations: the cost is then creeping along directions the data barely see, a gain no test
on the data could tell from noise (on the PUMA case of the tests, 0.07 in χ² left after the stop, measured by
a thousand more iterations)."""
GRADIENT_TOLERANCE = 1e-6
"""The second pass ends when the gradient of the cost in its scaled coordinates is below this times σ²
(σ² = ρ²/(rows − b), the residual variance per row): moving any coordinate by its typical size would change
χ² by about 1e-6 at most. With noise-free data (σ² = 0) it runs until the trust region falls below rounding."""
CERTIFIED_WITHIN = 1e-3
"""The fit has converged when its cost ‖y_w − W_w·β‖² (all weighted rows) is within this fraction of the
lower bound the convex form certifies (:attr:`symbolic.identify.conic.Certificate.guaranteed_ratio`):
within 0.1 % of the global optimum (issue 38 §3; measured: bench/results/consistent.md)."""
START_MARGIN = 1e-3
"""A start that is not strictly feasible is moved inside by this fraction of the body's scale."""


# -- a body's ten parameters ----------------------------------------------------------------------------

def log_cholesky(mass: float, com: Sequence[float], inertia: np.ndarray) -> np.ndarray:
    """φ = [α, d1, d2, d3, s12, s23, s13, t1, t2, t3] of (5) for a body with J ≻ 0 (the inverse of
    :func:`from_log_cholesky`; the order of Pinocchio's ``LogCholeskyParameters``).

    Log-Cholesky coordinates (Rucker & Wensing, "Smooth parameterization of rigid-body inertia", IEEE RA-L
    7(2), 2022, Sec. III): J = U·Uᵀ with

        U = e^α·[[e^{d1}, s12, s13, t1], [0, e^{d2}, s23, t2], [0, 0, e^{d3}, t3], [0, 0, 0, 1]]    (5)

    a smooth bijection from ℝ¹⁰ onto the bodies with J ≻ 0. Multiplying out,

        m = e^{2α},  c = t,  Σ_c = e^{2α}·A·Aᵀ  (A the upper 3×3 block of (5) without e^α)          (6)

    which gives the model file's own parameters (mass, centre of mass, inertia about the centre of mass,
    docs/model-format.md): I_c = tr(Σ_c)·1 − Σ_c.
    """
    Ic = np.asarray(inertia, float)
    sigma = 0.5 * np.trace(Ic) * np.eye(3) - Ic
    alpha = 0.5 * np.log(mass)
    A = _upper_cholesky(sigma / mass)
    return np.array([alpha, *np.log(np.diag(A)), A[0, 1], A[1, 2], A[0, 2], *np.asarray(com, float)])


def from_log_cholesky(phi: Sequence[float]) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia about the centre of mass) of (6) for φ as in :func:`log_cholesky`."""
    alpha, d1, d2, d3, s12, s23, s13, t1, t2, t3 = map(float, phi)
    A = np.array([[np.exp(d1), s12, s13], [0.0, np.exp(d2), s23], [0.0, 0.0, np.exp(d3)]])
    m = np.exp(2 * alpha)
    sigma = m * A @ A.T
    return m, np.array([t1, t2, t3]), np.trace(sigma) * np.eye(3) - sigma


def _upper_cholesky(M: np.ndarray) -> np.ndarray:
    """Upper-triangular A with A·Aᵀ = M (M ≻ 0): the lower Cholesky factor of M with its order reversed."""
    L = np.linalg.cholesky(M[::-1, ::-1])
    return L[::-1, ::-1]


# -- the model file's slots --------------------------------------------------------------------------

Slot = int | float | None
"""Where a body quantity comes from: an int indexes the free parameters (the quantity is that parameter
alone), a float is a constant (numbers, fixed parameters, geometry), None an expression of free ones."""


@dataclass(frozen=True)
class BodyPlan:
    """How (5) produces one body's free parameters: its slots and the coordinates φ it uses.

    The fit takes L = e^α·A in place of A of (6),

        m = e^{2α},  c = t,  Σ_c = L·Lᵀ,  L upper triangular, L_rr = e^{d_r}                          (7)

    the same parameterization in coordinates where mass and inertia about the centre of mass are
    independent (d_r ← d_r + α, s ← e^α·s: a smooth bijection). What the model file writes as numbers
    stays: a constant mass or centre of mass drops those coordinates, and products of inertia written as 0
    give L the same zero pattern (:func:`plan_bodies`), so (7) is still a bijection onto the feasible
    bodies of that form.

    ``order`` lists the axes in the order of A's rows (so that A keeps the zero pattern of the inertia's
    products), ``edges`` the free upper entries (k, l) of A in that order, ``offset`` where its
    coordinates start in φ.
    """

    name: str
    mass: Slot
    com: tuple[Slot, Slot, Slot]
    inertia: tuple[Slot, ...]  # in the order of INERTIA_KEYS
    order: tuple[int, int, int]
    edges: tuple[tuple[int, int], ...]
    offset: int

    @property
    def free_mass(self) -> bool:
        return isinstance(self.mass, int)

    @property
    def free_inertia(self) -> bool:
        return isinstance(self.inertia[0], int)

    @property
    def free_com(self) -> tuple[int, ...]:
        """Axes whose centre-of-mass coordinate is a free parameter."""
        return tuple(i for i in range(3) if isinstance(self.com[i], int))

    @property
    def size(self) -> int:
        return int(self.free_mass) + len(self.free_com) + (3 + len(self.edges) if self.free_inertia else 0)

    def forward(self, phi: np.ndarray, p: np.ndarray, jac: np.ndarray, linear: bool = False) -> None:
        """Write this body's free parameters into ``p`` and their derivatives ∂p/∂φ into ``jac`` ((7)):
        m = e^{2α}, ∂m/∂α = 2m; c = t; with S = L·Lᵀ (rows of L in :attr:`order`),
        ∂S/∂L_rc = E_rc·Lᵀ + L·E_cr, ∂L_rr/∂d_r = L_rr, and I_c = tr(S)·1 − S read at the permuted
        positions (the trace does not depend on the order). ``linear``: the coordinates of (8), m and
        L_rr themselves in place of α and d_r."""
        k = self.offset
        if self.free_mass:
            p[self.mass] = phi[k] if linear else np.exp(2 * phi[k])
            jac[self.mass, k] = 1.0 if linear else 2 * p[self.mass]
            k += 1
        for axis in self.free_com:
            p[self.com[axis]] = phi[k]
            jac[self.com[axis], k] = 1.0
            k += 1
        if not self.free_inertia:
            return
        rows, cols, slots, at, diagonal = self._indices
        n = len(rows)
        A = self._factor(phi, k, linear)
        S = A @ A.T
        unit = np.eye(3)[rows]  # n × 3: e_r of each entry
        column = A[:, cols].T  # n × 3: A[:, c] of each entry
        dS = unit[:, :, None] * column[:, None, :] + column[:, :, None] * unit[:, None, :]
        if not linear:
            dS[:3] *= np.diag(A)[:, None, None]
        p[slots] = np.trace(S) * diagonal - S[at]
        jac[np.ix_(slots, range(k, k + n))] = np.outer(diagonal, np.trace(dS, axis1=1, axis2=2)) - dS[:, at[0], at[1]].T

    def _factor(self, phi: np.ndarray, k: int, linear: bool) -> np.ndarray:
        """The lower-triangular factor L of this body's inertia coordinates starting at ``phi[k]``: its diagonal
        from the logarithms d (or the values themselves in the linear coordinates), then the entries below."""
        rows, cols = self._indices[:2]
        L = np.zeros((3, 3))
        L[rows, cols] = np.concatenate([phi[k:k + 3] if linear else np.exp(phi[k:k + 3]), phi[k + 3:k + len(rows)]])
        return L

    def curvature(self, phi: np.ndarray, q: np.ndarray, out: np.ndarray, linear: bool = False) -> None:
        """Add Σ_j q_j·∇²_φ p_j (this body's p_j, coordinates of (7)) to ``out``: ∂²m/∂α² = 4m, and with
        Σ_j q_j·p_j = ⟨G, S⟩ over the inertia slots (G = (Σ q_j·δ_j)·1 − Σ q_j·E_{a_j b_j}, G_s its
        symmetric part) and L_e = a_e-scaled units D_e = ∂L/∂u_e: ∂²⟨G, S⟩/∂u_e∂u_f =
        2·a_e·a_f·[c_e = c_f]·G_s[r_e, r_f], plus 2·a_e·(G_s·L)[r_e, c_e] on the diagonal of a logarithm."""
        k = self.offset
        if self.free_mass:
            out[k, k] += 0.0 if linear else 4.0 * q[self.mass] * np.exp(2 * phi[k])
            k += 1
        k += len(self.free_com)
        if not self.free_inertia:
            return
        rows, cols, slots, at, diagonal = self._indices
        n = len(rows)
        L = self._factor(phi, k, linear)
        G = float(q[slots] @ diagonal) * np.eye(3)
        np.add.at(G, at, -q[slots])
        G = 0.5 * (G + G.T)
        a = np.concatenate([np.ones(3) if linear else np.exp(phi[k:k + 3]), np.ones(n - 3)])
        block = 2.0 * np.outer(a, a) * (cols[:, None] == cols[None, :]) * G[np.ix_(rows, rows)]
        if not linear:
            block[range(3), range(3)] += 2.0 * a[:3] * (G @ L)[rows[:3], cols[:3]]
        out[k:k + n, k:k + n] += block

    def typical(self, phi: np.ndarray) -> np.ndarray:
        """Sizes of this body's coordinates around ``phi`` (for the solver's scaling and the anchor):
        1 for the logarithms α and d; the mean diagonal of L for its other entries; for the centre of mass
        |t|, or where larger the radius of gyration √(mean L_ii²/m) (or 1e-3 of the largest |t|)."""
        k = self.offset + int(self.free_mass)
        com = np.abs(phi[k:k + len(self.free_com)])
        k += len(self.free_com)
        mass = np.exp(2 * phi[self.offset]) if self.free_mass else abs(float(self.mass))
        diagonal = np.exp(phi[k:k + 3]) if self.free_inertia else np.zeros(3)
        radius = float(np.sqrt(np.mean(diagonal**2) / mass)) if self.free_inertia and mass > 0 else 0.0
        out = [1.0] * int(self.free_mass) + list(np.maximum(com, max(radius, 1e-3 * float(com.max(initial=0.0)), 1e-9)))
        if self.free_inertia:
            out += [1.0] * 3 + [float(np.mean(diagonal))] * len(self.edges)
        return np.array(out, float)

    @functools.cached_property
    def _indices(self):
        """(rows, cols) of A's free entries (diagonal first), the free inertia slots, their positions in S
        (row and column arrays) and whether each is a diagonal entry."""
        rows = np.array([0, 1, 2] + [r for r, _ in self.edges], int)
        cols = np.array([0, 1, 2] + [c for _, c in self.edges], int)
        position = {axis: k for k, axis in enumerate(self.order)}
        pairs = [(slot, AXES[key]) for key, slot in zip(INERTIA_KEYS, self.inertia) if isinstance(slot, int)]
        slots = np.array([s for s, _ in pairs], int)
        at = (np.array([position[i] for _, (i, _) in pairs], int), np.array([position[j] for _, (_, j) in pairs], int))
        diagonal = np.array([float(i == j) for _, (i, j) in pairs])
        return rows, cols, slots, at, diagonal

    def start(self, p: np.ndarray, floor_mass: float, floor_inertia: float, margin: float = START_MARGIN) -> np.ndarray:
        """φ of this body at parameters ``p`` (its constants as planned), moved inside the feasible set
        where p is not (a mass below ``floor_mass`` is raised to it; Σ_c + δ·1 keeps the zero pattern)."""
        out = []
        if self.free_mass:
            out.append(0.5 * np.log(max(p[self.mass], floor_mass)))
        out += [p[self.com[axis]] for axis in self.free_com]
        if self.free_inertia:
            Ic = np.zeros((3, 3))
            for key, slot in zip(INERTIA_KEYS, self.inertia):
                i, j = AXES[key]
                Ic[i, j] = Ic[j, i] = p[slot] if isinstance(slot, int) else float(slot)
            sigma = 0.5 * np.trace(Ic) * np.eye(3) - Ic
            smallest = np.linalg.eigvalsh(sigma)[0]
            margin = max(margin * np.trace(np.abs(sigma)) / 3, floor_inertia)
            if smallest < margin:
                sigma = sigma + (margin - smallest) * np.eye(3)
            A = _upper_cholesky(sigma[np.ix_(self.order, self.order)])
            out += list(np.log(np.diag(A))) + [A[r, c] for r, c in self.edges]
        return np.array(out, float)


def _pattern_order(free_products: set[tuple[int, int]]) -> tuple[tuple[int, int, int], tuple[tuple[int, int], ...]]:
    """An order of the axes whose upper Cholesky factor keeps the zero pattern of the products, and the
    free upper entries of A in that order. Elimination runs from the last index: its neighbours must be
    adjacent (a perfect elimination order; every graph on three vertices has one)."""
    for order in itertools.permutations(range(3)):
        position = {axis: k for k, axis in enumerate(order)}
        edges = {tuple(sorted((position[i], position[j]))) for i, j in free_products}
        if not ((0, 2) in edges and (1, 2) in edges and (0, 1) not in edges):
            return tuple(order), tuple(sorted(edges))
    raise AssertionError("unreachable: every pattern of a 3×3 matrix has a perfect elimination order")


def plan_bodies(bodies, free: Sequence[sp.Symbol], values: Mapping[sp.Symbol, float], elsewhere: set[sp.Symbol],
                explicit_bounds: Mapping[sp.Symbol, tuple[float | None, float | None]]):
    """Split the bodies into those (7) parameterizes exactly (:class:`BodyPlan`, offsets 0 until placed) and
    the others (the bodies themselves, for penalties), from the slots of their model-file entries.

    Exact: a mass and centre of mass that are each one free parameter or a number, and an inertia that is
    constant, or whose diagonal entries are free parameters and products free parameters or 0. The axes are
    ordered so that the upper Cholesky factor of the zero pattern has no fill (:func:`_pattern_order`; any
    pattern of a 3×3 matrix has such an order). Parameters written as expressions or kept fixed stay as they
    are. A body that fits none of these forms (an inertia entry shared with another, an inertia written as
    an expression of free parameters, an inertia with its own ``min``/``max``) keeps its parameters as they
    are in p and gets penalty residuals w·max(0, −λ_i(Σ_c)) and w·max(0, −m) instead (approximate: its
    eigenvalues may end slightly negative); :attr:`ConsistentFit.penalized` names such bodies.

    ``elsewhere`` holds the free parameters used outside the bodies (drives, friction, forces);
    ``explicit_bounds`` the ``min``/``max`` written in the model file.
    """
    index = {s: k for k, s in enumerate(free)}
    free_set = set(free)
    uses: dict[sp.Symbol, int] = {s: int(s in elsewhere) for s in free}
    for body in bodies:
        for expression in (body.mass, *body.com, *body.inertia.values()):
            for s in sp.sympify(expression).free_symbols & free_set:
                uses[s] += 1

    def slot(expression) -> Slot:
        expression = sp.sympify(expression)
        if expression in index:
            return index[expression] if uses[expression] == 1 else None
        if not expression.free_symbols & free_set:
            return float(expression.xreplace(values))
        return None

    exact, penalized = [], []
    for body in bodies:
        symbols = set().union(*(sp.sympify(e).free_symbols for e in (body.mass, *body.com, *body.inertia.values())))
        if not symbols & free_set:
            continue  # nothing of it is estimated
        mass, com = slot(body.mass), tuple(slot(e) for e in body.com)
        inertia = tuple(slot(body.inertia[k]) for k in INERTIA_KEYS)
        diagonal = [inertia[INERTIA_KEYS.index(k)] for k in ("xx", "yy", "zz")]
        products = {k: inertia[INERTIA_KEYS.index(k)] for k in ("xy", "xz", "yz")}
        constant_inertia = all(isinstance(s, float) for s in inertia)
        free_inertia = (all(isinstance(s, int) for s in diagonal)
                        and all(isinstance(s, int) or s == 0.0 for s in products.values())
                        and not any(explicit_bounds.get(free[s]) for s in inertia if isinstance(s, int)))
        if mass is None or None in com or not (constant_inertia or free_inertia):
            penalized.append(body)
            continue
        order, edges = _pattern_order({AXES[k] for k, s in products.items() if isinstance(s, int)}) if free_inertia \
            else ((0, 1, 2), ())
        exact.append(BodyPlan(body.name, mass, com, inertia, order, edges, 0))
    return exact, penalized


# -- the fit ------------------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class ConsistentFit:
    """The physically consistent parameters and what they give.

    Attributes
    ----------
    values
        Every estimated model-file parameter (name: value), determined by the data or not.
    sigmas
        Their standard deviations from the linearised fit; infinite for those the data do not determine
        alone (they move together with others without changing τ).
    beta
        The base parameters the values give (β = K·θ(p)).
    relative_error
        100·‖y − W·β‖/‖y‖ (%) of these parameters over all samples, unweighted (what the written model gives).
    least_squares_relative_error
        The same for the unconstrained least-squares optimum (the lower bound).
    exact, penalized
        Bodies parameterized by (5), and bodies kept feasible by penalty residuals only.
    boundary
        Bodies on the boundary of the feasible set at the answer (smallest eigenvalue of J below 1e-6 of
        its largest): the constraint is active there.
    evaluations, seconds
        Residual evaluations of the solver and the wall time of the fit (the QR included).
    """

    values: dict[str, float]
    sigmas: dict[str, float]
    beta: np.ndarray = field(repr=False)
    relative_error: float
    least_squares_relative_error: float
    exact: tuple[str, ...]
    penalized: tuple[str, ...]
    boundary: tuple[str, ...]
    evaluations: int
    seconds: float
    converged: bool = True
    message: str = ""
    certificate: Any = None

    def to_dict(self) -> dict[str, Any]:
        return {"relative_error": self.relative_error,
                "least_squares_relative_error": self.least_squares_relative_error,
                "exact_bodies": list(self.exact), "penalized_bodies": list(self.penalized),
                "bodies_on_boundary": list(self.boundary), "evaluations": self.evaluations, "seconds": self.seconds,
                "converged": self.converged, "message": self.message,
                "certificate": None if self.certificate is None else self.certificate.to_dict()}

    def summary(self) -> str:
        lines = [f"consistent fit: relative error {self.relative_error:.4g} % (least squares {self.least_squares_relative_error:.4g} %), "
                 f"{self.evaluations} evaluations, {self.seconds:.2f} s"]
        if self.certificate is not None:
            c = self.certificate
            lines.append(f"  global optimum certified by {c.solver} (the convex form{'' if c.exact else ', relaxed'}): "
                         f"cost ×{c.ratio:.6f} of its lower bound, at most ×{c.guaranteed_ratio:.6f}")
        if not self.converged:
            lines.append(f"  stopped before convergence ({self.message}): what is left to gain lies along directions "
                         "the data barely determine (an optimum on the boundary of consistency, or none at a finite point)")
        if self.boundary:
            lines.append("  on the boundary of physical consistency: " + ", ".join(self.boundary))
        if self.penalized:
            lines.append("  kept physical by penalty only (their inertia is not written as free parameters): "
                         + ", ".join(self.penalized))
        return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class Problem:
    """(2) for a model: the free parameters, how φ gives them, and θ(p) with its Jacobian.

    Built by :func:`problem`.
    """

    free: tuple[sp.Symbol, ...]
    bodies: tuple[BodyPlan, ...]
    raw: tuple[int, ...]  # free parameters that are coordinates of φ themselves (after the bodies' ones)
    raw_offset: int
    lower: np.ndarray  # bounds on φ
    upper: np.ndarray
    exponents: np.ndarray  # 2 for α (m = e^{2α}), 1 for d (L_rr = e^d), 0 for the coordinates used as they are
    theta: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    theta_jacobian: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    theta_hessian: Callable[[np.ndarray, np.ndarray], np.ndarray] = field(repr=False)
    penalties: tuple[tuple[str, Callable], ...] = field(repr=False)

    @property
    def size(self) -> int:
        return len(self.lower)

    def parameters(self, phi: np.ndarray, linear: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """p(φ) and ∂p/∂φ (len(p) × len(φ)); ``linear``: φ in the coordinates of (8)."""
        p = np.zeros(len(self.free))
        jac = np.zeros((len(self.free), self.size))
        for body in self.bodies:
            body.forward(phi, p, jac, linear)
        for k, i in enumerate(self.raw):
            p[i] = phi[self.raw_offset + k]
            jac[i, self.raw_offset + k] = 1.0
        return p, jac

    def start(self, p: np.ndarray, margin: float = START_MARGIN) -> np.ndarray:
        """φ at parameters ``p`` (nominal values), moved strictly inside the feasible set (by ``margin`` of each
        body's scale, masses by ``margin`` of the largest) and the bounds."""
        masses = [p[b.mass] for b in self.bodies if b.free_mass]
        floor_mass = margin * max([abs(m) for m in masses] + [1e-12])
        inertias = [abs(p[s]) for b in self.bodies for s in b.inertia if isinstance(s, int)]
        floor_inertia = min(1e-6, margin) * max(inertias + [1e-12])
        phi = np.zeros(self.size)
        for body in self.bodies:
            phi[body.offset:body.offset + body.size] = body.start(p, floor_mass, floor_inertia, margin)
        phi[self.raw_offset:] = p[list(self.raw)]
        return _inside(phi, self.lower, self.upper)

    def curvature(self, phi: np.ndarray, q: np.ndarray, linear: bool = False) -> np.ndarray:
        """Σ_j q_j·∇²_φ p_j(φ) (len(φ) × len(φ)): the part of the Hessian of qᵀp(φ) that ∂p/∂φ misses."""
        out = np.zeros((self.size, self.size))
        for body in self.bodies:
            body.curvature(phi, q, out, linear)
        return out

    def linear(self, phi: np.ndarray) -> np.ndarray:
        """φ in the coordinates of (8): m = e^{2α} and L_rr = e^{d_r} in place of α and d_r."""
        return np.where(self.exponents > 0, np.exp(self.exponents * phi), phi)

    def linear_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounds in the coordinates of (8): a mass within its min/max and ≥ 0, L_rr ≥ 0."""
        logs = self.exponents > 0
        with np.errstate(over="ignore", invalid="ignore"):
            return (np.where(logs, np.exp(self.exponents * self.lower), self.lower),
                    np.where(logs, np.exp(self.exponents * self.upper), self.upper))

    def typical(self, phi: np.ndarray) -> np.ndarray:
        """Sizes of the coordinates of φ around ``phi``: the bodies' (:meth:`BodyPlan.typical`), and for the
        other parameters |φ_i| or, where smaller, 1e-3 of the largest of them."""
        out = np.ones(self.size)
        for body in self.bodies:
            out[body.offset:body.offset + body.size] = body.typical(phi)
        raw = np.abs(phi[self.raw_offset:])
        out[self.raw_offset:] = np.maximum(raw, max(1e-3 * float(raw.max(initial=0.0)), 1e-9))
        return out


def _inside(x: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """x clipped into [lower, upper], a little inside a finite bound it crossed."""
    span = np.where(np.isfinite(upper - lower), upper - lower, np.inf)
    room = np.minimum(1e-9 * np.maximum(np.abs(x), 1.0), 0.5 * span)
    return np.clip(x, lower + np.where(np.isfinite(lower), room, 0.0), upper - np.where(np.isfinite(upper), room, 0.0))


def problem(model, reg, free: Sequence[sp.Symbol], bounds: Mapping[sp.Symbol, tuple[float, float]]) -> Problem:
    """The :class:`Problem` of ``model`` for the ``free`` parameters (those in θ, not fixed, not geometry).

    ``bounds`` are :func:`symbolic.identify.known.parameter_bounds` (role signs and ``min``/``max``).
    """
    free = tuple(free)
    values = {s: v for s, v in model.parameters.items() if s not in set(free)}
    kinds = reg.kinds
    elsewhere = set().union(*(e.free_symbols for e, kind in zip(reg.theta_expressions, kinds) if kind != "inertial"))
    explicit = {p.symbol: (p.minimum, p.maximum) for p in model.robot.parameters
                if p.minimum is not None or p.maximum is not None}
    exact, penalized = plan_bodies(model.robot.bodies, free, values, elsewhere & set(free),
                                   {s: b for s, b in explicit.items() if b != (None, None)})
    planned, offset, lower, upper, exponents = [], 0, [], [], []
    for body in exact:
        body = BodyPlan(body.name, body.mass, body.com, body.inertia, body.order, body.edges, offset)
        planned.append(body)
        offset += body.size
        exponents += [2] * int(body.free_mass) + [0] * len(body.free_com)
        exponents += ([1] * 3 + [0] * len(body.edges)) if body.free_inertia else []
        if body.free_mass:  # a mass's min/max bound α = ½·log m
            low, high = explicit.get(free[body.mass], (None, None))
            lower.append(0.5 * np.log(low) if low is not None and low > 0 else -np.inf)
            upper.append(0.5 * np.log(high) if high is not None and high > 0 else np.inf)
            if high is not None and high <= 0:
                raise ValueError(f"body {body.name}: max of its mass is {high} (a mass must be positive)")
        for axis in body.free_com:
            low, high = bounds.get(free[body.com[axis]], (-np.inf, np.inf))
            lower.append(low)
            upper.append(high)
        if body.free_inertia:
            lower += [-np.inf] * (3 + len(body.edges))
            upper += [np.inf] * (3 + len(body.edges))
    owned = {s for b in planned for s in (b.mass, *b.com, *b.inertia) if isinstance(s, int)}
    raw = tuple(i for i in range(len(free)) if i not in owned)
    for i in raw:
        low, high = bounds.get(free[i], (-np.inf, np.inf))
        lower.append(low)
        upper.append(high)
    theta, theta_jacobian, theta_hessian = _theta_functions(reg.theta_expressions, free, values)
    penalties = tuple((body.name, _penalty_function(body, free, values)) for body in penalized)
    exponents += [0] * len(raw)
    return Problem(free, tuple(planned), raw, offset, np.array(lower, float), np.array(upper, float),
                   np.array(exponents, float), theta, theta_jacobian, theta_hessian, penalties)


def _theta_functions(expressions: Sequence[sp.Expr], free: Sequence[sp.Symbol], values: Mapping[sp.Symbol, float]):
    """θ(p) and its Jacobian ∂θ/∂p (dense, from the nonzero entries of the symbolic one) for the free p."""
    exprs = [sp.expand(e.xreplace(values)) for e in expressions]
    entries = [(i, j, sp.diff(e, s)) for i, e in enumerate(exprs) for j, s in enumerate(free) if s in e.free_symbols]
    entries = [(i, j, d) for i, j, d in entries if d != 0]
    theta = sp.lambdify([list(free)], exprs, modules="numpy")
    derivative = sp.lambdify([list(free)], [d for _, _, d in entries], modules="numpy")
    rows = np.array([i for i, _, _ in entries], int)
    cols = np.array([j for _, j, _ in entries], int)
    shape = (len(exprs), len(free))

    def jacobian(p: np.ndarray) -> np.ndarray:
        out = np.zeros(shape)
        out[rows, cols] = np.array(derivative(p), float) if len(rows) else 0.0
        return out

    second = [(k, i, j, sp.diff(d, free[j])) for k, i, d in entries for j in range(i, len(free))
              if free[j] in d.free_symbols]  # ∂²θ_k/∂p_i∂p_j, i ≤ j
    second = [(k, i, j, d) for k, i, j, d in second if d != 0]
    second_of = sp.lambdify([list(free)], [d for *_, d in second], modules="numpy")
    which = np.array([k for k, *_ in second], int)
    at_i = np.array([i for _, i, _, _ in second], int)
    at_j = np.array([j for _, _, j, _ in second], int)

    def contracted(p: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Σ_k w_k·∇²θ_k(p) (len(p) × len(p))."""
        out = np.zeros((len(free), len(free)))
        if len(second):
            values = w[which] * np.array(second_of(p), float)
            np.add.at(out, (at_i, at_j), values)
            np.add.at(out, (at_j, at_i), np.where(at_i != at_j, values, 0.0))
        return out

    return (lambda p: np.array(theta(p), float)), jacobian, contracted


def _penalty_function(body, free: Sequence[sp.Symbol], values: Mapping[sp.Symbol, float]):
    """For a body (7) cannot parameterize: p ↦ (violations [−λ(Σ_c), −m]₊, their derivatives ∂/∂p)."""
    tensor = body.inertia_tensor.xreplace(values)
    sigma = (tensor.trace() / 2) * sp.eye(3) - tensor
    mass = sp.sympify(body.mass).xreplace(values)
    sigma_of = sp.lambdify([list(free)], sigma, modules="numpy")
    dsigma = [sp.lambdify([list(free)], sigma.diff(s), modules="numpy") for s in free]
    mass_of = sp.lambdify([list(free)], mass, modules="numpy")
    dmass = sp.lambdify([list(free)], [sp.diff(mass, s) for s in free], modules="numpy")
    acting = [k for k, s in enumerate(free) if s in sigma.free_symbols]

    def violations(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        eig, vec = np.linalg.eigh(np.array(sigma_of(p), float))
        jac = np.zeros((4, len(free)))
        for k in acting:  # ∂λ_i/∂p_k = v_iᵀ·(∂Σ_c/∂p_k)·v_i (simple eigenvalues)
            d = np.array(dsigma[k](p), float)
            jac[:3, k] = np.einsum("ji,jk,ki->i", vec, d, vec)
        jac[3] = np.array(dmass(p), float)
        value = np.append(eig, float(mass_of(p)))
        active = value < 0
        return np.where(active, -value, 0.0), np.where(active[:, None], -jac, 0.0)

    return violations


def row_weights(method: str, coordinate_sigmas: Sequence[float], samples: int) -> np.ndarray:
    """The weights of the fit's rows, as :func:`symbolic.identify.least_squares.solve` applies them:
    1/σ_j per coordinate for WLS with more than one coordinate and usable σ_j, 1 otherwise."""
    sigmas = np.asarray(coordinate_sigmas, float)
    if method == "wls" and len(sigmas) > 1 and np.all(np.isfinite(sigmas) & (sigmas > 0)):
        return np.repeat(1.0 / sigmas, samples)
    return np.ones(len(sigmas) * samples)


@dataclass(frozen=True, eq=False)
class Summary:
    """The weighted fit ``y ≈ W·β`` summarised: R (b × b), z, ρ, and ‖y_w‖.

    With the weighted rows, [W y] = Q·[[R, z], [0, ρ]] (Householder QR; Golub & Van Loan 5.3.3), so that for
    every β

        ‖y − W·β‖² = ‖z − R·β‖² + ρ²                                                              (1)
    """

    R: np.ndarray
    z: np.ndarray
    rho: float
    norm: float
    rows: int

    @classmethod
    def of(cls, W: np.ndarray, y: np.ndarray, weights: np.ndarray) -> Summary:
        """The triangular factor of the QR decomposition of [diag(w)·W, diag(w)·y] (Householder, through
        LAPACK: backward stable, one pass over the samples)."""
        b = W.shape[1]
        Rfull = np.linalg.qr(np.column_stack([W * weights[:, None], y * weights]), mode="r")
        rho = float(abs(Rfull[b, b])) if Rfull.shape[0] > b else 0.0
        return cls(Rfull[:b, :b], Rfull[:b, b], rho, float(np.linalg.norm(y * weights)), W.shape[0])


def fit(prob: Problem, K: np.ndarray, W: np.ndarray, y: np.ndarray, weights: np.ndarray, p0: np.ndarray,
        least_squares_beta: np.ndarray, name: str = "model") -> tuple[ConsistentFit, np.ndarray, np.ndarray]:
    """The physically consistent estimate for the fit ``y ≈ W·β`` (rows weighted by ``weights``), from the
    parameters ``p0``.

    By (1) (:class:`Summary`) the estimate

        min_φ ‖R·K·θ(p(φ)) − z‖²                                                                   (2)

    has b residuals. K maps the standard parameters θ to the base ones (β = K·θ,
    :class:`symbolic.numeric.base_parameters.BaseParameters`), θ(p) are the regressor's expressions of the
    model file's parameters p (:mod:`symbolic.derivation.regressor`), and p(φ) parameterizes the feasible
    set exactly ((7), :class:`BodyPlan`), so (2) is unconstrained but for box bounds. Its Jacobian is
    analytic,

        ∂r/∂φ = R·K·(∂θ/∂p)·(∂p/∂φ)                                                                (3)

    (∂θ/∂p from SymPy, ∂p/∂φ in closed form). The answer's β is unique where the feasible β form a convex
    set (the objective is strictly convex in β); the p that give it need not be.

    Where the answer lies on the boundary (a body with a singular Σ_c, a mass at 0) some coordinates of (7)
    must go to −∞, and a solver creeps there. The fit therefore runs two passes (:func:`_solve`):

    1. Gauss–Newton (:func:`scipy.optimize.least_squares`, ``trf``, Jacobian (3)) in the log-Cholesky
       coordinates (7) with a weak pull to the start, until a step gains less than :data:`FIRST_PASS_FTOL`
       of the cost: it brings every body near the answer while staying strictly feasible;
    2. Newton's method with a trust region and the exact Hessian (9) (:func:`_newton`) in the Cholesky
       coordinates

           m,  t,  L_rr ≥ 0,  L_rs (r < s)                                                         (8)

       — the same factor with its diagonal and the mass as they are, bounded below by 0, so that the
       boundary is at a finite point — until the gradient is below :data:`GRADIENT_TOLERANCE`·σ²
       (converged), or χ² stalls (:data:`STALL_CHI2`), or :data:`MAX_ITERATIONS`.

    Where the data leave combinations of parameters undetermined, the infimum of (2) may be approached only
    as some of them run off (a mass to 0 or ∞ with its centre of mass following): the second pass then stops
    with the cost still falling slowly, and :attr:`ConsistentFit.converged` says so.

    Friction coefficients, rotor inertias, stiffnesses and dampings keep the signs of their roles and their
    ``min``/``max`` as box bounds (:func:`symbolic.identify.known.parameter_bounds`), kept exactly (by ``trf``
    in the first pass, by a change of variable in the second, :class:`_Unbounded`); a mass's ``min``/``max``
    bound α, then m, and a centre of mass's bound t.

    Returns
    -------
    tuple
        The :class:`ConsistentFit`, the free parameters p* and their covariance (∞ on the rows of those not
        determined alone).
    """
    started = time.perf_counter()
    summary = Summary.of(W, y, weights)
    with one_blas_thread():
        p, evaluations, converged, message, certificate = _estimate(prob, summary.R @ K, summary, p0, name, started)
    beta = K @ prob.theta(p)
    norm = max(float(np.linalg.norm(y)), 1e-300)
    relative = 100.0 * float(np.linalg.norm(y - W @ beta)) / norm
    best = 100.0 * float(np.linalg.norm(y - W @ least_squares_beta)) / norm
    residual = summary.R @ beta - summary.z
    covariance = _covariance(summary.R @ K @ prob.theta_jacobian(p), p, p0, residual, summary.rho, W.shape[0])
    seconds = time.perf_counter() - started
    if seconds > PROGRESS_AFTER:
        log.info("%s: consistent fit done in %.1f s (%d evaluations)", name, seconds, evaluations)
    result = ConsistentFit(
        values={s.name: float(v) for s, v in zip(prob.free, p)},
        sigmas={s.name: float(np.sqrt(covariance[k, k])) for k, s in enumerate(prob.free)},
        beta=beta, relative_error=relative, least_squares_relative_error=best,
        exact=tuple(body.name for body in prob.bodies), penalized=tuple(n for n, _ in prob.penalties),
        boundary=tuple(_on_boundary(prob, p)), evaluations=evaluations, seconds=seconds, converged=converged,
        message=message, certificate=certificate)
    return result, p, covariance


def _estimate(prob: Problem, A: np.ndarray, summary: Summary, p0: np.ndarray, name: str,
              started: float) -> tuple[np.ndarray, int, bool, str, Any]:
    """p* of (2), the evaluations (or interior-point iterations) spent, whether it converged, why it stopped,
    and the certificate of its global optimality (None without one).

    Where θ is affine in the lifted variables of (11) (:func:`symbolic.identify.conic.lift`) the convex form
    is solved by Clarabel: where (11) is the problem itself (every constraint of the model file's form is
    convex there: bodies written with their ten parameters, constants, bounds) its polished answer is the
    answer; where it is a relaxation (constraints dropped), its optimum is a lower bound only, and the
    log-Cholesky passes (:func:`_solve`) run from its answer (brought into the model's form), and from ``p0``
    where that answer is not within :data:`CERTIFIED_WITHIN` of the bound, the better kept. Either way the
    answer's cost is compared with the certified lower bound (:class:`symbolic.identify.conic.Certificate`):
    converged when within :data:`CERTIFIED_WITHIN` of it. Where θ is not affine in those variables the
    log-Cholesky passes run alone and say themselves whether they converged."""
    from symbolic.identify import conic

    lifted = _lifted(prob, p0)
    if lifted is None:
        solution, evaluations = _solve(prob, A, summary, p0, name, started)
        return prob.parameters(solution.x, linear=True)[0], evaluations, solution.converged, solution.message, None
    sizes = conic.body_sizes(lifted, conic.lifted_point(prob, prob.parameters(prob.linear(prob.start(p0)), linear=True)[0]))
    solved = conic.solve(lifted, A, summary.z, sizes)
    bound = conic.dual_bound(lifted, A, summary.z, sizes, solved.x)

    def certify(p: np.ndarray) -> conic.Certificate:
        r = A @ prob.theta(p) - summary.z
        return conic.Certificate.of(solved, bound, float(r @ r), summary.rho**2, summary.norm**2, lifted)

    if lifted.exact:
        x = conic.polish(lifted, A, summary.z, solved.x)
        p = _newton_polish(prob, A, summary, _feasible(prob, conic.parameters_of(prob, x, p0)), name, started)
        p, evaluations, local = _feasible(prob, p), solved.iterations, None
    else:
        p, evaluations, local = _model_form(prob, A, summary, (conic.parameters_of(prob, solved.x, p0), p0),
                                            lambda q: certify(q).guaranteed_ratio <= 1.0 + CERTIFIED_WITHIN, name, started)
        p = _feasible(prob, p)
    certificate = certify(p)
    within = certificate.guaranteed_ratio <= 1.0 + CERTIFIED_WITHIN
    what = "global optimum" if lifted.exact else "global optimum of its convex relaxation"
    message = (f"cost ×{certificate.ratio:.7f} of the dual lower bound of the {what}, at most "
               f"×{certificate.guaranteed_ratio:.7f} allowing for the dual point's rounding ({certificate.solver}: "
               f"primal {solved.status}, dual {bound.status})")
    if local is not None:
        message += f"; log-Cholesky passes: {local.message}"
    return p, evaluations, within, message, certificate


def _lifted(prob: Problem, p0: np.ndarray) -> Any:
    """The convex form (11) of ``prob`` (:func:`symbolic.identify.conic.lift`), or None where θ is not affine in
    its variables or Clarabel cannot be imported (the log-Cholesky passes then run alone)."""
    try:
        import clarabel  # noqa: F401  (a run-time dependency; a broken install falls back to the passes)
    except ImportError:
        log.warning("clarabel cannot be imported: the consistent fit runs without its certificate")
        return None
    from symbolic.identify import conic

    return conic.lift(prob, p0)


def _lifted_typical(lifted, x0: np.ndarray) -> np.ndarray:
    """Sizes of the variables of (11) for the solver's scaling: each body's largest standard parameter (so
    that a body's scaling keeps its J's shape), the others |x0| or 1e-3 of the largest."""
    out = np.maximum(np.abs(x0), 1e-3 * max(float(np.abs(x0).max(initial=0.0)), 1e-12))
    for block in lifted.blocks:
        out[list(block)] = max(float(np.abs(x0[list(block)]).max()), 1e-12)
    return out


def _model_form(prob: Problem, A: np.ndarray, summary: Summary, starts: Sequence[np.ndarray],
                good: Callable[[np.ndarray], bool], name: str, started: float) -> tuple[np.ndarray, int, _Solution]:
    """The log-Cholesky passes from each of ``starts`` in turn (the relaxation's answer, moved into the model's
    form by :meth:`Problem.start`, then the nominal values) until an answer is ``good`` (certified close enough
    to the bound); the cheapest answer, the evaluations of all, its solution."""
    best, spent = None, 0
    for start in starts:
        solution, evaluations = _solve(prob, A, summary, start, name, started)
        spent += evaluations
        p = prob.parameters(solution.x, linear=True)[0]
        r = A @ prob.theta(p) - summary.z
        if best is None or float(r @ r) < best[0]:
            best = (float(r @ r), p, solution)
        if good(best[1]):
            break
    return best[1], spent, best[2]


def _newton_polish(prob: Problem, A: np.ndarray, summary: Summary, p: np.ndarray, name: str, started: float) -> np.ndarray:
    """p, or the answer of at most :data:`POLISH_ITERATIONS` Newton iterations (:func:`_newton`) from it where
    cheaper: the interior-point answer is optimal to about 1e-8 of the cost; Newton's method in the Cholesky
    coordinates (8), with the factor's diagonal free in sign (L·Lᵀ is positive semidefinite whatever the signs,
    so that a body at the boundary, L → 0, is a smooth minimum there), brings it to rounding where the answer
    is regular."""
    x1 = prob.linear(prob.start(p, margin=0.0))
    lower, upper = prob.linear_bounds()
    lower = np.where(prob.exponents == 1, -np.inf, lower)
    logs = prob.exponents > 0
    scale = np.where(logs, np.maximum(np.abs(x1), 1e-3 * float(np.abs(x1[logs]).max(initial=0.0)) + 1e-300),
                     prob.typical(prob.start(p, margin=0.0)))
    solution = _newton(prob, A, summary, _inside(x1, lower, upper), lower, upper, scale, 0.0,
                       _Progress(name, started, summary.norm), POLISH_ITERATIONS)
    polished = prob.parameters(solution.x, linear=True)[0]

    def cost(q: np.ndarray) -> float:
        r = A @ prob.theta(q) - summary.z
        return float(r @ r)

    return polished if cost(polished) < cost(p) else p


def _tidy(prob: Problem, p: np.ndarray) -> np.ndarray:
    """p with each body's free centre-of-mass coordinates and products of inertia below 1e-15 of its size
    (the largest |c|, and the largest diagonal inertia) set to 0."""
    for body in prob.bodies:
        com = [body.com[a] for a in body.free_com]
        if com:
            size = max(float(np.abs(p[com]).max()), 0.0)
            p[com] = np.where(np.abs(p[com]) < max(1e-15 * size, 1e-30), 0.0, p[com])
        if body.free_inertia:
            diagonal = [body.inertia[INERTIA_KEYS.index(k)] for k in ("xx", "yy", "zz")]
            products = [s for k, s in zip(INERTIA_KEYS, body.inertia) if k in ("xy", "xz", "yz") and isinstance(s, int)]
            size = float(np.abs(p[diagonal]).max())
            p[products] = np.where(np.abs(p[products]) < max(1e-15 * size, 1e-30), 0.0, p[products])
    return p


def _feasible(prob: Problem, p: np.ndarray) -> np.ndarray:
    """p with each body's Σ_c = ½·tr(I_c)·1 − I_c raised to positive semidefinite where the interior-point
    answer left it a rounding below (Σ_c + δ·1, δ = −λ_min + 1e-15 of J's scale: I_c's diagonal + 2δ, its zero
    pattern kept) and each free mass at 0 at least: every J of (4) is then ⪰ 0 (J ⪰ 0 ⇔ m ≥ 0, Σ_c ⪰ 0).
    Centres of mass and products of inertia below 1e-15 of the body's size (rounding, as 1e-44) are 0 first:
    the model file writes magnitudes of 1e-30 to 1e30 or 0 (docs/model-format.md)."""
    p = _tidy(prob, np.array(p, float))
    for body in prob.bodies:
        if body.free_mass:
            p[body.mass] = max(p[body.mass], 0.0)
        if not body.free_inertia:
            continue
        Ic = np.zeros((3, 3))
        for key, slot in zip(INERTIA_KEYS, body.inertia):
            Ic[AXES[key]] = Ic[AXES[key][::-1]] = p[slot] if isinstance(slot, int) else float(slot)
        mass = p[body.mass] if body.free_mass else float(body.mass)
        lam = np.linalg.eigvalsh(0.5 * np.trace(Ic) * np.eye(3) - Ic)
        scale = max(float(lam[-1]), abs(mass), 1e-300)
        delta = max(0.0, -float(lam[0])) + 1e-15 * scale if lam[0] < 1e-15 * scale else 0.0
        for key in ("xx", "yy", "zz"):
            p[body.inertia[INERTIA_KEYS.index(key)]] += 2.0 * delta
    return p


def _solve(prob: Problem, A: np.ndarray, summary: Summary, p0: np.ndarray, name: str, started: float):
    """The two passes of :func:`fit` on r(φ) = [A·θ(p(φ)) − z, pull, penalties] with A = R·K ((2)–(3)).

    Returns the second pass's solution (in the coordinates of (8)) and the number of evaluations."""
    import scipy.optimize  # here only: identification without --consistent never imports SciPy

    inertias = [abs(p0[s]) for body in prob.bodies for s in body.inertia if isinstance(s, int)]
    weight = PENALTY_WEIGHT * summary.norm / max(inertias + [1e-3])  # w·violation in units of ‖y_w‖
    cache: dict[str, Any] = {}
    progress = _Progress(name, started, summary.norm)
    x0 = prob.start(p0)
    typical = prob.typical(x0)
    anchor = ANCHOR_WEIGHT * max(summary.rho, 1e-6 * summary.norm) / np.sqrt(prob.size) / typical

    def evaluate(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = phi.tobytes()
        if cache.get("key") != key:
            p, dp = prob.parameters(phi)
            r = A @ prob.theta(p) - summary.z
            rows, jrows = [r, anchor * (phi - x0)], [A @ (prob.theta_jacobian(p) @ dp), np.diag(anchor)]
            for _, violations in prob.penalties:
                v, dv = violations(p)
                rows.append(weight * v)
                jrows.append(weight * dv @ dp)
            cache.update(key=key, r=np.concatenate(rows), jac=np.vstack(jrows))
            progress.tick(r)
        return cache["r"], cache["jac"]

    first = scipy.optimize.least_squares(lambda x: evaluate(x)[0], x0, jac=lambda x: evaluate(x)[1],
                                         bounds=(prob.lower, prob.upper), x_scale=typical, method="trf",
                                         ftol=FIRST_PASS_FTOL, xtol=1e-14, gtol=1e-14, max_nfev=MAX_EVALUATIONS)
    x1 = prob.linear(first.x)
    lower, upper = prob.linear_bounds()
    logs = prob.exponents > 0  # sizes of m and L_rr: their values at the first answer, at least 1e-3 of the largest
    scale = np.where(logs, np.maximum(x1, 1e-3 * float(x1[logs].max(initial=0.0)) + 1e-300), typical)
    solution = _newton(prob, A, summary, _inside(x1, lower, upper), lower, upper, scale, weight, progress)
    return solution, progress.evaluations


class _Progress:
    """Counts evaluations and says where the fit is every :data:`PROGRESS_AFTER` seconds (logging INFO)."""

    def __init__(self, name: str, started: float, norm: float) -> None:
        self.name, self.started, self.norm = name, started, norm
        self.next = started + PROGRESS_AFTER
        self.evaluations = 0

    def tick(self, residual: np.ndarray) -> None:
        self.evaluations += 1
        now = time.perf_counter()
        if now >= self.next:
            self.next = now + PROGRESS_AFTER
            log.info("%s: consistent fit: %d evaluations, ‖R·β − z‖/‖y‖ = %.4g, %.1f s", self.name,
                     self.evaluations, float(np.linalg.norm(residual)) / self.norm, now - self.started)


def _newton(prob: Problem, A: np.ndarray, summary: Summary, x1: np.ndarray, lower: np.ndarray, upper: np.ndarray,
            typical: np.ndarray, weight: float, progress: _Progress, iterations: int = MAX_ITERATIONS) -> _Solution:
    """The second pass: Newton's method with a trust region (Nocedal & Wright, Algorithm 4.1; the step of
    :func:`_trust_step`) on F(φ) = ½‖A·θ(p(φ)) − z‖² (+ the penalties) with its exact Hessian

        ∇²F = JᵀJ + (∂p/∂φ)ᵀ·(Σ_k w_k·∇²θ_k)·(∂p/∂φ) + Σ_j q_j·∇²p_j,  w = Aᵀ·r,  q = (∂θ/∂p)ᵀ·w      (9)

    (the penalties contribute their Gauss–Newton part only). Gauss–Newton alone drops the last two terms,
    which are large where the answer is far from the least-squares optimum: it then creeps along the curved
    valleys of m·c and of the boundary (the Panda's log: 11 194 → 11 008 in 2000 evaluations, not done).
    Bounded coordinates are mapped to unbounded ones u (:class:`_Unbounded`), so the box bounds still hold
    exactly. Returns the solution in the coordinates (8)."""
    coordinates = _Unbounded(lower, upper, typical)
    cache: dict[str, Any] = {}

    def parts(u: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        key = u.tobytes()
        if cache.get("key") != key:
            phi, d1, d2 = coordinates.forward(u)
            p, dp = prob.parameters(phi, linear=True)
            Jt = prob.theta_jacobian(p)
            r = A @ prob.theta(p) - summary.z
            J = A @ (Jt @ dp)
            w = A.T @ r
            g = J.T @ r
            H = J.T @ J + dp.T @ prob.theta_hessian(p, w) @ dp + prob.curvature(phi, Jt.T @ w, linear=True)
            cost = 0.5 * float(r @ r)
            for _, violations in prob.penalties:
                v, dv = violations(p)
                Jv = weight * dv @ dp
                g, H, cost = g + Jv.T @ (weight * v), H + Jv.T @ Jv, cost + 0.5 * float(weight**2 * v @ v)
            cache.update(key=key, out=(cost, d1 * g, d1[:, None] * H * d1[None, :] + np.diag(d2 * g)))
            progress.tick(r)
        return cache["out"]

    variance = summary.rho**2 / max(summary.rows - len(summary.z), 1)  # σ² per row of the weighted fit
    gtol = max(GRADIENT_TOLERANCE * variance, 1e-300)
    u = coordinates.inverse(x1)
    cost, g, H = parts(u)
    costs, radius, message, converged = [cost], 1.0, f"{iterations} Newton iterations", False
    for _ in range(iterations):
        if np.linalg.norm(g) <= gtol:
            message, converged = "the gradient is below its tolerance", True
            break
        if len(costs) > STALL_ITERATIONS and costs[-STALL_ITERATIONS - 1] - costs[-1] < 0.5 * STALL_CHI2 * variance:
            message = (f"χ² fell by less than {STALL_CHI2:g} in the last {STALL_ITERATIONS} Newton iterations, "
                       f"{len(costs) - 1} in all")
            break
        step, predicted = _trust_step(g, H, radius)
        trial = parts(u + step)
        ratio = (cost - trial[0]) / predicted if predicted > 0 and np.isfinite(trial[0]) else -1.0
        if ratio < 0.25:
            radius = 0.25 * np.linalg.norm(step)
        elif ratio > 0.75 and np.linalg.norm(step) >= 0.99 * radius:
            radius *= 2.0
        if ratio > 1e-4:  # accepted
            u, (cost, g, H) = u + step, trial
            costs.append(cost)
        if radius < 1e-14 * max(1.0, float(np.linalg.norm(u))):
            message, converged = "the trust region fell below rounding", True
            break
    return _Solution(coordinates.forward(u)[0], message, converged)


def _trust_step(g: np.ndarray, H: np.ndarray, radius: float) -> tuple[np.ndarray, float]:
    """The minimiser of gᵀs + ½·sᵀHs over ‖s‖ ≤ radius and the decrease it predicts (Moré & Sorensen 1983,
    through the eigendecomposition H = V·diag(λ)·Vᵀ): s = −V·(λ + μ)⁻¹·Vᵀg with μ ≥ max(0, −λ_min) the root of
    ‖s(μ)‖ = radius where the Newton step is longer or H is not positive definite; in the hard case (g
    orthogonal to the eigenvectors of λ_min) the missing length is taken along that eigenvector."""
    lam, V = np.linalg.eigh(0.5 * (H + H.T))
    gt = V.T @ g
    scale = max(float(np.abs(lam).max(initial=0.0)), 1e-300)

    def length(mu: float) -> float:
        return float(np.linalg.norm(gt / (lam + mu)))

    if lam[0] > 1e-14 * scale and length(0.0) <= radius:
        s = -V @ (gt / lam)
    else:
        low = max(0.0, -lam[0]) + 1e-14 * scale
        lowest = lam - lam[0] <= 1e-12 * scale  # the eigenspace of λ_min
        flat = np.all(np.abs(gt[lowest]) <= 1e-12 * max(float(np.linalg.norm(g)), 1e-300))
        rest = -V[:, ~lowest] @ (gt[~lowest] / (lam[~lowest] - lam[0])) if lam[0] <= 0 else None
        if flat and rest is not None and np.linalg.norm(rest) <= radius:
            # the hard case: g has no part along λ_min's eigenvectors; μ = −λ_min and the missing length
            # is taken along one of them
            s = rest + np.sqrt(max(radius**2 - float(rest @ rest), 0.0)) * V[:, 0]
        else:
            high = low + float(np.linalg.norm(g)) / radius + scale
            for _ in range(200):  # bisection on μ in [low, high]: ‖s(μ)‖ decreases with μ
                mu = 0.5 * (low + high)
                low, high = (mu, high) if length(mu) > radius else (low, mu)
                if high - low <= 1e-12 * high:
                    break
            s = -V @ (gt / (lam + high))
    return s, -float(g @ s + 0.5 * s @ H @ s)


@dataclass(frozen=True)
class _Solution:
    x: np.ndarray
    message: str
    converged: bool


@dataclass(frozen=True)
class _Unbounded:
    """φ of unbounded coordinates u, elementwise, scaled by the typical sizes t: φ = t·u where φ is free,
    l + t·u² (≥ l) with a lower bound only, h − t·u² with an upper bound only, and (l + h)/2 + (h − l)/2·sin u
    between two bounds."""

    lower: np.ndarray
    upper: np.ndarray
    typical: np.ndarray

    def forward(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """φ(u), dφ/du and d²φ/du² (elementwise)."""
        l, h, t = self.lower, self.upper, self.typical
        low, high = np.isfinite(l), np.isfinite(h)
        with np.errstate(invalid="ignore"):
            mid, half = np.where(low & high, 0.5 * (l + h), 0.0), np.where(low & high, 0.5 * (h - l), 0.0)
        phi = np.select([low & high, low, high], [mid + half * np.sin(u), l + t * u**2, h - t * u**2], t * u)
        d1 = np.select([low & high, low, high], [half * np.cos(u), 2 * t * u, -2 * t * u], t)
        d2 = np.select([low & high, low, high], [-half * np.sin(u), 2 * t, -2 * t], 0.0)
        return phi, d1, d2

    def inverse(self, phi: np.ndarray) -> np.ndarray:
        """u of a φ within the bounds."""
        l, h, t = self.lower, self.upper, self.typical
        low, high = np.isfinite(l), np.isfinite(h)
        with np.errstate(invalid="ignore", divide="ignore"):
            both = np.arcsin(np.clip((phi - 0.5 * (l + h)) / (0.5 * (h - l)), -1.0, 1.0))
            return np.select([low & high, low, high],
                             [both, np.sqrt(np.maximum(phi - l, 0.0) / t), np.sqrt(np.maximum(h - phi, 0.0) / t)], phi / t)


def _covariance(J: np.ndarray, p: np.ndarray, p0: np.ndarray, residual: np.ndarray, rho: float, rows: int) -> np.ndarray:
    """σ²·(JᵀJ)⁺ of the linearised fit in p, with σ² = (‖Rβ − z‖² + ρ²)/(rows − rank) (Janot et al. 2007
    (5)–(6) on the system (1)); ∞ for parameters with a component in the null space of J (not determined
    alone: they move with others without changing τ). Columns are scaled by the parameters' sizes first,
    so that the rank test does not depend on units."""
    typical = np.maximum(np.maximum(np.abs(p), np.abs(p0)), 1e-3 * max(float(np.abs(p0).max(initial=0.0)), 1e-12))
    _, s, Vt = np.linalg.svd(J * typical)
    rank = int(np.sum(s > 1e-8 * s.max(initial=0.0)))
    sigma2 = (float(residual @ residual) + rho**2) / max(rows - rank, 1)
    covariance = sigma2 * (Vt[:rank].T / s[:rank] ** 2) @ Vt[:rank] * np.outer(typical, typical)
    null = Vt[rank:]
    undetermined = np.linalg.norm(null, axis=0) > 1e-6 if null.size else np.zeros(len(p), bool)
    covariance[undetermined, :] = np.inf
    covariance[:, undetermined] = np.inf
    return covariance


def _on_boundary(prob: Problem, p: np.ndarray) -> list[str]:
    """Exactly parameterized bodies whose Σ_c (or mass) is singular to 1e-6 of its size at p."""
    out = []
    for body in prob.bodies:
        if not body.free_inertia:
            continue
        Ic = np.zeros((3, 3))
        for key, slot in zip(INERTIA_KEYS, body.inertia):
            i, j = AXES[key]
            Ic[i, j] = Ic[j, i] = p[slot] if isinstance(slot, int) else float(slot)
        eig = np.linalg.eigvalsh(0.5 * np.trace(Ic) * np.eye(3) - Ic)
        if eig[0] <= 1e-6 * max(eig[-1], 1e-300):
            out.append(body.name)
    return out
