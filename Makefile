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

# The whole suite (scripts/run_tests.sh): the real-time tests (`live`) at normal priority beside every other test
# on both cores and mypy, those two at nice 10, so that the live tests' clocks see an idle machine when they need it.
test: $(STAMP) lint
	BIN=$(BIN) bash scripts/run_tests.sh

FAST_TESTS := not slow and not live and not dask and not train and not browser

test-fast: $(STAMP)
	$(BIN)/ruff check auvlink logs_format recon classify tests benchmarks
	$(BIN)/python -m pytest -n 2 --dist loadgroup --no-loadscope-reorder -m "$(FAST_TESTS)"

bench: $(STAMP)
	$(BIN)/auvlink bench --out bench-out

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache
