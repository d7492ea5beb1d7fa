"""The fitted uncertainty as a file the design space draws from: a multivariate normal over the
chain's rate inputs, written by `snapo pharma fit` and read (through the one reading path) by
`snapo pharma design-space --posterior` and `snapo report pharma --posterior`.

Coordinates (`names`): `log_multiplier[eq]` [-] and `activation_temperature[eq]`, the latter
scaled by the fit's reference temperature (`scales`: the input moves by scale x the coordinate,
so every coordinate is O(1) and the design space's curvature step means the same in each). The
`mean` is the fitted inputs (log_multiplier, activation temperature [K]); the `covariance` is over
the scaled coordinates. A correlated draw is mean + scales * (L z), L L^T = covariance (its
symmetric square root, so a singular covariance draws along what the data determine only).
"""

import json
from typing import NamedTuple

import numpy as np

from snapo_ode import InputError, read_text, strict_json

FORMAT = "snapo-pharma-posterior/1"
MAX_POSTERIOR_BYTES = 4 * 2**20


class Posterior(NamedTuple):
    """`names` (chain input names), `mean` (their fitted values), `scales` (input per coordinate),
    `covariance` (m, m) over the scaled coordinates, `process` (the name of the process fitted)."""

    names: tuple[str, ...]
    mean: np.ndarray
    scales: np.ndarray
    covariance: np.ndarray
    process: str
    fit: dict | None = None
    """The fit's summary as its JSON states it (parameters, correlation, goodness of fit,
    experiments, residuals), for the report; None where the file carries none."""

    def root(self) -> np.ndarray:
        """The symmetric square root of the covariance (negative round-off eigenvalues as 0)."""
        values, vectors = np.linalg.eigh(self.covariance)
        return vectors @ np.diag(np.sqrt(np.clip(values, 0.0, None))) @ vectors.T

    def draws(self, normals: np.ndarray) -> np.ndarray:
        """Correlated coordinate draws (n, m) from standard normals (n, m)."""
        return np.asarray(normals) @ self.root().T

    def as_dict(self) -> dict:
        return {"format": FORMAT, "process": self.process, "names": list(self.names), "mean": self.mean.tolist(),
                "scales": self.scales.tolist(), "covariance": self.covariance.tolist(), "fit": self.fit,
                "coordinates": "log_multiplier[eq]: the input itself; activation_temperature[eq]: the input [K] "
                               "divided by its scale (the fit's reference temperature [K]); a draw is mean + scales "
                               "* x with x ~ N(0, covariance)"}


def posterior_from_fit(result, chain, process: str, summary: dict | None = None) -> Posterior:
    """The `Posterior` of a fit (`FitResult`): the fitted inputs and the internal covariance mapped linearly
    (log_multiplier = ln_k_ref + d, activation_temperature = T_a0 + d T_ref; coordinate d)."""
    names, mean, scales, a = coordinate_map(result, chain)
    return Posterior(names, mean, scales, a @ result.theta_covariance @ a.T, process, summary)


def coordinate_map(result, chain) -> tuple[tuple[str, ...], np.ndarray, np.ndarray, np.ndarray]:
    """(names, mean, scales, A) of a fit's (`FitResult`) posterior: A (m, p) maps the fit's internal
    parameters onto the posterior's scaled coordinates, so that a covariance C over the former is
    A C A^T over the latter."""
    fitted, theta = result.fitted, result.theta
    equations = chain.mechanism.reaction_equations
    rates = fitted.to_rates(theta, chain.rate_parameters, equations)
    names, mean, scales, rows = [], [], [], []
    n, p = len(fitted.reactions), len(theta)
    shift = dict(zip([eq for eq, a in zip(fitted.reactions, fitted.with_activation) if a], range(n, p)))
    for k, equation in enumerate(fitted.reactions):
        j = equations.index(equation)
        row = np.zeros(p)
        row[k] = 1.0
        if equation in shift:
            row[shift[equation]] = 1.0
        names.append(f"log_multiplier[{equation}]"), mean.append(float(rates.log_multiplier[j]))
        scales.append(1.0), rows.append(row)
    for equation, column in shift.items():
        j = equations.index(equation)
        row = np.zeros(p)
        row[column] = 1.0
        names.append(f"activation_temperature[{equation}]"), mean.append(float(rates.activation_temperature[j]))
        scales.append(fitted.reference_temperature), rows.append(row)
    return tuple(names), np.array(mean), np.array(scales), np.array(rows)


def write_posterior(posterior: Posterior, path) -> None:
    with open(path, "w", encoding="utf-8") as handle:
        json.dump(posterior.as_dict(), handle, indent=1)
        handle.write("\n")


def read_posterior(path, chain) -> Posterior:
    """The posterior file at `path`, checked against `chain`'s reactions.

    **Raises:** `InputError` naming the file and the field for a file that is not one, an unknown
    input, shapes that do not agree, a covariance that is not symmetric positive semi-definite, or
    a scale that is not positive."""
    label = f"posterior file {path}"
    data = strict_json(read_text(path, "posterior", MAX_POSTERIOR_BYTES), label)
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InputError(f"{label}: format = {data.get('format') if isinstance(data, dict) else None!r}; allowed: "
                         f"{FORMAT!r} (written by snapo pharma fit).")
    names = data.get("names")
    allowed = {f"{field}[{eq}]" for eq in chain.mechanism.reaction_equations
               for field in ("log_multiplier", "activation_temperature")}
    if not isinstance(names, list) or not names or len(set(names)) != len(names):
        raise InputError(f"{label}: names = {names!r}; allowed: a non-empty list of distinct rate inputs.")
    unknown = [name for name in names if name not in allowed]
    if unknown:
        raise InputError(f"{label}: names has {unknown[0]!r}, no rate input of the process's mechanism; allowed: "
                         "log_multiplier[EQ] or activation_temperature[EQ] of its reactions.")
    m = len(names)
    try:
        mean, scales = np.array(data["mean"], float), np.array(data["scales"], float)
        covariance = np.array(data["covariance"], float)
    except (KeyError, TypeError, ValueError):
        raise InputError(f"{label}: mean, scales and covariance must be numbers: lists of {m} and an {m} x {m} "
                         "matrix.") from None
    if mean.shape != (m,) or scales.shape != (m,) or covariance.shape != (m, m):
        raise InputError(f"{label}: mean {mean.shape}, scales {scales.shape}, covariance {covariance.shape}; allowed: "
                         f"({m},), ({m},), ({m}, {m}) for {m} names.")
    if not np.all(scales > 0):
        raise InputError(f"{label}: scales = {scales.tolist()}; allowed: > 0.")
    if not np.allclose(covariance, covariance.T, rtol=1e-9, atol=0) or np.linalg.eigvalsh(covariance).min() < \
            -1e-9 * max(np.abs(covariance).max(), 1e-300):
        raise InputError(f"{label}: covariance is not symmetric positive semi-definite.")
    if np.sqrt(np.diag(covariance)).max() > 2.0:
        raise InputError(f"{label}: a standard deviation of {np.sqrt(np.diag(covariance)).max():.3g} (a factor "
                         "above e^2 on a rate); allowed: <= 2. Refit with data that determine the parameters.")
    fit = data.get("fit")
    if fit is not None and not isinstance(fit, dict):
        raise InputError(f"{label}: fit = {fit!r}; allowed: the fit's summary (a mapping) or null.")
    return Posterior(tuple(names), mean, scales, covariance, str(data.get("process", "")), fit)


def posterior_draws(chain, inputs, posterior: Posterior, seed: int, n: int):
    """What the design space draws with a posterior: (inputs with the rates at its mean, the
    uncertain input names, their scales, n correlated coordinate draws from `seed`)."""
    import jax

    normals = np.asarray(jax.random.normal(jax.random.key(seed), (n, len(posterior.names))))
    return posterior_inputs(chain, inputs, posterior), list(posterior.names), posterior.scales.copy(), \
        posterior.draws(normals)


def posterior_inputs(chain, inputs, posterior: Posterior):
    """`inputs` (`ChainInputs`) with the posterior's rate inputs at its mean."""
    rates, equations = inputs.rates, chain.mechanism.reaction_equations
    fields = {"log_multiplier": rates.log_multiplier, "activation_temperature": rates.activation_temperature}
    for name, value in zip(posterior.names, posterior.mean, strict=True):
        field, _, equation = name.partition("[")
        fields[field] = fields[field].at[equations.index(equation[:-1])].set(value)
    rates = type(rates)(fields["log_multiplier"], rates.temperature_exponent, fields["activation_temperature"])
    return inputs._replace(rates=rates)


def posterior_summary(posterior: Posterior) -> dict:
    """The design space's `uncertainty` field for a posterior."""
    return {"source": "posterior", "process": posterior.process, "names": list(posterior.names),
            "mean": posterior.mean.tolist(), "scales": posterior.scales.tolist(),
            "covariance": posterior.covariance.tolist()}
