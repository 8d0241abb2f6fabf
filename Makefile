# odsuite: `make demo` runs the whole story on the simulated rig, `make test` runs the tests.
# Both create the virtual environment .venv themselves.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: venv demo test bench stress fuzz clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	@touch $(STAMP)

demo: venv
	$(BIN)/odsuite demo --out demo-output

test: venv
	$(BIN)/python -m pytest -q -m "not slow and not hardware"

bench: venv
	@for f in bench/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

stress: venv
	$(BIN)/python -m pytest -q -m slow

fuzz: venv
	FUZZ_EXAMPLES=10000 $(BIN)/python -m pytest -q tests/reliability/test_fuzz_readers.py

clean:
	rm -rf $(VENV) demo-output .pytest_cache
