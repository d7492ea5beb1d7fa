# Two commands on a fresh machine with only python3 (>= 3.11): `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-slow wheel-check bench accuracy docs clean

$(STAMP): pyproject.toml requirements.lock
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -r requirements.lock
	$(BIN)/python -m pip install -q --no-deps --no-build-isolation -e .
	touch $(STAMP)

DOCS_STAMP := $(VENV)/.docs-installed

$(DOCS_STAMP): $(STAMP) requirements-docs.lock
	$(BIN)/python -m pip install -q -c requirements.lock -r requirements-docs.lock
	touch $(DOCS_STAMP)

demo: $(STAMP)
	$(BIN)/snapo demo

test: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --dist loadfile -m "not slow" --durations=25

# The tests marked slow (docs/tests.md: the accuracy page's stiff and gradients studies, the
# kinetics bench with a batch, gri30's Rodas5 gradients and concentration Jacobian, the pharma
# design space on two devices, vmapped against one-at-a-time ignition gradients, the five notebooks
# end to end, which `make docs` also executes; ~37 minutes).
test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --dist loadfile -m slow --durations=10

# The package as a library: its wheel installed into a fresh environment with the newest releases
# pyproject.toml's ranges allow, beside python-control (whose import name is `control`), and both
# run from outside the checkout (CI runs it after `make test`).
wheel-check:
	bash .ci/wheel_smoke $(PYTHON)

bench: $(STAMP)
	$(BIN)/snapo bench gas

# Regenerates docs/accuracy.md, its plots and CSVs, each study in a process of its own (on a 2-core
# machine about 50 minutes: stiff 9 min, gradients 36 min, smoothing and Monte Carlo 3 min).
accuracy: $(STAMP)
	$(BIN)/snapo bench accuracy --out docs

# The documentation site into site/ (mkdocs.yml): the Markdown linted first (.pymarkdown.json),
# then built strict, any warning failing it; the API reference generated from the public names;
# the notebooks executed with their plots and rendered at their small size (`make docs
# NOTEBOOKS=full` runs them at the size of the figures in the docs: long); then every link,
# anchor and notebook page of the built site checked (docs/hooks/check_site.py).
docs: $(DOCS_STAMP)
	$(BIN)/pymarkdown --config .pymarkdown.json scan --recurse README.md docs
	NO_MKDOCS_2_WARNING=1 SNAPO_NOTEBOOK_SMALL=$(if $(filter full,$(NOTEBOOKS)),0,1) \
		$(BIN)/mkdocs build --strict

clean:
	rm -rf $(VENV) snapo-out .pytest_cache site .cache
