"""`snapo pharma sensitivities`: the ICH Q8 sensitivity study as a JSON-ready dict."""

import numpy as np

from ._chain import PharmaChain
from ._parameters import CPP_NAMES, CQA_NAMES, CPPs, outside_par
from ._sensitivities import (
    Sensitivities, bump_agreement, central_differences, chain_inputs, input_names, input_scales, max_rel_diff, sensitivities)
from ._solver import ChainSolver

# The reference is integrated by a different method (ESDIRK Kvaerno5 on every unit) from the
# default (Rodas4 and Tsit5), so that `reference_rel_error` checks the method as well as the step.
REFERENCE = ChainSolver(rtol=1e-12, atol=1e-14, solver="kvaerno5", nonstiff_solver="kvaerno5", max_steps=20000)
# Central differences need a solver error far below their step: the reference for the bumps.
BUMP_SOLVER = ChainSolver(rtol=1e-10, atol=1e-12)


def by_name(matrix, columns) -> dict:
    """cqa -> column -> value."""
    return {cqa: {name: float(value) for name, value in zip(columns, row, strict=True)}
            for cqa, row in zip(CQA_NAMES, np.asarray(matrix), strict=True)}


def sensitivity_study(chain: PharmaChain, cpps: CPPs, *, mode: str = "auto", repeats: int = 5,
                      check_bumps: bool = True, reference: ChainSolver | None = REFERENCE) -> tuple[dict, Sensitivities]:
    """Every CQA's sensitivity to every CPP and parameter at `cpps`, timed, with the central
    differences (at `BUMP_SOLVER`'s tolerances) and the tight-tolerance reference next to it."""
    inputs = chain_inputs(chain, cpps)
    result = sensitivities(chain, inputs, mode=mode, repeats=repeats)
    names = input_names(chain)
    full = np.concatenate([result.matrix, result.parameters], axis=1)
    scales = input_scales(inputs)
    out = {
        "cpps": cpps.as_dict(),
        "warnings": outside_par(cpps),
        "cqas": {name: float(v) for name, v in zip(CQA_NAMES, result.cqas, strict=True)},
        "matrix": by_name(result.matrix, CPP_NAMES),
        "normalized": by_name(result.normalized, CPP_NAMES),
        "parameter_sensitivities": by_name(result.parameters, result.parameter_names),
        "parameter_sensitivities_normalized": by_name(
            result.parameters * scales[len(CPP_NAMES):] / result.cqas[:, None], result.parameter_names),
        "mode": result.mode,
        "passes": len(CQA_NAMES) if result.mode == "reverse" else len(names),
        "seconds_median": result.seconds_median,
        "compile_seconds": result.compile_seconds,
        "solver": chain.solver.as_dict(),
        "effects": sorted(chain.scene.active),
    }
    if check_bumps:
        bumped = central_differences(chain.with_solver(BUMP_SOLVER), inputs, range(len(names)))
        out["max_rel_diff_fd"] = max_rel_diff(result.matrix, bumped[:, :len(CPP_NAMES)])
        nonzero, at_zeros = bump_agreement(full, bumped, scales)
        out["max_rel_diff_fd_parameters"] = nonzero
        out["fd_at_structural_zeros"] = at_zeros
        out["fd_solver"] = BUMP_SOLVER.as_dict()
    if reference is not None:
        tight = sensitivities(chain.with_solver(reference), inputs, mode="reverse", repeats=1)
        out["reference_rel_error"] = max_rel_diff(result.matrix, tight.matrix)
        out["reference_rel_error_parameters"] = max_rel_diff(
            full, np.concatenate([tight.matrix, tight.parameters], axis=1), scales)
        out["reference_cqa_rel_error"] = float(np.max(np.abs(result.cqas - tight.cqas) / np.abs(tight.cqas)))
        out["reference_solver"] = reference.as_dict()
    return out, result


def summary_table(study: dict) -> str:
    """The 5x4 matrix, normalised, with the checks, as text."""
    lines = [f"CQA sensitivities to CPPs ({study['mode']} mode, {study['passes']} passes): "
             f"{1e3 * study['seconds_median']:.1f} ms median, {study['compile_seconds']:.1f} s compile"]
    lines.append(f"{'CQA':<20}{'value':>12}  " + "".join(f"{n:>20}" for n in CPP_NAMES))
    for cqa in CQA_NAMES:
        row = "".join(f"{study['normalized'][cqa][n]:>20.4g}" for n in CPP_NAMES)
        lines.append(f"{cqa:<20}{study['cqas'][cqa]:>12.5g}  {row}")
    lines.append("(normalised: d ln CQA / d ln CPP)")
    if "max_rel_diff_fd" in study:
        lines.append(f"max relative difference to central differences: {study['max_rel_diff_fd']:.1e} (20 CPP), "
                     f"{study['max_rel_diff_fd_parameters']:.1e} (all)")
    if "reference_rel_error" in study:
        lines.append(f"relative error against the rtol {study['reference_solver']['rtol']:g} reference: "
                     f"{study['reference_rel_error']:.1e} (20 CPP), {study['reference_rel_error_parameters']:.1e} (all)")
    lines.extend(f"warning: {w}" for w in study["warnings"])
    return "\n".join(lines)
