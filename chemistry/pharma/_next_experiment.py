"""The next experiment: candidate kinetic runs ranked by how much they would sharpen the fitted
parameters, D-optimal on the Fisher information: the gain of ln det(F + J_c^T W J_c) over ln det F,
with F the current fit's information (J^T J of its weighted residuals, divided by its scale) and
J_c the candidate's Jacobian at the current estimates, its weights from the error model at the
predicted values. Also each parameter's standard error after the candidate, against now, and,
given the design space's `EdgeMap` under the fit's posterior, the edge uncertainty expected after
the candidate against now (`_edge_uncertainty`): the other ranking, by the design space's edge."""

import numpy as np

from snapo_ode import InputError

from ._experiments import ErrorModel, LabData
from ._fit import FitResult, residual_functions
from ._fit_model import experiment_model
from ._fit_synthetic import lab_design


RANKINGS = {"d-optimal": "log_det_gain", "edge": "edge_gain"}
"""The rankings by name, each by its field of a candidate's row."""


def rank_candidates(chain, data: LabData, result: FitResult, candidates, times: list[float],
                    species: list[str], *, edge=None, rank_by: str = "d-optimal") -> list[dict]:
    """Each candidate (`Experiment`) sampled at `times` [min] for `species`, ranked best first by
    `rank_by` (`RANKINGS`): {name, temperature_K, charges, log_det_gain, standard_errors_after
    (name -> value), standard_error_ratio (after / now, per parameter)}; with `edge` (the
    `EdgeMap` of the design space under the fit's posterior) also `edge_uncertainty_now`,
    `edge_uncertainty_after` (expected) and `edge_gain` (their difference, >= 0).

    **Raises:** `InputError` for a species the data's error model does not state (its sd would be
    unknown) when the fit's sds were known, or `rank_by` "edge" without `edge`."""
    if rank_by not in RANKINGS or (rank_by == "edge" and edge is None):
        raise InputError(f"rank_by = {rank_by!r}; allowed: {', '.join(RANKINGS)} (edge with the design space's map).")
    missing = [s for s in species if s not in data.error_model]
    if result.sd_known and missing:
        raise InputError(f"--species {missing[0]}: the experiments file's error_model states no sd for it; a candidate's "
                         "weights come from the error model.")
    errors = {s: data.error_model.get(s, ErrorModel(float(np.sqrt(result.scale)), 0.0)) for s in species}
    plan = lab_design(tuple(candidates), list(times), list(species), errors)
    model = experiment_model(chain, plan, result.fitted)
    predicted = np.asarray(model.predict(result.theta))
    sd = np.zeros_like(predicted)
    for name, error in errors.items():
        rows = np.asarray(plan.measurements.species) == name
        sd[rows] = error.sd(np.abs(predicted[rows]))
    _, with_jacobian = residual_functions(model, predicted, sd)
    jacobian = np.asarray(with_jacobian(result.theta)[1])
    information = np.linalg.pinv(result.theta_covariance)
    now = np.linalg.slogdet(information)[1]
    se_now = result.standard_errors
    if edge is not None:
        from ._posterior import coordinate_map

        to_coordinates = coordinate_map(result, chain)[3]
        coordinates_now = to_coordinates @ result.theta_covariance @ to_coordinates.T
        edge_now = edge.uncertainty(coordinates_now)
    rows = []
    for e, candidate in enumerate(candidates):
        j = jacobian[plan.measurements.experiment == e]
        after = information + j.T @ j
        covariance = updated_covariance(result.theta_covariance, j)
        _, _, reported = result.fitted.physical(result.theta, covariance, np.zeros(len(result.fitted.reactions)))
        se_after = np.sqrt(np.diag(reported))
        rows.append({"name": candidate.name, "temperature_K": candidate.temperature, "charges": candidate.charges,
                     "log_det_gain": float(np.linalg.slogdet(after)[1] - now),
                     "standard_errors_after": dict(zip(result.names, se_after.tolist())),
                     "standard_error_ratio": dict(zip(result.names, (se_after / se_now).tolist()))})
        if edge is not None:
            coordinates_after = to_coordinates @ covariance @ to_coordinates.T
            expected = edge.uncertainty(coordinates_after)
            rows[-1].update(edge_uncertainty_now=edge_now, edge_uncertainty_after=expected, edge_gain=edge_now - expected)
    return sorted(rows, key=lambda row: -row[RANKINGS[rank_by]])


def updated_covariance(covariance: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
    """The covariance after measurements of weighted Jacobian `jacobian` (n, p): (C^-1 + J^T J)^-1
    in Woodbury's form, C - C J^T (I + J C J^T)^-1 J C, which needs no inverse of a singular C and
    returns C itself, exactly, for a J of zeros."""
    gain = covariance @ jacobian.T
    return covariance - gain @ np.linalg.solve(np.eye(len(jacobian)) + jacobian @ gain, gain.T)
