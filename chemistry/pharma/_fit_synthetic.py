"""Synthetic lab data from a stated truth, for the shipped examples, the tests and the coverage
bench: the experiments simulated at the true rate parameters (`ExperimentModel`), with Gaussian
noise of the error model added, written as an experiments file and a data file a fit reads."""

import numpy as np

from ._chain import PharmaChain
from ._experiments import ErrorModel, Experiment, LabData, Measurements
from ._fit_model import FittedParameters, experiment_model


def lab_design(experiments: tuple[Experiment, ...], times: list, species: list[str],
           error_model: dict[str, ErrorModel]) -> LabData:
    """The `LabData` of `experiments` sampled at `times` [min] (the same for each) for each of
    `species`, with NaN values (to be simulated) and the error model's sds to come."""
    rows = [(e, t, s) for e in range(len(experiments)) for t in times for s in species]
    m = Measurements(np.array([r[0] for r in rows]), np.array([r[1] for r in rows], float),
                     tuple(r[2] for r in rows), np.full(len(rows), np.nan), np.full(len(rows), np.nan),
                     np.arange(2, len(rows) + 2))
    return LabData(tuple(experiments), dict(error_model), m)


def simulate_lab_data(chain: PharmaChain, data: LabData, fitted: FittedParameters, theta, seed: int | None) -> LabData:
    """`data` with values simulated at `theta` (`fitted`'s internal coordinates) plus noise of its
    error model drawn with `seed` (None: no noise)."""
    exact = np.asarray(experiment_model(chain, data, fitted).predict(np.asarray(theta, float)))
    m = data.measurements
    sd = np.zeros_like(exact)
    for species, model in data.error_model.items():
        rows = np.asarray(m.species) == species
        sd[rows] = model.sd(np.abs(exact[rows]))
    noise = 0.0 if seed is None else np.random.default_rng(seed).standard_normal(len(exact)) * sd
    return data._replace(measurements=m._replace(value=exact + noise))


def experiments_yaml(data: LabData, header: str) -> str:
    """The experiments file of `data` (its error model included), `header` as comment lines."""
    lines = [f"# {line}" for line in header.splitlines()] + ["experiments:"]
    for e in data.experiments:
        charges = ", ".join(f"{name}: {value:.6g} mol/L" for name, value in e.charges.items())
        lines += [f"  - name: {e.name}", f"    unit: {e.unit}", f"    temperature: {e.temperature:.6g} K",
                  f"    charges: {{{charges}}}"]
    if data.error_model:
        lines.append("error_model:")
        lines += [f"  {name}: {{constant: {model.constant:.6g} mol/L, proportional: {model.proportional:.6g}}}"
                  for name, model in data.error_model.items()]
    return "\n".join(lines) + "\n"


def data_csv(data: LabData) -> str:
    """The data file of `data`: experiment, time [min], species, value [mol/L]."""
    m = data.measurements
    lines = ["experiment,time [min],species,value [mol/L]"]
    lines += [f"{data.experiments[e].name},{t:.6g},{s},{v:.8g}"
              for e, t, s, v in zip(m.experiment, m.time, m.species, m.value, strict=True)]
    return "\n".join(lines) + "\n"
