"""Reading one reaction's rate expression into SI numbers (Arrhenius, Blowers-Masel, Troe, Tsang
and SRI falloff parameters, PLOG table, Chebyshev fit), and stacking the PLOG and Chebyshev
reactions into the padded arrays of `Plog` and `Chebyshev`."""

import math

import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError

from ._pressure_rates import Chebyshev, Plog
from ._units import UnitSystem, rate_constant_factor


def _as_mapping(label: str, rate, keys: tuple[str, ...], least: int):
    """A rate constant given as a list (`[A, b, Ea]`, which Cantera also reads) as the mapping of
    `keys`; a mapping as it is.

    **Raises:** `InputError` for a list of fewer than `least` or more than `len(keys)` numbers."""
    if not isinstance(rate, (list, tuple)):
        return rate
    if not least <= len(rate) <= len(keys):
        raise InputError(f"{label}: a rate constant written as a list is [{', '.join(keys)}], the first {least} "
                         f"required; got {list(rate)!r}.")
    return dict(zip(keys, rate))


def arrhenius(label: str, rate, order: float, units: UnitSystem, concentration_scaled: bool):
    """(A [SI], b [-], Ea/R [K]) of an Arrhenius rate of `order`: a mapping {A, b, Ea} or a list
    [A, b] or [A, b, Ea]."""
    rate = _as_mapping(label, rate, ("A", "b", "Ea"), 2)
    if not isinstance(rate, dict) or "A" not in rate:
        raise InputError(f"{label}: a rate constant is {{A: ..., b: ..., Ea: ...}} or [A, b, Ea]; got {rate!r}.")
    a = rate["A"]
    if isinstance(a, str):
        a = units.convert(f"{label} A", a, "")
    else:
        a = float(a) * rate_constant_factor(units, order, concentration_scaled)
    return a, float(rate.get("b", 0.0)), units.activation_temperature(f"{label} Ea", rate.get("Ea", 0.0))


def blowers_masel(label: str, rate, order: float, units: UnitSystem, concentration_scaled: bool):
    """(A [SI], b [-], E_a0/R [K], w/R [K]) of a Blowers-Masel `rate-constant` {A, b, Ea0, w} or
    [A, b, Ea0, w] (energies in the file's activation-energy units or their own).

    **Raises:** `InputError` without A or w, or unless w > Ea0 (the barrier's V_P divides by
    w - Ea0)."""
    rate = _as_mapping(label, rate, ("A", "b", "Ea0", "w"), 4)
    if not isinstance(rate, dict) or "A" not in rate or "w" not in rate:
        raise InputError(f"{label}: a Blowers-Masel reaction needs rate-constant: {{A: ..., b: ..., Ea0: ..., "
                         f"w: ...}}; got {rate!r}.")
    a, b, _ = arrhenius(label, {"A": rate["A"], "b": rate.get("b", 0.0)}, order, units, concentration_scaled)
    intrinsic = units.activation_temperature(f"{label} Ea0", rate.get("Ea0", 0.0))
    bond = units.activation_temperature(f"{label} w", rate["w"])
    if not bond > intrinsic:
        raise InputError(f"{label}: Blowers-Masel w = {rate['w']!r} must exceed Ea0 = {rate.get('Ea0', 0.0)!r}.")
    return a, b, intrinsic, bond


def troe_parameters(troe):
    """(A, 1/T3 [1/K], 1/T1 [1/K], T2 [K], has T2) of a `Troe` mapping, or the neutral zeros
    without one (Lindemann); Cantera reads |T| below 1e-300 as infinite: 1/T = 0, no term."""
    if troe is None:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    inverse = [0.0 if abs(float(troe[key])) < 1e-300 else 1.0 / float(troe[key]) for key in ("T3", "T1")]
    return float(troe["A"]), *inverse, float(troe.get("T2", 0.0)), float("T2" in troe)


def tsang_parameters(label: str, tsang):
    """(A - 1, B [1/K]) of a `Tsang` mapping (F_cent = A + B T; B defaults to 0), or (0, 0)
    without one: the terms `Falloff` adds to the neutral Troe centring, which is 1."""
    if tsang is None:
        return 0.0, 0.0
    if "A" not in tsang or not set(tsang) <= {"A", "B"}:
        raise InputError(f"{label}: Tsang needs A and optionally B; got {', '.join(map(str, tsang))}.")
    return float(tsang["A"]) - 1.0, float(tsang.get("B", 0.0))


def sri_parameters(label: str, sri):
    """(a, b [K], c [K], d, e) of an `SRI` mapping, or the neutral (1, 0, 0, 1, 0) without one;
    Cantera's checks: 3 or 5 parameters, c >= 0, d >= 0."""
    if sri is None:
        return 1.0, 0.0, 0.0, 1.0, 0.0
    if set(sri) not in ({"A", "B", "C"}, {"A", "B", "C", "D", "E"}):
        raise InputError(f"{label}: SRI needs A, B, C or A, B, C, D, E; got {', '.join(map(str, sri))}.")
    values = tuple(float(sri.get(key, default)) for key, default in zip("ABCDE", (0.0, 0.0, 0.0, 1.0, 0.0)))
    if values[2] < 0 or values[3] < 0:
        raise InputError(f"{label}: SRI C and D must not be negative; got C = {values[2]}, D = {values[3]}.")
    return values


def plog_table(label: str, node, order: float, units: UnitSystem, concentration_scaled: bool):
    """A PLOG reaction's `rate-constants` as [(ln P [ln Pa], [(A, b, Ea/R), ...]), ...], ascending
    in P, the expressions given at one pressure grouped (Cantera sums them)."""
    levels: dict[float, list] = {}
    for rate in node.get("rate-constants") or []:
        if not isinstance(rate, dict):
            # Cantera reads each entry as a mapping: [P, A, b, Ea] is refused there too.
            raise InputError(f"{label}: each PLOG rate-constants entry is a mapping {{P: ..., A: ..., b: ..., Ea: ...}}"
                             f"; got {rate!r}.")
        pressure = units.convert(f"{label} P", rate["P"], "pressure")
        if not pressure > 0:
            raise InputError(f"{label}: PLOG pressure P = {rate['P']!r} is not positive.")
        levels.setdefault(math.log(pressure), []).append(arrhenius(label, rate, order, units, concentration_scaled))
    if not levels:
        raise InputError(f"{label}: a pressure-dependent-Arrhenius reaction needs a non-empty 'rate-constants' list.")
    return sorted(levels.items())


def chebyshev_fit(label: str, node, order: float, units: UnitSystem, concentration_scaled: bool):
    """A Chebyshev reaction as (coefficients (n_T, n_P) for k in SI, (T_min, T_max) [K],
    (P_min, P_max) [Pa]); a_00 absorbs the log10 of the rate constant's unit conversion, as in
    Cantera."""
    rows = [[float(value) for value in row] for row in node["data"]]
    if not rows or any(len(row) != len(rows[0]) or not row for row in rows):
        raise InputError(f"{label}: Chebyshev 'data' must be a non-empty rectangular list of rows.")
    coefficients = np.array(rows)
    coefficients[0, 0] += math.log10(rate_constant_factor(units, order, concentration_scaled))
    t_range = [units.convert(f"{label} temperature-range", t, "temperature") for t in node["temperature-range"]]
    p_range = [units.convert(f"{label} pressure-range", p, "pressure") for p in node["pressure-range"]]
    if len(t_range) != 2 or len(p_range) != 2 or not (0 < t_range[0] < t_range[1] and 0 < p_range[0] < p_range[1]):
        raise InputError(f"{label}: Chebyshev temperature-range and pressure-range must be increasing "
                         "positive pairs.")
    return coefficients, t_range, p_range


def stack_plog(index: list[int], tables: list) -> Plog:
    """`Plog` of the reactions `index` with their `plog_table`s, padded to the longest table and
    the most expressions at one pressure."""
    n_levels = max([len(table) for table in tables] + [1])
    n_terms = max([len(terms) for table in tables for _, terms in table] + [1])
    shape = (len(tables), n_levels, n_terms)
    log_pressure = np.zeros(shape[:2])
    terms = np.zeros((3, *shape))
    segment_weight = np.zeros((len(tables), n_levels - 1))
    for g, table in enumerate(tables):
        padded = table + [(table[-1][0] + j + 1, table[-1][1]) for j in range(n_levels - len(table))]
        for level, (log_p, expressions) in enumerate(padded):
            log_pressure[g, level] = log_p
            terms[:, g, level, :len(expressions)] = np.array(expressions).T
        segment_weight[g, :len(table) - 1] = 1.0
    return Plog(jnp.asarray(np.array(index, np.int32)), jnp.asarray(log_pressure),
                *(jnp.asarray(part) for part in terms), jnp.asarray(segment_weight))


def stack_chebyshev(index: list[int], fits: list) -> Chebyshev:
    """`Chebyshev` of the reactions `index` with their `chebyshev_fit`s, zero-padded to the
    largest fit."""
    n_t = max([fit[0].shape[0] for fit in fits] + [1])
    n_p = max([fit[0].shape[1] for fit in fits] + [1])
    coefficients = np.zeros((len(fits), n_t, n_p))
    for g, (fit, _, _) in enumerate(fits):
        coefficients[g, :fit.shape[0], :fit.shape[1]] = fit
    t_range = np.array([fit[1] for fit in fits]).reshape(len(fits), 2)
    p_range = np.array([fit[2] for fit in fits]).reshape(len(fits), 2)
    return Chebyshev(jnp.asarray(np.array(index, np.int32)), jnp.asarray(coefficients),
                     jnp.asarray(1.0 / t_range[:, 0]), jnp.asarray(1.0 / t_range[:, 1]),
                     jnp.asarray(np.log10(p_range[:, 0])), jnp.asarray(np.log10(p_range[:, 1])))
