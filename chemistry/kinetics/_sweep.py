"""`snapo kinetics sweep`: every ideal-gas phase of the YAML files shipped with Cantera, read by us
and compared with Cantera (rates of progress, net production rates, species thermo), or refused
with an `InputError` that names the feature."""

import re
import time
from pathlib import Path
from typing import NamedTuple

from snapo_ode import InputError, read_text, read_yaml

from ._crosscheck import RateComparison, compare_rates, compare_thermo
from ._mechanism import Mechanism
from ._units import ONE_ATM

TEMPERATURES = (500.0, 2500.0)
"""The sweep's random temperatures [K]."""
PRESSURES = (0.01 * ONE_ATM, 100.0 * ONE_ATM)
"""The sweep's random pressures [Pa]: 0.01 to 100 atm."""

# A file's top-level `phases:` block, up to the next top-level key: listing the phases this way
# is quick, where parsing every file whole is slow (the large mechanisms, such as
# n-hexane-NUIG-2015.yaml; docs/chemistry.md, Measurements behind the design).
_PHASES_BLOCK = re.compile(r"^phases:[ \t]*\n(.*?)(?=^[A-Za-z_]|\Z)", re.S | re.M)


def cantera_data_directory() -> Path:
    """The data directory installed with the `cantera` package."""
    import cantera

    return Path(cantera.__file__).parent / "data"


def ideal_gas_phases(paths: list[Path]) -> list[tuple[Path, str]]:
    """(file, phase name) of every phase with `thermo: ideal-gas` in the YAML files `paths`, in
    their order."""
    phases = []
    for path in paths:
        block = _PHASES_BLOCK.search(read_text(path, "mechanism"))
        for node in read_yaml(block.group(1), f"mechanism file {path}") if block else []:
            if node.get("thermo") == "ideal-gas":
                phases.append((path, str(node["name"])))
    return phases


class PhaseSweep(NamedTuple):
    """One phase against Cantera: the `file` (relative to the swept directory) and `phase`; if we
    read it, its size, `rates` (`RateComparison`), `thermo` (largest error of cp/R, h/RT and s/R,
    `compare_thermo`) and the `seconds` taken (reading, compiling, comparing); if we refuse it,
    the `InputError`'s message as `refused`."""

    file: str
    phase: str
    n_species: int | None = None
    n_reactions: int | None = None
    rates: RateComparison | None = None
    thermo: float | None = None
    seconds: float | None = None
    refused: str | None = None

    @property
    def max_error(self) -> float:
        """The largest relative error of the rates of progress and net production rates."""
        return max(self.rates.rates_of_progress, self.rates.net_production)


def sweep_phase(path: Path, phase: str, *, n_states: int = 4, seed: int = 0) -> PhaseSweep:
    """Read `phase` of `path` and compare it with Cantera at `n_states` random states (T in
    `TEMPERATURES`, P in `PRESSURES`, random compositions), or record our refusal. The file is
    named relative to Cantera's data directory when it is in it.

    **Raises:** whatever is not an `InputError` (a crash, or `ValueError` when Cantera reads
    other species or reactions): those are defects, not refusals."""
    data = cantera_data_directory()
    name = str(path.relative_to(data)) if path.is_relative_to(data) else str(path)
    start = time.perf_counter()
    try:
        mechanism = Mechanism.from_yaml(path, phase)
    except InputError as error:
        return PhaseSweep(name, phase, refused=str(error))
    rates = compare_rates(mechanism, path, phase, n_states=n_states, seed=seed, temperature=TEMPERATURES,
                          pressure=PRESSURES)
    thermo = compare_thermo(mechanism, path, phase, n_states=n_states, seed=seed, temperature=TEMPERATURES)
    return PhaseSweep(name, phase, mechanism.n_species, mechanism.n_reactions, rates, thermo,
                      time.perf_counter() - start)


def markdown_table(results: list[PhaseSweep]) -> str:
    """The sweep as a Markdown table: loaded (size, largest relative errors) or refused (why)."""
    lines = ["| file | phase | species | reactions | result |", "| --- | --- | --- | --- | --- |"]
    for r in results:
        if r.refused is not None:
            # The message without the file's path and the list of what is supported.
            reason = (r.refused.split(": ", 1)[-1] if r.refused.startswith("/") else r.refused).split("; supported")[0]
            lines.append(f"| {r.file} | {r.phase} | | | refused: {reason} |")
        elif r.n_reactions == 0:
            lines.append(f"| {r.file} | {r.phase} | {r.n_species} | 0 | loaded (no kinetics); thermo "
                         f"{r.thermo:.1e} |")
        else:
            lines.append(f"| {r.file} | {r.phase} | {r.n_species} | {r.n_reactions} | loaded: rates "
                         f"{r.max_error:.1e}, thermo {r.thermo:.1e} |")
    return "\n".join(lines)


def as_json(results: list[PhaseSweep], *, n_states: int, seed: int) -> dict:
    """The sweep's JSON (`snapo kinetics sweep --json`): the random states' count and seed, and one
    entry per phase with `PhaseSweep`'s fields (`rates` as its `RateComparison` fields; the
    fields that do not apply, null)."""
    phases = [{**result._asdict(), "rates": result.rates and result.rates._asdict()} for result in results]
    return {"states": n_states, "seed": seed, "phases": phases}


def sweep(paths: list[Path] | None = None, *, n_states: int = 4, seed: int = 0) -> list[PhaseSweep]:
    """`sweep_phase` on every ideal-gas phase of the YAML files `paths` (default: every `*.yaml`
    under Cantera's data directory)."""
    paths = sorted(cantera_data_directory().rglob("*.yaml")) if paths is None else [Path(p) for p in paths]
    return [sweep_phase(path, phase, n_states=n_states, seed=seed) for path, phase in ideal_gas_phases(paths)]
