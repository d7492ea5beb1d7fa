"""Reading a Cantera YAML file into a `Mechanism`: species thermo, reactions, units."""

import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError

from ._equation import Equation, parse_equation
from ._rate_laws import BlowersMasel, Falloff, Orders, RateParameters, ThirdBodies
from ._rate_reader import (arrhenius, blowers_masel, chebyshev_fit, plog_table, sri_parameters, stack_chebyshev,
                           stack_plog, troe_parameters, tsang_parameters)
from ._sources import Sources, find_file, load, naming, phase_species, section_names
from ._thermo_reader import molar_volumes, species_thermo
from ._units import ONE_ATM

_THERMO_MODELS = ("ideal-gas", "ideal-condensed")
_ACTIVITY_BASES = ("unity", "species-molar-volume", "solvent-molar-volume")
_PRESSURE_TYPES = ("pressure-dependent-Arrhenius", "Chebyshev")
_GAS_ONLY_TYPES = (*_PRESSURE_TYPES, "Blowers-Masel")
"""Types that need an ideal gas's pressure or enthalpies."""
_FALLOFF_TYPES = ("falloff", "chemically-activated")
_SUPPORTED_TYPES = ("elementary", "three-body", *_FALLOFF_TYPES, *_GAS_ONLY_TYPES)
_SURFACE_THERMO = ("ideal-surface", "coverage-dependent-surface", "edge")
_SURFACE_KEYS = ("sticking-coefficient", "sticking-species", "Motz-Wise", "coverage-dependencies", "beta",
                 "exchange-current-density-formulation")
_SURFACE_TYPES = ("interface-Arrhenius", "sticking-Arrhenius", "interface-Blowers-Masel", "sticking-Blowers-Masel",
                  "electrochemical")
"""What makes a reaction an interface or edge reaction in Cantera's YAML: refused by name."""
_TYPE_ALIASES = {"three-body-Arrhenius": "three-body", "three-body-Blowers-Masel": "Blowers-Masel",
                 **dict.fromkeys(("Lindemann", "Troe", "Tsang", "SRI"), "falloff")}
"""Cantera's other names for types we read; its type 'Arrhenius' is the one the equation implies."""
_SUPPORTED = ("elementary, three-body, falloff and chemically-activated (Lindemann, Troe, Tsang, SRI), "
              "pressure-dependent-Arrhenius (PLOG), Chebyshev, Blowers-Masel")


def _pick_phase(path, document, phase):
    phases = document.get("phases") or []
    if not phases:
        raise InputError(f"{path} has no 'phases' section.")
    names = [p["name"] for p in phases]
    if phase is None:
        return phases[0]
    if phase not in names:
        raise InputError(f"phase = {phase!r} is not in {path}; phases: {', '.join(names)}.")
    return phases[names.index(phase)]


def _equation(label: str, node, species, declared_only: bool, skip_third_bodies: bool) -> Equation | None:
    """The parsed equation of a reaction the phase keeps, or None for one it leaves out, by
    Cantera's rules: a reaction with a species not in the phase is left out under
    `declared-species` and refused otherwise; one whose specific third body (`(+AR)`) is not in
    the phase is left out under `skip-undeclared-third-bodies: true` and refused otherwise (also
    written as a species on both sides, `H + O2 + AR <=> HO2 + AR`, which Cantera reads as a
    third body)."""
    try:
        equation = parse_equation(str(node["equation"]))
    except ValueError as error:
        raise InputError(f"{label}: {error}.") from None
    undeclared = [name for name in (*equation.reactants, *equation.products) if name not in species]
    if undeclared:
        name = undeclared[0]
        collider = set(undeclared) == {name} and name in equation.reactants and name in equation.products
        if declared_only or (collider and skip_third_bodies):
            return None
        raise InputError(f"{label}: species {undeclared[0]!r} is not in the phase.")
    if equation.collider not in (None, "M", *species):
        if skip_third_bodies:
            return None
        raise InputError(f"{label}: third body {equation.collider!r} is not in the phase; set "
                         "skip-undeclared-third-bodies: true on the phase to leave such reactions out.")
    return equation


def _explicit_collider(label: str, eq: Equation) -> Equation:
    """A three-body reaction written without M (`H + O2 + AR <=> HO2 + AR`, `type: three-body`)
    as Cantera reads it: the one species on both sides is the third body, not a reactant."""
    both = [name for name in eq.reactants if name in eq.products]
    if len(both) != 1:
        raise InputError(f"{label}: a three-body reaction needs M, or exactly one species on both sides as its "
                         f"third body; got {', '.join(both) or 'none'}.")

    def without(side):
        side = {**side, both[0]: side[both[0]] - 1}
        return {name: nu for name, nu in side.items() if nu}

    return eq._replace(reactants=without(eq.reactants), products=without(eq.products), collider=both[0])


class _Reaction:
    """One reaction's numbers, in SI, before they are stacked into arrays."""

    def __init__(self, where, index, node, eq: Equation, species, units, concentration_scaled, skip_third_bodies):
        self.where, self.index, self.equation = where, index, str(node["equation"])
        label = f"{where}: reaction {index} ({self.equation})"
        units = units.within(node)
        declared = node.get("type")
        kind = None if declared == "Arrhenius" else _TYPE_ALIASES.get(declared, declared)
        if kind is None:
            kind = "falloff" if eq.falloff else ("three-body" if eq.collider else "elementary")
        if kind == "three-body" and eq.collider is None:
            eq = _explicit_collider(label, eq)
        surface = [f"field {key!r}" for key in _SURFACE_KEYS if key in node]
        surface += [f"type {kind!r}"] * (kind in _SURFACE_TYPES)
        if surface:
            raise InputError(f"{label}: {surface[0]} belongs to a surface or edge reaction, which is not supported "
                             "(only gas and bulk-phase kinetics are).")
        misplaced = ("rate-constants", "data") if kind not in _PRESSURE_TYPES else ()
        if kind not in _SUPPORTED_TYPES or any(key in node for key in misplaced):
            raise InputError(f"{label}: reaction type {kind!r} is not supported; supported types: {_SUPPORTED}.")
        # Cantera ignores an M on a Chebyshev reaction (deprecated), refuses any other collider there
        # and on a PLOG reaction, and reads a Blowers-Masel one with a third body ('+ M', '+ AR' on
        # both sides) as a three-body reaction with a Blowers-Masel rate.
        if kind in _PRESSURE_TYPES and eq.collider is not None and not (kind == "Chebyshev" and eq.collider == "M"):
            raise InputError(f"{label}: a {kind} reaction with a third body is not supported.")
        if kind == "Blowers-Masel" and eq.falloff:
            # Cantera 3.2 accepts it but applies no third-body concentration: refused, not copied.
            raise InputError(f"{label}: a Blowers-Masel reaction's third body written '(+{eq.collider})' is not "
                             f"supported; write it '+ {eq.collider}' on both sides.")
        self.kind = kind
        self.third_body = kind == "three-body" or (kind == "Blowers-Masel" and eq.collider is not None)
        self.reactants, self.products, self.reversible = eq.reactants, eq.products, eq.reversible
        if node.get("orders") and self.reversible:
            raise InputError(f"{label}: explicit orders are only allowed on irreversible reactions.")
        self.orders = dict(eq.reactants)
        for name, order in (node.get("orders") or {}).items():
            if name not in species:
                raise InputError(f"{label}: orders names species {name!r}, which is not in the phase.")
            if name not in eq.reactants and not node.get("nonreactant-orders", False):
                raise InputError(f"{label}: orders names non-reactant {name!r}; set nonreactant-orders: true.")
            if float(order) < 0 and not node.get("negative-orders", False):
                raise InputError(f"{label}: orders gives {name!r} the negative order {order}; allowed only with "
                                 "negative-orders: true, as in Cantera.")
            self.orders[name] = float(order)
        # Cantera counts a third body in the rate constant's units where it is written '+ M' (or
        # '+ AR'), not where it is written '(+M)'; a Chebyshev reaction's it then ignores.
        written = eq.collider is not None and not eq.falloff and kind in ("three-body", "Blowers-Masel", "Chebyshev")
        order = sum(self.orders.values()) + written
        self.pressure_rate = None
        if kind in _PRESSURE_TYPES:
            read = plog_table if kind == "pressure-dependent-Arrhenius" else chebyshev_fit
            self.pressure_rate = read(label, node, order, units, concentration_scaled)
            self.a, self.b, self.t_a = 0.0, 0.0, 0.0  # unused: the rate is the table's or the fit's
        elif kind == "Blowers-Masel":
            self.a, self.b, self.t_a, self.bond_energy = blowers_masel(label, node.get("rate-constant"), order, units,
                                                                       concentration_scaled)
        else:
            # A chemically-activated rate tends to k_low at low pressure and k_high / [M] at high
            # pressure, so its k_low has the reaction's order and its k_high one less; a falloff
            # rate's k_high has the reaction's order and its k_low one more.
            rate_key = "high-P-rate-constant" if kind in _FALLOFF_TYPES else "rate-constant"
            if rate_key not in node:
                raise InputError(f"{label}: missing {rate_key!r}.")
            high_order = order - 1 if kind == "chemically-activated" else order
            self.a, self.b, self.t_a = arrhenius(label, node[rate_key], high_order, units, concentration_scaled)
        if self.a < 0 and not node.get("negative-A", False):
            raise InputError(f"{label}: A = {self.a} is negative; allowed only with negative-A: true.")
        self.efficiencies = None
        if self.third_body or kind in _FALLOFF_TYPES:
            if eq.collider not in (None, "M"):
                self.efficiencies = {name: 0.0 for name in species}
                self.efficiencies[eq.collider] = 1.0
            else:
                default = float(node.get("default-efficiency", 1.0))
                self.efficiencies = {name: default for name in species}
                for name, value in (node.get("efficiencies") or {}).items():
                    if name in species:
                        self.efficiencies[name] = float(value)
                    elif not skip_third_bodies:
                        raise InputError(f"{label}: efficiency for {name!r}, which is not in the phase; set "
                                         "skip-undeclared-third-bodies: true on the phase to ignore it.")
        if kind in _FALLOFF_TYPES:
            if "low-P-rate-constant" not in node:
                raise InputError(f"{label}: missing 'low-P-rate-constant'.")
            self.low = arrhenius(label, node["low-P-rate-constant"], high_order + 1, units, concentration_scaled)
            # Cantera's type 'Lindemann' ignores any Troe, Tsang or SRI parameters given with it.
            centring = {} if declared == "Lindemann" else node
            given = [key for key in ("Troe", "Tsang", "SRI") if key in centring]
            if len(given) > 1:
                raise InputError(f"{label}: a {kind} reaction has one of Troe, Tsang or SRI parameters; got "
                                 f"{' and '.join(given)}.")
            if declared in ("Troe", "Tsang", "SRI") and declared not in given:
                raise InputError(f"{label}: a reaction of type {declared!r} needs {declared} parameters.")
            self.centring = troe_parameters(centring.get("Troe")) + tsang_parameters(label, centring.get("Tsang"))
            self.sri = sri_parameters(label, centring.get("SRI"))



def _orders(species, rows):
    width = max([len(row) for row in rows] + [1])
    index = np.full((len(rows), width), len(species), np.int32)
    order = np.ones((len(rows), width))
    for i, row in enumerate(rows):
        for j, (name, value) in enumerate(row.items()):
            index[i, j] = species.index(name)
            order[i, j] = value
    return Orders.of(index, order)


def _changed_species(net_stoichiometry: np.ndarray) -> np.ndarray:
    """Each reaction's species with a non-zero net stoichiometric coefficient, padded with
    n_species to the longest row, shape (n_reactions, q)."""
    n_r, n_s = net_stoichiometry.shape
    rows = [np.flatnonzero(row) for row in net_stoichiometry]
    width = max((len(row) for row in rows), default=0)
    changed = np.full((n_r, max(width, 1)), n_s, np.int32)
    for i, row in enumerate(rows):
        changed[i, :len(row)] = row
    return changed


def read_mechanism(cls, path, phase=None):
    """Build `cls` (a `Mechanism`) from phase `phase` of the YAML file at `path`."""
    sources = Sources(load(find_file(path)))
    path = sources.main.path
    phase_node = _pick_phase(path, sources.main.document, phase)
    thermo_model = phase_node.get("thermo")
    where = f"{sources.main.where(phase_node)}: phase {phase_node['name']!r}"
    if thermo_model in _SURFACE_THERMO or phase_node.get("kinetics") in ("surface", "edge"):
        raise InputError(f"{where}: a surface or edge phase (thermo {thermo_model!r}, kinetics "
                         f"{phase_node.get('kinetics')!r}) is not supported; only bulk phases are.")
    if thermo_model not in _THERMO_MODELS:
        raise InputError(f"{where}: thermo = {thermo_model!r} is not supported; "
                         f"supported: {', '.join(_THERMO_MODELS)}.")
    if thermo_model == "ideal-gas":
        basis = "concentration"
    else:
        basis = str(phase_node.get("standard-concentration-basis", "unity"))
        if basis not in _ACTIVITY_BASES:
            raise InputError(f"{where}: standard-concentration-basis = {basis!r}; allowed: "
                             f"{', '.join(_ACTIVITY_BASES)}.")

    species_nodes = phase_species(sources, phase_node)
    species = [str(node["name"]) for _, node in species_nodes]
    if not species:
        raise InputError(f"{where}: no species (neither the phase's `species` nor a `species` section "
                         "lists one); a mechanism needs at least one.")
    volumes = molar_volumes(species_nodes) if thermo_model == "ideal-condensed" else np.zeros(len(species))
    reference_pressure = ONE_ATM
    for source, node in species_nodes:
        if "reference-pressure" in node["thermo"]:
            reference_pressure = source.units.convert("reference-pressure", node["thermo"]["reference-pressure"],
                                                      "pressure")

    reactions = []
    skip_third_bodies = bool(phase_node.get("skip-undeclared-third-bodies", False))
    if phase_node.get("kinetics") not in (None, "none"):
        for reference, which in section_names(phase_node.get("reactions"), "reactions"):
            source, nodes = sources.section(reference)
            for node in nodes:
                where, index = source.where(node), len(reactions)
                label = f"{where}: reaction {index} ({node.get('equation')})"
                with naming(label):
                    equation = _equation(label, node, species, which == "declared", skip_third_bodies)
                    if equation is not None:
                        reactions.append(_Reaction(where, index, node, equation, species, source.units,
                                                   basis != "unity", skip_third_bodies))
    if thermo_model != "ideal-gas" and any(r.reversible for r in reactions):
        first = next(r for r in reactions if r.reversible)
        raise InputError(f"{first.where}: reaction {first.index} ({first.equation}) is reversible in an "
                         "ideal-condensed phase; write it as two irreversible reactions.")
    for r in reactions:
        if thermo_model != "ideal-gas" and r.kind in _GAS_ONLY_TYPES:
            raise InputError(f"{r.where}: reaction {r.index} ({r.equation}): a {r.kind} reaction needs the "
                             "pressure or enthalpies of an ideal-gas phase; it is not supported in an "
                             "ideal-condensed one.")
    thermo = species_thermo(species_nodes)  # device arrays: built once every reaction has been checked
    n_s, n_r = len(species), len(reactions)
    reactant = np.zeros((n_r, n_s))
    product = np.zeros((n_r, n_s))
    for i, r in enumerate(reactions):
        for name, nu in r.reactants.items():
            reactant[i, species.index(name)] = nu
        for name, nu in r.products.items():
            product[i, species.index(name)] = nu
    reversible = np.array([i for i, r in enumerate(reactions) if r.reversible], np.int32)
    three = [r for r in reactions if r.third_body]
    blowers = [r for r in reactions if r.kind == "Blowers-Masel"]
    fall = [r for r in reactions if r.kind in _FALLOFF_TYPES]

    def efficiencies(rows):
        return jnp.asarray(np.array([[r.efficiencies[s] for s in species] for r in rows]).reshape(len(rows), n_s))

    def column(rows, get):
        return jnp.asarray(np.array([get(r) for r in rows], dtype=float).reshape(len(rows)))

    def pressure_rated(kind):
        rows = [r for r in reactions if r.kind == kind]
        return [r.index for r in rows], [r.pressure_rate for r in rows]

    return cls(
        species_names=tuple(species),
        reaction_equations=tuple(r.equation for r in reactions),
        thermo_model=thermo_model,
        activity_basis=basis,
        reference_pressure=reference_pressure,
        thermo=thermo,
        molar_volumes=jnp.asarray(volumes),
        pre_exponential=column(reactions, lambda r: r.a),
        net_stoichiometry=jnp.asarray(product - reactant),
        changed_species=jnp.asarray(_changed_species(product - reactant)),
        forward=_orders(species, [r.orders for r in reactions]),
        reverse=_orders(species, [reactions[i].products for i in reversible]),
        reversible_index=jnp.asarray(reversible),
        blowers_masel=BlowersMasel(jnp.asarray(np.array([r.index for r in blowers], np.int32)),
                                   column(blowers, lambda r: r.bond_energy)),
        three_body=ThirdBodies(jnp.asarray(np.array([r.index for r in three], np.int32)), efficiencies(three)),
        falloff=Falloff(
            jnp.asarray(np.array([r.index for r in fall], np.int32)),
            efficiencies(fall),
            jnp.asarray(np.array([r.kind == "chemically-activated" for r in fall], bool)),
            *(column(fall, lambda r, j=j: r.low[j]) for j in range(3)),
            *(column(fall, lambda r, j=j: r.centring[j]) for j in range(7)),
            *(column(fall, lambda r, j=j: r.sri[j]) for j in range(5)),
        ),
        plog=stack_plog(*pressure_rated("pressure-dependent-Arrhenius")),
        chebyshev=stack_chebyshev(*pressure_rated("Chebyshev")),
        parameters=RateParameters(
            jnp.zeros(n_r),
            column(reactions, lambda r: r.b),
            column(reactions, lambda r: r.t_a),
        ),
    )
