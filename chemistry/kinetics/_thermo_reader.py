"""Reading the species of a phase into `SpeciesThermo` (NASA7, constant-cp, NASA9, Shomate) and, in an
ideal-condensed phase, their molar volumes (constant-volume equation of state), as Cantera reads
them."""

import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError

from ._sources import Source, naming
from ._thermo import Nasa9, SpeciesThermo
from ._units import GAS_CONSTANT

_MODELS = "'NASA7', 'constant-cp', 'NASA9', 'Shomate'"


def _polynomials(label: str, thermo, model: str, width: int):
    """(ranges [K], coefficient rows) of a NASA7 or NASA9 `thermo` mapping, checked."""
    data = [list(map(float, row)) for row in thermo["data"]]
    ranges = list(map(float, thermo["temperature-ranges"]))
    counts = "one or more sets" if model == "NASA9" else "one or two sets"
    if (not data or (model != "NASA9" and len(data) > 2) or len(ranges) != len(data) + 1
            or any(len(row) != width for row in data)):
        raise InputError(f"{label} {model} needs {counts} of {width} coefficients and one more temperature-ranges "
                         f"entry; got {[len(row) for row in data]} coefficients and {len(ranges)} temperatures.")
    if any(upper <= lower for lower, upper in zip(ranges, ranges[1:])):
        raise InputError(f"{label} {model} temperature-ranges {ranges} must increase.")
    return ranges, data


def _shomate_as_nasa9(ranges: list[float], data: list[list[float]]):
    """Shomate polynomials (A..G in t = T/1000 [K], cp in J/mol/K, h in kJ/mol, as NIST and
    Cantera write them) as the same functions of T in NASA9 form. Cantera takes the low range at
    T <= T_mid, where NASA9 takes the high one: the boundary moves up by one ulp."""
    per_r = 1e3 / GAS_CONSTANT  # [mol K/J]
    rows = [[e * 1e6 * per_r, 0.0, a * per_r, b * 1e-3 * per_r, c * 1e-6 * per_r, d * 1e-9 * per_r, 0.0,
             f * 1e3 * per_r, (g - a * np.log(1e3)) * per_r] for a, b, c, d, e, f, g in data]
    return [ranges[0], *np.nextafter(ranges[1:-1], np.inf), ranges[-1]], rows


def _stack_nasa9(index: list[int], polynomials: list) -> Nasa9 | None:
    if not index:
        return None
    n_ranges = max(len(data) for _, data in polynomials)
    boundaries = np.full((len(index), n_ranges - 1), np.inf)
    coefficients = np.zeros((len(index), n_ranges, 9))
    for row, (ranges, data) in enumerate(polynomials):
        boundaries[row, :len(data) - 1] = ranges[1:-1]
        coefficients[row, :len(data)] = data
    return Nasa9(jnp.asarray(np.array(index, np.int32)), jnp.asarray(boundaries), jnp.asarray(coefficients))


def species_thermo(species_nodes: list[tuple[Source, dict]]) -> SpeciesThermo:
    """`SpeciesThermo` of the species nodes, in their order.

    **Raises:** `InputError` naming the file, line and species for a thermo model other than
    NASA7, constant-cp, NASA9 and Shomate, or polynomials of the wrong shape."""
    n = len(species_nodes)
    is_nasa = np.zeros(n, bool)
    t_mid = np.full(n, 1000.0)
    low, high = np.zeros((n, 7)), np.zeros((n, 7))
    t0, h0, s0, cp0 = np.full(n, 298.15), np.zeros(n), np.zeros(n), np.zeros(n)
    nasa9_index, nasa9 = [], []
    fitted_up_to = []  # each fitted species' hottest range end [K]
    for k, (source, node) in enumerate(species_nodes):
        with naming(f"{source.where(node)}: species {node.get('name')!r}"):
            name, units = node["name"], source.units.within(node)
            label = f"{source.where(node)}: species {name!r}:"
            thermo = node.get("thermo")
            model = thermo.get("model") if thermo else None
            if model == "NASA7":
                ranges, data = _polynomials(label, thermo, model, 7)
                fitted_up_to.append(ranges[-1])
                is_nasa[k] = True
                low[k] = data[0]
                high[k] = data[-1]
                t_mid[k] = ranges[1] if len(data) == 2 else ranges[-1]
            elif model in ("NASA9", "Shomate"):
                ranges, data = _polynomials(label, thermo, model, 9 if model == "NASA9" else 7)
                fitted_up_to.append(ranges[-1])
                nasa9_index.append(k)
                nasa9.append((ranges, data) if model == "NASA9" else _shomate_as_nasa9(ranges, data))
            elif model == "constant-cp":
                units = units.within(thermo)
                t0[k] = units.convert(f"species {name} T0", thermo.get("T0", 298.15), "temperature")
                for values, key, dimension in ((h0, "h0", "energy/quantity"), (s0, "s0", "energy/quantity/temperature"),
                                               (cp0, "cp0", "energy/quantity/temperature")):
                    values[k] = units.convert(f"species {name} {key}", thermo.get(key, 0.0), dimension) / GAS_CONSTANT
            else:
                raise InputError(f"{source.where(node)}: species {name!r} has thermo model {model!r}; "
                                 f"supported: {_MODELS}.")
    return SpeciesThermo(jnp.asarray(is_nasa), jnp.asarray(t_mid), jnp.asarray(low), jnp.asarray(high),
                         jnp.asarray(t0), jnp.asarray(h0), jnp.asarray(s0), jnp.asarray(cp0),
                         _stack_nasa9(nasa9_index, nasa9), max(fitted_up_to, default=float("inf")))


def _molecular_weight(source: Source, node) -> float:
    """[kg/kmol]: the composition's atomic weights, from the file's own `elements` section or
    Cantera's table, as Cantera weighs a species."""
    import cantera

    custom = {str(e["symbol"]): float(e["atomic-weight"]) for e in source.document.get("elements") or []}
    weight = 0.0
    for element, count in (node.get("composition") or {}).items():
        try:
            atomic = custom[element] if element in custom else cantera.Element(str(element)).weight
        except cantera.CanteraError:
            raise InputError(f"{source.where(node)}: species {node['name']!r}: element {element!r} has no "
                             "atomic weight, which its density needs.") from None
        weight += float(count) * atomic
    return weight


def molar_volumes(species_nodes: list[tuple[Source, dict]]) -> np.ndarray:
    """[m^3/kmol] of the species of an ideal-condensed phase, shape `(n,)`, from each one's
    constant-volume equation of state: `density` (with the molecular weight), else
    `molar-density`, else `molar-volume`, the order in which Cantera looks for them.

    **Raises:** `InputError` naming the file, line and species without one of them."""
    volumes = np.zeros(len(species_nodes))
    for k, (source, node) in enumerate(species_nodes):
        with naming(f"{source.where(node)}: species {node.get('name')!r}"):
            name, units = node["name"], source.units.within(node)
            eos = node.get("equation-of-state") or {}
            # Cantera also takes a list of models and uses the constant-volume one.
            eos = next((e for e in eos if e.get("model") == "constant-volume"), {}) if isinstance(eos, list) else eos
            if eos.get("model") != "constant-volume" or not {"density", "molar-density", "molar-volume"} & set(eos):
                raise InputError(f"{source.where(node)}: species {name!r} needs an equation-of-state {{model: "
                                 "constant-volume, molar-volume (or molar-density, or density): ...}} in an "
                                 "ideal-condensed phase.")
            units = units.within(eos)
            if "density" in eos:
                volumes[k] = _molecular_weight(source, node) / units.convert(f"species {name} density", eos["density"],
                                                                             "mass/length^3")
            elif "molar-density" in eos:
                volumes[k] = 1.0 / units.convert(f"species {name} molar-density", eos["molar-density"],
                                                 "quantity/length^3")
            else:
                volumes[k] = units.convert(f"species {name} molar-volume", eos["molar-volume"], "length^3/quantity")
    return volumes
