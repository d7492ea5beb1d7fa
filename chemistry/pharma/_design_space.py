"""The design space (ICH Q8; Peterson's Bayesian design space): the region of two CPPs where the
probability that every CQA meets its specification, under uncertainty of the kinetic parameters,
is at least a stated level.

The uncertain parameters are rate constants, each log-normal around its value, ln k_j - ln k0_j
~ N(0, sigma^2), independent: by default the five reactions' rate constants (their
log-multipliers) and the four rate constants of the other units (crystal growth, nucleation,
drying and degradation in the dryer), so that every CQA's spread is represented.

The probability is mapped on a fine grid over the proven acceptable ranges (the other CPPs at
their values) by a surrogate built from the sensitivities (`_surrogate`): ln CQA to second order
in ln k, the slopes from one reverse-mode Jacobian per grid point (the program the report
already compiles), the curvature from differences of Jacobians on a coarse grid. In logs because
every CQA is positive and the kinetics act multiplicatively: with the five reaction rates
uncertain, at the hot corner of R1's range the log-linear form classified 2,000 of 2,000 draws as
the full model did, the linear form 17 wrongly. The draws are the same at every grid point, so
the map is smooth. The full model is then run by Monte Carlo at a stated subset of points (the
operating point and points spread over the band where the probability changes) on the first
`samples` of those same draws: the surrogate's error is what separates the two estimates there.
"""

import dataclasses
import time

import equinox as eqx
import jax
import numpy as np

from snapo_ode import InputError, Result, Settings, check_choice, check_count, check_range

from ._chain import PharmaChain
from ._cqa import meets_specs, spec_margins
from ._design_edges import acceptable_range, choose_verification_points, probability_se
from ._parameters import ChainInputs, CPPs
from ._process_file import CPP_NAMES
from ._posterior import posterior_draws, posterior_summary
from ._sensitivities import input_names, jacobians_function, rate_names, shifted_cqas
from ._surrogate import (
    curvature, grid_inputs, input_offsets, interpolate, log_scales, log_sensitivities, surrogate_cqas)

FIRST_ORDER = ("first order in the log rate constants: ln CQA = ln CQA0 + S d with d = ln k - ln k0; S = d ln CQA / "
               "d ln k from one reverse-mode Jacobian per grid point")
SURROGATE = ("second order in the log rate constants: ln CQA = ln CQA0 + S d + d' H d / 2 with d = ln k - ln k0; "
             "S = d ln CQA / d ln k from one reverse-mode Jacobian per grid point, H from one-sided differences of S "
             "(step sigma) on a coarse grid, interpolated bilinearly")


@dataclasses.dataclass(frozen=True, kw_only=True)
class DesignSpace(Result):
    """P(all CQAs within spec) over a grid of CPPs `x` and `y` (`x_values`, `y_values`, spanning
    their PARs; arrays indexed `[i_x][i_y]`).

    **Fields:** `probability` (the surrogate map, `surrogate_samples` draws), `probability_by_cqa`
    (cqa -> map), `nominal_cqas` (cqa -> map of the CQA at the nominal kinetics), `limiting_cqa`
    (the CQA least likely to be in spec at each point); at the `operating_point` (x and y values):
    `operating_probability`; `nor_min_probability` and `par_min_probability` (the least over the
    grid points in the NOR box and over the whole grid), `fraction_meeting_level` (of the PAR box);
    `acceptable_ranges` and `edges` (along the grid lines through the operating point, see
    `acceptable_range`); `verification` (the full-model Monte Carlo at `points`, with the
    agreement); `seconds` (surrogate, Monte Carlo)."""

    x: str
    y: str
    x_values: list
    y_values: list
    level: float
    sigma_log_rate: float
    uncertain: list
    surrogate: str
    curvature_points: int
    surrogate_samples: int
    seed: int
    operating_point: dict
    probability: list
    probability_by_cqa: dict
    nominal_cqas: dict
    limiting_cqa: list
    operating_probability: float
    nor_min_probability: float
    par_min_probability: float
    fraction_meeting_level: float
    acceptable_ranges: dict
    edges: dict
    verification: dict
    seconds: dict
    uncertainty: dict | None = None
    """How the uncertain inputs were drawn: None for independent normals of `sigma_log_rate` on
    each ln k; with a posterior file, {source: "posterior", file, names, mean, covariance}."""

    def summary(self) -> str:
        check = self.verification
        lines = [f"P(all specs) over {self.x} x {self.y} on {len(self.x_values)} x {len(self.y_values)} points "
                 f"(surrogate, {self.surrogate_samples} draws of ln k, sigma {self.sigma_log_rate:g}); at the operating "
                 f"point {self.operating_probability:.4f}, least over the NOR box {self.nor_min_probability:.4f}",
                 f"full Monte Carlo at {len(check['points'])} points x {check['samples']} draws: largest |surrogate - "
                 f"MC| = {check['max_abs_difference']:.4f} ({check['max_difference_over_se']:.2f} standard errors); "
                 f"within one standard error at every point: {check['all_within_se']}"]
        lines += [f"  {name}: P >= {self.level:g} on {interval}" for name, interval in self.acceptable_ranges.items()]
        return "\n".join(lines)


def default_uncertain(chain: PharmaChain) -> list[str]:
    """The process file's `uncertain` parameters (the built-in: the reactions' rate constants as
    log-multipliers and the other units' rate constants), or every reaction's log-multiplier."""
    return list(chain.process.uncertain) or rate_names(chain)


class DesignSpaceSettings(Settings):
    """What `design_space` computes (its arguments but the chain, the CPPs, `uncertain` and the
    mesh), checked when built, before anything is computed: the CLI builds one from its flags."""

    x: str | None = eqx.field(static=True, default=None)
    y: str | None = eqx.field(static=True, default=None)
    cpp_names: tuple[str, ...] | None = eqx.field(static=True, default=None)
    """The process's CPPs, which `x` and `y` must be among (default: the built-in's); `x` and `y`
    default to the first and the last."""
    points: int = eqx.field(static=True, default=21)
    level: float = eqx.field(static=True, default=0.95)
    sigma: float = eqx.field(static=True, default=0.1)
    seed: int = eqx.field(static=True, default=0)
    surrogate_samples: int = eqx.field(static=True, default=4096)
    verify_points: int = eqx.field(static=True, default=9)
    samples: int = eqx.field(static=True, default=1000)
    curvature_points: int = eqx.field(static=True, default=6)

    @property
    def axes(self) -> tuple[str, str]:
        """(x, y): as given, or the process's first and last CPP."""
        names = CPP_NAMES if self.cpp_names is None else self.cpp_names
        return names[0] if self.x is None else self.x, names[-1] if self.y is None else self.y

    def __check_init__(self):
        names, (x, y) = CPP_NAMES if self.cpp_names is None else self.cpp_names, self.axes
        check_choice("x", x, names)
        check_choice("y", y, tuple(n for n in names if n != x))
        check_count("points", self.points, 3, 201)
        check_count("samples", self.samples, 2, 100_000)
        check_count("surrogate_samples", self.surrogate_samples, 2, 1_000_000)
        check_count("verify_points", self.verify_points, 1, self.points * self.points)
        check_count("curvature_points", self.curvature_points, 0, self.points)
        if self.curvature_points == 1:
            raise InputError("curvature_points = 1; allowed: 0 (first order) or 2 and more (a grid to interpolate on).")
        check_range("sigma", self.sigma, 0.0, 2.0, low_open=True)
        check_range("level", self.level, 0.0, 1.0, low_open=True, high_open=True)
        check_count("seed", self.seed, 0)


def design_space(chain: PharmaChain, cpps: CPPs | ChainInputs, *, x: str | None = None, y: str | None = None,
                 points: int = 21, level: float = 0.95, sigma: float = 0.1, seed: int = 0,
                 surrogate_samples: int = 4096, verify_points: int = 9, samples: int = 1000,
                 uncertain=None, curvature_points: int = 6, mesh=None, posterior=None) -> DesignSpace:
    """The design space of CPPs `x` and `y` (default: the process's first and last CPP) on a
    `points` x `points` grid over their PARs, at `cpps` (`CPPs`, the other inputs the process
    file's; or the `ChainInputs` themselves, used as given).

    **Arguments:** `level`: the probability the design space guarantees; `sigma`: the standard
    deviation of each ln k_j; `uncertain`: the names of the uncertain inputs (default
    `default_uncertain`: log-multipliers or positive rate constants);
    `surrogate_samples`: draws of the surrogate map (at least `samples`); `verify_points`: where
    the full model is run by Monte Carlo (the operating point first), `samples` draws each;
    `curvature_points`: the coarse grid (per CPP) of the surrogate's second-order term (0: first
    order only); `mesh`: the devices the grid points, the curvature's Jacobians and the full
    model's Monte Carlo draws split over (`snapo_ode.sample_mesh`); `posterior`: a fit's
    `Posterior` (`_posterior`), whose correlated draws replace `sigma` and `uncertain`, the rates
    at its mean (`sigma` then only sets the curvature's step).

    **Returns:** a `DesignSpace`.

    **Raises:** `InputError` for an unknown CPP, equal x and y, a bad size or level.
    """
    settings = DesignSpaceSettings(x=x, y=y, cpp_names=chain.cpp_names, points=points, level=level, sigma=sigma,
                                   seed=seed, surrogate_samples=surrogate_samples, verify_points=verify_points,
                                   samples=samples, curvature_points=curvature_points)
    names, cqa_names, (x, y) = chain.cpp_names, chain.cqa_names, settings.axes
    inputs = cpps if isinstance(cpps, ChainInputs) else chain.inputs(cpps)
    cpps, ranges = inputs.cpps, {r.name: r for r in chain.cpp_ranges}
    xs, ys = np.linspace(*ranges[x].par, points), np.linspace(*ranges[y].par, points)
    if posterior is not None:
        inputs, uncertain, scales, draws = posterior_draws(chain, inputs, posterior, seed,
                                                           max(surrogate_samples, samples))
    else:
        uncertain = list(default_uncertain(chain) if uncertain is None else uncertain)
        for name in uncertain:
            check_choice("uncertain", name, tuple(n for n in input_names(chain)[len(names):]
                                                  if n.startswith("log_multiplier[") or not n.endswith("]")))
        scales = log_scales(chain, inputs, uncertain)
        draws = sigma * np.asarray(jax.random.normal(jax.random.key(seed), (max(surrogate_samples, samples),
                                                                              len(uncertain))))

    start = time.perf_counter()
    evaluate_many = jacobians_function(chain, True, "reverse", mesh)
    values, slopes = grid_sensitivities(evaluate_many, chain, inputs, (x, xs), (y, ys), uncertain, scales)
    hessians = np.zeros(slopes.shape + (len(uncertain),))
    if curvature_points:
        cx, cy = np.linspace(*ranges[x].par, curvature_points), np.linspace(*ranges[y].par, curvature_points)
        coarse = np.array([[curvature(evaluate_many, chain, grid_inputs(inputs, x, y, vx, vy), uncertain, scales,
                                      sigma) for vy in cy] for vx in cx])
        hessians = interpolate(cx, cy, coarse, xs, ys)
    by_cqa = np.zeros((points, points, len(cqa_names)))
    probability = np.zeros((points, points))
    for i in range(points):
        for j in range(points):
            surrogate = surrogate_cqas(values[i, j], slopes[i, j], hessians[i, j], draws)
            by_cqa[i, j] = np.mean(np.asarray(spec_margins(surrogate, chain.process)) >= 0, axis=0)
            probability[i, j] = float(np.mean(np.asarray(meets_specs(surrogate, chain.process))))
    surrogate_seconds = time.perf_counter() - start

    operating = {x: float(cpps[x]), y: float(cpps[y])}
    io, jo = int(np.argmin(np.abs(xs - operating[x]))), int(np.argmin(np.abs(ys - operating[y])))
    chosen = choose_verification_points(probability, (io, jo), verify_points, level)
    start = time.perf_counter()
    verification = _verify(chain, inputs, x, y, xs, ys, chosen, draws[:samples], (values, slopes, hessians),
                           probability, uncertain, scales, mesh)
    nor = (ranges[x].nor, ranges[y].nor)
    inside = np.outer((xs >= nor[0][0] - 1e-9) & (xs <= nor[0][1] + 1e-9), (ys >= nor[1][0] - 1e-9) & (ys <= nor[1][1] + 1e-9))
    range_x = acceptable_range(xs, probability[:, jo], io, level, ranges[x])
    range_y = acceptable_range(ys, probability[io, :], jo, level, ranges[y])
    return DesignSpace(
        x=x, y=y, x_values=xs.tolist(), y_values=ys.tolist(), level=level, sigma_log_rate=sigma, uncertain=uncertain,
        surrogate=SURROGATE if curvature_points else FIRST_ORDER,
        curvature_points=curvature_points, surrogate_samples=len(draws), seed=seed, operating_point=operating,
        probability=probability.tolist(),
        probability_by_cqa={cqa: by_cqa[:, :, k].tolist() for k, cqa in enumerate(cqa_names)},
        nominal_cqas={cqa: values[:, :, k].tolist() for k, cqa in enumerate(cqa_names)},
        limiting_cqa=[[cqa_names[int(k)] for k in row] for row in np.argmin(by_cqa, axis=-1)],
        operating_probability=float(probability[io, jo]),
        nor_min_probability=float(probability[inside].min()) if inside.any() else None,
        par_min_probability=float(probability.min()),
        fraction_meeting_level=float(np.mean(probability >= level)),
        acceptable_ranges={x: range_x.interval, y: range_y.interval},
        edges={x: range_x.as_dict(), y: range_y.as_dict()},
        verification=verification,
        seconds={"surrogate": surrogate_seconds, "monte_carlo": time.perf_counter() - start},
        uncertainty=None if posterior is None else posterior_summary(posterior))


def grid_sensitivities(evaluate_many, chain: PharmaChain, inputs: ChainInputs, x: tuple[str, np.ndarray],
                       y: tuple[str, np.ndarray], uncertain, scales) -> tuple[np.ndarray, np.ndarray]:
    """The CQAs (n_x, n_y, n_cqas) and their log sensitivities S = d ln CQA / d coordinate
    (n_x, n_y, n_cqas, m) of the `uncertain` inputs (`log_sensitivities`) at every point of the
    grid `x` = (CPP name, values) by `y`, one reverse-mode Jacobian per point through
    `evaluate_many` (`jacobians_function`)."""
    (x, xs), (y, ys) = x, y
    grid = [grid_inputs(inputs, x, y, vx, vy) for vx in xs for vy in ys]
    pairs = [log_sensitivities(result, chain, point, uncertain, scales)
             for point, result in zip(grid, evaluate_many(grid))]
    shape = (len(xs), len(ys), len(chain.cqa_names))
    return (np.array([value for value, _ in pairs]).reshape(shape),
            np.array([slope for _, slope in pairs]).reshape(*shape, len(uncertain)))


def _verify(chain, inputs, x, y, xs, ys, chosen, draws, surrogate, probability, uncertain, scales, mesh) -> dict:
    """The full model at the `chosen` grid points on `draws` (one vmapped call), against the
    surrogate on the same draws and against the map."""
    cpps = inputs.cpps
    column = {name: k for k, name in enumerate(input_names(chain))}
    columns = [column[name] for name in uncertain]
    offsets = input_offsets(uncertain, scales, draws)
    values, slopes, hessians = surrogate
    n = len(draws)
    shifts = np.zeros((len(chosen), n, len(column)))
    for p, (i, j) in enumerate(chosen):
        shifts[p, :, column[x]] = xs[i] - float(cpps[x])
        shifts[p, :, column[y]] = ys[j] - float(cpps[y])
        shifts[p][:, columns] += offsets
    full = shifted_cqas(chain, inputs, shifts.reshape(len(chosen) * n, -1), mesh).reshape(len(chosen), n, -1)
    rows = []
    for p, (i, j) in enumerate(chosen):
        passes = np.asarray(meets_specs(full[p], chain.process)).astype(bool)
        same = surrogate_cqas(values[i, j], slopes[i, j], hessians[i, j], draws)
        surrogate = np.asarray(meets_specs(same, chain.process)).astype(bool)
        p_mc, p_same = float(passes.mean()), float(surrogate.mean())
        se = probability_se(int(passes.sum()), n)
        rows.append({"x": float(xs[i]), "y": float(ys[j]), "i": int(i), "j": int(j), "probability_mc": p_mc,
                     "se_mc": se, "probability_surrogate": p_same, "difference": p_same - p_mc,
                     "disagreeing_draws": int(np.sum(passes != surrogate)),
                     "within_se": bool(abs(p_same - p_mc) <= se),
                     "probability_map": float(probability[i, j]),
                     "map_minus_mc_over_se": float((probability[i, j] - p_mc) / se)})
    ratios = [abs(r["difference"]) / r["se_mc"] for r in rows]
    return {"points": rows, "samples": n, "all_within_se": all(r["within_se"] for r in rows),
            "max_abs_difference": max(abs(r["difference"]) for r in rows), "max_difference_over_se": max(ratios),
            "max_abs_map_minus_mc_over_se": max(abs(r["map_minus_mc_over_se"]) for r in rows),
            "se_convention": "binomial, sqrt(q (1 - q) / n) with q = (passes + 1) / (n + 2), so that it is not "
                             "zero when every draw passes or every draw fails"}
