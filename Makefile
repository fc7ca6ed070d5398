# ndbg: every target works on a fresh machine with only Python 3.11 (they run `setup` first).
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: setup bytecode browser demo test lint bench fuzz invariance clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

# ndbg's own bytecode, as a regular (non-editable) install would have it: with
# PYTHONDONTWRITEBYTECODE set, every run would otherwise compile the package from source
# (0.3-0.5 s of each command on a 2-core machine). Up-to-date files are skipped. Then the
# infinite-translation kernels compiled ahead of time with the machine's C compiler (about
# 40 s, once and after each change of their source), which spares every run numba's start
# (0.5 s); should that fail, the kernels run just in time and every command still works.
bytecode: setup
	@$(BIN)/python -m compileall -q ndbg_cli
	@$(BIN)/python -m ndbg_cli.kernels || true

demo: bytecode
	$(BIN)/ndbg analyze assemblies/bell.yaml --html build/bell.html
	@echo "HTML report (opens offline in a browser): $(abspath build/bell.html)"

# the HTML report's browser tests use Debian's chromium: installed here when missing (as root;
# elsewhere, or without apt, those tests skip and say why)
browser:
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 \
	  || (apt-get update -qq && apt-get install -y -qq --no-install-recommends chromium) \
	  || echo "make: chromium not installed: the browser tests will skip"

test: bytecode browser
	$(BIN)/python -m pytest -q -n auto

lint: setup
	$(BIN)/ruff check ndbg_cli tests benchmarks assemblies
	$(BIN)/lint-imports --no-cache

bench: bytecode
	$(BIN)/python benchmarks/run.py

# the fuzzing campaign (tests/fuzz_campaign.py): FUZZ_CASES cases (default 10,000; about half
# an hour on 2 cores), FUZZ_JOBS fork servers (default 2), FUZZ_SEED; prints the counts of
# each outcome and fails on any traceback, timeout, signal, partial file or invalid report.
# A fixed-seed slice of it runs in `make test` (tests/test_fuzz_campaign.py).
fuzz: bytecode
	$(BIN)/python tests/fuzz_campaign.py

# the invariance table (issue 34): every example and ../shared/data model under a rigid
# motion, two changes of units, a permutation of the parts and an ndbg convert round trip;
# exits 1 on a silent difference. About 35 min on 2 cores (INVARIANCE_ARGS="hover rod" for some)
invariance: bytecode
	$(BIN)/python benchmarks/invariance.py $(INVARIANCE_ARGS)

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache ndbg_cli/kernels/_*_aot.*
