"""The documentation holds together without building it (`make docs` builds it, strict, in CI):
the API reference names every public name of every public package, every page is in the site's
navigation, the README stays a first page (<= 200 lines) and its links lead somewhere."""

import importlib.util
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parent.parent


def _hook():
    spec = importlib.util.spec_from_file_location("api_pages", ROOT / "docs" / "hooks" / "api_pages.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_api_reference_names_every_public_name():
    hook = _hook()
    for package in hook.PACKAGES:
        module = importlib.import_module(package)
        text = hook.page(package)
        if not hasattr(module, "__getattr__"):
            assert f"::: {package}\n" in text
            continue
        for name, home in hook.definitions(package).items():
            assert f"::: {home}.{name}\n" in text or f"## `{name}`\n" in text, (package, name)
    # a re-export is linked, not documented twice; a name defined in the package itself is documented
    assert "Re-exported from [`snapo_ode`](snapo_ode.md)" in hook.page("chemistry")
    assert "::: chemistry.MECHANISMS\n" in hook.page("chemistry")
    assert "::: chemistry.kinetics._mechanism.Mechanism\n" in hook.page("chemistry")


def test_every_page_is_in_the_navigation_and_every_generated_page_too():
    config = (ROOT / "mkdocs.yml").read_text()
    listed = set(re.findall(r":\s+(\S+\.(?:md|ipynb))\s*$", config, re.M))
    pages = {path.relative_to(ROOT / "docs").as_posix() for path in (ROOT / "docs").glob("*.md")}
    notebooks = {f"notebooks/{path.name}" for path in (ROOT / "notebooks").glob("*.ipynb")}
    generated = {"index.md"} | {f"api/{package}.md" for package in _hook().PACKAGES}
    assert listed == pages | notebooks | generated


def test_the_readme_is_a_first_page_and_its_links_lead_somewhere():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 200
    assert "make demo\nmake test\n" in readme  # the quickstart CI runs (`.ci/run`: `make test`)
    for target in re.findall(r"\]\(([^)#]+)\)", readme):
        assert (ROOT / target).exists(), target
