"""Straight-line programs for code generation.

A generated function evaluates a list of output expressions written in intermediate symbols
(:class:`symbolic.derivation.subexpressions.Subexpressions`). This module gathers the definitions they need,
runs a common-subexpression elimination once over all of them (catching sharing the derivation did not
see), and orders the statements so that each comes after what it uses. Local names are renumbered
``v0, v1, …`` in emission order, so the text is deterministic.

Two eliminations (docs/architecture.md, "Programs of large models"): SymPy's ``cse`` with its ``"basic"``
preprocessing (``factor_terms`` on every definition, and its search for common subsets of sums' and
products' arguments), and, for programs larger than :data:`LARGE_PROGRAM`, only the repeated subtrees, with
sums and products rebuilt from their arguments as they stand (no new canonical ordering, which is most of
the cost of rebuilding an expression in SymPy). SymPy's ``cse`` shares a little more (on a spatial 12-axis chain,
even without its preprocessing: 1 % fewer operations in τ, 4 % in its derivatives, 12 % in the Coriolis
matrix) at about 5 times the cost without its preprocessing and 15–20 times with it, growing faster than the
program; a 20-axis chain's programs would take minutes. A large
program is also printed in the order its sums and products hold (``order="none"``), SymPy's canonical order
of the derivation's names: it depends on the expressions alone. The built-in robots' programs are all below
the threshold: their generated code does not depend on the second path.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import sympy as sp

from symbolic.derivation.subexpressions import Subexpressions, count_operations, symbols_in

LARGE_PROGRAM = 2500
"""Definitions and outputs above which a program is large (:func:`build_program`'s ``large``): only repeated
subtrees are shared. The largest built-in program, the Panda's ``inverse_dynamics_derivatives``, has 1,835 (2,200 before its ∂τ/∂q̇ came from the Coriolis matrix)."""


@dataclass(frozen=True)
class Program:
    """Statements ``(local, expression)`` in evaluation order and the output expressions."""

    statements: tuple[tuple[sp.Symbol, sp.Expr], ...]
    outputs: tuple[sp.Expr, ...]
    large: bool = False  # built by the large-program path: later substitutions rebuild without re-sorting too

    @cached_property
    def operations(self) -> int:
        """SymPy ``count_ops`` of all statements and outputs (:func:`count_operations`; counted once)."""
        return sum(count_operations(e) for _, e in self.statements) + sum(count_operations(e) for e in self.outputs)




def program_size(sub: Subexpressions, outputs: Sequence[sp.Expr]) -> int:
    """Definitions needed by ``outputs`` and the outputs: what :data:`LARGE_PROGRAM` is compared with."""
    return len(sub.program([sp.sympify(e) for e in outputs])) + len(outputs)


def build_program(sub: Subexpressions, outputs: Sequence[sp.Expr], local_prefix: str = "v",
                  large: bool | None = None) -> Program:
    """Definitions needed by ``outputs``, CSE'd and scheduled, with locals renamed ``v0, v1, …``.

    Parameters
    ----------
    sub : the intermediates the outputs are written in
    outputs : the expressions the program computes, in order
    local_prefix : the prefix of the renumbered locals
    large : share only repeated subtrees (:func:`shared_subtrees`) instead of SymPy's ``cse`` with its
        ``"basic"`` optimisations, and rename without re-sorting (:func:`replaced`); by default when the program
        has more than :data:`LARGE_PROGRAM` definitions and outputs. Either way the result depends only on the
        expressions (SymPy's canonical argument order), not on hash seeds.

    Returns
    -------
    Program
        The statements in evaluation order and the outputs in the locals.
    """
    outputs = [sp.sympify(e) for e in outputs]
    definitions = sub.program(outputs)
    exprs = [d for _, d in definitions] + outputs
    temporaries = sp.numbered_symbols("_cse", real=True)
    if large is None:
        large = len(exprs) > LARGE_PROGRAM
    if large:
        replacements, reduced = shared_subtrees(exprs, temporaries)
    else:
        replacements, reduced = sp.cse(exprs, symbols=temporaries, optimizations="basic")
    statements: dict[sp.Symbol, sp.Expr] = dict(replacements)
    order: list[sp.Symbol] = [s for s, _ in replacements]
    for (symbol, _), expr in zip(definitions, reduced[: len(definitions)]):
        statements[symbol] = expr
        order.append(symbol)
    reduced_outputs = list(reduced[len(definitions) :])
    statements, order, reduced_outputs = _inline_aliases(statements, order, reduced_outputs)

    uses = {s: [t for t in symbols_in(e) if t in statements] for s, e in statements.items()}  # walked once
    needed: set[sp.Symbol] = set()
    stack = [t for e in reduced_outputs for t in symbols_in(e) if t in statements]
    while stack:
        s = stack.pop()
        if s not in needed:
            needed.add(s)
            stack.extend(uses[s])

    # the derivation's order where dependencies allow
    emitted = [s for s in _topological(statements, order, uses) if s in needed]
    rename = {s: local_symbol(f"{local_prefix}{k}") for k, s in enumerate(emitted)}
    substitute = _substitution(large)
    final = tuple((rename[s], substitute(statements[s], rename)) for s in emitted)
    return Program(final, tuple(substitute(e, rename) for e in reduced_outputs), large)


_LOCALS: dict[str, sp.Symbol] = {}


def local_symbol(name: str) -> sp.Symbol:
    """``sp.Symbol(name, real=True)``, made once per name: every program names its locals v0, v1, … again, and
    SymPy's own cache of symbols (the last thousand made) is smaller than a large program."""
    found = _LOCALS.get(name)
    if found is None:
        found = _LOCALS[name] = sp.Symbol(name, real=True)
    return found


def shared_subtrees(exprs: Sequence[sp.Expr], symbols) -> tuple[list[tuple[sp.Symbol, sp.Expr]], list[sp.Expr]]:
    """Every subtree that occurs more than once in ``exprs`` computed once, as a temporary from ``symbols``.

    SymPy's ``tree_cse`` without ``opt_subs`` (its ``order="none"``: arguments in SymPy's canonical order,
    which does not depend on hashes), except that sums and products are rebuilt by :func:`replaced`.

    Parameters
    ----------
    exprs : the expressions
    symbols : an iterator of fresh symbols, none of them in ``exprs``

    Returns
    -------
    tuple
        The (temporary, expression) pairs in evaluation order, and ``exprs`` written in them.
    """
    seen: set[sp.Basic] = set()
    repeated: set[sp.Basic] = set()

    def find(expr: sp.Basic) -> None:
        if expr.is_Atom:
            return
        if expr in seen:
            repeated.add(expr)  # its own subtrees were counted at its first occurrence
            return
        seen.add(expr)
        for arg in expr.args:
            find(arg)

    for e in exprs:
        find(e)
    replacements: list[tuple[sp.Symbol, sp.Expr]] = []
    done: dict[sp.Basic, sp.Expr] = {}

    def rebuild(expr: sp.Basic) -> sp.Expr:
        if expr.is_Atom:
            return expr
        if expr in done:
            return done[expr]
        args = [rebuild(a) for a in expr.args]
        new = _unsorted(expr, args)
        if expr in repeated:
            symbol = next(symbols)
            replacements.append((symbol, new))
            new = symbol
        done[expr] = new
        return new

    return replacements, [rebuild(e) for e in exprs]


def replaced(expr: sp.Expr, mapping: dict) -> sp.Expr:
    """``expr.xreplace(mapping)`` for a mapping to symbols (of symbols, or of sines and cosines), sums and
    products rebuilt from their arguments as they stand (``evaluate=False``) instead of sorted again: such a
    renaming changes no sum's or product's terms, only SymPy's canonical order of them, which the printers
    impose themselves."""
    found = mapping.get(expr)
    if found is not None:
        return found
    if expr.is_Atom:
        return expr
    args = []
    changed = False
    for a in expr.args:
        b = replaced(a, mapping)
        changed = changed or b is not a
        args.append(b)
    return _rebuilt(expr, args) if changed else expr


def _unsorted(expr: sp.Basic, args: list) -> sp.Basic:
    """``expr`` with ``args``: itself when they are its own, a sum or product as given, other heads evaluated."""
    if all(a is b for a, b in zip(args, expr.args)):
        return expr
    return _rebuilt(expr, args)


def _rebuilt(expr: sp.Basic, args: list) -> sp.Basic:
    """``expr`` with other ``args``: a sum or product as given, other heads evaluated."""
    if expr.is_Add or expr.is_Mul:
        # what ``expr.func(*args, evaluate=False)`` builds, without its cache lookup and sympification (a
        # sum's or product's arguments here are expressions already; no constructor postprocessor applies)
        return expr.func._from_args(args)
    return expr.func(*args)


def _substitution(large: bool):
    """How a program's symbols are substituted: :func:`replaced` for a large program, else ``xreplace``."""
    return replaced if large else (lambda expr, mapping: expr.xreplace(mapping))


def _inline_aliases(statements: dict, order: list, outputs: list) -> tuple[dict, list, list]:
    """Substitute statements that are a bare symbol or number (CSE leaves such copies behind)."""
    alias: dict[sp.Symbol, sp.Expr] = {}
    kept: dict[sp.Symbol, sp.Expr] = {}
    for s in _topological(statements, order):
        expr = statements[s]
        if alias and _mentions(expr, alias):  # the walk xreplace would make, without rebuilding what it leaves
            expr = expr.xreplace(alias)
        if expr.is_Atom or (expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1 and expr.args[1].is_Atom):
            alias[s] = expr
        else:
            kept[s] = expr
    new_order = [s for s in order if s in kept]
    return kept, new_order, [e.xreplace(alias) for e in outputs]


def _mentions(expr: sp.Basic, names: dict) -> bool:
    """Whether a node of ``expr`` (``expr`` itself included) is a key of ``names``."""
    stack = [expr]
    while stack:
        node = stack.pop()
        if node in names:
            return True
        stack.extend(node.args)
    return False


def _topological(statements: dict, order: list, uses: dict | None = None) -> list:
    """``order``'s symbols with each after the statements it uses (``uses``: symbol → the statements' symbols it
    holds, computed here when not given)."""
    if uses is None:
        uses = {s: [t for t in symbols_in(e) if t in statements] for s, e in statements.items()}
    position = {s: k for k, s in enumerate(order)}
    out, done = [], set()
    for root in order:
        todo = [(root, False)]
        while todo:
            s, ready = todo.pop()
            if s in done:
                continue
            if ready:
                done.add(s)
                out.append(s)
                continue
            todo.append((s, True))
            deps = [t for t in uses[s] if t not in done]
            todo.extend((t, False) for t in sorted(deps, key=position.__getitem__, reverse=True))
    return out


@dataclass(frozen=True)
class BatchedTrig:
    """A program whose sines and cosines of input-only angles come from one batched evaluation.

    ``angles[k]`` is the k-th angle; in ``program`` its sine is the symbol ``sines[k]`` and its cosine
    ``cosines[k]``. Generated C computes all of them in one vectorisable loop instead of one libm
    call each (see templates/sincos.c.j2).
    """

    angles: tuple[sp.Expr, ...]
    sines: tuple[sp.Symbol, ...]
    cosines: tuple[sp.Symbol, ...]
    program: Program


def batch_trig(
    program: Program, inputs: set[sp.Symbol], local_prefix: str = "v", order: Sequence[sp.Symbol] = ()
) -> BatchedTrig:
    """Replace sin/cos of angles that depend on inputs only by batch symbols; locals renumbered.

    Angles that are one of the symbols in ``order`` come first, in that order (so that angles
    q[1], ..., q[6] form one run the generated C can pass without copying); the others follow in
    order of first appearance.
    """
    angles: list[sp.Expr] = []
    for expr in [e for _, e in program.statements] + list(program.outputs):
        found = sorted(expr.atoms(sp.sin, sp.cos), key=sp.default_sort_key)
        for atom in found:
            angle = atom.args[0]
            if angle.free_symbols <= inputs and angle not in angles:
                angles.append(angle)
    rank = {s: k for k, s in enumerate(order)}
    angles.sort(key=lambda a: rank.get(a, len(rank)))  # stable: the others keep their order
    sines = tuple(sp.Symbol(f"_sin{k}", real=True) for k in range(len(angles)))
    cosines = tuple(sp.Symbol(f"_cos{k}", real=True) for k in range(len(angles)))
    table = {sp.sin(a): s for a, s in zip(angles, sines)} | {sp.cos(a): c for a, c in zip(angles, cosines)}

    statements: dict[sp.Symbol, sp.Expr] = {}
    order: list[sp.Symbol] = []
    substitute = _substitution(program.large)
    for symbol, expr in program.statements:
        statements[symbol] = substitute(expr, table)
        order.append(symbol)
    statements, order, outputs = _inline_aliases(statements, order, [substitute(e, table) for e in program.outputs])
    rename = {s: local_symbol(f"{local_prefix}{k}") for k, s in enumerate(order)}
    final = tuple((rename[s], substitute(statements[s], rename)) for s in order)
    return BatchedTrig(tuple(angles), sines, cosines,
                       Program(final, tuple(substitute(e, rename) for e in outputs), program.large))
