# ndbg: every target works on a fresh machine with only Python 3.11 (they run `setup` first).
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: setup browser demo test lint bench clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: setup
	$(BIN)/ndbg analyze assemblies/bell.yaml --html build/bell.html
	@echo "HTML report (opens offline in a browser): $(abspath build/bell.html)"

# the HTML report's browser tests use Debian's chromium: installed here when missing (as root;
# elsewhere, or without apt, those tests skip and say why)
browser:
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 \
	  || (apt-get update -qq && apt-get install -y -qq --no-install-recommends chromium) \
	  || echo "make: chromium not installed: the browser tests will skip"

test: setup browser
	$(BIN)/python -m pytest -q -n auto

lint: setup
	$(BIN)/ruff check ndbg_cli tests benchmarks assemblies
	$(BIN)/lint-imports --no-cache

bench: setup
	$(BIN)/python benchmarks/run.py

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache
