"""Writes the shipped example lab data of `snapo pharma fit` (synthetic, from a stated truth):
chemistry/pharma/processes/lab/<process>/experiments.yaml and data.csv.

    PYTHONPATH=$PWD python benchmarks/pharma_fit_lab_data.py

The truth: each fitted reaction's rate constant at the reference temperature shifted by TRUTH's
ln k shift from the mechanism's, its activation energy by TRUTH's shift [kJ/mol]; noise from the
error model (constant 2 mmol/L and 1% of the value for the main species, 0.1 mmol/L and 2% for the
minor ones), seed 0. These are not measurements of any real process.
"""

import pathlib

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from chemistry import GAS_CONSTANT  # noqa: E402
from chemistry.pharma._chain import PharmaChain  # noqa: E402
from chemistry.pharma._experiments import ErrorModel, Experiment  # noqa: E402
from chemistry.pharma._fit_model import fitted_parameters  # noqa: E402
from chemistry.pharma._fit_synthetic import data_csv, experiments_yaml, lab_design, simulate_lab_data  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1] / "chemistry" / "pharma" / "processes"
CASES = {
    "api_chain": {"unit": "r1", "charges": {"A": 0.33, "B": 0.363}, "temperatures": (303.15, 313.15, 323.15),
                  "times": (5, 10, 20, 30, 45, 60, 90, 120), "main": ("A", "P"), "minor": ("I",),
                  "truth": {"A + B => P": (0.15, 2.0), "P => I": (-0.2, -3.0)}},
    "antisolvent_route": {"unit": "ageing", "charges": {"SM": 0.5, "AM": 0.55},
                          "temperatures": (298.15, 313.15, 328.15), "times": (10, 20, 40, 60, 90, 120, 180, 240),
                          "main": ("SM", "INT", "API"), "minor": ("DIMER",),
                          "truth": {"SM + AM => INT": (0.1, 1.5), "INT + SM => DIMER": (-0.15, -2.0),
                                    "INT => API": (0.2, 3.0)}},
}


def truth_theta(fitted, truth: dict) -> np.ndarray:
    """The internal coordinates of `truth` (equation -> (ln k shift, E_a shift [kJ/mol]))."""
    scale = GAS_CONSTANT * fitted.reference_temperature * 1e-6  # kJ/mol per unit of the activation shift
    return np.array([truth[eq][0] for eq in fitted.reactions] + [truth[eq][1] / scale for eq in fitted.reactions])


def case_data(process: str, case: dict, seed: int | None = 0):
    chain = PharmaChain(process=str(ROOT / f"{process}.yaml"))
    experiments = tuple(Experiment(f"run_{T - 273.15:.0f}C", case["unit"], T, dict(case["charges"]))
                        for T in case["temperatures"])
    errors = {**{s: ErrorModel(0.002, 0.01) for s in case["main"]}, **{s: ErrorModel(1e-4, 0.02) for s in case["minor"]}}
    data = lab_design(experiments, list(case["times"]), [*case["main"], *case["minor"]], errors)
    names = [f"{field}[{eq}]" for eq in case["truth"] for field in ("log_multiplier", "E_a")]
    fitted = fitted_parameters(chain, data, names)
    return chain, simulate_lab_data(chain, data, fitted, truth_theta(fitted, case["truth"]), seed), names, fitted


def main() -> None:
    for process, case in CASES.items():
        _, data, names, _ = case_data(process, case)
        folder = ROOT / "lab" / process
        folder.mkdir(parents=True, exist_ok=True)
        truth = "; ".join(f"{eq}: ln k(T_ref) {s:+g}, E_a {e:+g} kJ/mol" for eq, (s, e) in case["truth"].items())
        header = (f"Synthetic lab data for {process} (not measurements): written by benchmarks/pharma_fit_lab_data.py\n"
                  f"from the mechanism's kinetics shifted by the truth {truth},\nwith the error model's noise (seed 0). "
                  f"Fit: snapo pharma fit --process {process} --experiments THIS --data data.csv\n"
                  + "".join(f"  --fit '{n}'" for n in names))
        (folder / "experiments.yaml").write_text(experiments_yaml(data, header))
        (folder / "data.csv").write_text(data_csv(data))
        print(f"written: {folder}")


if __name__ == "__main__":
    main()
