# Two entry points: `make demo` and `make test`. Both create .venv on first use.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
# the numerics are many small matrix products: one BLAS thread is faster than a pool on 2 cores
export OPENBLAS_NUM_THREADS ?= 1

# tests run on both cores (pytest-xdist); the ones whose verdict depends on a real-time loop's wall clock run
# after them, alone (marker `realtime`)
WORKERS ?= 2
RUFF := $(BIN)/ruff check src tests benchmarks docs scripts

.PHONY: demo test check browser figures bench clean

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

# the tests whose verdict depends on how caps are numbered: make test runs them again under a second OpenBLAS kernel
# (issue 35: the numbering, hence coil and magnet indices, must not depend on the CPU)
NUMBERING_TESTS := tests/test_numbering.py tests/test_packing.py tests/test_gallery.py tests/test_iron_fem_patch.py \
	tests/test_design_file.py tests/test_docs_numbers.py

# everything (CI): ruff, the suite on both cores, the numbering under another BLAS kernel, then the real-time tests
test: $(VENV)/.installed-test browser
	$(RUFF)
	$(BIN)/python -m pytest -q -n $(WORKERS) -m "not realtime" --durations=25
	OPENBLAS_CORETYPE=$$($(BIN)/python scripts/blas_kernel.py --other) \
		$(BIN)/python -m pytest -q -n $(WORKERS) -m "not realtime" $(NUMBERING_TESTS)
	$(BIN)/python -m pytest -q -m realtime

# the edit loop: ruff and every test not marked slow or realtime (a few minutes)
check: $(VENV)/.installed-test
	$(RUFF)
	$(BIN)/python -m pytest -q -n $(WORKERS) -m "not slow and not realtime"

# Debian's chromium and its driver for tests/test_report_browser.py, the cross-compilers for the firmware's
# boards (tests/test_firmware.py: the Teensy 4.1's Cortex-M7, the relay sketch's Mega 2560) and QEMU's Arm machines
# for the firmware run as firmware (tests/test_firmware_qemu.py: mps2-an500); installed only as root (as in CI,
# .ci/run: make test)
browser:
	@if command -v chromium >/dev/null && command -v chromedriver >/dev/null && command -v arm-none-eabi-g++ >/dev/null && command -v avr-g++ >/dev/null && command -v qemu-system-arm >/dev/null; then :; \
	elif [ "$$(id -u)" = 0 ]; then \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver \
			gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib gcc-avr avr-libc \
			qemu-system-arm >/dev/null; \
	else echo "chromium/chromedriver, a cross-compiler or qemu-system-arm missing and not root: the browser test, the board builds and the firmware in QEMU will be skipped (sudo make browser)"; fi

figures: $(VENV)/.installed
	$(BIN)/python docs/make_figures.py

bench: $(VENV)/.installed
	for f in benchmarks/bench_*.py; do $(BIN)/python $$f || exit 1; done

clean:
	rm -rf $(VENV) spherestep-out .pytest_cache
