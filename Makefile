# odsuite: `make demo` runs the whole story on the simulated rig, `make test` runs the tests.
# Both create the virtual environment .venv themselves.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: venv sysdeps demo test bench stress fuzz report-check clean

# the project's own modules compiled to bytecode: an editable install leaves them to each import,
# which compiles them again in every process where Python writes no bytecode (PYTHONDONTWRITEBYTECODE)
venv: $(STAMP)
	@$(BIN)/python -m compileall -q odsuite plugins >/dev/null

# Optional system tools some tests use (h5dump; headless Chromium for the report page). Installed
# with apt-get when running as root on Debian/Ubuntu; elsewhere those tests skip and say what to
# install. VTK renders off-screen through EGL (libegl1, libgl1-mesa-dri), present on most systems.
SYSDEPS := hdf5-tools chromium
sysdeps:
	@missing=""; command -v h5dump >/dev/null || missing="$$missing hdf5-tools"; \
	 command -v chromium >/dev/null || missing="$$missing chromium"; \
	 if [ -n "$$missing" ]; then \
	   if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	     echo "installing system packages:$$missing"; \
	     (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null) \
	       || echo "could not install$$missing: the tests that need them will skip"; \
	   else echo "optional system packages missing:$$missing (install them to run every test)"; fi; \
	 fi

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	@touch $(STAMP)

demo: venv
	$(BIN)/odsuite demo --out demo-output

test: venv sysdeps
	$(BIN)/python -m pytest -q -m "not slow and not hardware"

bench: venv
	@for f in bench/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

stress: venv
	$(BIN)/python -m pytest -q -m slow

fuzz: venv
	FUZZ_EXAMPLES=10000 $(BIN)/python -m pytest -q -s tests/reliability/test_fuzz_readers.py

# the report page: numbers equal compare's, self-contained, renders in headless Chromium (skips
# with the apt-get line when /usr/bin/chromium is absent)
report-check: venv
	$(BIN)/python -m pytest -q -m "slow or render or not slow" tests/plugins/renderers/test_report.py

clean:
	rm -rf $(VENV) demo-output .pytest_cache
