"""mkdocs hook: the home page is the README, and the API reference has one page per public
package, generated from the packages' own lists of public names (`__all__`, `lazy_exports`), so a
name added to the code appears in the reference without anyone editing a page. Each name is
documented from the module that defines it (mkdocstrings); a name that a package re-exports from
another public package links to that package's page."""

import importlib
import importlib.util
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
    """The Markdown of `package`'s page: its docstring, then every public name."""
    module = importlib.import_module(package)
    if not hasattr(module, "__getattr__"):  # a plain module (`snapo_ode.smooth`): all of it
        return f"# `{package}`\n\n{PACKAGES[package]}\n\n::: {package}\n"
    lines = [f"# `{package}`", "", PACKAGES[package], "", f"::: {package}", "    options:", "      members: false", ""]
    for name, home in sorted(definitions(package).items(), key=lambda item: item[0].lower()):
        submodule = f"{package}.{name}"
        owner = max((other for other in PACKAGES if home == other or home.startswith(other + ".")), key=len,
                    default=package)
        if home == package and importlib.util.find_spec(submodule) is not None:
            link = f"[`{submodule}`]({submodule}.md)" if submodule in PACKAGES else f"`{submodule}`"
            lines += [f"## `{name}`", "", f"The submodule {link}.", ""]
        elif owner != package:
            lines += [f"## `{name}`", "", f"Re-exported from [`{owner}`]({owner}.md).", ""]
        else:
            lines += [f"::: {home}.{name}", ""]
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
