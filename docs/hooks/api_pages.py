"""mkdocs hook: the home page is the README, and the API reference has one page per public
package, generated from the packages' own lists of public names (`__all__`, `lazy_exports`), so a
name added to the code appears in the reference without anyone editing a page. The names are
grouped by task: one section per module that defines them (modules hold one idea each), titled by
the module docstring's first phrase, the groups a user starts with first. Each name is documented
from its module (mkdocstrings: signature and docstring); a name that a package re-exports from
another public package links to that package's page."""

import importlib
import importlib.util
import re
from pathlib import Path


# The public packages, in the order of the site's navigation, with what each page is about.
PACKAGES = {
    "snapo_ode": "The domain-free core: surrogates, effects, policies, rollouts, solvers, sensitivities, "
                 "verification, training, results, reports and the command line.",
    "snapo_ode.smooth": "Smooth surrogates of hard constraints, each with its exact counterpart.",
    "snapo_ode.cli": "The `snapo` command line, and how a domain plugs its verbs into it.",
    "finance.gas_storage": "Natural-gas storage.",
    "finance.alm": "Pension-fund asset-liability management.",
    "chemistry": "Kinetics and reactors (`chemistry.kinetics`, re-exported by `chemistry`).",
    "chemistry.pharma": "The pharmaceutical chain and its ICH Q8 study.",
    "snapo_control.pendulum": "Pendulum-v1 with a periodic state.",
}


# The modules whose groups open a page, in this order; the others follow in the package's own order.
FIRST = ("snapo_ode._platform.config", "snapo_ode._ode", "snapo_ode._solver.settings", "snapo_ode._sensitivity",
         "snapo_ode._verification", "snapo_ode._training", "snapo_ode._policy", "snapo_ode._rollout",
         "snapo_ode._effects", "snapo_ode._periodic", "snapo_ode._runtime.results", "snapo_ode._platform.validation")


def title(module_name: str) -> str:
    """A group's heading: the first phrase of the module's docstring (up to a colon or the end of
    its first sentence), or the module's name."""
    text = " ".join((importlib.import_module(module_name).__doc__ or "").split())
    phrase = re.split(r"(?<=[^.])\. |: |\.$", text, maxsplit=1)[0].strip().rstrip(".")
    if len(phrase) > 60:  # a long first phrase: its head, before a parenthesis, comma or semicolon
        head = re.split(r" \(|, |; ", phrase, maxsplit=1)[0]
        phrase = head if head.count("[") == head.count("]") else phrase
    if len(phrase) > 70:
        phrase = phrase[:70].rsplit(" ", 1)[0] + " ..."
    if not phrase:
        return module_name
    return phrase[0].upper() + phrase[1:]


def definitions(package: str) -> dict[str, str]:
    """Public name -> the module that defines it, following re-exports through lazy packages
    (`chemistry.Mechanism` -> `chemistry.kinetics._mechanism`); a name defined in the package's
    `__init__` itself maps to the package."""
    module = importlib.import_module(package)
    where = dict(getattr(module.__getattr__, "modules", {}))
    found = {}
    for name in module.__all__:
        home = where.get(name, package)
        while (lazy := getattr(getattr(importlib.import_module(home), "__getattr__", None), "modules", {})) \
                and name in lazy:
            home = lazy[name]
        found[name] = home
    return found


def page(package: str) -> str:
    """The Markdown of `package`'s page: its docstring, then every public name, grouped by task."""
    module = importlib.import_module(package)
    if not hasattr(module, "__getattr__"):  # a plain module (`snapo_ode.smooth`): all of it
        return f"# `{package}`\n\n{PACKAGES[package]}\n\n::: {package}\n"
    lines = [f"# `{package}`", "", PACKAGES[package], "", f"::: {package}", "    options:", "      members: false", ""]
    groups: dict[str, list[str]] = {}
    for name, home in definitions(package).items():
        submodule = f"{package}.{name}"
        owner = max((other for other in PACKAGES if home == other or home.startswith(other + ".")), key=len,
                    default=package)
        if home == package and importlib.util.find_spec(submodule) is not None:
            link = f"[`{submodule}`]({submodule}.md)" if submodule in PACKAGES else f"`{submodule}`"
            entry = f"### `{name}`\n\nThe submodule {link}.\n"
            home = "submodules"
        elif owner != package:
            entry = f"### `{name}`\n\nRe-exported from [`{owner}`]({owner}.md).\n"
            home = f"re-exported from {owner}"
        else:
            entry = f"::: {home}.{name}\n    options:\n      heading_level: 3\n"
        groups.setdefault(home, []).append(entry)
    order = sorted(groups, key=lambda home: (FIRST.index(home) if home in FIRST else len(FIRST),
                                             home.startswith(("submodules", "re-exported"))))
    for home in order:
        heading = ("Submodules" if home == "submodules" else home.capitalize() if home.startswith("re-exported")
                   else title(home))
        lines += [f"## {heading}", ""] + groups[home]
    return "\n".join(lines)


def on_files(files, config):
    """Add the home page (the README, its links made relative to the documentation) and
    `api/PACKAGE.md` for every public package."""
    from mkdocs.structure.files import File  # here: the tests read the pages without mkdocs

    readme = (Path(config.config_file_path).parent / "README.md").read_text()
    home = readme.replace("](docs/", "](").replace("](notebooks/)", "](notebooks/01_gas_storage.ipynb)")
    files.append(File.generated(config, "index.md", content=home))
    for package in PACKAGES:
        files.append(File.generated(config, f"api/{package}.md", content=page(package)))
    return files
