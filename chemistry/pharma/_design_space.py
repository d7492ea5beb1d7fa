"""The design space: the probability of meeting every CQA spec over a grid of two CPPs (the others
at nominal) under uncertainty of the kinetic parameters, by Monte Carlo (all grid points and draws
in one vmapped call) next to the linearised estimate (the same draws pushed through the
sensitivities), and the proven acceptable ranges that follow."""

import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import check_choice, check_range, flatten_inputs

from ._chain import PharmaChain
from ._cqa import meets_specs
from ._parameters import CPP_NAMES, CPP_RANGES, CPPs
from ._sensitivities import bumped_cqas, chain_inputs, jacobian_function


def design_space(chain: PharmaChain, cpps: CPPs, *, x: str = "r1_temperature", y: str = "dryer_temperature",
                 points: int = 7, samples: int = 64, sigma: float = 0.1, seed: int = 0,
                 confidence: float = 0.95) -> dict:
    """P(all CQAs within spec) on a `points` x `points` grid spanning the proven acceptable ranges
    of CPPs `x` and `y`, with each reaction's rate constant uncertain: ln k_j ~ N(ln k_j, `sigma`^2),
    independent (`samples` draws, the same at every grid point).

    **Returns:** a dict with the grid values, `probability_mc` and `probability_linear` (shape
    (points, points), index [i_x, i_y]), their largest difference, and `acceptable_ranges`: for
    each of x and y (the other at nominal), the grid values where the Monte Carlo probability is
    >= `confidence`.

    **Raises:** `InputError` for an unknown CPP, equal x and y, or a bad size.
    """
    check_choice("x", x, CPP_NAMES)
    check_choice("y", y, tuple(n for n in CPP_NAMES if n != x))
    check_range("points", points, 2, 101)
    check_range("samples", samples, 2, 100_000)
    check_range("sigma", sigma, 0.0, 2.0, low_open=True)
    check_range("confidence", confidence, 0.0, 1.0, low_open=True, high_open=True)
    ranges = {r.name: r for r in CPP_RANGES}
    xs = np.linspace(*ranges[x].par, points)
    ys = np.linspace(*ranges[y].par, points)
    inputs = chain_inputs(chain, cpps)
    flat, _ = flatten_inputs(inputs)
    n_reactions = chain.mechanism.n_reactions
    ix, iy = CPP_NAMES.index(x), CPP_NAMES.index(y)
    first_rate = len(CPP_NAMES)  # log-multipliers follow the CPPs in the flattened inputs
    draws = sigma * np.asarray(jax.random.normal(jax.random.key(seed), (samples, n_reactions)))
    shifts = []
    for vx in xs:
        for vy in ys:
            base = np.zeros(flat.shape[0])
            base[ix], base[iy] = vx - float(flat[ix]), vy - float(flat[iy])
            block = np.tile(base, (samples, 1))
            block[:, first_rate:first_rate + n_reactions] += draws
            shifts.append(block)
    cqas = bumped_cqas(chain, inputs, np.concatenate(shifts))
    cqas = cqas.reshape(points, points, samples, -1)
    probability_mc = np.asarray(meets_specs(cqas)).mean(axis=-1)

    evaluate = jacobian_function(chain, True, "reverse")
    probability_linear = np.zeros((points, points))
    nominal_cqas = np.zeros((points, points, cqas.shape[-1]))
    for i, vx in enumerate(xs):
        for j, vy in enumerate(ys):
            point = chain_inputs(chain, CPPs(**{**{n: getattr(cpps, n) for n in CPP_NAMES},
                                                x: jnp.asarray(vx), y: jnp.asarray(vy)}))
            values, matrix = evaluate(point)
            sensitivity = np.asarray(matrix)[:, first_rate:first_rate + n_reactions]
            linear = np.asarray(values)[None, :] + draws @ sensitivity.T
            probability_linear[i, j] = float(np.mean(np.asarray(meets_specs(linear))))
            nominal_cqas[i, j] = np.asarray(values)
    nominal_x = int(np.argmin(np.abs(xs - float(getattr(cpps, x)))))
    nominal_y = int(np.argmin(np.abs(ys - float(getattr(cpps, y)))))
    return {
        "x": x, "y": y, "x_values": xs.tolist(), "y_values": ys.tolist(),
        "samples": samples, "sigma_log_rate": sigma, "seed": seed, "confidence": confidence,
        "probability_mc": probability_mc.tolist(), "probability_linear": probability_linear.tolist(),
        "max_abs_difference": float(np.max(np.abs(probability_mc - probability_linear))),
        "nominal_cqas": nominal_cqas.tolist(),
        "acceptable_ranges": {
            x: _acceptable(xs, probability_mc[:, nominal_y] >= confidence),
            y: _acceptable(ys, probability_mc[nominal_x, :] >= confidence),
        },
    }


def _acceptable(values, ok) -> list[float] | None:
    """[low, high] of the grid values that pass (None when none does)."""
    passing = values[np.asarray(ok)]
    return [float(passing.min()), float(passing.max())] if passing.size else None
