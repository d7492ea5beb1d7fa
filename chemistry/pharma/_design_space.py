"""The design space: the probability of meeting every CQA spec over a grid of two CPPs (the others
at nominal) under uncertainty of the kinetic parameters, by Monte Carlo (all grid points and draws
in one vmapped call) next to the linearised estimate (the same draws pushed through the
sensitivities), and the proven acceptable ranges that follow."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import Result, check_choice, check_count, check_range

from ._chain import PharmaChain
from ._cqa import meets_specs
from ._parameters import CPPs
from ._ranges import CPP_NAMES, CPP_RANGES
from ._sensitivities import input_names, jacobian_function, named_jacobian, rate_names, shifted_cqas


@dataclasses.dataclass(frozen=True, kw_only=True)
class DesignSpace(Result):
    """P(all CQAs within spec) over a grid of CPPs `x` and `y` (values `x_values`, `y_values`),
    by Monte Carlo (`probability_mc`) and linearised (`probability_linear`), shape
    (points, points), index [i_x, i_y]; their `max_abs_difference`; the `nominal_cqas` at each
    point; and `acceptable_ranges`: for each of x and y (the other at nominal), [low, high] of
    the grid values where the Monte Carlo probability is >= `confidence` (None when none is)."""

    x: str
    y: str
    x_values: list
    y_values: list
    samples: int
    sigma_log_rate: float
    seed: int
    confidence: float
    probability_mc: list
    probability_linear: list
    max_abs_difference: float
    nominal_cqas: list
    acceptable_ranges: dict

    def summary(self) -> str:
        lines = [f"P(all specs) over {self.x} x {self.y}, {self.samples} draws of the rate constants (sigma ln k = "
                 f"{self.sigma_log_rate:g}); largest |MC - linearised| = {self.max_abs_difference:.3f}"]
        lines += [f"  {name}: P >= {self.confidence:g} on {interval}" for name, interval in
                  self.acceptable_ranges.items()]
        return "\n".join(lines)


def design_space(chain: PharmaChain, cpps: CPPs, *, x: str = "r1_temperature", y: str = "dryer_temperature",
                 points: int = 7, samples: int = 64, sigma: float = 0.1, seed: int = 0,
                 confidence: float = 0.95) -> DesignSpace:
    """P(all CQAs within spec) on a `points` x `points` grid spanning the proven acceptable ranges
    of CPPs `x` and `y`, with each reaction's rate constant uncertain: ln k_j ~ N(ln k_j, `sigma`^2),
    independent (`samples` draws, the same at every grid point).

    **Returns:** a `DesignSpace`.

    **Raises:** `InputError` for an unknown CPP, equal x and y, or a bad size.
    """
    check_choice("x", x, CPP_NAMES)
    check_choice("y", y, tuple(n for n in CPP_NAMES if n != x))
    check_count("points", points, 2, 101)
    check_count("samples", samples, 2, 100_000)
    check_range("sigma", sigma, 0.0, 2.0, low_open=True)
    check_range("confidence", confidence, 0.0, 1.0, low_open=True, high_open=True)
    ranges = {r.name: r for r in CPP_RANGES}
    xs = np.linspace(*ranges[x].par, points)
    ys = np.linspace(*ranges[y].par, points)
    inputs = chain.inputs(cpps)
    column = {name: i for i, name in enumerate(input_names(chain))}
    rates = rate_names(chain)
    draws = sigma * np.asarray(jax.random.normal(jax.random.key(seed), (samples, len(rates))))
    shifts = []
    for vx in xs:
        for vy in ys:
            base = np.zeros(len(column))
            base[column[x]], base[column[y]] = vx - float(getattr(cpps, x)), vy - float(getattr(cpps, y))
            block = np.tile(base, (samples, 1))
            block[:, [column[name] for name in rates]] += draws
            shifts.append(block)
    cqas = shifted_cqas(chain, inputs, np.concatenate(shifts))
    cqas = cqas.reshape(points, points, samples, -1)
    probability_mc = np.asarray(meets_specs(cqas)).mean(axis=-1)

    evaluate = jacobian_function(chain, True, "reverse")
    probability_linear = np.zeros((points, points))
    nominal_cqas = np.zeros((points, points, cqas.shape[-1]))
    for i, vx in enumerate(xs):
        for j, vy in enumerate(ys):
            point = chain.inputs(CPPs(**{**{n: getattr(cpps, n) for n in CPP_NAMES}, x: jnp.asarray(vx),
                                         y: jnp.asarray(vy)}))
            values, matrix = evaluate(point)
            sensitivity = np.asarray(named_jacobian(chain, point, values, matrix, "reverse").columns(rates))
            linear = np.asarray(values)[None, :] + draws @ sensitivity.T
            probability_linear[i, j] = float(np.mean(np.asarray(meets_specs(linear))))
            nominal_cqas[i, j] = np.asarray(values)
    nominal_x = int(np.argmin(np.abs(xs - float(getattr(cpps, x)))))
    nominal_y = int(np.argmin(np.abs(ys - float(getattr(cpps, y)))))
    return DesignSpace(
        x=x, y=y, x_values=xs.tolist(), y_values=ys.tolist(), samples=samples, sigma_log_rate=sigma, seed=seed,
        confidence=confidence, probability_mc=probability_mc.tolist(), probability_linear=probability_linear.tolist(),
        max_abs_difference=float(np.max(np.abs(probability_mc - probability_linear))),
        nominal_cqas=nominal_cqas.tolist(),
        acceptable_ranges={x: _acceptable(xs, probability_mc[:, nominal_y] >= confidence),
                           y: _acceptable(ys, probability_mc[nominal_x, :] >= confidence)})


def _acceptable(values, ok) -> list[float] | None:
    """[low, high] of the grid values that pass (None when none does)."""
    passing = values[np.asarray(ok)]
    return [float(passing.min()), float(passing.max())] if passing.size else None
