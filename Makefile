PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3 2>/dev/null)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test verify test-fast fuzz kernels clean-kernels lint bench clean

$(BIN)/python:
	@test -n "$(PYTHON)" || { echo "error: no python3.11 or python3 on PATH"; exit 1; }
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' || { echo "error: $(PYTHON) is older than Python 3.11"; exit 1; }
	$(PYTHON) -m venv $(VENV)

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	@touch $(STAMP)

demo: $(STAMP)
	$(BIN)/roadgrip demo --out report

# Compile every numba kernel once, in one process, before the test workers load them.
kernels: $(STAMP)
	$(BIN)/python tests/compile_kernels.py

# The contract a newcomer runs (README): lint, the import layers, then every unit, property,
# contract and estimator-check test with the short accuracy and honesty checks (the short
# honesty matrix, short multi-body and real-data runs). Everything marked `slow` is left
# to `make verify`.
test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/lint-imports --no-cache
	$(BIN)/python tests/compile_kernels.py
	$(BIN)/python -m pytest -n 2 -m "not slow" --durations=15

# The full acceptance: the tests marked `slow` (the multi-body acceptance, every real
# recording at full length, long and streamed drives, the full honesty matrix).
verify: $(STAMP)
	$(BIN)/python tests/compile_kernels.py
	$(BIN)/python -m pytest -n 2 -m "slow" --durations=25

# The edit loop: without the slow tests, those reading ../shared/data and the honesty matrix.
test-fast: $(STAMP)
	$(BIN)/python tests/compile_kernels.py
	$(BIN)/python -m pytest -n 2 -m "not slow and not realdata and not matrix" --durations=15

# The generated bad-input corpora at full size: more than 10,000 derandomised cases over
# readers, validation, vehicle files, the grid and the estimators (tests/test_fuzz_inputs.py),
# and malformed files through every reader and command (tests/test_malformed_inputs.py, its
# slow property included). `make test` runs the same properties on a few hundred.
FUZZ_EXAMPLES ?= 12000
fuzz: $(STAMP)
	ROADGRIP_FUZZ_EXAMPLES=$(FUZZ_EXAMPLES) $(BIN)/python -m pytest tests/test_fuzz_inputs.py \
		tests/test_malformed_inputs.py -m "slow or not slow" -p no:cacheprovider --hypothesis-show-statistics -q

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/lint-imports --no-cache

bench: $(STAMP)
	for f in benchmarks/bench_*.py; do $(BIN)/python $$f || exit 1; done

# numba invalidates a cached kernel only when its own module's file changes, not when a
# module it calls, or reads a constant from, does: after such an edit the cache runs the old code.
clean-kernels:
	find src -name '*.nbi' -delete
	find src -name '*.nbc' -delete

clean: clean-kernels
	rm -rf $(VENV) report .pytest_cache
