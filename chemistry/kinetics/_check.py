"""`snapo kinetics check`: one mechanism against Cantera on rates, constant-volume ignition and
temperature sensitivities, as a typed result."""

import dataclasses
from pathlib import Path

import jax.numpy as jnp
import numpy as np
from tqdm import tqdm

from snapo_ode import InputError, Result, SolverFailed, call_checked, check_count, check_range, exported

from ._crosscheck import compare_rates
from ._ignition import IGNITION_CASES, IgnitionCase, cantera_ignition, initial_concentrations, solve_ignition
from ._mechanism import Mechanism
from ._reactor import REACTOR_BDF_SOLVER
from ._sensitivities import cantera_sensitivities, compare_sensitivities, temperature_sensitivities
from ._sources import find_file
from ._units import ONE_ATM

GAS_TEMPERATURES = (300.0, 2500.0)
CONDENSED_TEMPERATURES = (280.0, 400.0)
"""Random-state temperature ranges [K]: a liquid mechanism's thermo is fitted near ambient."""
_SENSITIVITY_SETTINGS = REACTOR_BDF_SOLVER.replace(rtol=1e-10, atol=1e-14)
"""The check's one reverse pass, through the BDF (`REACTOR_BDF_SOLVER`): here the trace and the
compile are the wait, and the BDF's program is the smaller, quicker to compile and to run
(`snapo bench kinetics`). Its d ln T / d ln A differ from Rodas5's far inside the check's 1e-3
against Cantera (the measurement: docs/dev/chemistry_notes.md, Measurements behind the design)."""
_exported_sensitivities = exported(temperature_sensitivities, name="kinetics-temperature-sensitivities")
"""The reverse pass, traced once and kept on disk (`snapo_ode.exported`): otherwise gri30's is
traced and compiled again, at length, in every process (docs/dev/chemistry_notes.md, Measurements behind
the design)."""


def default_case(mechanism: Mechanism, path: str | Path) -> IgnitionCase | None:
    """The built-in case of a Cantera file of the same name, else H2/O2 (1000 K) or CH4/air
    (1500 K) when the species are there (diluted in N2 or AR if present), else None."""
    stem = Path(path).stem
    if stem in IGNITION_CASES:
        return IGNITION_CASES[stem]
    names = set(mechanism.species_names)
    diluent = next((d for d in ("N2", "AR", "Ar") if d in names), None)
    dilution = f",{diluent}:3.76" if diluent else ""
    if {"H2", "O2"} <= names:
        return IgnitionCase("H2:2,O2:1" + dilution, 1000.0, ONE_ATM, 1e-3, float("nan"))
    if {"CH4", "O2"} <= names:
        return IgnitionCase("CH4:1,O2:2" + dilution.replace("3.76", "7.52"), 1500.0, ONE_ATM, 5e-3, float("nan"))
    return None


@dataclasses.dataclass(frozen=True, kw_only=True)
class KineticsCheck(Result):
    """A mechanism against Cantera: the file and its size; `rates` (max relative errors of the
    rates of progress and net production rates at random states); `ignition` and `sensitivities`
    (each with "skipped" and the reason where they do not apply)."""

    mechanism: str
    phase: str | None
    thermo: str
    n_species: int
    n_reactions: int
    rates: dict
    ignition: dict
    sensitivities: dict

    def summary(self) -> str:
        rates = self.rates
        lines = [f"{self.mechanism}: {self.n_species} species, {self.n_reactions} reactions ({self.thermo})",
                 f"  rates at {rates['n_states']} random states: max relative error {rates['net_production']:.2e} "
                 f"(net production), {rates['rates_of_progress']:.2e} (rates of progress)"]
        ignition = self.ignition
        if "skipped" in ignition:
            lines.append(f"  ignition: skipped ({ignition['skipped']})")
        else:
            case = ignition["case"]
            lines.append(f"  ignition of {case['composition']} from {case['temperature']:g} K, {case['pressure']:g} Pa: "
                         f"delay {ignition['delay_s'] * 1e3:.6f} ms vs Cantera {ignition['cantera_delay_s'] * 1e3:.6f} "
                         f"ms: relative error {ignition['delay_relative_error']:.2e}; T history "
                         f"{ignition['temperature_max_relative_error']:.2e}")
        sensitivity = self.sensitivities
        if "skipped" not in sensitivity:
            lines.append(f"  top {len(sensitivity['top'])} d ln T / d ln A at {sensitivity['time_s'] * 1e3:.4f} ms: "
                         f"max relative difference {sensitivity['max_relative_difference']:.2e}, same ranking: "
                         f"{sensitivity['same_ranking']}"
                         + (" (after ignition: at equilibrium every d ln T / d ln A is ~0, so both are solver noise)"
                            if sensitivity["after_ignition"] else ""))
        return "\n".join(lines)


def ignition_case(mechanism: Mechanism, path: str | Path, mixture: str | None, overrides: dict
                  ) -> IgnitionCase | None:
    """The case of `mixture` (default: `default_case`) with `overrides` of its fields.

    **Raises:** `InputError` for a non-positive value, a sensitivity time after the end time, or
    overrides with no mixture to apply them to."""
    for field, value in overrides.items():
        check_range(field, value, 0.0, low_open=True)
    case = default_case(mechanism, path) if mixture is None else IgnitionCase(mixture, 1000.0, ONE_ATM, 1e-3,
                                                                              float("nan"))
    if case is None:
        if overrides:
            raise InputError(f"{', '.join(overrides)} given, but {Path(path).name} has no built-in ignition case "
                             "(no H2/O2 or CH4/O2): give a mixture as well.")
        return None
    if "sensitivity_time" not in overrides and overrides.keys() & {"temperature", "pressure"}:
        # The built-in case's time is late in its own induction; from another start the delay
        # differs (from 2000 K, h2o2 ignites long before it: docs/dev/chemistry_notes.md, Measurements
        # behind the design), and after ignition every
        # d ln T / d ln A is ~0 (the equilibrium temperature does not depend on the rates), so
        # comparing them relatively compares noise. Take 0.9 x the delay instead.
        overrides = {**overrides, "sensitivity_time": float("nan")}
    case = case._replace(**overrides)
    if case.sensitivity_time > case.end_time:
        raise InputError(f"sensitivity_time = {case.sensitivity_time:g} s is after end_time = {case.end_time:g} s.")
    return case


def check_against_cantera(path: str | Path, *, phase: str | None = None, n_states: int = 120, seed: int = 0,
                          mixture: str | None = None, case_overrides: dict | None = None, ignition: bool = True,
                          sensitivities: bool = True, top: int = 10, n_times: int = 51,
                          progress: bool = True) -> KineticsCheck:
    """Compare the mechanism at `path` with Cantera.

    **Arguments:** `n_states` random states for the rates (T in 300-2500 K for a gas, 280-400 K
    for a condensed phase; pressures 1e3-1e7 Pa); the constant-volume adiabatic ignition, saved
    at `n_times` times, of `mixture` (Cantera's mole ratios; default: `default_case`) with any
    `IgnitionCase` field replaced by `case_overrides` (temperature [K], pressure [Pa], end_time
    [s], sensitivity_time [s]); `sensitivities`: the `top` largest d ln T / d ln A_i at the
    case's `sensitivity_time` (default: 0.9 x Cantera's delay).

    **Returns:** a `KineticsCheck` ("ignition" and "sensitivities" say "skipped" and why where
    they do not apply: a condensed phase, or no H2/O2 or CH4/O2 mixture).

    **Raises:** `InputError` for a missing file, an unsupported mechanism, or bad options.
    """
    path = find_file(path)  # a bare name (gri30.yaml) is found as cantera.Solution finds it
    check_count("n_states", n_states, 1)
    check_count("top", top, 1)
    mechanism = Mechanism.from_yaml(path, phase)
    gas = mechanism.thermo_model == "ideal-gas"
    stages = tqdm(total=3, desc=f"kinetics check {path.name}", disable=not progress)
    temperatures = GAS_TEMPERATURES if gas else CONDENSED_TEMPERATURES
    rates = compare_rates(mechanism, path, phase, n_states=n_states, seed=seed, temperature=temperatures)
    result = {
        "mechanism": str(path), "phase": phase, "thermo": mechanism.thermo_model,
        "n_species": mechanism.n_species, "n_reactions": mechanism.n_reactions,
        "rates": {**rates._asdict(), "temperature_range_K": list(temperatures)},
    }
    stages.update()
    case = ignition_case(mechanism, path, mixture, case_overrides or {})
    reason = (None if gas and case is not None else
              "a condensed phase: Cantera runs it only at constant pressure" if not gas else
              "no H2/O2 or CH4/O2 in the mechanism; give a mixture")
    if not ignition or reason:
        result["ignition"] = {"skipped": reason or "not asked for"}
        result["sensitivities"] = {"skipped": reason or "needs the ignition"}
        stages.close()
        return KineticsCheck(**result)
    times = np.linspace(0.0, case.end_time, n_times)
    reference = cantera_ignition(path, case, times, phase=phase)
    concentrations = initial_concentrations(path, case, phase)
    ours = solve_ignition(mechanism, concentrations, case, times)
    result["ignition"] = {
        "case": {key: (value if value == value else None) for key, value in case._asdict().items()},
        "delay_s": ours.delay, "cantera_delay_s": reference.delay,
        "delay_relative_error": abs(ours.delay / reference.delay - 1),
        "temperature_max_relative_error": float(np.max(np.abs(ours.temperature / reference.temperature - 1))),
        "steps": ours.steps, "cantera_steps": reference.steps,
        "definition": "first time T reaches T0 + 400 K, bisected on each solver's interpolant",
    }
    stages.update()
    if not sensitivities:
        result["sensitivities"] = {"skipped": "not asked for"}
        stages.close()
        return KineticsCheck(**result)
    time = case.sensitivity_time if np.isfinite(case.sensitivity_time) else 0.9 * reference.delay
    try:
        ours_sensitivity, _ = call_checked(_exported_sensitivities, mechanism, jnp.asarray(concentrations), case,
                                           float(time), _SENSITIVITY_SETTINGS, what="d ln T / d ln A")
    except SolverFailed as failure:
        raise SolverFailed(f"the reverse pass for d ln T / d ln A at t = {time:g} s gave non-finite values, although "
                           f"the ignition itself solved (delay {ours.delay:g} s, as Cantera's). Close to a fast "
                           "front: give an earlier --sensitivity-time, or --no-sensitivities.") from failure
    cantera_sensitivity, _ = cantera_sensitivities(path, case, time, phase=phase)
    comparison = compare_sensitivities(ours_sensitivity, cantera_sensitivity, top=min(top, mechanism.n_reactions))
    result["sensitivities"] = {
        "quantity": "d ln T(t) / d ln A_i", "time_s": time, "after_ignition": bool(time > reference.delay),
        "solver": _SENSITIVITY_SETTINGS.as_dict(),
        "max_relative_difference": comparison.max_relative_difference, "same_ranking": comparison.same_ranking,
        "top": [{"reaction": int(i), "equation": mechanism.reaction_equations[i], "ours": float(a),
                 "cantera": float(b)} for i, a, b in zip(comparison.indices, comparison.ours, comparison.cantera,
                                                         strict=True)],
    }
    stages.update()
    stages.close()
    return KineticsCheck(**result)
