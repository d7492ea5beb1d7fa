"""The architecture holds: the core imports no domain and the domains never import each other;
inside the core, no room imports a room above it (platform < numerics < solvers < runtime); no
import cycles; pyflakes finds nothing; notebooks import no private module; no module grows past
about 300 lines; and `snapo --help` imports no JAX."""

import ast
import json
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGES = ("snapo_ode", "finance", "chemistry", "snapo_control")
MAX_LINES = 330


def _modules() -> dict[str, pathlib.Path]:
    modules = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            modules[name.removesuffix(".__init__")] = path
    return modules


def _imports(name: str, path: pathlib.Path, modules) -> set[str]:
    """The project modules `name` imports anywhere in its body (function-level imports too)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(parts + ([node.module] if node.module else []))
            candidates = [base] + [f"{base}.{alias.name}" for alias in node.names]
        elif isinstance(node, ast.Import):
            candidates = [alias.name for alias in node.names]
        else:
            continue
        found.update(c for c in candidates if c in modules and c != name)
    return found


@pytest.fixture(scope="module")
def graph():
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def test_layers(graph):
    for name, targets in graph.items():
        top = name.split(".")[0]
        for target in targets:
            other = target.split(".")[0]
            if top == "snapo_ode":
                assert other == "snapo_ode", f"the core module {name} imports the domain module {target}"
            else:
                assert other in (top, "snapo_ode"), f"{name} imports {target}: domains never import each other"


# The core's rooms, lowest first (docs/architecture.md): a module imports only its own room and those below.
ROOMS = ("snapo_ode._platform", "snapo_ode", "snapo_ode._solver", "snapo_ode._runtime")


def _room(module: str) -> int:
    """The room of a core module: its folder, the numerics at the package's root, `cli` the runtime's."""
    if module == "snapo_ode.cli":
        return ROOMS.index("snapo_ode._runtime")
    folder = module.rpartition(".")[0] if module.count(".") > 1 else "snapo_ode"
    return ROOMS.index(folder)


def test_the_core_rooms_import_only_downwards(graph):
    core = [name for name in graph if name.startswith("snapo_ode.")]
    assert {_room(name) for name in core} == set(range(len(ROOMS))), "every room holds modules"
    for name in core:
        for target in graph[name]:
            if target != "snapo_ode":
                assert _room(target) <= _room(name), f"{name} imports {target}, a room above its own"


# The CLI layer: the only modules that see argparse namespaces; past it, requests are typed
# (settings objects and keyword arguments).
CLI_LAYER = ("snapo_ode.cli", "snapo_ode._runtime.options", "snapo_ode._runtime.apart",
             "snapo_ode._runtime.first_result")


def test_argparse_namespaces_stay_in_the_cli_layer():
    for name, path in _modules().items():
        in_cli = name in CLI_LAYER or name.rpartition(".")[2].endswith("_cli")  # a domain's _cli, _fit_cli, ...
        if not in_cli:
            tree = ast.parse(path.read_text())
            imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
            assert "argparse" not in imported and "Namespace" not in path.read_text(), name


# A figure in a docstring or comment goes stale where nobody looks: measurements live in the docs
# pages ("Measurements behind the design") and the bench outputs they come from (issue 34, item 4).
LAB_NOTE = re.compile(r"(?i)measured[^.\n]*\d|\d+(\.\d+)?x (faster|slower)|\d+% (faster|slower)")


def test_docstrings_and_comments_carry_no_measurements():
    for name, path in _modules().items():
        for number, line in enumerate(path.read_text().splitlines(), 1):
            assert not LAB_NOTE.search(line), f"{name}:{number}: a measurement belongs in the docs: {line.strip()}"


def test_no_import_cycles(graph):
    state: dict[str, int] = {}

    def visit(node, trail):
        state[node] = 1
        for target in graph[node]:
            if state.get(target) == 1:
                cycle = trail[trail.index(target):] + [target]
                raise AssertionError(f"import cycle: {' -> '.join(cycle)}")
            if target not in state:
                visit(target, trail + [target])
        state[node] = 2

    for node in graph:
        if node not in state:
            visit(node, [node])


def test_pyflakes_reports_nothing():
    result = subprocess.run([sys.executable, "-m", "pyflakes", *PACKAGES, "tests"], cwd=ROOT, capture_output=True,
                            text=True)
    assert result.stdout + result.stderr == ""


def test_notebooks_import_only_public_modules():
    for path in (ROOT / "notebooks").glob("*.ipynb"):
        for cell in json.loads(path.read_text())["cells"]:
            if cell["cell_type"] != "code":
                continue
            for node in ast.walk(ast.parse("".join(cell["source"]))):
                names = [node.module or ""] if isinstance(node, ast.ImportFrom) else (
                    [alias.name for alias in node.names] if isinstance(node, ast.Import) else [])
                for module in names:
                    assert not any(part.startswith("_") for part in module.split(".")), f"{path.name}: {module}"


def test_modules_stay_small():
    long = {name: lines for name, path in _modules().items() if (lines := len(path.read_text().splitlines())) > MAX_LINES}
    assert not long, f"split these modules by idea: {long}"


def test_the_cli_and_the_packages_import_no_jax():
    script = ("import sys\nfrom snapo_ode.cli import build\nbuild()\n"
              "import finance.gas_storage, chemistry.pharma, snapo_control.pendulum\n"
              "assert 'jax' not in sys.modules, sorted(m for m in sys.modules if 'jax' in m)[:5]")
    subprocess.run([sys.executable, "-c", script], cwd=ROOT, check=True)
