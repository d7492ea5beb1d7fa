"""The fit's calibration and cost on families of synthetic data, for both shipped processes.

    PYTHONPATH=$PWD python benchmarks/pharma_fit_coverage.py [--datasets 100] [--repeats 5]

For each process (the designs of `pharma_fit_lab_data.py`: three temperatures, eight times, the
main and minor species), `--datasets` noisy datasets are drawn from the stated truth (seeds 1..N)
and each is fitted; the share of datasets whose 95% Wald interval covers the truth is printed per
parameter (a calibrated fit: 0.95, and with N = 100 the binomial standard error is 0.022). Then
the cost: the forward simulation of all experiments (one vmapped call) against the residuals
with their Jacobian (forward mode, same batch), medians of `--repeats` runs after the compile.
"""

import argparse
import json
import statistics
import time

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from pharma_fit_lab_data import CASES, case_data, truth_theta  # noqa: E402

from chemistry.pharma._fit import fit, residual_programs  # noqa: E402
from chemistry.pharma._fit_model import experiment_model  # noqa: E402


def _median_seconds(function, repeats: int) -> float:
    jax.block_until_ready(function())
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        jax.block_until_ready(function())
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def run_case(process: str, case: dict, datasets: int, repeats: int) -> dict:
    chain, exact, names, fitted = case_data(process, case, seed=None)
    truth = truth_theta(fitted, case["truth"])
    model = experiment_model(chain, exact, fitted)
    programs = residual_programs(model)
    sd = exact.sd()
    covered, estimates, seconds = np.zeros(len(truth)), [], []
    for seed in range(1, datasets + 1):
        noise = np.random.default_rng(seed).standard_normal(len(sd)) * sd
        noisy = exact._replace(measurements=exact.measurements._replace(value=exact.measurements.value + noise))
        start = time.perf_counter()
        result = fit(chain, noisy, names, profile=False, programs=programs)
        seconds.append(time.perf_counter() - start)
        reported_truth = fitted.physical(truth, result.theta_covariance, _base(chain, fitted))[1]
        wald = result.wald()
        covered += (wald[:, 0] <= reported_truth) & (reported_truth <= wald[:, 1])
        estimates.append(result.estimates)
    values, sd_j = jax.numpy.asarray(exact.measurements.value), jax.numpy.asarray(sd)
    theta = jax.numpy.asarray(truth)
    forward = jax.jit(model.predict)
    t_forward = _median_seconds(lambda: forward(theta), repeats)
    t_jacobian = _median_seconds(lambda: programs[1](theta, values, sd_j), repeats)
    return {"process": process, "datasets": datasets, "measurements": len(sd), "experiments": len(exact.experiments),
            "parameters": result.names, "coverage_95": dict(zip(result.names, (covered / datasets).round(3).tolist())),
            "mean_estimate": dict(zip(result.names, np.mean(estimates, axis=0).round(5).tolist())),
            "truth": dict(zip(result.names, np.round(reported_truth, 5).tolist())),
            "fit_seconds_median": statistics.median(seconds), "forward_seconds": t_forward,
            "jacobian_seconds": t_jacobian, "jacobian_over_forward": t_jacobian / t_forward}


def _base(chain, fitted):
    equations = chain.mechanism.reaction_equations
    return np.asarray(chain.rate_parameters.activation_temperature)[[equations.index(eq) for eq in fitted.reactions]]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--processes", default=",".join(CASES))
    args = parser.parse_args()
    for process in args.processes.split(","):
        print(json.dumps(run_case(process, CASES[process], args.datasets, args.repeats), indent=1), flush=True)


if __name__ == "__main__":
    main()
