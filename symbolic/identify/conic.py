"""The convex form of the physically consistent fit, solved to a certified global optimum (issue 38 §3).

In the standard parameters of each body — [XX XY XZ YY YZ ZZ MX MY MZ M] about its frame, which the
regressor's θ is affine in — physical consistency is a linear matrix inequality (Wensing, Kim & Slotine,
"Linear matrix inequalities for physically consistent inertial parameter identification: a statistical
perspective on the mass distribution", IEEE RA-L 3(1), 2018, arXiv:1701.04395: the pseudo-inertia of a body
is positive semidefinite exactly when some mass distribution has its ten parameters; their equation numbers
are not quoted here, not having been checked against the published text):

    J(π) = [[½·tr(I_O)·1 − I_O, h], [hᵀ, m]] ⪰ 0                                                    (10)

so that with the summary (1) of :mod:`symbolic.identify.consistent` the fit

    min_x ‖R·K·(T·x + t₀) − z‖²  s.t.  J_b(x) ⪰ 0 (each body b),  E·x = e,  G·x ≤ g                   (11)

is a small semidefinite program (the form Wensing et al. solve to global optimality): its size is b
residuals and ten variables a body, whatever the log's length. x holds each body's standard parameters and the other free parameters
(friction, drives: θ is affine in them); E·x = e keeps what the model file writes as numbers (a constant
mass, a constant centre-of-mass coordinate, m·c linear in m; products of inertia written as 0 where one of
the two centre-of-mass coordinates is constant), G·x ≤ g the bounds (the signs of the roles, ``min``/``max``;
a centre of mass's bound l ≤ c is l·m ≤ h, linear since m ≥ 0). Where the model file's form is not convex in x
(a product of inertia written as 0 with both centre-of-mass coordinates free, a constant inertia with a free
centre of mass) those constraints are dropped: (11) is then a relaxation, and its optimum a lower bound of
the model's.

:func:`solve` solves (11) with Clarabel (Goulart & Chen, "Clarabel: an interior-point solver for conic
programs with quadratic objectives", 2024), a primal–dual interior-point method, and :func:`polish` removes
its last inaccuracy on the face of the cones the answer lies on. :func:`dual_bound` solves the Lagrange dual
of (11), also with Clarabel, and recomputes its bound in NumPy (weak duality: no consistent parameters cost
less); :class:`Certificate` sets the written parameters' cost against it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from symbolic.identify.pseudo_inertia import (AXES, INERTIA_KEYS, body_of_standard, inertia_entries, inertia_matrix,
                                              standard_parameters)

Problem = Any
"""A :class:`symbolic.identify.consistent.Problem` (not imported: that module calls this one)."""
BodyPlan = Any
"""A :class:`symbolic.identify.consistent.BodyPlan`."""

SAMPLES_EXTRA = 12
"""Samples of θ(p) beyond the number of unknowns of the affine map x ↦ θ (:func:`lift`)."""
AFFINE_TOLERANCE = 1e-9
"""θ is taken as affine in x when the map fitted on random samples reproduces fresh samples to this
fraction of their size."""
DUAL_TOLERANCE = 1e-2
"""A dual bound (:func:`dual_bound`) counts when what its point's infeasibility may take from it is below
this fraction of it (:attr:`Certificate.guaranteed_ratio` allows for that part)."""
UNSEEN = 1e-10
"""A point mass the data see less than this (relative, :func:`_unseen`) is taken as unseen: the data of a
body's whole frame structurally miss it (rounding), as a mass on the first joint's axis."""
FACE_TOLERANCES = (1e-10, 1e-8, 1e-6, 1e-4)
"""Eigenvalues of a body's J below these fractions of its largest are taken as zero by :func:`polish`, in turn."""
SQRT2 = np.sqrt(2.0)
PSD_ORDER = [(i, j) for j in range(4) for i in range(j + 1)]
"""Clarabel's vectorization of a symmetric 4×4 matrix: the upper triangle column by column, the entries off
the diagonal multiplied by √2 (so that the inner product is kept)."""


@dataclass(frozen=True, eq=False)
class Lifted:
    """(11) for a :class:`symbolic.identify.consistent.Problem`: θ = T·x + t₀, E·x = e, G·x ≤ g.

    ``blocks[k]`` holds the ten indices of x of the k-th body of the problem (XX … M), ``raw`` the indices of
    the problem's other free parameters (in the order of ``Problem.raw``); ``dropped`` says which constraints
    of the model file's form are not in (11) (empty: (11) is the problem itself, not a relaxation).
    """

    T: np.ndarray
    t0: np.ndarray
    E: np.ndarray
    e: np.ndarray
    G: np.ndarray
    g: np.ndarray
    blocks: tuple[tuple[int, ...], ...]
    raw: tuple[int, ...]
    dropped: tuple[str, ...]

    @property
    def size(self) -> int:
        return self.T.shape[1]

    @property
    def exact(self) -> bool:
        return not self.dropped


def lifted_point(prob: Problem, p: np.ndarray) -> np.ndarray:
    """x of (11) at the model-file parameters p: each body's ten standard parameters, then the others."""
    parts = [standard_parameters(*_body_values(body, p)) for body in prob.bodies]
    return np.concatenate(parts + [p[list(prob.raw)]])


def _body_values(body: BodyPlan, p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia about the centre of mass) of a planned body at p (constants as written)."""
    def value(slot):
        return float(p[slot]) if isinstance(slot, int) else float(slot)

    Ic = inertia_matrix([value(slot) for slot in body.inertia])
    return value(body.mass), np.array([value(s) for s in body.com]), Ic


def parameters_of(prob: Problem, x: np.ndarray, p_start: np.ndarray) -> np.ndarray:
    """The model-file parameters p of a point x of (11) (the inverse of :func:`lifted_point` on its image):
    m = M, c = h/m, I_c = I_O − m·(cᵀc·1 − c·cᵀ) (parallel axes). A body of mass 0 keeps the centre of mass of
    ``p_start`` (any serves: h = 0)."""
    p = np.array(p_start, float)
    for k, body in enumerate(prob.bodies):
        standard = x[10 * k:10 * k + 10]
        M = float(standard[9])
        if M > 0:
            _, c, Ic = body_of_standard(standard)
        else:  # no mass: I_c = I_O, and any centre of mass
            c, Ic = _body_values(body, p_start)[1], inertia_matrix(standard[:6])
        if isinstance(body.mass, int):
            p[body.mass] = M
        for axis in body.free_com:
            p[body.com[axis]] = c[axis]
        for key, slot in zip(INERTIA_KEYS, body.inertia):
            if isinstance(slot, int):
                p[slot] = Ic[AXES[key]]
    p[list(prob.raw)] = x[10 * len(prob.bodies):]
    return p


def lift(prob: Problem, p0: np.ndarray, seed: int = 0) -> Lifted | None:
    """(11) for ``prob``, or None where θ is not affine in x (a body the log-Cholesky plan could not hold, a
    parameter written in expressions of others: their θ is not an affine image of x).

    T and t₀ are fitted on random parameter vectors around ``p0`` (masses positive) and checked on as many
    fresh ones (:data:`AFFINE_TOLERANCE`): θ is polynomial in p, so the check holds exactly or fails clearly."""
    if prob.penalties:
        return None
    rng = np.random.default_rng(seed)
    n = 10 * len(prob.bodies) + len(prob.raw)
    samples = [_sample(prob, p0, rng) for _ in range(2 * (n + 1 + SAMPLES_EXTRA))]
    X = np.array([np.append(lifted_point(prob, p), 1.0) for p in samples])
    Theta = np.array([prob.theta(p) for p in samples])
    half = len(samples) // 2
    coefficients, *_ = np.linalg.lstsq(X[:half], Theta[:half], rcond=None)
    error = np.abs(X[half:] @ coefficients - Theta[half:]).max(initial=0.0)
    if error > AFFINE_TOLERANCE * max(float(np.abs(Theta).max(initial=0.0)), 1e-300):
        return None
    E, e, G, g, dropped = _constraints(prob, n)
    blocks = tuple(tuple(range(10 * k, 10 * k + 10)) for k in range(len(prob.bodies)))
    raw = tuple(range(10 * len(prob.bodies), n))
    return Lifted(coefficients[:-1].T, coefficients[-1], E, e, G, g, blocks, raw, tuple(dropped))


def _sample(prob: Problem, p0: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Random free parameters of the size of p0's (masses positive)."""
    size = np.maximum(np.abs(p0), 0.1 * max(float(np.abs(p0).max(initial=0.0)), 1.0))
    p = p0 + size * rng.uniform(-1.0, 1.0, len(p0))
    for body in prob.bodies:
        if isinstance(body.mass, int):
            p[body.mass] = size[body.mass] * rng.uniform(0.5, 2.0)
    return p


def _constraints(prob: Problem, n: int):
    """E, e, G, g of (11) and the constraints of the model file's form left out (see the module's docstring)."""
    eq, ineq, dropped = [], [], []
    for k, body in enumerate(prob.bodies):
        _body_constraints(prob, body, 10 * k, n, eq, ineq, dropped)
    for j, i in enumerate(prob.raw):
        at = prob.raw_offset + j
        row = np.zeros(n)
        row[10 * len(prob.bodies) + j] = 1.0
        if np.isfinite(prob.lower[at]):
            ineq.append((-row, -prob.lower[at]))
        if np.isfinite(prob.upper[at]):
            ineq.append((row, prob.upper[at]))
    E = np.array([r for r, _ in eq]).reshape(-1, n)
    G = np.array([r for r, _ in ineq]).reshape(-1, n)
    return E, np.array([v for _, v in eq], float), G, np.array([v for _, v in ineq], float), dropped


MASS, FIRST_MOMENTS = 9, (6, 7, 8)
"""Where M and MX, MY, MZ are among a body's ten standard parameters."""


def _body_constraints(prob: Problem, body: BodyPlan, at: int, n: int, eq: list, ineq: list, dropped: list) -> None:
    """A body's rows of E·x = e and G·x ≤ g (x[at:at+10] = XX XY XZ YY YZ ZZ MX MY MZ M), appended to ``eq`` and
    ``ineq`` as (row, right-hand side); what (11) cannot hold is named in ``dropped``."""
    def unit(*pairs: tuple[int, float]) -> np.ndarray:
        row = np.zeros(n)
        for i, v in pairs:
            row[at + i] += v
        return row

    _mass_and_com_rows(prob, body, unit, eq, ineq)
    if not body.free_inertia:
        _constant_inertia_rows(prob, body, unit, eq, dropped)
    else:
        _zero_product_rows(body, unit, eq, dropped)


def _mass_and_com_rows(prob: Problem, body: BodyPlan, unit, eq: list, ineq: list) -> None:
    """The mass: its value, or its bounds (``prob.lower``/``upper`` hold α = ½·log m); each centre-of-mass
    coordinate: h = c·m for a constant c, l·m ≤ h ≤ u·m for bounds l, u (linear: m ≥ 0)."""
    M, H = MASS, FIRST_MOMENTS
    k = body.offset
    if isinstance(body.mass, int):
        low, high = np.exp(2 * prob.lower[k]), np.exp(2 * prob.upper[k])
        if low > 0:
            ineq.append((unit((M, -1.0)), -low))
        if np.isfinite(high):
            ineq.append((unit((M, 1.0)), high))
        k += 1
    else:
        eq.append((unit((M, 1.0)), float(body.mass)))
    for axis in range(3):
        if isinstance(body.com[axis], float):  # h = c·m
            eq.append((unit((H[axis], 1.0), (M, -body.com[axis])), 0.0))
            continue
        low, high = prob.lower[k], prob.upper[k]
        if np.isfinite(low):  # l·m ≤ h
            ineq.append((unit((H[axis], -1.0), (M, low)), 0.0))
        if np.isfinite(high):
            ineq.append((unit((H[axis], 1.0), (M, -high)), 0.0))
        k += 1


def _constant_inertia_rows(prob: Problem, body: BodyPlan, unit, eq: list, dropped: list) -> None:
    """A constant inertia I_c: I_O = I_c + m·(cᵀc·1 − c·cᵀ), affine in m where c is constant (else dropped)."""
    if not all(isinstance(s, float) for s in body.com):
        dropped.append(f"{body.name}: constant inertia about a free centre of mass")
        return
    c = np.array(body.com, float)
    _, _, Ic = _body_values(body, np.zeros(len(prob.free)))
    shift = c @ c * np.eye(3) - np.outer(c, c)
    for index, key in enumerate(INERTIA_KEYS):
        i, j = AXES[key]
        eq.append((unit((index, 1.0), (MASS, -shift[i, j])), Ic[i, j]))


def _zero_product_rows(body: BodyPlan, unit, eq: list, dropped: list) -> None:
    """A product of inertia written as 0: I_c,ij = 0, i.e. I_O,ij = −m·c_i·c_j = −c_i·h_j, linear where c_i (or
    c_j) is constant (else dropped)."""
    constant_com = [isinstance(s, float) for s in body.com]
    for key in ("xy", "xz", "yz"):
        if isinstance(body.inertia[INERTIA_KEYS.index(key)], int):
            continue
        i, j = AXES[key]
        if constant_com[i] or constant_com[j]:
            ci, hj = (body.com[i], FIRST_MOMENTS[j]) if constant_com[i] else (body.com[j], FIRST_MOMENTS[i])
            eq.append((unit((INERTIA_KEYS.index(key), 1.0), (hj, ci)), 0.0))
        else:
            dropped.append(f"{body.name}: I{key} = 0 about a free centre of mass")


def pseudo_rows(block: tuple[int, ...], n: int) -> np.ndarray:
    """The linear map x ↦ svec(J(x)) of (10) for one body (10 × n, Clarabel's order :data:`PSD_ORDER`):
    Σ = ½·tr(I_O)·1 − I_O, i.e. Σ_xx = ½(−XX + YY + ZZ), Σ_xy = −XY, …; J's last column (h, m)."""
    XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = block
    entries = {(0, 0): {XX: -0.5, YY: 0.5, ZZ: 0.5}, (1, 1): {XX: 0.5, YY: -0.5, ZZ: 0.5},
               (2, 2): {XX: 0.5, YY: 0.5, ZZ: -0.5}, (0, 1): {XY: -1.0}, (0, 2): {XZ: -1.0}, (1, 2): {YZ: -1.0},
               (0, 3): {MX: 1.0}, (1, 3): {MY: 1.0}, (2, 3): {MZ: 1.0}, (3, 3): {M: 1.0}}
    out = np.zeros((10, n))
    for row, (i, j) in enumerate(PSD_ORDER):
        for column, value in entries[(i, j)].items():
            out[row, column] = value * (1.0 if i == j else SQRT2)
    return out


def pseudo_matrix(x: np.ndarray, block: tuple[int, ...]) -> np.ndarray:
    """J of (10) at x for one body."""
    return _matrix(pseudo_rows(block, len(x)) @ x)


@dataclass(frozen=True)
class ConicSolution:
    """What :func:`solve` found: x, the costs ‖R·β − z‖² of its primal point and of the dual's lower bound, the
    solver's status, its iterations and time."""

    x: np.ndarray
    cost: float
    lower_bound: float
    status: str
    iterations: int
    seconds: float

    @property
    def solved(self) -> bool:
        return self.status == "Solved"


@dataclass(frozen=True, eq=False)
class _Scaled:
    """(11) in the solver's units: x = D·u; the residual M·u − d (M = A·T·D/‖d‖, d = (z − A·t₀)/‖d‖); each body's
    J in the congruent units S·J·S, S = diag(1/ℓ, 1/ℓ, 1/ℓ, 1)/√μ (its rows ``cones``); E, G row-normalised."""

    D: np.ndarray
    M: np.ndarray
    d: np.ndarray
    norm: float
    cones: tuple[np.ndarray, ...]
    E: np.ndarray
    e: np.ndarray
    G: np.ndarray
    g: np.ndarray


def _scaled(lifted: Lifted, A: np.ndarray, z: np.ndarray, sizes: np.ndarray) -> _Scaled:
    """:class:`_Scaled` for bodies of masses μ and lengths ℓ ``sizes[k] = (μ, ℓ)`` (the other variables by
    their own sizes, ``sizes[-1]``): the units in which each body's J has entries of order 1."""
    n = lifted.size
    D = np.array(sizes[-1], float)
    weights = []
    for block, (mu, ell) in zip(lifted.blocks, sizes[:-1]):
        D[list(block)] = [ell * ell * mu] * 6 + [ell * mu] * 3 + [mu]
        weights.append(np.array([1 / (ell * ell * mu) if j < 3 else (1 / (ell * mu) if i < 3 else 1 / mu)
                                 for i, j in PSD_ORDER]))
    d = z - A @ lifted.t0
    norm = max(float(np.linalg.norm(d)), 1e-300)
    cones = tuple(pseudo_rows(block, n) * D * w[:, None] for block, w in zip(lifted.blocks, weights))

    def normalised(rows: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        size = np.maximum(np.abs(rows * D).max(axis=1, initial=0.0), 1e-300) if len(rhs) else np.ones(0)
        return (rows * D) / size[:, None], rhs / size

    E, e = normalised(lifted.E, lifted.e)
    G, g = normalised(lifted.G, lifted.g)
    return _Scaled(D, A @ lifted.T * D / norm, d / norm, norm, cones, E, e, G, g)


def body_sizes(lifted: Lifted, x0: np.ndarray) -> list:
    """(μ, ℓ) of each body at x0 — its mass (or, where 0, the mean of the others'), and its radius of gyration
    √(tr Σ/m) (at least 1e-3 of the largest) — and the sizes of the other variables (|x0|, at least 1e-3 of
    the largest); the units of :func:`_scaled`."""
    masses = np.array([abs(x0[block[9]]) for block in lifted.blocks])
    fallback = float(masses[masses > 0].mean()) if np.any(masses > 0) else 1.0
    out = []
    for block, mass in zip(lifted.blocks, masses):
        mu = mass if mass > 0 else fallback
        trace = max(float(np.trace(pseudo_matrix(x0, block)[:3, :3])), 0.0)
        out.append((mu, np.sqrt(trace / mu)))
    lengths = np.array([ell for _, ell in out] + [0.0])
    out = [(mu, max(ell, 1e-3 * float(lengths.max()), 1e-6)) for mu, ell in out]
    raw = np.abs(x0)
    out.append(np.maximum(raw, 1e-3 * max(float(raw.max(initial=0.0)), 1e-12)))
    return out


def _settings(tight: bool = False):
    """Clarabel's settings, quiet; ``tight``: its tolerances at 1e-12 (the dual of :func:`dual_bound`, whose
    point's rounding is multiplied by the size of the primal answer)."""
    import clarabel

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    if tight:
        settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-12
        settings.tol_ktratio = 1e-10
    return settings


def solve(lifted: Lifted, A: np.ndarray, z: np.ndarray, sizes: list) -> ConicSolution:
    """The primal of (11) with Clarabel: min ½‖r‖² over (u, r) subject to the zero cone (r = M·u − d,
    E·u = e), the nonnegative cone (g − G·u) and one 4×4 PSD cone a body (in the units of :func:`_scaled`).

    Returns x = D·u, its cost ‖A·θ − z‖², and Clarabel's dual objective as a cost (a bound only to the
    solver's tolerance; :func:`dual_bound` gives one checked independently)."""
    import clarabel
    import scipy.sparse as sparse

    sc = _scaled(lifted, A, z, sizes)
    n, b = lifted.size, len(z)
    rows = [np.hstack([sc.M, -np.eye(b)]), np.hstack([sc.E, np.zeros((len(sc.e), b))])]
    rhs, cones = [sc.d, sc.e], [clarabel.ZeroConeT(b + len(sc.e))]
    if len(sc.g):
        rows.append(np.hstack([sc.G, np.zeros((len(sc.g), b))]))
        rhs.append(sc.g)
        cones.append(clarabel.NonnegativeConeT(len(sc.g)))
    for J in sc.cones:
        rows.append(np.hstack([-J, np.zeros((10, b))]))
        rhs.append(np.zeros(10))
        cones.append(clarabel.PSDTriangleConeT(4))
    P = sparse.csc_matrix(sparse.block_diag([sparse.csc_matrix((n, n)), sparse.identity(b)]))
    out: Any = clarabel.DefaultSolver(P, np.zeros(n + b), sparse.csc_matrix(np.vstack(rows)), np.concatenate(rhs),
                                      cones, _settings()).solve()
    x = sc.D * np.array(out.x[:n])
    r = A @ (lifted.T @ x + lifted.t0) - z
    return ConicSolution(x, float(r @ r), 2.0 * sc.norm**2 * float(out.obj_val_dual), str(out.status),
                         int(out.iterations), float(out.solve_time))


@dataclass(frozen=True)
class DualBound:
    """A lower bound of (11) checked in NumPy from a dual point (:func:`dual_bound`): ``value`` and
    ``error`` (what the point's infeasibility may take from it) as costs ‖A·θ − z‖², the solver's status,
    iterations and time."""

    value: float
    error: float
    status: str
    iterations: int
    seconds: float


def dual_bound(lifted: Lifted, A: np.ndarray, z: np.ndarray, sizes: list, x: np.ndarray) -> DualBound:
    """The Lagrange dual of (11), solved with Clarabel and its bound recomputed in NumPy.

    With multipliers Z_b ⪰ 0 (the bodies' J), ν (E·x = e) and λ ≥ 0 (G·x ≤ g), minimising the Lagrangian
    ‖M·x − d‖² − Σ⟨Z_b, J_b(x)⟩ + νᵀ(E·x − e) + λᵀ(G·x − g) over x is finite exactly when
    Σ J_b*(Z_b) − Eᵀν − Gᵀλ = 2·Mᵀs for some s, and is then −‖s‖² − 2·sᵀd − νᵀe − λᵀg (Boyd & Vandenberghe,
    Convex Optimization, §5.2). Every such point bounds (11) from below
    (weak duality), whether or not the primal optimum is attained, and the dual's optimum is unique in s.

    Where the data do not see a point mass w (M·x(w·wᵀ) = 0: a mass on the first joints' axes), the infimum
    of (11) is approached only as such masses grow without bound, and any rounding of Z_b along w is
    multiplied by their size. The dual is therefore solved twice: the second time with Z_b·w = 0 imposed for
    each unseen w (:func:`_unseen`), which every optimal Z_b satisfies (Z_b ⪰ 0 and wᵀZ_b·w = 0) and which,
    imposed on a nearby w, only restricts the dual (its points stay dual feasible: the bound stays a bound).
    ``x`` (the primal answer) sizes what the dual point's rounding may cost (:func:`_checked_bound`)."""
    first = _dual(lifted, A, z, sizes, x, ())
    directions = _unseen(lifted, A, first.Z, sizes)
    return _dual(lifted, A, z, sizes, x, directions).bound if any(len(w) for w in directions) else first.bound


@dataclass(frozen=True, eq=False)
class _DualSolution:
    bound: DualBound
    Z: tuple[np.ndarray, ...]


def _dual(lifted: Lifted, A: np.ndarray, z: np.ndarray, sizes: list, x: np.ndarray, unseen) -> _DualSolution:
    """One solve of the dual (:func:`dual_bound`), with Z_b·w = 0 for the directions ``unseen[b]`` (in the
    congruent units of :func:`_scaled`, as Z_b is)."""
    import clarabel
    import scipy.sparse as sparse

    sc = _scaled(lifted, A, z, sizes)
    n, b, nb, ne, ng = lifted.size, len(z), len(sc.cones), len(sc.e), len(sc.g)
    Jt = np.hstack([J.T for J in sc.cones]) if nb else np.zeros((n, 0))
    equality = np.hstack([Jt, -sc.E.T, -sc.G.T, -2.0 * sc.M.T])  # variables [ζ_b…, ν, λ, s]
    size = equality.shape[1]
    rows, rhs = [equality], [np.zeros(n)]
    for k, directions in enumerate(unseen):
        for w in directions:
            rows.append(np.hstack([np.zeros((4, 10 * k)), _times(w),
                                   np.zeros((4, size - 10 * k - 10))]))
            rhs.append(np.zeros(4))
    cones = [clarabel.ZeroConeT(sum(len(r) for r in rhs))]
    if ng:
        rows.append(np.hstack([np.zeros((ng, 10 * nb + ne)), -np.eye(ng), np.zeros((ng, b))]))
        rhs.append(np.zeros(ng))
        cones.append(clarabel.NonnegativeConeT(ng))
    for k in range(nb):
        block = np.zeros((10, size))
        block[:, 10 * k:10 * k + 10] = -np.eye(10)
        rows.append(block)
        rhs.append(np.zeros(10))
        cones.append(clarabel.PSDTriangleConeT(4))
    P = sparse.csc_matrix(sparse.block_diag([sparse.csc_matrix((size - b, size - b)), 2.0 * sparse.identity(b)]))
    q = np.concatenate([np.zeros(10 * nb), sc.e, sc.g, 2.0 * sc.d])
    out: Any = clarabel.DefaultSolver(P, q, sparse.csc_matrix(np.vstack(rows)), np.concatenate(rhs), cones,
                                      _settings(tight=True)).solve()
    s = np.array(out.x[size - b:])
    zs = tuple(_matrix(np.array(out.x[10 * k:10 * k + 10])) for k in range(nb))
    return _DualSolution(_checked_bound(sc, Jt, s, out, x), zs)


def _times(w: np.ndarray) -> np.ndarray:
    """The 4 × 10 matrix of ζ ↦ Z(ζ)·w (Z of Clarabel's vector, :data:`PSD_ORDER`)."""
    out = np.zeros((4, 10))
    for k, (i, j) in enumerate(PSD_ORDER):
        scale = 1.0 if i == j else 1.0 / SQRT2
        out[i, k] += scale * w[j]
        if i != j:
            out[j, k] += scale * w[i]
    return out


def _unseen(lifted: Lifted, A: np.ndarray, Z: tuple[np.ndarray, ...], sizes: list) -> tuple[tuple[np.ndarray, ...], ...]:
    """For each body, the eigenvectors w of Z_b (congruent units of :func:`_scaled`) of eigenvalues below 1e-6
    of its largest whose point masses the data do not see: v = S⁻¹·w = √μ·(ℓ·w₁, ℓ·w₂, ℓ·w₃, w₄) in the
    original units, ‖A·T·x(v·vᵀ)‖ below :data:`UNSEEN` of ‖A·T‖·‖x(v·vᵀ)‖."""
    AT = A @ lifted.T
    scale = max(float(np.linalg.norm(AT, 2)), 1e-300)
    out = []
    for block, Zb, (mu, ell) in zip(lifted.blocks, Z, sizes):
        lam, V = np.linalg.eigh(Zb)
        found = []
        for i in np.flatnonzero(lam <= 1e-6 * max(float(np.abs(lam).max()), 1e-300)):
            v = np.sqrt(mu) * V[:, i] * np.array([ell, ell, ell, 1.0])
            x = _standard_of_pseudo(np.outer(v, v), block, lifted.size)
            if np.linalg.norm(AT @ x) <= UNSEEN * scale * np.linalg.norm(x):
                found.append(V[:, i])
        out.append(tuple(found))
    return tuple(out)


def _checked_bound(sc: _Scaled, Jt: np.ndarray, s: np.ndarray, out: Any, x: np.ndarray) -> DualBound:
    """The dual bound at the solver's point, recomputed (λ clipped at 0): −‖s‖² − 2·sᵀd − νᵀe − λᵀg as a cost,
    and what the point's infeasibility could cost at the primal point x (:func:`solve`'s): Σ_b Σ_{λ_i(Z_b) < 0} |λ_i|·w_iᵀ·J_b(x)·w_i
    + |(Σ J_b*(Z_b) − Eᵀν − Gᵀλ − 2Mᵀs)ᵀ·x|, as a cost (weak duality holds exactly for a feasible
    dual point; this is what rounding, or a solver's tolerance, may take from it near x)."""
    nb, ne = Jt.shape[1] // 10, len(sc.e)
    v = np.array(out.x[:Jt.shape[1] + ne + len(sc.g)])
    nu, lam = v[10 * nb:10 * nb + ne], np.maximum(v[10 * nb + ne:], 0.0)
    v = np.concatenate([v[:10 * nb], nu, lam])
    u = x / sc.D
    residual = np.hstack([Jt, -sc.E.T, -sc.G.T]) @ v - 2.0 * sc.M.T @ s
    error = abs(float(residual @ u))
    for k, J in enumerate(sc.cones):  # ⟨Z, J⟩ ≥ Σ_{λ_i < 0} λ_i·w_iᵀJw_i for J ⪰ 0 (Z = Σ λ_i·w_i·w_iᵀ)
        lam_z, w = np.linalg.eigh(_matrix(v[10 * k:10 * k + 10]))
        extent = np.einsum("ji,jk,ki->i", w, _matrix(J @ u), w)
        error += float(np.sum(np.maximum(-lam_z, 0.0) * np.maximum(extent, 0.0)))
    value = -float(s @ s) - 2.0 * float(s @ sc.d) - float(nu @ sc.e) - float(lam @ sc.g)
    return DualBound(sc.norm**2 * value, sc.norm**2 * error, str(out.status), int(out.iterations), float(out.solve_time))


def _matrix(v: np.ndarray) -> np.ndarray:
    """The symmetric 4×4 matrix of a vector in Clarabel's order (:data:`PSD_ORDER`)."""
    out = np.zeros((4, 4))
    for value, (i, j) in zip(v, PSD_ORDER):
        out[i, j] = out[j, i] = value / (1.0 if i == j else SQRT2)
    return out


def polish(lifted: Lifted, A: np.ndarray, z: np.ndarray, x: np.ndarray) -> np.ndarray:
    """x moved to the exact optimum of (11) on the face of the cones it lies on, where that stays feasible.

    An interior-point answer is optimal to the solver's tolerance only (about 1e-8 of the cost, so about 1e-4
    in β where the least squares are already consistent). On a face — each body's J = V·S·Vᵀ with V the
    eigenvectors of J's eigenvalues above a fraction of its largest, S free, the active bounds held — (11) is
    a least-squares problem with linear equalities, solved exactly (the minimum-norm step). The fractions
    :data:`FACE_TOLERANCES` are tried in turn; a step is kept only if every J stays positive semidefinite,
    the bounds hold and the cost falls."""
    best = x
    for tolerance in FACE_TOLERANCES:
        candidate = _face_optimum(lifted, A, z, x, tolerance)
        if candidate is not None and _better(lifted, A, z, best, candidate):
            best = candidate
    return best


def _face_optimum(lifted: Lifted, A: np.ndarray, z: np.ndarray, x: np.ndarray, tolerance: float) -> np.ndarray | None:
    """The least-squares optimum of (11) on the face of x at ``tolerance`` (:func:`polish`), or None."""
    F, f0 = _face(lifted, x, tolerance)
    rows, rhs = [lifted.E @ F], [lifted.e - lifted.E @ f0]
    if len(lifted.g):
        active = lifted.g - lifted.G @ x <= tolerance * np.maximum(np.abs(lifted.g), np.abs(lifted.G @ x) + 1e-300)
        rows.append(lifted.G[active] @ F)
        rhs.append(lifted.g[active] - lifted.G[active] @ f0)
    C, c = np.vstack(rows), np.concatenate(rhs)
    w0 = np.linalg.lstsq(F, x - f0, rcond=None)[0]
    M = A @ lifted.T @ F
    target = z - A @ (lifted.T @ f0 + lifted.t0)
    null = _null_space(C) if C.size else np.eye(F.shape[1])
    if null.shape[1] == 0:
        return None
    w_particular = w0 + (np.linalg.lstsq(C, c - C @ w0, rcond=None)[0] if C.size else 0.0)
    step = np.linalg.lstsq(M @ null, target - M @ w_particular, rcond=None)[0]
    return F @ (w_particular + null @ step) + f0


def _face(lifted: Lifted, x: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """x = F·w + f0 on the face of the PSD cones at x: each body's ten entries as the image of the symmetric
    r×r matrices S under S ↦ π(V·S·Vᵀ) (V: J's eigenvectors of the eigenvalues kept), the others free."""
    n = lifted.size
    columns, f0 = [], np.zeros(n)
    for block in lifted.blocks:
        J = pseudo_matrix(x, block)
        lam, V = np.linalg.eigh(J)
        V = V[:, lam > tolerance * max(float(lam[-1]), 1e-300)]
        for i in range(V.shape[1]):
            for j in range(i, V.shape[1]):
                E = np.outer(V[:, i], V[:, j])
                columns.append(_standard_of_pseudo(0.5 * (E + E.T), block, n))
    for i in lifted.raw:
        column = np.zeros(n)
        column[i] = 1.0
        columns.append(column)
    return np.array(columns).reshape(-1, n).T, f0


def _standard_of_pseudo(J: np.ndarray, block: tuple[int, ...], n: int) -> np.ndarray:
    """The standard parameters (at ``block`` of an n-vector) of a pseudo-inertia J: I_O = tr(Σ)·1 − Σ,
    h = J[:3, 3], m = J[3, 3] (the inverse of (10))."""
    sigma = J[:3, :3]
    IO = np.trace(sigma) * np.eye(3) - sigma
    out = np.zeros(n)
    out[list(block)] = [*inertia_entries(IO), *J[:3, 3], J[3, 3]]
    return out


def _null_space(C: np.ndarray) -> np.ndarray:
    """An orthonormal basis of C's null space (SVD, rank to 1e-10 of the largest singular value)."""
    _, s, Vt = np.linalg.svd(C)
    rank = int(np.sum(s > 1e-10 * s.max(initial=0.0)))
    return Vt[rank:].T


def _better(lifted: Lifted, A: np.ndarray, z: np.ndarray, x: np.ndarray, candidate: np.ndarray) -> bool:
    """Whether ``candidate`` is feasible (every J ⪰ 0 to 1e-12 of its size, the bounds and equalities to
    1e-9) and costs no more than x."""
    for block in lifted.blocks:
        lam = np.linalg.eigvalsh(pseudo_matrix(candidate, block))
        if lam[0] < -1e-12 * max(float(np.abs(lam).max()), 1e-300):
            return False
    size = max(float(np.abs(candidate).max(initial=0.0)), 1e-300)
    if len(lifted.g) and np.any(lifted.G @ candidate - lifted.g > 1e-9 * size):
        return False
    if len(lifted.e) and np.any(np.abs(lifted.E @ candidate - lifted.e) > 1e-9 * size):
        return False

    def cost(v: np.ndarray) -> float:
        r = A @ (lifted.T @ v + lifted.t0) - z
        return float(r @ r)

    return cost(candidate) <= cost(x)


@dataclass(frozen=True)
class Certificate:
    """How far the written parameters are from the global optimum, as the convex form certifies it.

    ``cost`` is the written parameters' ‖y_w − W_w·β‖² over all weighted rows (‖R·β − z‖² + ρ², (1)),
    ``lower_bound`` the same for the dual bound of (11) (:func:`dual_bound`: no consistent parameters cost
    less, weak duality; where (11) is a relaxation, ``exact`` is False and ``dropped`` names what it leaves
    out), ``duality_gap`` the primal solve's cost minus that bound relative to the bound; ``dual_error`` what the
    dual point's rounding may take from the bound, as a cost (:func:`_checked_bound`); ``floor`` the rounding of
    the costs themselves (1e-12·‖y_w‖²: below it, noise-free data, cost and bound are both 0).
    """

    solver: str
    status: str
    dual_status: str
    cost: float
    lower_bound: float
    duality_gap: float
    dual_error: float
    floor: float
    exact: bool
    dropped: tuple[str, ...]
    iterations: int
    seconds: float

    @property
    def ratio(self) -> float:
        """cost / lower bound (≥ 1 up to the dual point's rounding); 1 where the cost is within its rounding."""
        if self.cost <= self.floor:
            return 1.0
        return self.cost / self.lower_bound if self.lower_bound > 0 else float("inf")

    @property
    def guaranteed_ratio(self) -> float:
        """cost / (lower bound less what the dual point's rounding may take from it): the written parameters
        cost at most this times the global optimum; ∞ where a solve did not end (solved, or solved to
        Clarabel's reduced tolerances) or the rounding may take more than :data:`DUAL_TOLERANCE` of the bound.
        1 where the cost itself is within the costs' rounding (``floor``): a cost is never below 0, the bound that
        needs no dual point (noise-free data, where the dual point's rounding is all there is to its bound)."""
        if self.cost <= self.floor:
            return 1.0
        ended = ("Solved", "AlmostSolved")
        if self.status not in ended or self.dual_status not in ended or self.dual_error > DUAL_TOLERANCE * max(
                self.lower_bound, self.floor):
            return float("inf")
        lower = self.lower_bound - self.dual_error
        if self.cost - lower <= self.floor:
            return 1.0
        return self.cost / lower if lower > 0 else float("inf")

    @classmethod
    def of(cls, solved: ConicSolution, bound: DualBound, cost: float, rho2: float, norm2: float,
           lifted: Lifted) -> Certificate:
        """From :func:`solve`'s and :func:`dual_bound`'s answers, the written parameters' ‖R·β − z‖², ρ² of (1)
        and ‖y_w‖²."""
        import clarabel

        gap = (solved.cost - bound.value) / max(bound.value + rho2, 1e-300)
        lower = bound.value + rho2
        return cls(f"clarabel {getattr(clarabel, '__version__', '?')}", solved.status, bound.status, cost + rho2, lower, gap,
                   bound.error, 1e-12 * norm2, lifted.exact, lifted.dropped,
                   solved.iterations + bound.iterations, solved.seconds + bound.seconds)

    def to_dict(self) -> dict[str, Any]:
        return {"solver": self.solver, "status": self.status, "dual_status": self.dual_status, "cost": self.cost,
                "lower_bound": self.lower_bound, "cost_ratio": self.ratio,
                "relative_error_ratio": float(np.sqrt(self.ratio)), "duality_gap": self.duality_gap,
                "dual_error": self.dual_error, "guaranteed_cost_ratio": self.guaranteed_ratio, "exact": self.exact,
                "relaxed": list(self.dropped),
                "iterations": self.iterations, "seconds": self.seconds}
