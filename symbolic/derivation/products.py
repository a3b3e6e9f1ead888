"""What is derived from a :class:`~symbolic.derivation.dynamics.DynamicModel`, built once and owned by the model.

Pinocchio keeps a frozen ``Model`` and a ``Data`` of what is computed from it; here the model holds SymPy
expressions only and its :attr:`~symbolic.derivation.dynamics.DynamicModel.products` hold what the layers
build from it: the parameter regressor (derive), the base parameters and the numeric model (numeric), the
straight-line programs (codegen), the simulation plant (simulation), the identification's base regressor
and terms (identify, workflow). A :class:`Product` names one and says how to build it;
``model.products.get(product)`` builds it on first use and keeps it as long as the model lives.

Each recipe is defined in the layer that builds it and handed down to the model, so imports go one way
(derive never imports a higher layer) and no registry has to be filled before use. Each layer names its
products with an accessor: ``model.regressor()``, ``codegen.programs(model)``,
``numeric.model_base_parameters(model)``, ``numeric.numeric_model(model)``, ...

A product marked ``persist`` (SymPy objects that take seconds to build) is also kept in the cache folder
(:mod:`symbolic.cache`) under the digest of the robot description (:func:`symbolic.description.robot.digest`):
a second process on the same model reads it instead of building it. The model's robot, the model itself
and its intermediate registry are left out of the file and given back on reading, so a product read from
the cache refers to the live objects (and error messages name the file the robot was read from now).
"""

from __future__ import annotations

import logging
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

import sympy as sp

from symbolic import cache
from symbolic.description.robot import Robot, digest

log = logging.getLogger(__name__)

T = TypeVar("T")


class Model(Protocol):
    """What a product holder needs of a model (:class:`~symbolic.derivation.dynamics.DynamicModel`)."""

    robot: Robot
    sub: Any

    @property
    def name(self) -> str: ...


def sympy_reducer(obj: Any) -> Any:
    """How a cache entry rebuilds sums, products and powers: from their arguments as they are.

    SymPy's own pickling calls ``Add(*args)``, which sorts and combines the (already canonical) arguments
    again; rebuilding without evaluation gives the same expression — the same arguments in the same order,
    hence the same hash and the same printed code — 4 to 5 times faster (a derivation of the Panda: 0.06 s
    instead of 0.28 s).
    """
    kind = type(obj)
    if kind is sp.Add or kind is sp.Mul:
        return _associative, (kind, obj.args, obj.is_commutative)
    if kind is sp.Pow:
        return _power, obj.args
    return NotImplemented


def _associative(kind: type, args: tuple, commutative: bool | None) -> sp.Expr:
    return kind._from_args(args, commutative)


def _power(base: sp.Expr, exponent: sp.Expr) -> sp.Expr:
    return sp.Pow(base, exponent, evaluate=False)


@dataclass(frozen=True, eq=False)
class Product(Generic[T]):
    """A recipe: what is built from a model, under which name.

    Attributes
    ----------
    name
        Unique among products; also the kind of its cache entry.
    build
        ``build(model) -> value``.
    persist
        Keep the value in the cache folder between processes (it must pickle).
    """

    name: str
    build: Callable[[Any], T]
    persist: bool = False


class Products:
    """The products built from one model, by name (module docstring)."""

    def __init__(self, model: Model) -> None:
        self._model = weakref.ref(model)  # the model owns this holder: no cycle keeping it alive
        self._built: dict[str, tuple[Product, Any]] = {}
        self._digest: str | None = None

    @property
    def model(self) -> Model:
        model = self._model()
        if model is None:
            raise ReferenceError("the model of these products no longer exists")
        return model

    @property
    def digest(self) -> str:
        """The key of the model's entries in the cache folder: the digest of its robot description."""
        if self._digest is None:
            self._digest = digest(self.model.robot)
        return self._digest

    def __contains__(self, product: Product) -> bool:
        return product.name in self._built

    def names(self) -> tuple[str, ...]:
        """The products built so far, in the order they were built."""
        return tuple(self._built)

    def get(self, product: Product[T]) -> T:
        """The value of ``product`` for this model: kept, else read from the cache folder, else built."""
        entry = self._built.get(product.name)
        if entry is not None:
            if entry[0] is not product:
                raise ValueError(f"two different products are named {product.name!r}")
            return entry[1]
        found = self._read(product) if product.persist else None
        if found is None:
            found = (self._build(product),)
            if product.persist:
                self._write(product, found[0])
        self._built[product.name] = (product, found[0])
        return found[0]

    def _build(self, product: Product[T]) -> T:
        model = self.model
        start = time.perf_counter()
        value = product.build(model)
        elapsed = time.perf_counter() - start
        log.log(logging.INFO if elapsed > 0.1 else logging.DEBUG, "%s: %s built in %.1f s", model.name, product.name, elapsed)
        return value

    def _read(self, product: Product) -> tuple[Any] | None:
        start = time.perf_counter()
        found = cache.load(product.name, self.digest, self._live().__getitem__)
        if found is not None:
            log.debug("%s: %s read from the cache in %.2f s", self.model.name, product.name, time.perf_counter() - start)
        return found

    def _write(self, product: Product, value: Any) -> None:
        live = {id(obj): name for name, obj in self._live().items()}
        cache.save(product.name, self.digest, value, lambda obj: live.get(id(obj)), sympy_reducer)

    def _live(self) -> dict[str, Any]:
        """Objects a product may refer to that are the model's own: left out of its cache entry."""
        model = self.model
        return {"robot": model.robot, "model": model, "sub": model.sub}
