"""`snapo pharma fit`: kinetics fitted to lab data, its JSON (`FitReport`) and the posterior file
beside it (`.posterior.json`), which `snapo pharma design-space --posterior` and `snapo report
pharma --posterior` draw from."""

import argparse
import dataclasses
import time

import numpy as np

from snapo_ode import InputError, Result
from snapo_ode.cli import count, numbers


@dataclasses.dataclass(frozen=True, kw_only=True)
class FitReport(Result):
    """A fit as the JSON states it: `parameters` (name -> estimate, standard_error, wald_95,
    profile_95, identifiable), `correlation` (names and matrix), `goodness_of_fit` (chi-square,
    dof, p-value, scale), `identifiability` (rank, condition number, singular values, the
    combinations the data cannot determine), `experiments` (name -> unit, temperature,
    measurements, RMS weighted residual), `residuals` (per measurement), `reference_temperature`
    [K], `seconds`."""

    process: str
    parameters: dict
    correlation: dict
    goodness_of_fit: dict
    identifiability: dict
    reference_temperature: float
    experiments: dict
    residuals: list
    seconds: dict

    def summary(self) -> str:
        lines = [f"fit of {len(self.parameters)} parameters to {len(self.residuals)} measurements: chi-square "
                 f"{self.goodness_of_fit['chi_square']:.4g} on {self.goodness_of_fit['dof']} dof (p = "
                 f"{self.goodness_of_fit['p_value']:.3g})"]
        for name, p in self.parameters.items():
            wald = "not identifiable" if p["wald_95"] is None else f"[{p['wald_95'][0]:.5g}, {p['wald_95'][1]:.5g}]"
            lines.append(f"  {name} = {p['estimate']:.6g} +/- {p['standard_error']:.3g} ({p['unit']}), 95% {wald}")
        for combination in self.identifiability["unidentifiable"]:
            terms = " + ".join(f"{v:.2f} {k}" for k, v in combination["coefficients"].items())
            lines.append(f"  the data cannot determine: {terms}")
        return "\n".join(lines)


def _finite(value):
    return None if value is None or not np.isfinite(value) else float(value)


def fit_report(result, data, process: str, seconds: dict) -> FitReport:
    """The `FitReport` of a `FitResult` on `data` (`LabData`). `rank`: the directions the data
    determine (standard error within `UNIDENTIFIABLE_SE`); `numerical_rank`: the singular values
    above `RANK_TOLERANCE` of the largest."""
    import scipy.stats

    from ._fit import RANK_TOLERANCE

    se, wald, blocked = result.standard_errors, result.wald(), result.unidentifiable()
    parameters = {}
    for k, name in enumerate(result.names):
        parameters[name] = {
            "estimate": float(result.estimates[k]), "standard_error": _finite(se[k]),
            "unit": "kJ/mol" if name.startswith("E_a[") else "-",
            "wald_95": None if blocked[k] else [float(v) for v in wald[k]],
            "profile_95": result.profile.get(name), "identifiable": not bool(blocked[k])}
    scale = np.outer(se, se)
    correlation = np.where(scale > 0, result.covariance / np.where(scale > 0, scale, 1.0), 0.0)
    singular = result.singular_values
    m = data.measurements
    experiments = {}
    for e, experiment in enumerate(data.experiments):
        rows = m.experiment == e
        experiments[experiment.name] = {"unit": experiment.unit, "temperature_K": experiment.temperature,
                                        "charges_mol_per_L": experiment.charges, "measurements": int(rows.sum()),
                                        "rms_weighted_residual": float(np.sqrt(np.mean(result.residuals[rows] ** 2)))}
    residuals = [{"experiment": data.experiments[e].name, "time_min": float(t), "species": s, "measured": float(v),
                  "model": float(p), "weighted_residual": float(r), "line": int(line)}
                 for e, t, s, v, p, r, line in zip(m.experiment, m.time, m.species, m.value, result.predictions,
                                                   result.residuals, m.line, strict=True)]
    goodness = {"chi_square": result.chi_square, "dof": result.dof, "scale": result.scale,
                "sd_known": result.sd_known,
                "p_value": float(scipy.stats.chi2.sf(result.chi_square, result.dof)) if result.sd_known else None,
                "rms_weighted_residual": float(np.sqrt(np.mean(result.residuals ** 2)))}
    identifiability = {"rank": len(result.names) - len(result.null_combinations),
                       "numerical_rank": int(np.sum(singular > RANK_TOLERANCE * singular[0])),
                       "parameters": len(result.names),
                       "condition_number": float(singular[0] / singular[-1]) if singular[-1] > 0 else None,
                       "singular_values": singular.tolist(), "unidentifiable": result.null_combinations,
                       "identifiable": not result.null_combinations}
    return FitReport(process=process, parameters=parameters,
                     correlation={"names": list(result.names), "matrix": correlation.tolist()},
                     goodness_of_fit=goodness, identifiability=identifiability,
                     reference_temperature=result.fitted.reference_temperature, experiments=experiments,
                     residuals=residuals, seconds=seconds)


def run_fit(args) -> int:
    from ._chain_cli import chain_from_args
    from ._experiments import read_lab_data
    from ._fit import fit
    from ._posterior import posterior_from_fit

    chain, _ = chain_from_args(args)
    data = read_lab_data(args.experiments, args.data, chain.process, tuple(chain.mechanism.species_names))
    start = time.perf_counter()
    result = fit(chain, data, args.fit or None, profile=not args.no_profile)
    report = fit_report(result, data, chain.process.name, {"fit": time.perf_counter() - start})
    summary = {key: value for key, value in report.to_json().items()
               if key in ("parameters", "correlation", "goodness_of_fit", "experiments", "residuals")}
    posterior = posterior_from_fit(result, chain, chain.process.name, summary)
    import json

    written = report.publish(args.json, {".posterior.json": json.dumps(posterior.as_dict(), indent=1).encode() + b"\n"})
    print(report.summary())
    print(f"written: {', '.join(map(str, written))}")
    return 0


@dataclasses.dataclass(frozen=True, kw_only=True)
class NextExperiment(Result):
    """Candidate experiments ranked (`_next_experiment.rank_candidates`) by `rank_by` (d-optimal
    or edge; `criterion` says how): `ranking` (best first), the `current` fit's parameters and
    standard errors, the `times` [min] and `species` each candidate samples, and `edge`: the
    design space's grid (x, y, points), its spec `limits` with each one's edge uncertainty and
    edge length now, and the edge uncertainty now (`_edge_uncertainty`)."""

    process: str
    criterion: str
    current: dict
    times: list
    species: list
    ranking: list
    rank_by: str = "d-optimal"
    edge: dict | None = None
    seconds: dict | None = None
    """The fit, the edge map (the grid's Jacobians) and the ranking (the candidates' Jacobians)."""

    def summary(self) -> str:
        by = "the gain of ln det(Fisher information)" if self.rank_by == "d-optimal" else \
            "the expected reduction of the design space's edge uncertainty"
        lines = [f"{len(self.ranking)} candidates ranked by {by}:"]
        for row in self.ranking[:10]:
            worst = max(row["standard_error_ratio"].items(), key=lambda item: item[1])
            best = min(row["standard_error_ratio"].items(), key=lambda item: item[1])
            edge = "" if "edge_gain" not in row else "; no edge in the grid" if row["edge_uncertainty_now"] == 0 else \
                f"; edge uncertainty x{row['edge_uncertainty_after'] / row['edge_uncertainty_now']:.3f}"
            lines.append(f"  {row['name']} ({row['temperature_K']:.2f} K): +{row['log_det_gain']:.3f}; standard error "
                         f"of {best[0]} x{best[1]:.3f} (the least helped: {worst[0]} x{worst[1]:.3f}){edge}")
        if self.edge is not None:
            lines.append(f"edge uncertainty of the design space over {self.edge['x']} x {self.edge['y']} now: "
                         f"{self.edge['uncertainty_now']:.4g} (edge length x location sd, a fraction of the PAR box)")
        return "\n".join(lines)


CRITERIA = {"d-optimal": "D-optimal: ln det(F + J_c^T J_c) - ln det F",
            "edge": "edge: U(C) - U(C_c), U the design space's edge uncertainty (its spec limits' edges' location "
                    "standard deviation integrated along them, the CPPs scaled to their PARs), C the fitted "
                    "covariance, C_c = (C^-1 + J_c^T J_c)^-1"}


def run_next_experiment(args) -> int:
    from ._chain_cli import chain_from_args
    from ._experiments import read_experiments, read_lab_data
    from ._fit import fit
    from snapo_ode import check_choice

    from ._edge_uncertainty import edge_map
    from ._next_experiment import RANKINGS, rank_candidates
    from ._posterior import posterior_from_fit

    check_choice("--rank-by", args.rank_by, tuple(RANKINGS))
    grid = grid_settings(args)
    chain, inputs = chain_from_args(args)
    species = tuple(chain.mechanism.species_names)
    data = read_lab_data(args.experiments, args.data, chain.process, species)
    candidates, _ = read_experiments(args.candidates, chain.process, species)
    measured = [s.strip() for s in args.species.split(",") if s.strip()]
    unknown = [s for s in measured if s not in species]
    if unknown or not measured:
        raise InputError(f"--species = {args.species!r}; allowed: species of the mechanism ({', '.join(species)}).")
    start = time.perf_counter()
    result = fit(chain, data, args.fit or None, profile=False)
    posterior = posterior_from_fit(result, chain, chain.process.name)
    (x, y), mesh = grid.axes, getattr(args, "mesh", None)
    seconds = {"fit": time.perf_counter() - start}
    edge = edge_map(chain, inputs, posterior, x=x, y=y, points=grid.points, mesh=mesh)
    seconds["edge_map"] = time.perf_counter() - start - seconds["fit"]
    ranking = rank_candidates(chain, data, result, candidates, list(args.times), measured, edge=edge,
                              rank_by=args.rank_by)
    seconds["ranking"] = time.perf_counter() - start - seconds["fit"] - seconds["edge_map"]
    by_limit, length = edge.uncertainty_by_limit(posterior.covariance), edge.edge_length()
    report = NextExperiment(process=chain.process.name, criterion=CRITERIA[args.rank_by],
                            current={name: {"estimate": float(v), "standard_error": float(s)} for name, v, s in
                                     zip(result.names, result.estimates, result.standard_errors, strict=True)},
                            times=list(args.times), species=measured, ranking=ranking, rank_by=args.rank_by,
                            edge={"x": x, "y": y, "points": grid.points, "x_values": edge.xs.tolist(),
                                  "y_values": edge.ys.tolist(), "uncertainty_now": float(by_limit.sum()),
                                  "limits": {name: {"uncertainty_now": float(u), "edge_length": float(n)}
                                             for name, u, n in zip(edge.limits, by_limit, length, strict=True)}},
                            seconds=seconds)
    return _finish(report, args.json)


def _finish(report, path) -> int:
    print(report.summary())
    print(f"written: {report.write_json(path)}")
    return 0


def add_grid_arguments(parser: argparse.ArgumentParser) -> None:
    """The design space's grid: its two CPPs and the points per CPP."""
    parser.add_argument("--x", default=None, help="the CPP on the map's horizontal axis (default: the process's first; "
                        "the built-in: r1_temperature)")
    parser.add_argument("--y", default=None, help="the CPP on the map's vertical axis (default: the process's last; "
                        "the built-in: dryer_temperature)")
    parser.add_argument("--points", type=count(), default=21, help="grid points per CPP over its PAR (default 21)")


def grid_settings(args):
    """The `DesignSpaceSettings` of the grid flags (`add_grid_arguments`), checked against the
    process's CPPs read from its file, before anything is built or computed."""
    from ._design_space import DesignSpaceSettings
    from ._process_file import load_process

    return DesignSpaceSettings(x=args.x, y=args.y, cpp_names=tuple(spec.name for spec in load_process(args.process).cpps),
                               points=args.points, curvature_points=0, verify_points=1)  # the grid alone


def add_posterior_argument(parser) -> None:
    parser.add_argument("--posterior", default=None, metavar="FILE", help="draw the rate parameters from a fit's "
                        "posterior file (snapo pharma fit's .posterior.json: correlated, at the fitted values) instead "
                        "of independent ln k with --sigma")


def posterior_option(args, chain) -> dict:
    """{"posterior": the file read against `chain`} where `--posterior` is given, else {}."""
    if getattr(args, "posterior", None) is None:
        return {}
    from ._posterior import read_posterior

    return {"posterior": read_posterior(args.posterior, chain)}


def register_fit(cli, pharma) -> None:
    from ._chain_cli import add_chain_arguments

    command = cli.command("fit", "fit the process's kinetics to lab data (experiments file, data file): estimates, "
                          "standard errors, correlation, Wald and profile intervals, identifiability; writes a "
                          "posterior file for design-space --posterior", group=pharma)
    add_chain_arguments(command)
    _lab_arguments(command)
    command.add_argument("--no-profile", action="store_true", help="skip the profile-likelihood intervals")
    command.set_defaults(handler=run_fit)
    following = cli.command("next-experiment", "rank candidate experiments by the expected reduction of the fitted "
                            "parameters' uncertainty (D-optimal on the Fisher information) or of the design space's "
                            "edge uncertainty", group=pharma)
    add_chain_arguments(following)
    _lab_arguments(following)
    following.add_argument("--candidates", required=True, metavar="FILE", help="the candidate experiments (YAML, as "
                           "the experiments file: conditions and charges within the ranges you would run)")
    following.add_argument("--times", type=numbers(0), default="5,10,20,30,45,60,90,120",
                           help="sampling times of each candidate [min], comma-separated")
    following.add_argument("--species", required=True, help="the species each candidate measures, comma-separated")
    following.add_argument("--rank-by", default="d-optimal", help="d-optimal (the gain of ln det of the Fisher "
                           "information; default) or edge (the expected reduction of the design space's edge "
                           "uncertainty over --x and --y); both are reported for every candidate")
    add_grid_arguments(following)
    following.set_defaults(handler=run_next_experiment)


def _lab_arguments(command) -> None:
    command.add_argument("--experiments", required=True, metavar="FILE", help="the experiments (YAML)")
    command.add_argument("--data", required=True, metavar="FILE", help="the measurements (CSV: experiment, time "
                         "[unit], species, value [unit], optional sd [unit])")
    command.add_argument("--fit", action="append", default=[], metavar="NAME", help="a parameter to fit: "
                         "log_multiplier[EQ] (its rate constant) or E_a[EQ] (its activation energy, with its rate "
                         "constant); repeatable; default: the process's uncertain rate constants, each with its "
                         "activation energy when the experiments span two temperatures")
