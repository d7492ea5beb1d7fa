"""`snapo pharma sensitivities`: the ICH Q8 sensitivity study as a typed result, every sensitivity
checked against central differences and a tight-tolerance reference through the core's one
verification path (`snapo_ode.compare_with_bumps`, `snapo_ode.agreement`)."""

import dataclasses
import functools
from typing import ClassVar

import jax.numpy as jnp
import numpy as np

from snapo_ode import (
    ONCE_COMPILE, Jacobian, Result, agreement, bump_steps, bumps_program, call_checked, compare_with_bumps, exported, field,
    flatten_inputs, prefetch_checked, time_function)

from ._chain import CHAIN_SOLVER, PharmaChain, chain_method
from ._parameters import ChainInputs, CPPs
from ._process import outside_par
from ._sensitivities import (
    cqa_function, input_names, input_scales, jacobian_function, named_jacobian, normalized, parameter_names,
    prefetch_jacobian, resolve_mode)

REFERENCE = CHAIN_SOLVER.replace(rtol=1e-12, atol=1e-14, solver=chain_method("kvaerno5"),
                                 nonstiff_solver=chain_method("kvaerno5"), max_steps=20000)
"""The reference Jacobian's solver: a different method (ESDIRK Kvaerno5 on every unit) from the
default (Rodas5 and Tsit5), so that `reference_rel_error` checks the method and the step.
`sensitivity_study` differentiates it by the other mode from the study's (`other_mode`). The BDF
on R1 and R2 (a multistep family) agrees with it to 1e-9 (tested) and traces faster, but ran no
faster cold and is less accurate at the same rtol: not taken (docs/pharma.md, Decisions and
limits)."""
REFERENCE_METHODS = "Kvaerno5 on every unit"
"""`REFERENCE`'s methods, as notes and reports name them."""
BUMP_SOLVER = CHAIN_SOLVER.replace(rtol=1e-10, atol=1e-12)
"""The central differences' solver: an error far below their step."""
BUMP_RELATIVE_STEP = 1e-3
"""Relative step of the Richardson central differences (error O(h^4), so the solver's error over h
stays far below 1e-5)."""


def other_mode(mode: str) -> str:
    """The reference's mode for a study in `mode`: the other one, so that the reference also
    checks the study's derivative. For the default reverse study that is forward mode, which
    also traces in half the time of reverse mode through Kvaerno5's root finder (the critical
    path of a cold `snapo pharma sensitivities` then) and runs in about the same (docs/dev/pharma_notes.md,
    Decisions and limits)."""
    return "forward" if mode == "reverse" else "reverse"


def by_name(matrix, rows, columns) -> dict:
    """row (a CQA) -> column -> value."""
    return {cqa: {name: float(value) for name, value in zip(columns, row, strict=True)}
            for cqa, row in zip(rows, np.asarray(matrix), strict=True)}


@dataclasses.dataclass(frozen=True, kw_only=True)
class SensitivityStudy(Result):
    """Every CQA's sensitivity to every CPP and parameter at one operating point, with its checks.

    JSON fields (docs/pharma.md): `cpps`, `warnings` (CPPs outside their PAR), `cqas`, `matrix`
    (d CQA / d CPP), `normalized` (d ln CQA / d ln CPP), `parameter_sensitivities` (and
    `_normalized`), `mode`, `passes`, `seconds_median`, `compile_seconds`, `solver`, `effects`;
    with the bumps `max_rel_diff_fd` (the 20 CPP entries), `max_rel_diff_fd_parameters` (all,
    as d CQA / d ln x), `fd_at_structural_zeros`, `fd_solver`; with the reference
    `reference_rel_error`, `reference_rel_error_parameters`, `reference_cqa_rel_error`,
    `reference_solver`. Also carried: the named `jacobian` and the `inputs`."""

    cpps: dict
    warnings: list
    cqas: dict
    matrix: dict
    normalized: dict
    parameter_sensitivities: dict
    parameter_sensitivities_normalized: dict
    mode: str
    passes: int
    seconds_median: float
    compile_seconds: float
    solver: dict
    effects: list
    max_rel_diff_fd: float | None = None
    max_rel_diff_fd_parameters: float | None = None
    fd_at_structural_zeros: float | None = None
    fd_solver: dict | None = None
    reference_rel_error: float | None = None
    reference_rel_error_parameters: float | None = None
    reference_cqa_rel_error: float | None = None
    reference_solver: dict | None = None
    jacobian: Jacobian = field(json=False)
    inputs: ChainInputs = field(json=False)
    omit_none: ClassVar[bool] = True

    def summary(self) -> str:
        """The 5x4 matrix, normalised, with the checks."""
        lines = [f"CQA sensitivities to CPPs ({self.mode} mode, {self.passes} passes): "
                 f"{1e3 * self.seconds_median:.1f} ms median, {self.compile_seconds:.1f} s compile"]
        cpps = list(self.cpps)
        width = max(20, *(len(n) + 2 for n in cpps))
        lines.append(f"{'CQA':<20}{'value':>12}  " + "".join(f"{n:>{width}}" for n in cpps))
        for cqa in self.cqas:
            row = "".join(f"{self.normalized[cqa][n]:>{width}.4g}" for n in cpps)
            lines.append(f"{cqa:<20}{self.cqas[cqa]:>12.5g}  {row}")
        lines.append("(normalised: d ln CQA / d ln CPP)")
        if self.max_rel_diff_fd is not None:
            lines.append(f"max relative difference to central differences: {self.max_rel_diff_fd:.1e} (CQA x CPP), "
                         f"{self.max_rel_diff_fd_parameters:.1e} (all)")
        if self.reference_rel_error is not None:
            lines.append(f"relative error against the rtol {self.reference_solver['rtol']:g} reference: "
                         f"{self.reference_rel_error:.1e} (CQA x CPP), {self.reference_rel_error_parameters:.1e} (all)")
        lines.extend(f"warning: {w}" for w in self.warnings)
        return "\n".join(lines)


def sensitivities(chain: PharmaChain, inputs: ChainInputs, *, mode: str = "auto", repeats: int = 5
                  ) -> tuple[Jacobian, object]:
    """The named Jacobian of the CQAs over every input (`mode` "auto" picks reverse for 5
    outputs and ~50 inputs: 5 passes) and its `snapo_ode.Timing`."""
    mode = resolve_mode(mode, len(input_names(chain)), len(chain.cqa_names))
    timing, (values, matrix) = time_function(jacobian_function(chain, True, mode), inputs, repeats=repeats)
    return named_jacobian(chain, inputs, values, matrix, mode), timing


MAX_SOLVER_ERROR = 1e-4
"""Relative error against the tight-tolerance reference above which a study warns."""


def solver_error_warnings(checks: dict, rtol: float, threshold: float = MAX_SOLVER_ERROR) -> list[str]:
    """A warning for each reference error in `checks` above `threshold` (relative)."""
    what = {"reference_cqa_rel_error": "the CQAs", "reference_rel_error": "the 20 dCQA/dCPP",
            "reference_rel_error_parameters": "the parameter sensitivities"}
    return [f"solver error: {label} are off by {checks[key]:.1e} relative against the reference, above "
            f"{threshold:g}: tighten --rtol (now {rtol:g})" for key, label in what.items()
            if checks.get(key) is not None and checks[key] > threshold]


def _cqa_shape(n_cqas: int):
    """A stand-in of `cqa_function` with its output shape, (n_cqas,): `compare_with_bumps`, given
    the adjoint and the bumped functions, reads only that, through `equinox.filter_eval_shape`,
    which on the chain itself would trace every unit's solve, in every process (docs/dev/pharma_notes.md,
    Measurements behind the design)."""
    return lambda inputs: jnp.zeros(n_cqas)


def _bumped_cqas(bumped_chain: PharmaChain, inputs: ChainInputs, args, steps):
    """The central differences of `cqa_function(bumped_chain)` at `inputs` with Richardson steps,
    as `compare_with_bumps` computes them (`snapo_ode.bumps_program`)."""
    return bumps_program(cqa_function(bumped_chain), richardson=True)(inputs, args, steps)


_exported_bumps = exported(_bumped_cqas, name="pharma-bumps", compiler_options=ONCE_COMPILE)
"""The central differences' program, exported (keyed by the bumped chain and the steps' shape), so
that a second process does not trace it."""


def _call_bumps(adjoint, bumped_chain: PharmaChain, program, *args):
    """How `sensitivity_study` calls its programs: the adjoint as it is (exported already), and
    for the central differences' program (the only other one), `_exported_bumps`."""
    if program is adjoint:
        return call_checked(adjoint, *args, what="the chain's sensitivities")
    return call_checked(_exported_bumps, bumped_chain, *args, what="the chain's sensitivities")


def _prefetch(chain: PharmaChain, inputs: ChainInputs, mode: str, bumped_chain, reference) -> bool:
    """Prepare the study's programs before the first runs (`snapo_ode.prefetch_checked`): the
    adjoint, the bumps (of `bumped_chain`, or None) and the reference Jacobian (its solver
    settings or None); whether the reference was on disk. A second process reads them in
    background threads (one after another, their reading was a large share of a warm `snapo
    pharma sensitivities`). A first one hands the reference to a helper process (`elsewhere`),
    started first, and traces the adjoint here meanwhile (tracing holds the interpreter lock: the
    three traces one after another were most of a cold run), then the bumps while the adjoint
    compiles (a second helper for the bumps was slower). The figures: docs/dev/pharma_notes.md,
    Measurements behind the design. The bumps' steps are built as
    `compare_with_bumps` builds them: the entry's key is their shape and dtype."""
    on_disk = reference is not None and prefetch_jacobian(chain.with_solver(reference), inputs, True,
                                                          other_mode(mode), once=True, elsewhere=True)
    prefetch_jacobian(chain, inputs, True, mode)
    if bumped_chain is not None:
        steps = jnp.asarray(bump_steps(flatten_inputs(inputs)[0], BUMP_RELATIVE_STEP, 0.0))
        prefetch_checked(_exported_bumps, bumped_chain, inputs, (), steps)
    return on_disk


def _reference_jacobian(chain: PharmaChain, inputs: ChainInputs, reference, mode: str) -> Jacobian:
    """The named Jacobian at `reference`'s settings by the other mode: a check, run once and not
    timed (a second run only to time it would be time lost: docs/dev/pharma_notes.md, Measurements behind
    the design)."""
    values, matrix = jacobian_function(chain.with_solver(reference), True, other_mode(mode), once=True)(inputs)
    return named_jacobian(chain, inputs, values, matrix, other_mode(mode))


def sensitivity_study(chain: PharmaChain, cpps: CPPs | ChainInputs, *, mode: str = "auto", repeats: int = 5,
                      check_bumps: bool = True, reference=REFERENCE,
                      max_solver_error: float = MAX_SOLVER_ERROR) -> SensitivityStudy:
    """Every CQA's sensitivity to every CPP and parameter at `cpps` (`CPPs`, the other inputs the
    process file's; or the `ChainInputs` themselves, used as given), timed, next to Richardson
    central differences (at `BUMP_SOLVER`'s tolerances) and the Jacobian at `reference`'s
    tolerances by the other mode (`other_mode`; `reference` None: skipped). Errors against the
    reference above `max_solver_error` (relative) are warnings in the result
    (`solver_error_warnings`). The runs go one after another, so that the adjoint's timing
    shares the cores with no other run (in a first process the reference's helper may still be
    compiling beside it, at a lower priority); the reference runs first when it was on disk
    (ready before the adjoint, whose executable takes the longest to read: running the reference
    meanwhile hides part of that wait; docs/dev/pharma_notes.md, Measurements behind the design), else last
    (a helper process traces and compiles it)."""
    inputs = cpps if isinstance(cpps, ChainInputs) else chain.inputs(cpps)
    cpps, cpp_names, cqa_names = inputs.cpps, chain.cpp_names, chain.cqa_names
    mode = resolve_mode(mode, len(input_names(chain)), len(cqa_names))
    scales = input_scales(inputs)
    checks = {}
    bumped_chain = chain.with_solver(BUMP_SOLVER)
    reference_first = _prefetch(chain, inputs, mode, bumped_chain if check_bumps else None, reference)
    tight = _reference_jacobian(chain, inputs, reference, mode) if reference_first else None
    if check_bumps:
        adjoint = jacobian_function(chain, True, mode)
        comparison = compare_with_bumps(
            _cqa_shape(len(cqa_names)), inputs, adjoint_fn=adjoint, bump_fn=cqa_function(bumped_chain),
            relative_step=BUMP_RELATIVE_STEP, step_floor=0.0, richardson=True, scales=scales, zero=1e-12,
            repeats=repeats, bump_repeats=0, call=functools.partial(_call_bumps, adjoint, bumped_chain))
        jac = named_jacobian(chain, inputs, comparison.value, comparison.adjoint, mode)
        seconds, compile_seconds = comparison.adjoint_seconds, comparison.adjoint_compile_seconds
        bumped = named_jacobian(chain, inputs, comparison.value, comparison.bumped, mode)
        checks.update(max_rel_diff_fd=agreement(jac.columns(cpp_names), bumped.columns(cpp_names)).max_rel_diff,
                      max_rel_diff_fd_parameters=comparison.agreement.max_rel_diff,
                      fd_at_structural_zeros=comparison.agreement.at_structural_zeros,
                      fd_solver=BUMP_SOLVER.as_dict())
    else:
        jac, timing = sensitivities(chain, inputs, mode=mode, repeats=repeats)
        seconds, compile_seconds = timing.median_seconds, timing.compile_seconds
    if reference is not None:
        tight = _reference_jacobian(chain, inputs, reference, mode) if tight is None else tight
        values, tight_values = np.asarray(jac.values), np.asarray(tight.values)
        checks.update(reference_rel_error=agreement(jac.columns(cpp_names), tight.columns(cpp_names)).max_rel_diff,
                      reference_rel_error_parameters=agreement(jac.matrix, tight.matrix, scales=scales).max_rel_diff,
                      reference_cqa_rel_error=float(np.max(np.abs(values - tight_values) / np.abs(tight_values))),
                      reference_solver=reference.replace(differentiation=other_mode(mode)).as_dict())
    parameters = parameter_names(chain)
    return SensitivityStudy(
        cpps=cpps.as_dict(),
        warnings=outside_par(cpps, chain.process) + solver_error_warnings(checks, chain.solver.rtol, max_solver_error),
        cqas={name: float(v) for name, v in zip(cqa_names, np.asarray(jac.values), strict=True)},
        matrix=jac.named(cpp_names), normalized=by_name(normalized(jac, inputs, cpp_names), cqa_names, cpp_names),
        parameter_sensitivities=jac.named(parameters),
        parameter_sensitivities_normalized=by_name(normalized(jac, inputs, parameters), cqa_names, parameters),
        mode=mode, passes=len(cqa_names) if mode == "reverse" else len(jac.input_names),
        seconds_median=seconds, compile_seconds=compile_seconds, solver=chain.solver.as_dict(),
        effects=sorted(chain.scene.active), jacobian=jac, inputs=inputs, **checks)
