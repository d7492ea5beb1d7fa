"""The built-in pharma chain's numbers, recorded once so that a change of how the chain is
described (issue 35: the process file) can show it reproduces them: `--write` records them
(`tests/data/pharma_golden.json`), `--check` recomputes them and prints the largest relative
difference of each group. Recorded at commit 43442d2, before the process file: at 66309fd (the
process file) every group was 0.0; the two balance fixes that followed moved them (the CQAs'
changes are stated in docs/pharma.md and held by tests/test_pharma_process_file.py).

    .venv/bin/python benchmarks/pharma_golden.py --check

Groups: the CQAs and every sensitivity (by input name) at the default solver and at the
central differences' solver (the tests' chain), at nominal CPPs and at a second point, and the
tests' design-space map (probabilities by CQA, nominal CQAs, the full Monte Carlo's)."""

import argparse
import json
import pathlib
import sys

import numpy as np

GOLDEN = pathlib.Path(__file__).resolve().parents[1] / "tests" / "data" / "pharma_golden.json"
RENAMED = {  # the physical parameters before the process file (issue 35) -> their names in it
    "feed_a": "feed.A", "feed_b": "feed.B", "jacket_ua": "r1.jacket_ua", "hold_temperature": "r2.temperature",
    "hold_time": "r2.time", **{name: f"crystallizer.{name}" for name in (
        "final_temperature", "solubility_ref", "solubility_ref_temperature", "solubility_enthalpy", "growth_rate",
        "growth_order", "growth_activation", "nucleation_rate", "nucleation_order", "seed_loading", "seed_size",
        "crystal_density", "shape_factor", "partition_impurity", "partition_degradant")},
    "cake_liquor": "filter.cake_liquor", "wash_residue": "filter.wash_residue", "drying_time": "dryer.time",
    "drying_rate": "dryer.drying_rate", "dryer_ref_temperature": "dryer.reference_temperature",
    "drying_activation": "dryer.drying_activation", "solid_degradation_rate": "dryer.degradation_rate",
    "solid_degradation_activation": "dryer.degradation_activation"}
SECOND_POINT = {"r1_temperature": 320.0, "r1_residence_time": 38.0, "cooling_rate": 0.3, "dryer_temperature": 325.0}


def record() -> dict:
    import snapo_ode

    snapo_ode.configure()
    from chemistry.pharma import BUMP_SOLVER, PharmaChain, design_space, make_cpps, sensitivities

    out = {}
    for solver_name, chain in (("default", PharmaChain()), ("bump_solver", PharmaChain(solver=BUMP_SOLVER))):
        for point_name, cpps in (("nominal", make_cpps()), ("second", make_cpps(**SECOND_POINT))):
            jac, _ = sensitivities(chain, chain.inputs(cpps), repeats=1)
            out[f"{solver_name}/{point_name}"] = {
                "cqas": dict(zip(jac.output_names, np.asarray(jac.values).tolist(), strict=True)),
                "jacobian": {cqa: dict(zip(jac.input_names, row.tolist(), strict=True))
                             for cqa, row in zip(jac.output_names, np.asarray(jac.matrix), strict=True)}}
    space = design_space(PharmaChain(solver=BUMP_SOLVER), make_cpps(), points=3, verify_points=4, samples=47,
                         surrogate_samples=512, curvature_points=2)
    out["design_space"] = {"probability": space.probability, "probability_by_cqa": space.probability_by_cqa,
                           "nominal_cqas": space.nominal_cqas,
                           "verification": [[p["probability_mc"], p["probability_surrogate"]]
                                            for p in space.verification["points"]]}
    return out


def differences(golden: dict, now: dict, renamed=lambda name: name) -> dict:
    """group -> the largest relative difference (absolute where the golden value is 0)."""
    worst = {}

    def walk(key, a, b):
        if isinstance(a, dict):
            for name, value in a.items():
                walk(key, value, b[renamed(name)])
        elif isinstance(a, list):
            for x, y in zip(a, b, strict=True):
                walk(key, x, y)
        else:
            difference = abs(a - b) / abs(a) if a else abs(b)
            worst[key] = max(worst.get(key, 0.0), difference)

    for key, value in golden.items():
        walk(key, value, now[key])
    return worst


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true")
    parser.add_argument("--check", action="store_true")
    args = parser.parse_args()
    now = record()
    if args.write:
        GOLDEN.parent.mkdir(exist_ok=True)
        GOLDEN.write_text(json.dumps(now, indent=1) + "\n")
        print(f"written: {GOLDEN}")
    if args.check:
        worst = differences(json.loads(GOLDEN.read_text()), now, lambda name: RENAMED.get(name, name))
        for key, value in worst.items():
            print(f"{key:<24} largest relative difference {value:.2e}")
        return 0 if max(worst.values()) <= 1e-10 else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
