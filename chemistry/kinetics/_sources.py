"""The YAML files a phase draws on: its own and those its `species` and `reactions` fields name
(`gri30.yaml/species: [H2, O2]`), each with its own units, and the species nodes the phase
selects, as Cantera selects them."""

from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

from ruamel.yaml import YAML, YAMLError

from snapo_ode import InputError, check_cantera_yaml, read_text

from ._units import UnitSystem


class Source(NamedTuple):
    """One YAML file: its `path`, parsed `document` (line numbers kept) and its `units`."""

    path: Path
    document: dict
    units: UnitSystem

    def where(self, node) -> str:
        """`path:line` of `node` in this file (the path alone where the line is unknown)."""
        line = getattr(getattr(node, "lc", None), "line", None)
        return f"{self.path}:{line + 1}" if line is not None else str(self.path)


@contextmanager
def naming(label: str):
    """Inside it, a node of the wrong shape (a KeyError, TypeError, ... from reading it) raises an
    `InputError` that names `label` (file, line and what the node is) instead."""
    try:
        yield
    except InputError:
        raise
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as error:
        raise InputError(f"{label}: malformed or unsupported content ({type(error).__name__}: {error}).") from error


def load(path: Path) -> Source:
    """The `Source` of the YAML file at `path`.

    **Raises:** `InputError` for a missing or oversized file, invalid YAML or non-UTF-8 text, a
    bound of `snapo_ode.check_cantera_yaml` passed (aliases that never end or expand the file past
    10 times its size, deep nesting, huge values: the file is checked by it before Cantera reads
    it), or a document that is not a mapping."""
    if not path.is_file():
        raise InputError(f"mechanism path {str(path)!r} is not a file.")
    text = read_text(path, "mechanism")
    # The round-trip loader keeps line numbers, which unsupported-reaction errors cite.
    try:
        check_cantera_yaml(text, f"mechanism file {path}")
        document = YAML(typ="rt").load(text)
    except YAMLError as error:
        raise InputError(f"mechanism file {path}: not valid YAML: {' '.join(str(error).split())}") from None
    except RecursionError:
        raise InputError(f"mechanism file {path}: nested too deeply to read.") from None
    if not isinstance(document, dict):
        raise InputError(f"mechanism file {path}: expected a YAML mapping with a 'phases' section.")
    return Source(path, document, UnitSystem(document.get("units")))


def checked_file(name: str | Path) -> Path:
    """`find_file(name)`, read through `load` (bounded, no aliases) so that Cantera can be handed it.

    **Raises:** `InputError` as `find_file` and `load` do."""
    path = find_file(name)
    load(path)
    return path


def _data_directories() -> list[Path]:
    import cantera

    return [Path(directory) for directory in cantera.get_data_directories()]


def find_file(name: str | Path) -> Path:
    """Where `cantera.Solution(name)` finds the file `name`: as given if it is a file there (a
    path relative to the working directory, or absolute), else a relative name in Cantera's data
    directories (`gri30.yaml`, `example_data/ohn.yaml`).

    **Raises:** `InputError` if it is in neither."""
    path = Path(name)
    if path.is_file():
        return path
    if not path.is_absolute():
        for directory in _data_directories():
            if (directory / path).is_file():
                return directory / path
    raise InputError(f"mechanism path {str(name)!r} is not a file, nor one in Cantera's data directories "
                     f"({', '.join(map(str, _data_directories()))}).")


def _included_file(parent: Path, name: str) -> Path:
    """Where Cantera finds the file `name` that `parent` refers to: next to `parent`, else in
    Cantera's data directories."""
    if (parent.parent / name).is_file():
        return parent.parent / name
    try:
        return find_file(name)
    except InputError:
        raise InputError(f"{parent}: the file {name!r} it refers to is neither next to it nor in Cantera's data "
                         f"directories.") from None


class Sources:
    """The files one phase reads from, each loaded once, starting from the phase's own file."""

    def __init__(self, main: Source):
        self.main = main
        self._loaded = {main.path: main}

    def section(self, reference: str) -> tuple[Source, list]:
        """The file and the list of nodes of a section reference: `name` (a section of the main
        file) or `file.yaml/name` (a section of another file). A missing section is empty."""
        file_name, _, name = reference.rpartition("/")
        source = self.main
        if file_name:
            path = _included_file(self.main.path, file_name)
            if path not in self._loaded:
                self._loaded[path] = load(path)
            source = self._loaded[path]
        return source, list(source.document.get(name) or [])


def section_names(value, default_section: str) -> list[tuple[str, object]]:
    """The (section reference, "all", "declared" or a list of names) pairs a phase's `species`
    or `reactions` field refers to; "none" refers to none."""
    if value is None or value == "all":
        return [(default_section, "all")]
    if isinstance(value, str):
        return [] if value == "none" else [(default_section, "declared")] if value == "declared-species" else [
            (value, "all")]
    if all(isinstance(item, str) for item in value):
        if default_section == "species":
            return [("species", list(value))]
        return [(item, "all") for item in value]
    sections = []
    for item in value:
        for section, names in item.items():
            if names == "none":
                continue
            sections.append((section, "declared" if names == "declared-species" else names))
    return sections


def phase_species(sources: Sources, phase_node) -> list[tuple[Source, dict]]:
    """The species nodes of the phase, each with its file, in Cantera's order. With the phase's
    `elements` given, a species with another element is left out under
    `skip-undeclared-elements: true`, as in Cantera, and refused otherwise.

    **Raises:** `InputError` naming a species that is not in its section, a species given twice,
    or a species with an undeclared element."""
    phase = phase_node["name"]
    elements = phase_node.get("elements")
    skip = bool(phase_node.get("skip-undeclared-elements", False))
    chosen, seen = [], set()
    for reference, names in section_names(phase_node.get("species"), "species"):
        source, nodes = sources.section(reference)
        by_name = {str(node["name"]): node for node in nodes}
        for name in list(by_name) if names == "all" else [str(name) for name in names]:
            if name not in by_name:
                raise InputError(f"{sources.main.where(phase_node)}: species {name!r} of phase {phase!r} is not in "
                                 f"section {reference!r}.")
            node = by_name[name]
            undeclared = sorted(set(node.get("composition") or {}) - set(elements)) if elements is not None else []
            if undeclared:
                if skip:
                    continue
                raise InputError(f"{source.where(node)}: species {name!r} contains element {undeclared[0]!r}, which "
                                 f"is not in phase {phase!r}'s elements [{', '.join(map(str, elements))}]; add it "
                                 "there, or set skip-undeclared-elements: true to leave such species out.")
            if name in seen:
                raise InputError(f"species {name!r} is given twice in phase {phase!r}.")
            seen.add(name)
            chosen.append((source, node))
    return chosen
