"""Recomputed numbers of Milne et al. (see :mod:`symbolic.reproduction`).

Two parts, in the order of the paper: the sinusoidal steady-state identification and the inertia model
(sections 2.2 and 3.1, Tables 3–5 and 9), then the α-invariant model (sections 2.3–2.4 and 3.2–3.4,
Tables 6–8, 10 and 11).
"""

from __future__ import annotations

from symbolic.reproduction.item import Item


def items() -> list[Item]:
    """The Milne items, in the order of the paper."""
    return sine_identification_items() + alpha_invariant_items()


def sine_identification_items() -> list[Item]:
    """Tables 3, 4, 5 and 9 and the 3.4 Hz linear resonance (:mod:`symbolic.reproduction.milne.sine_items`)."""
    from symbolic.reproduction.milne import sine_items as milne_sine  # here, not at the top: the α-invariant part edits the imports

    found: list[Item] = milne_sine.items()
    return found


def alpha_invariant_items() -> list[Item]:
    """Tables 6–8, 10 and 11: the α-invariant model's coefficients and comparison statistics.

    Table 10 (γ₁ = 65°, γ₂ = 90°) is recomputed from Tables 6 and 7 through (40), (42) at the
    configuration's inertia (:meth:`symbolic.reproduction.milne.alpha_damping.AlphaInertiaModel.at`); the summary
    rows of Tables 8 and 11 from their printed rows. The per-configuration rows of Tables 8 and 11 need
    the measured responses, which are not published; tests/test_milne_alpha.py computes the same
    statistics (:mod:`symbolic.reproduction.milne.alpha_comparison`) on a simulated plant.
    """
    # Local imports keep this function self-contained (the sine items above have their own).
    import numpy as np

    from symbolic.reproduction.milne.alpha_damping import AlphaInertiaModel
    from symbolic.reproduction.item import compare, not_reproducible, printed_tolerance

    # Table 6 and Table 7 exactly as printed: (quantity, α value, value[, ratio to C̄0]).
    table6 = (("β̃01", "0", "1.3405"), ("β̃11", "250", "0.8558"))
    table7 = (("C01", "61.733", "0", "1.68238"), ("C11", "35.316", "2.2", "0.96245"),
              ("C21", "21.570", "25", "0.58783"), ("C31", "13.509", "250", "0.36816"))
    table10_inertia = "0.004366"
    table10_damping = ("16.955", "10.619", "6.486", "3.710")
    table10_torque = ("267.6", "170.9")
    table5_beta_tilde_65_90 = "229.04"          # Table 5, γ₁ = 65°, γ₂ = 90°, modelled β̃_linear = 1/I (25)
    table4_c0 = "36.693"                         # Table 4 C̄0 (the "identified C̄0" of Table 7)
    table8 = (("0.6410", "12.1902", "0.4146", "6.3605"), ("0.4776", "19.4772", "0.2756", "2.7394"),
              ("0.4737", "10.6066", "0.1935", "3.4813"), ("0.5002", "13.2881", "0.2202", "2.1805"),
              ("0.3675", "25.3134", "0.5202", "7.3346"), ("0.5762", "15.0195", "0.5173", "4.3214"),
              ("0.3939", "14.0549", "0.3714", "13.9204"), ("0.4312", "16.2316", "0.2028", "2.7323"),
              ("0.3403", "14.3577", "0.2968", "5.9665"))
    table8_average = ("0.4668", "15.6155", "0.3347", "5.4485")
    table11 = (("0.0083", "0.0207", "0.0036", "0.0123"), ("0.0098", "0.0230", "0.0045", "0.0138"),
               ("0.0120", "0.0276", "0.0067", "0.0157"), ("0.0138", "0.0314", "0.0082", "0.0160"),
               ("0.0145", "0.0320", "0.0087", "0.0167"), ("0.0075", "0.0217", "0.0021", "0.0068"),
               ("0.0099", "0.0230", "0.0029", "0.0078"), ("0.0140", "0.0270", "0.0036", "0.0088"),
               ("0.0167", "0.0293", "0.0041", "0.0100"), ("0.0175", "0.0298", "0.0043", "0.0096"),
               ("0.0087", "0.0206", "0.0030", "0.0109"), ("0.0097", "0.0230", "0.0036", "0.0119"),
               ("0.0118", "0.0270", "0.0058", "0.0138"), ("0.0133", "0.0298", "0.0073", "0.0150"),
               ("0.0137", "0.0303", "0.0076", "0.0156"), ("0.0070", "0.0265", "0.0020", "0.0092"),
               ("0.0088", "0.0259", "0.0025", "0.0093"), ("0.0120", "0.0256", "0.0037", "0.0090"),
               ("0.0137", "0.0270", "0.0037", "0.0091"), ("0.0139", "0.0271", "0.0036", "0.0093"),
               ("0.0066", "0.0192", "0.0023", "0.0089"), ("0.0078", "0.0209", "0.0024", "0.0111"),
               ("0.0097", "0.0231", "0.0034", "0.0118"), ("0.0108", "0.0235", "0.0037", "0.0126"),
               ("0.0112", "0.0238", "0.0041", "0.0129"))
    table11_summary = ("0.0113", "0.0256", "0.0043", "0.0115")
    accuracy_ratio = "2.6"

    def chain(*printed: tuple[str, ...] | str) -> float:
        """Rounding of a product/quotient of printed numbers: the sum of their half-last-digit tolerances."""
        return sum(printed_tolerance(p) for p in printed)

    found: list[Item] = []

    # Table 10 I: by (25) β̃_linear(I) = 1/I, so Table 5's modelled β̃_linear at 65°/90° fixes I.
    inertia_from_table5 = 1.0 / float(table5_beta_tilde_65_90)
    found.append(compare(
        "milne", "Table 10 I", table10_inertia, inertia_from_table5, "kg m²",
        tolerance=chain(table10_inertia, table5_beta_tilde_65_90),
        how="I = 1/β̃_linear(I) by (25), with Table 5's modelled β̃_linear = 229.04 at γ₁ = 65°, γ₂ = 90° "
            "(tolerance: the rounding of both printed numbers)."))

    # Table 10 C0…C3, β̃0, β̃1 from Tables 6, 7 through (40), (42) at Table 10's I.
    inertia = float(table10_inertia)
    value_column = tuple(float(row[1]) for row in table7)
    alpha_column = tuple(float(row[2]) for row in table7)
    torque_values = tuple(float(row[2]) for row in table6)
    torque_alphas = tuple(float(row[1]) for row in table6)
    # The reading that makes Tables 6, 7 and 10 consistent: both Value columns are printed in reverse
    # α order. C(α) must decrease with α (Milne 2.3.3: "damping increased with decreasing α") and β̃(α)
    # too (2.3.4); with the printed order, (40) gives C0 = 3.710 (Table 10's C3) and β̃0 = 170.9 (β̃1).
    corrected = AlphaInertiaModel(alpha_column, value_column[::-1], torque_alphas, torque_values[::-1])
    as_printed = AlphaInertiaModel(alpha_column, value_column, torque_alphas, torque_values)
    at_i = corrected.at(inertia)
    printed_at_i = as_printed.at(inertia)
    found.append(compare(
        "milne", "Table 10 C0, C1, C2, C3", table10_damping, at_i.damping_values, "1/s",
        tolerance=chain(table10_inertia, tuple(row[1] for row in table7), table10_damping),
        correcting="Table 7's Value column, printed in reverse α order (C01 = 13.509 at α = 0 … C31 = 61.733 "
                   "at α = 250)",
        how="C_k = 1/(C_k1·I) (40) via AlphaInertiaModel(...).at(I) with Table 10's I = 0.004366; Table 7 "
            "as printed gives C0…C3 = " + ", ".join(f"{c:.4g}" for c in printed_at_i.damping_values)
            + ", Table 10's values in reverse order (tolerance: rounding of I, C_k1 and the printed C_k)."))
    found.append(compare(
        "milne", "Table 10 β̃0, β̃1", table10_torque, at_i.torque_values, "rad/(V s²)",
        tolerance=chain(table10_inertia, tuple(row[2] for row in table6), table10_torque),
        correcting="Table 6's rows, swapped (β̃01 = 0.8558 at ᾱ = 0, β̃11 = 1.3405 at ᾱ = 250)",
        how="β̃_k = 1/(β̃_k1·I) (42) via AlphaInertiaModel(...).at(I) with I = 0.004366; Table 6 as printed gives "
            "β̃0, β̃1 = " + ", ".join(f"{b:.4g}" for b in printed_at_i.torque_values)
            + " (β̃ would increase with α, against 2.3.4)."))

    # Table 7's last column: C_k1/C̄0 = C_linear(I)/C_k(I) at any I, (24) over (40).
    c_linear = 1.0 / (float(table4_c0) * inertia)
    ratios = tuple(c_linear / c for c in printed_at_i.damping_values)
    printed_ratios = tuple(row[3] for row in table7)
    found.append(compare(
        "milne", "Table 7 ratio to identified C̄0", printed_ratios, ratios, "",
        tolerance=chain(tuple(row[1] for row in table7), table4_c0, printed_ratios),
        how="C_linear(I)/C_k(I) = C_k1/C̄0 with (24), (40), Table 4's C̄0 = 36.693 and Table 7's values in "
            "their printed rows (the ratio column is in the same reversed order as the values; tolerance: "
            "rounding of C_k1, C̄0 and the ratio)."))

    # Table 8's Average row: the mean of its nine rows (magnitudes and phases as two items).
    rows8 = np.array([[float(x) for x in row] for row in table8])
    for label, columns, unit in (("magnitude", (0, 2), ""), ("phase", (1, 3), "deg")):
        printed = tuple(table8_average[c] for c in columns)
        found.append(compare(
            "milne", f"Table 8 Average {label} error (linear, non-linear)", printed,
            tuple(rows8.mean(axis=0)[list(columns)]), unit,
            tolerance=2 * printed_tolerance(printed),
            how="Column means of Table 8's nine printed rows (tolerance: the rows and the average are rounded "
                "to the same digit, half a unit each)."))
    found.append(not_reproducible(
        "milne", "Table 8 rows (90th-percentile errors)", [x for row in table8 for x in row],
        "magnitude 1, phase deg", why="the measured sine responses of the Omni are not published",
        how="symbolic.reproduction.milne.alpha_comparison.frequency_response_errors computes them from measured and "
            "simulated sweeps; tests/test_milne_alpha.py does so on a plant with energy-dependent damping."))

    # Table 11's summary row, labelled "Medians", holds the column means.
    rows11 = np.array([[float(x) for x in row] for row in table11])
    means, medians = rows11.mean(axis=0), np.median(rows11, axis=0)
    found.append(compare(
        "milne", "Table 11 Medians row", table11_summary,
        tuple(means), "rad", tolerance=2 * printed_tolerance(table11_summary),
        correcting="the row label: the printed \"Medians\" are the column means",
        how="Column means of Table 11's 25 printed rows; the column medians are "
            + ", ".join(f"{m:.4f}" for m in medians)
            + " (tolerance: the rows and the summary are rounded to the same digit, half a unit each)."))
    found.append(compare(
        "milne", "3.4 \"2.6 times more accurate\"", accuracy_ratio,
        means[0] / means[2], "", correcting="Table 11's summary label (means, as above)",
        how=f"Ratio of Table 11's summary values 0.0113/0.0043 (column means); the ratio of the column medians "
            f"would be {medians[0] / medians[2]:.2f}."))
    found.append(not_reproducible(
        "milne", "Table 11 rows (absolute angle errors)",
        [x for row in table11 for x in row], "rad", why="the measured step responses of the Omni are not published",
        how="symbolic.reproduction.milne.alpha_comparison.step_errors computes them; tests/test_milne_alpha.py does so on "
            "a plant with energy-dependent damping."))
    # in the paper's order: Table 7 (3.2), Table 8 (3.2), Table 10 (3.3), Table 11 (3.4)
    order = ("Table 7", "Table 8", "Table 10", "Table 11", "3.4")
    return sorted(found, key=lambda i: next(k for k, prefix in enumerate(order) if i.item.startswith(prefix)))
