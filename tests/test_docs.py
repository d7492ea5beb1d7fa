"""The documentation holds together without building it (`make docs` builds it, strict, in CI):
the API reference names every public name of every public package, grouped; every page is in the
site's navigation; the README stays a first page (<= 120 lines, `pip install` on its first
screen) and its links lead somewhere; and the checks `make docs` runs on the built site catch
what they are for."""

import importlib.util
import pathlib
import re
import sys
import types

ROOT = pathlib.Path(__file__).resolve().parent.parent


def _hook(name="api_pages"):
    spec = importlib.util.spec_from_file_location(name, ROOT / "docs" / "hooks" / f"{name}.py")
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
            assert f"::: {home}.{name}\n" in text or f"### `{name}`\n" in text, (package, name)
    # a re-export is linked, not documented twice; a name defined in the package itself is documented
    assert "Re-exported from [`snapo_ode`](snapo_ode.md)" in hook.page("chemistry")
    assert "::: chemistry.MECHANISMS\n" in hook.page("chemistry")
    assert "::: chemistry.kinetics._mechanism.Mechanism\n" in hook.page("chemistry")
    # grouped by task, the groups a user starts with first: the solve, then its sensitivities
    core = hook.page("snapo_ode")
    assert "## Sensitivities\n" in core and "## Verification\n" in core
    assert core.index("::: snapo_ode._ode.diffeqsolve_checked") < core.index("::: snapo_ode._sensitivity.jacobian") \
        < core.index("::: snapo_ode._runtime.accuracy.AccuracyStudy")


def test_every_page_is_in_the_navigation_and_every_generated_page_too():
    config = (ROOT / "mkdocs.yml").read_text()
    listed = set(re.findall(r":\s+(\S+\.(?:md|ipynb))\s*$", config, re.M))
    pages = {path.relative_to(ROOT / "docs").as_posix() for path in (ROOT / "docs").rglob("*.md")
             if not path.relative_to(ROOT / "docs").parts[0] == "notebooks"}
    notebooks = {f"notebooks/{path.name}" for path in (ROOT / "notebooks").glob("*.ipynb")}
    generated = {"index.md"} | {f"api/{package}.md" for package in _hook().PACKAGES}
    assert listed == pages | notebooks | generated


def test_the_readme_is_a_first_page_and_its_links_lead_somewhere():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 120
    assert "pip install ." in "\n".join(readme.splitlines()[:40])  # on the first screen
    assert "make demo\nmake test\n" in readme  # the quickstart CI runs (`.ci/run`: `make test`)
    for target in re.findall(r"\]\(([^)#]+)\)", readme):
        assert target.startswith("https://") or (ROOT / target).exists(), target


def test_the_site_checks_find_what_they_are_for(tmp_path):
    check = _hook("check_site")
    # Markdown that renders as something else, each class once, and what is fine
    broken = ("| a | b |\n| --- | --- |\n| 1 | 2 |\nswallowed by the table\n\n"
              "a paragraph\n- rendered as text\n\nsee [the bound](m) and [a page](gas_storage.md#run-your-own)\n"
              "```text\n| a |\nnot a table\n```\n")
    problems = check.markdown_problems(broken)
    assert [problem.split(":")[0] for problem in problems] == ["line 4", "line 7", "line 9"], problems
    assert check.markdown_problems("text\n\n- a list\n- of two\n\n| a |\n| --- |\n\nafter\n") == []
    assert check.lab_note_problems("as in issue 32, a /tmp/ script\nissues 3") == [
        "line 1: 'issue 32' belongs in the development notes", "line 1: '/tmp/' belongs in the development notes"]
    # a built site: a link to a missing page and to a missing anchor; a notebook page without an
    # image and with a stderr box
    (tmp_path / "page").mkdir()
    (tmp_path / "page" / "index.html").write_text('<h2 id="here">x</h2><a href="../gone/">x</a><a href="#there">y</a>'
                                                  '<a href="#here">z</a><a href="https://example.org/">w</a>')
    (tmp_path / "notebook").mkdir()
    (tmp_path / "notebook" / "index.html").write_text(
        '<div data-mime-type="application/vnd.jupyter.stderr"><pre>TqdmWarning</pre></div><a href="../page/#here">p</a>')
    assert check.link_problems(tmp_path) == ["page/index.html: link '../gone/' leads to no file of the site",
                                             "page/index.html: link '#there' names no anchor of its page"]
    assert check.notebook_problems(tmp_path, ["notebook/index.html"]) == [
        "notebook/index.html: no image (is the kernel's matplotlib backend the inline one?)",
        "notebook/index.html: 1 output(s) written to stderr"]
    (tmp_path / "notebook" / "index.html").write_text('<img src="data:image/png;base64,AAAA">')
    assert check.notebook_problems(tmp_path, ["notebook/index.html"]) == []


def test_the_api_pages_render_the_docstrings_lists_as_lists(monkeypatch):
    if importlib.util.find_spec("griffe") is None:  # `make test` has no docs packages: the base class only
        monkeypatch.setitem(sys.modules, "griffe", types.SimpleNamespace(Extension=object))
    lists = _hook("docstring_lists")
    docstring = ("Solve it.\n\n**Arguments:**\n- `fn`: the model,\n  over two lines.\n- `mode`: how:\n"
                 "  - \"reverse\": one pass.\n\n```python\n- not a list\n```")
    assert lists.as_markdown_lists(docstring) == (
        "Solve it.\n\n**Arguments:**\n\n- `fn`: the model,\n  over two lines.\n- `mode`: how:\n"
        "    - \"reverse\": one pass.\n\n```python\n- not a list\n```")
