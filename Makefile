# Two entry points: `make demo` and `make test`. Both create .venv on first use.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
# the numerics are many small matrix products: one BLAS thread is faster than a pool on 2 cores
export OPENBLAS_NUM_THREADS ?= 1

.PHONY: demo test browser figures bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $@

demo: $(VENV)/.installed
	$(BIN)/spherestep demo

test: $(VENV)/.installed-test browser
	$(BIN)/ruff check src tests benchmarks docs
	$(BIN)/python -m pytest -q

# Debian's chromium and its driver for tests/test_report_browser.py; installed only as root (as in CI)
browser:
	@if command -v chromium >/dev/null && command -v chromedriver >/dev/null; then :; \
	elif [ "$$(id -u)" = 0 ]; then \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null; \
	else echo "chromium/chromedriver missing and not root: the browser test will be skipped (sudo make browser)"; fi

figures: $(VENV)/.installed
	$(BIN)/python docs/make_figures.py

bench: $(VENV)/.installed
	for f in benchmarks/bench_*.py; do $(BIN)/python $$f || exit 1; done

clean:
	rm -rf $(VENV) spherestep-out .pytest_cache
