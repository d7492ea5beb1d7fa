"""The fit's calibration and cost on families of synthetic data, for both shipped processes.

    cd benchmarks && PYTHONPATH=$PWD/..:$PWD python pharma_fit_coverage.py [--datasets 100] [--repeats 5]
        [--against GIT_REVISION]

For each process (the designs of `pharma_fit_lab_data.py`: three temperatures, eight times, the
main and minor species), `--datasets` noisy datasets are drawn from the stated truth (seeds 1..N)
and each is fitted; the share of datasets whose 95% Wald interval covers the truth is printed per
parameter (a calibrated fit: 0.95, and with N = 100 the binomial standard error is 0.022). Then
the cost: the forward simulation of all experiments (one vmapped call) against the fit's
residuals with their Jacobian (forward mode, same batch, one pass), and against the same two in
two programs (the residuals, then `jax.jacfwd` of them); `--against` adds that two-program pair
with the Rosenbrock solver module of an earlier revision (the old code). The programs run in
turn, `--repeats` rounds after the compile, so that a load on a shared machine hits them alike:
the medians of each one's seconds and of its ratio to the forward simulation of the same round.
"""

import argparse
import dataclasses
import importlib.util
import json
import pathlib
import statistics
import subprocess
import tempfile
import time

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from pharma_fit_lab_data import CASES, case_data, truth_theta  # noqa: E402

from chemistry.pharma._fit import fit, residual_programs  # noqa: E402
from chemistry.pharma._fit_model import experiment_model  # noqa: E402


def _paired_medians(functions: dict, repeats: int) -> dict:
    """{name: (median seconds, median ratio to the same round's forward simulation: the one of
    its solver, `forward_against` for another name ending in `_against`, else `forward`)}."""
    for function in functions.values():
        jax.block_until_ready(function())
    seconds = {name: [] for name in functions}
    for _ in range(repeats):
        for name, function in functions.items():
            start = time.perf_counter()
            jax.block_until_ready(function())
            seconds[name].append(time.perf_counter() - start)
    def forward(name):
        own = name.endswith("_against") and name != "forward_against"
        return np.array(seconds["forward_against" if own else "forward"])

    return {name: (statistics.median(times), float(np.median(np.array(times) / forward(name))))
            for name, times in seconds.items()}


def _rosenbrock_at(revision: str):
    """The module snapo_ode/_solver/rosenbrock.py as it was at git `revision`."""
    root = pathlib.Path(__file__).resolve().parents[1]
    source = subprocess.run(["git", "show", f"{revision}:snapo_ode/_solver/rosenbrock.py"], cwd=root, check=True,
                            capture_output=True, text=True).stdout
    path = pathlib.Path(tempfile.mkdtemp()) / "rosenbrock_at_revision.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("rosenbrock_at_revision", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _two_programs(model, values, sd):
    """The residuals and, in a second program, their Jacobian (the fit's way before one pass)."""
    def residuals(theta):
        return (model.predict(theta) - values) / sd

    return jax.jit(lambda theta: (residuals(theta), jax.jacfwd(residuals)(theta)))


def run_case(process: str, case: dict, datasets: int, repeats: int, against: str | None = None) -> dict:
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
    forward, two_programs = jax.jit(model.predict), _two_programs(model, values, sd_j)
    timed = {"forward": lambda: forward(theta), "jacobian": lambda: programs[1](theta, values, sd_j),
             "two_programs": lambda: two_programs(theta)}
    if against:
        solver = model.solver.solver  # the same method and options, from the old module
        method = getattr(_rosenbrock_at(against), type(solver).__name__)(
            **{field.name: getattr(solver, field.name) for field in dataclasses.fields(solver)})
        old = model._replace(solver=model.solver.replace(solver=method))
        old_forward, old_two = jax.jit(old.predict), _two_programs(old, values, sd_j)
        timed |= {"forward_against": lambda: old_forward(theta), "two_programs_against": lambda: old_two(theta)}
    cost = _paired_medians(timed, repeats)
    return {"process": process, "datasets": datasets, "measurements": len(sd), "experiments": len(exact.experiments),
            "parameters": result.names, "coverage_95": dict(zip(result.names, (covered / datasets).round(3).tolist())),
            "mean_estimate": dict(zip(result.names, np.mean(estimates, axis=0).round(5).tolist())),
            "truth": dict(zip(result.names, np.round(reported_truth, 5).tolist())),
            "fit_seconds_median": statistics.median(seconds), "repeats": repeats, "forward_seconds": cost["forward"][0],
            "jacobian_seconds": cost["jacobian"][0], "jacobian_over_forward": cost["jacobian"][1],
            **{f"{name}_seconds": value[0] for name, value in cost.items() if name not in ("forward", "jacobian")},
            **{f"{name}_over_forward": value[1] for name, value in cost.items() if name not in ("forward", "jacobian")},
            "against": against}


def _base(chain, fitted):
    equations = chain.mechanism.reaction_equations
    return np.asarray(chain.rate_parameters.activation_temperature)[[equations.index(eq) for eq in fitted.reactions]]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--processes", default=",".join(CASES))
    parser.add_argument("--against", default=None, help="a git revision: also time its Rosenbrock solver, two programs")
    args = parser.parse_args()
    for process in args.processes.split(","):
        print(json.dumps(run_case(process, CASES[process], args.datasets, args.repeats, args.against), indent=1),
              flush=True)


if __name__ == "__main__":
    main()
