# Two entry points: `make demo` (the main job) and `make test` (CI: lint, types, every test). Both build .venv
# themselves. `make test-fast` is the edit-run loop: ruff and the tests no marker puts aside (pyproject.toml).
PY ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-fast lint typecheck bench clean venv

$(STAMP): pyproject.toml
	@bash scripts/ensure_system_deps.sh
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q torch==2.13.0
	$(BIN)/python -m pip install -q -e '.[dev]'
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(BIN)/auvlink demo --force  # make demo regenerates demo-out/ (auvlink demo alone keeps an existing one)

lint: $(STAMP)
	$(BIN)/ruff check auvlink logs_format recon classify tests benchmarks
	$(BIN)/lint-imports  # the layers and no import cycle (contracts in .importlinter)

typecheck: $(STAMP)
	$(BIN)/mypy

# The suite on both cores (pytest-xdist; a file's tests stay on one worker, so module fixtures are built once,
# conftest.py starts the longest first), then the real-time tests (`live`) in one process, so no other test
# competes with their clocks; mypy (one core, its report printed after them) runs beside those, which mostly wait.
test: $(STAMP) lint
	$(BIN)/python -m pytest -n 2 --dist loadgroup --no-loadscope-reorder -m "not live"
	@report=$$(mktemp); $(BIN)/mypy > $$report 2>&1 & mypy_pid=$$!; \
	$(BIN)/python -m pytest -m live; live=$$?; \
	wait $$mypy_pid; typed=$$?; echo "$(BIN)/mypy"; cat $$report; rm -f $$report; \
	test $$live -eq 0 -a $$typed -eq 0

FAST_TESTS := not slow and not live and not dask and not train and not browser

test-fast: $(STAMP)
	$(BIN)/ruff check auvlink logs_format recon classify tests benchmarks
	$(BIN)/python -m pytest -n 2 --dist loadgroup --no-loadscope-reorder -m "$(FAST_TESTS)"

bench: $(STAMP)
	$(BIN)/auvlink bench --out bench-out

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache
