"""Kinetics fitted to lab data: weighted least squares on the experiments' residuals
((model - measured) / sd), by Levenberg-Marquardt on the residual Jacobian that forward-mode
sensitivities of the batched simulation give (`_fit_model`), then what a filing needs:
estimates, standard errors, the correlation matrix, Wald and profile-likelihood 95% intervals,
the chi-square and its goodness of fit, identifiability (rank, condition number and the
parameter combinations the data cannot determine, named) and the residuals.

Where every measurement has a standard deviation (the data's `sd` or the error model's), the
covariance is (J^T J)^-1 and the chi-square tests the fit; where none has one, every weight is 1
and the covariance is scaled by the residual variance s^2 = chi^2 / (n - p), the intervals by
Student's t.
"""

from typing import NamedTuple

import jax
import numpy as np
import scipy.stats

from snapo_ode import InputError

from ._chain import PharmaChain
from ._experiments import LabData
from ._fit_model import ExperimentModel, FittedParameters, experiment_model, fitted_parameters

UNIDENTIFIABLE_SE = 5.0
"""A combination of the fitted coordinates (ln k shifts, scaled activation shifts) whose standard
error exceeds this is named as one the data cannot determine (a factor e^(1.96 x 5) ~ 2e4 at 95%)."""
RANK_TOLERANCE = 1e-8
"""Singular values below this times the largest count as zero (the rank)."""


class FitResult(NamedTuple):
    """A fit: `names` (reported coordinates: `ln_k_ref[eq]` / `log_multiplier[eq]` [-], `E_a[eq]`
    [kJ/mol]), `estimates`, `covariance` (in those coordinates), `theta` and `theta_covariance`
    (the internal coordinates, what a posterior file stores), `fitted` (`FittedParameters`),
    `chi_square`, `dof`, `scale` (s^2, 1 with known sds), `sd_known`, `residuals` (weighted, in
    the data's row order), `predictions` [kmol/m^3], `singular_values`, `null_combinations`
    (list of {coefficients: {name: weight}, standard_error}), `profile` (name -> [low, high] or
    None), `iterations`."""

    names: list
    estimates: np.ndarray
    covariance: np.ndarray
    theta: np.ndarray
    theta_covariance: np.ndarray
    fitted: FittedParameters
    chi_square: float
    dof: int
    scale: float
    sd_known: bool
    residuals: np.ndarray
    predictions: np.ndarray
    singular_values: np.ndarray
    null_combinations: list
    profile: dict
    iterations: int

    @property
    def standard_errors(self) -> np.ndarray:
        return np.sqrt(np.diag(self.covariance))

    @property
    def quantile(self) -> float:
        """The two-sided 95% quantile: normal with known sds, Student's t on the dof otherwise."""
        return float(scipy.stats.norm.ppf(0.975) if self.sd_known else scipy.stats.t.ppf(0.975, max(self.dof, 1)))

    def wald(self) -> np.ndarray:
        """(n, 2) 95% Wald intervals; NaN for a parameter in an unidentifiable combination."""
        half = self.quantile * self.standard_errors
        intervals = np.stack([self.estimates - half, self.estimates + half], axis=1)
        intervals[self.unidentifiable()] = np.nan
        return intervals

    def unidentifiable(self) -> np.ndarray:
        """Boolean per parameter: part of a combination the data cannot determine."""
        flags = np.zeros(len(self.names), bool)
        for combination in self.null_combinations:
            for name in combination["coefficients"]:
                flags[self.names.index(name)] = True
        return flags


def _weights(data: LabData) -> tuple[np.ndarray, bool]:
    sd = data.sd()
    missing = np.isnan(sd)
    if missing.all():
        return np.ones_like(sd), False
    if missing.any():
        row = int(np.flatnonzero(missing)[0])
        m = data.measurements
        raise InputError(f"data file, line {m.line[row]}: {m.species[row]} has no sd and the experiments file no "
                         "error_model for it; give every measurement a standard deviation, or none (then one common "
                         "scale is estimated).")
    return sd, True


def residual_functions(model: ExperimentModel, values: np.ndarray, sd: np.ndarray, programs=None):
    """(residuals(theta), residuals_and_jacobian(theta)): the weighted residuals (n,) and their
    Jacobian (n, p), forward mode through the solves. `programs` (`residual_programs(model)`)
    lets fits of other data on the same design reuse one compile."""
    residuals, with_jacobian = residual_programs(model) if programs is None else programs
    values, sd = jax.numpy.asarray(values), jax.numpy.asarray(sd)
    return (lambda theta: residuals(theta, values, sd)), (lambda theta: with_jacobian(theta, values, sd))


def residual_programs(model: ExperimentModel):
    """The jitted (residuals(theta, values, sd), residuals_and_jacobian(theta, values, sd)); the
    second runs the batched solves once, the residuals and their Jacobian from the same pass."""

    def residuals(theta, values, sd):
        return (model.predict(theta) - values) / sd

    def with_jacobian(theta, values, sd):
        # One pass: the residuals are the primal of the forward-mode Jacobian's solves (its aux
        # output, not batched over the tangents), not a second simulation beside it.
        jacobian, r = jax.jacfwd(lambda t: (residuals(t, values, sd),) * 2, has_aux=True)(theta)
        return r, jacobian

    return jax.jit(residuals), jax.jit(with_jacobian)


def levenberg_marquardt(with_jacobian, theta0: np.ndarray, free: np.ndarray | None = None, *, max_steps: int = 200,
                        xtol: float = 1e-12, gtol: float = 1e-14) -> tuple[np.ndarray, int]:
    """Minimise 1/2 |r(theta)|^2 from `theta0` over the coordinates `free` (bool mask; default all),
    Levenberg-Marquardt with Marquardt's diagonal scaling. Returns (theta, iterations).

    **Raises:** `InputError` if it does not converge in `max_steps` or the residuals are not finite."""
    theta = np.asarray(theta0, float).copy()
    free = np.ones(len(theta), bool) if free is None else np.asarray(free)
    r, jac = (np.asarray(a, float) for a in with_jacobian(theta))
    cost, damping = r @ r, 1e-3
    for step in range(1, max_steps + 1):
        if not np.all(np.isfinite(r)) or not np.all(np.isfinite(jac)):
            raise InputError("the fit's residuals are not finite (a simulation failed at these parameters); check the "
                             "units of the data and the charges.")
        j = jac[:, free]
        normal, gradient = j.T @ j, j.T @ r
        if np.max(np.abs(gradient)) <= gtol * max(cost, 1.0):
            return theta, step
        diagonal = np.maximum(np.diag(normal), 1e-300)
        while True:
            delta = np.linalg.solve(normal + damping * np.diag(diagonal), -gradient)
            trial = theta.copy()
            trial[free] += delta
            r_trial, jac_trial = (np.asarray(a, float) for a in with_jacobian(trial))
            cost_trial = r_trial @ r_trial
            if np.isfinite(cost_trial) and cost_trial <= cost:
                theta, r, jac, cost = trial, r_trial, jac_trial, cost_trial
                damping = max(damping / 10.0, 1e-12)
                break
            damping *= 10.0
            if damping > 1e16:
                return theta, step
        if np.max(np.abs(delta)) <= xtol * (np.max(np.abs(theta[free])) + xtol):
            return theta, step
    raise InputError(f"the fit did not converge in {max_steps} Levenberg-Marquardt steps; fit fewer parameters "
                     "(--fit) or give data that determines them.")


def _null_combinations(names, jac, scale) -> tuple[np.ndarray, list]:
    """The singular values of the weighted Jacobian and the right singular vectors the data
    cannot determine (standard error above UNIDENTIFIABLE_SE, or a singular value below
    RANK_TOLERANCE of the largest), each named by its coefficients above 0.1."""
    _, singular, vt = np.linalg.svd(jac, full_matrices=False)
    combinations = []
    for value, vector in zip(singular, vt, strict=True):
        error = np.inf if value <= RANK_TOLERANCE * singular[0] else np.sqrt(scale) / value
        if error > UNIDENTIFIABLE_SE:
            vector = vector * np.sign(vector[np.argmax(np.abs(vector))])
            combinations.append({"coefficients": {names[k]: float(vector[k]) for k in np.argsort(-np.abs(vector))
                                                  if abs(vector[k]) > 0.1},
                                 "standard_error": float(error)})
    return singular, combinations


def _profile_side(with_jacobian, theta, k, sign, se, threshold, chi_min) -> float | None:
    """The point on one side of theta[k] where the profile chi-square rises by `threshold`: secant
    steps on the signed root sqrt(chi^2 - chi^2_min), near linear in theta[k]; None past 20 SE."""
    free = np.ones(len(theta), bool)
    free[k] = False
    target = np.sqrt(threshold)
    points = [(0.0, 0.0)]  # (offset, signed root)
    offset, start = sign * np.sqrt(threshold) * se, theta.copy()
    for _ in range(8):
        if abs(offset) > 20 * se:
            return None
        trial = start.copy()
        trial[k] = theta[k] + offset
        fitted, _ = levenberg_marquardt(with_jacobian, trial, free, max_steps=50)
        r = np.asarray(with_jacobian(fitted)[0])
        root = np.sqrt(max(r @ r - chi_min, 0.0))
        start = fitted
        if abs(root - target) <= 1e-4 * target:
            return float(theta[k] + offset)
        points.append((offset, root))
        (o1, r1), (o2, r2) = points[-2], points[-1]
        slope = (r2 - r1) / (o2 - o1) * sign if o2 != o1 else 0.0
        offset = o2 + sign * (target - r2) / slope if slope > 0 else 2 * o2
    return float(theta[k] + offset)


def fit(chain: PharmaChain, data: LabData, names: list[str] | None = None, *, profile: bool = True,
        programs=None) -> FitResult:
    """Fit the parameters `names` (`fitted_parameters`) of `chain` to `data` (module docstring);
    `profile`: also the profile-likelihood intervals (a few constrained fits per parameter);
    `programs`: `residual_programs` of an earlier fit on the same experiments, times and species
    (other values), to reuse its compile."""
    fitted = fitted_parameters(chain, data, names)
    model = experiment_model(chain, data, fitted)
    sd, sd_known = _weights(data)
    residuals, with_jacobian = residual_functions(model, data.measurements.value, sd, programs)
    theta, iterations = levenberg_marquardt(with_jacobian, np.zeros(len(fitted.names())))
    r, jac = (np.asarray(a, float) for a in with_jacobian(theta))
    n, p = jac.shape
    chi_square, dof = float(r @ r), n - p
    if dof <= 0:
        raise InputError(f"{n} measurements for {p} parameters; a fit needs more measurements than parameters.")
    scale = 1.0 if sd_known else chi_square / dof
    internal = fitted.names()
    singular, null = _null_combinations(internal, jac, scale)
    theta_covariance = scale * np.linalg.pinv(jac.T @ jac, rcond=RANK_TOLERANCE ** 2)
    base = np.asarray(chain.rate_parameters.activation_temperature)[
        [chain.mechanism.reaction_equations.index(eq) for eq in fitted.reactions]]
    reported, estimates, covariance = fitted.physical(theta, theta_covariance, base)
    rename = dict(zip(internal, reported, strict=True))
    null = [{**c, "coefficients": {rename[k]: v for k, v in c["coefficients"].items()}} for c in null]
    result = FitResult(reported, estimates, covariance, theta, theta_covariance, fitted, chi_square, dof, scale,
                       sd_known, r, np.asarray(model.predict(theta)), singular, null, {}, iterations)
    if profile:
        threshold = scipy.stats.chi2.ppf(0.95, 1) * scale if sd_known else result.quantile ** 2 * scale
        blocked = result.unidentifiable()
        se_theta = np.sqrt(np.diag(theta_covariance))
        for k, name in enumerate(reported):
            if blocked[k]:
                result.profile[name] = None
                continue
            sides = [_profile_side(with_jacobian, theta, k, sign, se_theta[k], threshold, chi_square)
                     for sign in (-1.0, 1.0)]
            ends = [None if v is None else float(fitted.physical(np.where(np.arange(p) == k, v, theta),
                                                                 theta_covariance, base)[1][k]) for v in sides]
            result.profile[name] = ends
    return result
