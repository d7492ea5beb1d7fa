"""The design space's surrogate of the CQAs under uncertain rate constants, from the chain's
Jacobian: second order in the log rate constants,

    ln CQA(k) ~= ln CQA(k0) + S d + (1/2) d' H d,   d = ln k - ln k0,

with S = d ln CQA / d ln k from one reverse-mode Jacobian at each grid point, and H by one-sided
differences of S (step h in each ln k_j, one more Jacobian per direction) on a coarse grid,
interpolated bilinearly between its points. Why second order: the residual solvent leaves the
dryer as exp(-k t), so ln(solvent) is linear in k, not in ln k; to first order the surrogate
misclassified 9 of 1,000 draws at the edge of the solvent spec (1.5 standard errors of the Monte
Carlo there), and H is what corrects it. H varies with the CPPs only through smooth Arrhenius
factors, which is why a coarse grid suffices.
"""

import numpy as np

from snapo_ode import flatten_inputs

from ._chain import PharmaChain
from ._parameters import ChainInputs
from ._sensitivities import input_names, named_jacobian


def is_log_input(name: str) -> bool:
    """An input that moves additively by its scale times the coordinate: a log-multiplier (ln k
    itself, scale 1) or an activation temperature (a posterior's, scaled by the fit's reference
    temperature); other uncertain inputs are rate constants k, moved by k0 (e^d - 1)."""
    return name.startswith(("log_multiplier[", "activation_temperature["))


def log_scales(chain: PharmaChain, inputs: ChainInputs, uncertain) -> np.ndarray:
    """d input / d ln k of each uncertain input at `inputs`: 1 for a log-multiplier, k for a rate."""
    flat = np.asarray(flatten_inputs(inputs)[0])
    column = {name: k for k, name in enumerate(input_names(chain))}
    return np.array([1.0 if is_log_input(name) else flat[column[name]] for name in uncertain])


def input_offsets(uncertain, scales: np.ndarray, draws: np.ndarray) -> np.ndarray:
    """The change of each uncertain input when ln k moves by `draws` (..., m): the draw for a
    log-multiplier, k0 (e^d - 1) for a rate constant."""
    is_log = np.array([is_log_input(name) for name in uncertain])
    return np.where(is_log, scales * draws, scales * np.expm1(draws))


def grid_inputs(inputs: ChainInputs, x: str, y: str, vx: float, vy: float) -> ChainInputs:
    """`inputs` with CPPs `x` and `y` at `vx`, `vy`."""
    return inputs._replace(cpps=inputs.cpps.replace(**{x: float(vx), y: float(vy)}))


def log_sensitivities(result, chain: PharmaChain, inputs, uncertain, scales) -> tuple[np.ndarray, np.ndarray]:
    """(CQAs (n_cqas,), S (n_cqas, m)) at `inputs` from `result` = (CQAs, Jacobian) there (one point of
    `jacobians_function(chain, True, "reverse")`)."""
    cqas, matrix = result
    values = np.asarray(cqas)
    jac = np.asarray(named_jacobian(chain, inputs, cqas, matrix, "reverse").columns(list(uncertain)))
    return values, jac * scales[None, :] / values[:, None]


def curvature(evaluate_many, chain: PharmaChain, inputs, uncertain, scales, step: float) -> np.ndarray:
    """H (n_cqas, m, m) at `inputs`: the one-sided difference of S over a step `step` in each ln k_j,
    symmetrised; the m + 1 Jacobians in one call of `evaluate_many` (see `jacobians_function`)."""
    flat, rebuild = flatten_inputs(inputs)
    flat = np.asarray(flat)
    column = {name: k for k, name in enumerate(input_names(chain))}
    points, shifted = [inputs], []
    for j, name in enumerate(uncertain):
        moved = flat.copy()
        moved[column[name]] += input_offsets([name], scales[j:j + 1], np.array([step]))[0]
        shifted_scales = scales.copy()
        if not is_log_input(name):
            shifted_scales[j] = scales[j] * np.exp(step)
        points.append(rebuild(moved))
        shifted.append(shifted_scales)
    results = evaluate_many(points)
    _, base = log_sensitivities(results[0], chain, inputs, uncertain, scales)
    hessian = np.zeros((base.shape[0], len(uncertain), len(uncertain)))
    for j, (point, result, shifted_scales) in enumerate(zip(points[1:], results[1:], shifted)):
        _, after = log_sensitivities(result, chain, point, uncertain, shifted_scales)
        hessian[:, :, j] = (after - base) / step
    return 0.5 * (hessian + np.swapaxes(hessian, 1, 2))


def interpolate(coarse_x: np.ndarray, coarse_y: np.ndarray, values: np.ndarray, xs: np.ndarray, ys: np.ndarray
                ) -> np.ndarray:
    """Bilinear interpolation of `values` (cx, cy, ...) from the coarse grid onto xs x ys."""
    from scipy.interpolate import RegularGridInterpolator

    interpolator = RegularGridInterpolator((coarse_x, coarse_y), values, method="linear")
    grid = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1)
    return interpolator(grid)


def surrogate_cqas(values: np.ndarray, sensitivities: np.ndarray, hessian: np.ndarray, draws: np.ndarray
                   ) -> np.ndarray:
    """The CQAs (n, n_cqas) of the surrogate at `draws` (n, m) of ln k - ln k0."""
    quadratic = 0.5 * np.einsum("nm,cmk,nk->nc", draws, hessian, draws)
    return values[None, :] * np.exp(draws @ sensitivities.T + quadratic)
