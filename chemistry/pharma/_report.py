"""`snapo report pharma --out DIR`: the ICH Q8 sensitivity report. This module computes every
number (`build_report` -> the JSON document's data); `_report_content` says what the report
shows; the core (`snapo_ode.write_report`) writes report.html, report.pdf (printed from the HTML),
the CSV files and report.json as one set."""

import pathlib
import time

import numpy as np

import snapo_ode
from snapo_ode import Report

from ._balances import balance_table
from ._chain import PharmaChain
from ._design_space import design_space
from ._parameters import ChainInputs, CPPs
from ._report_fit import fit_data
from ._study import MAX_SOLVER_ERROR, REFERENCE, sensitivity_study
from ._verification import cantera_check, stiffness_ratio

PACKAGES = ("optimistix", "lineax", "cantera")
# Impact of a CPP on a CQA: the largest linearised change of the CQA over the CPP's PAR, as a
# fraction of the CQA's margin to its nearest specification limit at the operating point.
IMPACT_THRESHOLDS = {"high": 1.0, "medium": 0.25}


def _margin(value: float, low: float, high: float) -> tuple[float, float]:
    """(distance to the nearest limit, positive inside the spec; that limit)."""
    distances = [(value - low, low), (high - value, high)]
    return min((d, limit) for d, limit in distances if np.isfinite(limit))


def _grade(fraction: float | None) -> str:
    return ("high" if fraction is None or fraction >= IMPACT_THRESHOLDS["high"] else
            "medium" if fraction >= IMPACT_THRESHOLDS["medium"] else "low")


def range_ends(chain: PharmaChain, inputs: ChainInputs) -> dict:
    """The CQAs by the full model with one CPP at an end of its PAR, the others at `inputs`:
    cpp -> {"low": {cqa: value}, "high": {cqa: value}} (one compile, two solves per CPP)."""
    import equinox as eqx

    from ._sensitivities import cpp_only

    evaluate = eqx.filter_jit(cpp_only(chain, inputs))
    out = {}
    for r in chain.cpp_ranges:
        out[r.name] = {}
        for side, end in zip(("low", "high"), r.par, strict=True):
            at = inputs.cpps[r.name]  # shifted, not rebuilt: the same dtype and weak type, no recompile
            cqas = np.asarray(evaluate(inputs.cpps.replace(**{r.name: at + (end - float(at))})))
            out[r.name][side] = {name: float(v) for name, v in zip(chain.cqa_names, cqas, strict=True)}
    return out


def summary(study: dict, cpps: dict, chain: PharmaChain, ends: dict | None = None) -> dict:
    """What a reader needs first: each CQA's margin to its specification, and how far each CPP
    can move each CQA over its PAR relative to that margin (`impact`, classed by
    IMPACT_THRESHOLDS): linearised (`grade`, from the sensitivity) and, with `ends`
    (`range_ends`), by the full model at the PAR's ends (`grade_full_model`, the one the report
    leads with: a CQA that is curved over the PAR is graded by what it does)."""
    cqas, impact, counts = {}, {}, {"high": 0, "medium": 0, "low": 0}
    counts_full = dict(counts)
    for spec in chain.cqa_specs:
        value = study["cqas"][spec.name]
        margin, limit = _margin(value, spec.low, spec.high)
        cqas[spec.name] = {"value": value, "margin": margin, "limit": limit, "relative_margin": margin / abs(limit),
                           "meets": bool(margin >= 0)}
        impact[spec.name] = {}
        for r in chain.cpp_ranges:
            slope = study["matrix"][spec.name][r.name]
            change = max(abs(slope * (end - cpps[r.name])) for end in r.par)
            fraction = change / margin if margin > 0 else None
            grade = _grade(fraction)
            counts[grade] += 1
            impact[spec.name][r.name] = {"change_over_par": change, "fraction_of_margin": fraction, "grade": grade}
            if ends is not None:
                at_ends = [ends[r.name][side][spec.name] for side in ("low", "high")]
                full = max(abs(v - value) for v in at_ends)  # as the linearised change, by the full model
                full_fraction = full / margin if margin > 0 else None
                counts_full[_grade(full_fraction)] += 1
                impact[spec.name][r.name].update(
                    at_par_low=at_ends[0], at_par_high=at_ends[1], change_over_par_full_model=full,
                    fraction_of_margin_full_model=full_fraction, grade_full_model=_grade(full_fraction))
    closest = min(cqas, key=lambda name: cqas[name]["relative_margin"])
    return {"all_specs_met": all(c["meets"] for c in cqas.values()), "cqas": cqas, "closest_cqa": closest,
            "impact": impact, "impact_counts": counts, "impact_thresholds": IMPACT_THRESHOLDS,
            "impact_counts_full_model": counts_full if ends is not None else None}


def build_report(chain: PharmaChain, cpps: CPPs | ChainInputs, *, points: int = 21, verify_points: int = 9,
                 samples: int = 1000, surrogate_samples: int = 4096, curvature_points: int = 6, level: float = 0.95,
                 sigma: float = 0.1, x: str | None = None, y: str | None = None, seed: int = 0, repeats: int = 5,
                 mechanism_path=None, max_solver_error: float = MAX_SOLVER_ERROR, check_warnings=None,
                 mesh=None, posterior=None) -> dict:
    """Every number of the report, as the JSON document's data (see docs/pharma.md), at `cpps`
    (`CPPs`, the other inputs the process file's; or the `ChainInputs` themselves); solver
    errors against the tight reference above `max_solver_error` are warnings in it, handed to
    `check_warnings(warnings)` (which may raise) before the design space is computed. R1 is
    checked against Cantera on `mechanism_path` (default: the process's mechanism), and so is every
    reactor against Cantera's own; every unit's mass balance is stated. With a fit's `posterior`
    the design space draws from it, and the data gain the fit's section (`_report_fit`)."""
    start = time.perf_counter()
    inputs = cpps if isinstance(cpps, ChainInputs) else chain.inputs(cpps)
    cpps = inputs.cpps
    mechanism_path = chain.process.mechanism if mechanism_path is None else mechanism_path
    study = sensitivity_study(chain, inputs, repeats=repeats, max_solver_error=max_solver_error).to_json()
    if check_warnings is not None:
        check_warnings(study["warnings"])
    study_seconds = time.perf_counter() - start
    cantera = cantera_check(chain.with_solver(REFERENCE), cpps, inputs.physical, mechanism_path)
    space = design_space(chain, inputs, x=x, y=y, points=points, level=level, sigma=sigma, seed=seed,
                         surrogate_samples=surrogate_samples, verify_points=verify_points, samples=samples,
                         curvature_points=curvature_points, mesh=mesh, posterior=posterior).to_json()
    fitted = None if posterior is None else fit_data(posterior, fitted_space=space, independent=design_space(
        chain, inputs, x=x, y=y, points=points, level=level, sigma=sigma, seed=seed,
        surrogate_samples=surrogate_samples, verify_points=verify_points, samples=samples,
        curvature_points=curvature_points, mesh=mesh).to_json())
    space.update(grid_size=points, verification_count=len(space["verification"]["points"]),
                 uncertain_text=", ".join(space["uncertain"]))
    ends_began = time.perf_counter()
    ends = range_ends(chain, inputs)
    ends_seconds = time.perf_counter() - ends_began
    values = study["cpps"]
    mapped = [space["x"], space["y"]]
    balances = balance_table(chain, inputs)
    for row in balances:
        row["residual_digits"] = agreement_digits(row["residual"])
    data = {
        "process": {"name": chain.process.name, "description": chain.process.description,
                    "units": " -> ".join(f"{u.name} ({u.type})" for u in chain.process.units),
                    "first_reactor": chain.process.units[0].name,
                    "reactor_count": len(cantera.reactors)},
        "operating_point": {r.name: {"unit": r.unit, "value": values[r.name], "nominal": r.nominal, "nor": list(r.nor),
                                     "par": list(r.par), "description": r.description} for r in chain.cpp_ranges},
        "specifications": {s.name: {"unit": s.unit, "low": None if np.isinf(s.low) else s.low,
                                    "high": None if np.isinf(s.high) else s.high, "spec": s.text(),
                                    "description": s.description} for s in chain.cqa_specs},
        "summary": summary(study, values, chain, ends),
        "mapped": {"cpps": mapped, "count": len(mapped), "of": len(values),
                   "held": {name: values[name] for name in values if name not in mapped},
                   "held_text": ", ".join(name for name in values if name not in mapped)},
        "document": document_control(chain, study),
        "mass_balances": balances,
        "sensitivities": study,
        "design_space": space,
        "uncertainty_fit": fitted,
        "verification": {
            "max_rel_diff_fd": study["max_rel_diff_fd"],
            "max_rel_diff_fd_parameters": study["max_rel_diff_fd_parameters"],
            "reference_rel_error": study["reference_rel_error"],
            "reference_rel_error_parameters": study["reference_rel_error_parameters"],
            "reference_cqa_rel_error": study["reference_cqa_rel_error"],
            "cantera_rates_of_progress": cantera.rates_of_progress,
            "cantera_net_production": cantera.net_production,
            "cantera_r1_amounts": cantera.r1_amounts,
            "cantera_r1_temperature": cantera.r1_temperature,
            "cantera_reactors": {name: {"amounts": amounts, "temperature": temperature}
                                 for name, (amounts, temperature) in cantera.reactors.items()},
            "cantera_reactors_max_amounts": max(amounts for amounts, _ in cantera.reactors.values()),
            "r1_stiffness_ratio": stiffness_ratio(chain, cpps, inputs.physical),
        },
        "solver": chain.solver.as_dict(),
        "solver_text": {key: ({option: readable(v) for option, v in value.items()} if isinstance(value, dict)
                              else readable(value)) for key, value in chain.solver.as_dict().items()},
        "model": {"mechanism_file": pathlib.Path(mechanism_path).name},
        "timings": {"seconds_median": study["seconds_median"], "compile_seconds": study["compile_seconds"],
                    "mode": study["mode"], "passes": study["passes"], "study_seconds": study_seconds,
                    "design_space_surrogate_seconds": space["seconds"]["surrogate"],
                    "design_space_monte_carlo_seconds": space["seconds"]["monte_carlo"],
                    "range_ends_seconds": ends_seconds,
                    "total_seconds": time.perf_counter() - start},
    }
    verification = data["verification"]
    data["verification_digits"] = {
        **{key: agreement_digits(verification[key]) for key in (
            "max_rel_diff_fd", "max_rel_diff_fd_parameters", "reference_rel_error", "reference_rel_error_parameters",
            "reference_cqa_rel_error", "cantera_rates_of_progress", "cantera_net_production",
            "cantera_reactors_max_amounts")},
        "cantera_reactors": {name: {key: agreement_digits(value) for key, value in reactor.items()}
                             for name, reactor in verification["cantera_reactors"].items()}}
    return data


SUPERSCRIPTS = str.maketrans("-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079")


def readable(value):
    """A setting as a reader reads it: a number below 1e-3 or from 1e6 in magnitude as
    "1 x 10^-10" with a true times sign and superscripts, other numbers as `format(value, "g")`,
    anything else as it is."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return value
    if value == 0 or 1e-3 <= abs(value) < 1e6:
        return format(value, "g")
    mantissa, exponent = f"{value:.3g}".split("e") if "e" in f"{value:.3g}" else (f"{value:.3g}", "0")
    exponent = str(int(exponent)).translate(SUPERSCRIPTS)
    return f"10{exponent}" if mantissa == "1" else f"{mantissa} \u00d7 10{exponent}"


def agreement_digits(relative_difference: float | None) -> float | None:
    """A relative difference as the significant digits two results share, -log10 of it (16, a
    double's, for an exact match)."""
    if relative_difference is None:
        return None
    return float(min(16.0, -np.log10(max(relative_difference, 1e-16))))


def document_control(chain: PharmaChain, study: dict) -> dict:
    """The report's document ID (the process's name and the first eight hex digits of the SHA-256
    of its file: the same process file, the same ID), its version (the package's) and the roles
    that sign it."""
    import hashlib
    from importlib.metadata import PackageNotFoundError, version

    digest = hashlib.sha256(pathlib.Path(chain.process.path).read_bytes()).hexdigest()[:8]
    try:
        package = version("snapo-ode")
    except PackageNotFoundError:
        package = "unreleased"
    return {"id": f"SNAPO-Q8-{chain.process.name}-{digest}".upper(), "version": package,
            "roles": ["Prepared by (process modelling)", "Reviewed by (process development)",
                      "Approved by (quality assurance)"]}


def report_provenance(chain: PharmaChain, cpps: CPPs | ChainInputs, *, mechanism_path=None, command=None) -> dict:
    """`snapo_ode.provenance` with the chain's inputs: the process file and its mechanism file, the
    CPPs, the physical parameters, the solver and the effects."""
    inputs = cpps if isinstance(cpps, ChainInputs) else chain.inputs(cpps)
    mechanism = chain.process.mechanism if mechanism_path is None else mechanism_path
    return snapo_ode.provenance({
        "process": pathlib.Path(chain.process.path), "mechanism": pathlib.Path(mechanism), "cpps": inputs.cpps.as_dict(),
        "physical_parameters": inputs.physical.as_dict(),
        "solver": chain.solver.as_dict(), "effects": sorted(chain.scene.active)}, packages=PACKAGES, command=command)


def sensitivity_rows(data: dict) -> list[list]:
    """sensitivities.csv: one row per CQA and input (CPPs and parameters)."""
    study = data["sensitivities"]
    rows = [["cqa", "input", "kind", "sensitivity", "normalized"]]
    for cqa in data["specifications"]:
        rows += [[cqa, cpp, "cpp", study["matrix"][cqa][cpp], study["normalized"][cqa][cpp]]
                 for cpp in data["operating_point"]]
        rows += [[cqa, name, "parameter", value, study["parameter_sensitivities_normalized"][cqa][name]]
                 for name, value in study["parameter_sensitivities"][cqa].items()]
    return rows


def design_space_rows(data: dict) -> list[list]:
    """design_space.csv: the map, one row per grid point."""
    space = data["design_space"]
    cqa_names = list(data["specifications"])
    rows = [[space["x"], space["y"], "probability", *(f"probability_{c}" for c in cqa_names), "limiting_cqa"]]
    for i, vx in enumerate(space["x_values"]):
        for j, vy in enumerate(space["y_values"]):
            rows.append([vx, vy, space["probability"][i][j],
                         *(space["probability_by_cqa"][c][i][j] for c in cqa_names), space["limiting_cqa"][i][j]])
    return rows


def pharma_report(data: dict, provenance: dict) -> Report:
    """The report's content (`_report_content`) over `data`."""
    from ._report_content import sections

    return Report(name="pharma", title=f"{data['process']['name']}: ICH Q8 sensitivity and design-space report",
                  data=data, provenance=provenance, sections=sections(data),
                  subtitle=("Document ", snapo_ode.Value(("document", "id")), ", version ",
                            snapo_ode.Value(("document", "version")), ". The process ",
                            snapo_ode.Value(("process", "units")), " at the operating point below; every number from "
                            "one run, computed at ", snapo_ode.Value(("provenance", "timestamp_utc")), "."),
                  warnings=tuple(data["sensitivities"]["warnings"]),
                  csv={"sensitivities.csv": sensitivity_rows(data), "design_space.csv": design_space_rows(data)})


def write_report(out, data: dict, provenance: dict, json_path=None, pdf: str = "auto") -> snapo_ode.WrittenReport:
    """Write the report (`pharma_report`) as the directory `out` (`snapo_ode.write_report`)."""
    import matplotlib

    matplotlib.use("Agg")
    return snapo_ode.write_report(out, pharma_report(data, provenance), json_path=json_path, pdf=pdf)
