# Two set-up commands (README): `make test` and `make demo`. Both build .venv on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: test demo bench interpreters pico-frozen clean

$(STAMP): pyproject.toml setup.py
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[test,plots]'
	touch $(STAMP)

# the interpreters a board has, built once from ../shared into build/ (cached)
interpreters: $(STAMP)
	$(BIN)/python -m desktop.firmware.interpreters build

# the Pico image with the firmware frozen in (part of `interpreters`; rebuilt when a frozen file
# changes): build/interpreters/rp2-pico-frozen/firmware.uf2 for a real Pico, firmware.bin
pico-frozen: $(STAMP)
	$(BIN)/python -m desktop.firmware.interpreters build rp2-pico rp2-pico-frozen

# three workers on two cores: the real-time tests (a handheld turned or walked at the wall clock's
# pace) wait most of their time, and the third worker fills it (tests/conftest.py)
test: $(STAMP) interpreters
	$(BIN)/python -m pytest -q -n 3 --dist worksteal --durations=15

demo: $(STAMP)
	$(BIN)/fluxcal demo

# the core, the interpreters, the 32-bit heap and the Cortex-M counts (about a minute); the
# firmware's unix-port sweep and the commands' wall times are longer: README, Benchmarks
bench: $(STAMP) interpreters
	$(BIN)/python -m desktop.bench
	$(BIN)/python -m desktop.bench.interpreters
	$(BIN)/python -m desktop.bench.heap
	$(BIN)/python -m desktop.bench.cortexm

clean:
	rm -rf $(VENV) out .pytest_cache build
