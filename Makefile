# Two entry points for users: `make demo` and `make test`. Each sets itself up from scratch:
# a private virtual environment in .venv with every Python package pinned in requirements/lock.txt.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
EXTRAS := train,sim,record,report,live,hardware,ray,dev

.PHONY: venv demo test test-fast lint bench bench-quick regen hardware firmware firmware-test firmware-native flash clean

venv: $(STAMP)

$(STAMP): pyproject.toml requirements/lock.txt
	$(PYTHON) -m venv $(VENV)
	# Pinned: every package (torch included, ==2.13.0 CPU) comes from the lock file.
	$(BIN)/pip install --quiet -c requirements/lock.txt -e '.[$(EXTRAS)]'
	# Fail set-up, not experiments, if cobs/crcmod fell back to pure Python (35x slower framing).
	$(BIN)/python -W error -m spectratac.protocol.accel_check
	touch $@

# The main job on the built-in simulated sensor (real firmware core on the digital twin).
# --force: demo-output/ is the demo's own folder, rewritten on every run.
demo: $(STAMP)
	$(BIN)/spectratac demo --force

# The suite on every core (pytest-xdist): a worker per core, one test module per
# unit of work, costliest first (tests/xdist_plan.py).
# Serially, or with other pytest options: make test PYTEST_ARGS="-n 0".
XDIST       := -n auto --dist loadfile --no-loadscope-reorder
PYTEST_ARGS ?=
test: $(STAMP)
	$(BIN)/python -m pytest $(XDIST) $(PYTEST_ARGS)

# The inner loop: everything but training, processes, firmware builds, QEMU, KiCad and the
# fuzz suite (markers in pyproject.toml; tests/conftest.py applies most of them).
FAST := not (train or subprocess or qemu or firmware or kicad or slow or fuzz)
test-fast: $(STAMP)
	$(BIN)/python -m pytest $(XDIST) -m "$(FAST)" $(PYTEST_ARGS)

lint: $(STAMP)
	$(BIN)/ruff check host tools tests

# The regression benchmarks (tools/bench/registry.py), each figure a ratio to a reference
# measured in the same run; results kept in build/bench/results/<commit>.json
# (compare two: .venv/bin/python -m tools.bench compare A B). One or some:
# make bench BENCH_ARGS="protocol twin"; the list: .venv/bin/python -m tools.bench --list.
BENCH_ARGS ?=
bench: $(STAMP)
	$(BIN)/python -m tools.bench $(BENCH_ARGS)

# Every benchmark's few-seconds version: it checks that they all run, not what they measure.
bench-quick: $(STAMP)
	$(BIN)/python -m tools.bench --quick $(BENCH_ARGS)

# Regenerate every committed generated file from its one definition in hardware/definitions/
# (the list: tools/codegen/manifest.toml; a test fails on drift).
regen: $(STAMP)
	$(BIN)/python -m tools.codegen.generate

# KiCad board + schematic, Gerbers/drill/BOM/CPL, mould STLs and renders from hardware/definitions/params.toml.
# Needs apt's kicad, openscad, gerbv and xvfb (.ci/run installs them).
hardware: $(STAMP)
	$(BIN)/python -m tools.hardware.build

# Firmware (offline PlatformIO: project platforms + pip scons; never the registry).
FW_BIN := build/pio/blackpill/firmware.bin
firmware: $(STAMP)
	$(BIN)/python -m tools.platformio.pio run -e blackpill

# C unit tests of the core with ASan + UBSan through PlatformIO's native env.
firmware-test: $(STAMP)
	$(BIN)/python -m tools.platformio.pio run -e native -t exec

# The simulator library (build/firmware/native/libstac_sim.so, C ABI in generated/stac_sim.h) as
# tools/firmware/build.toml describes it; rebuilt only when a source is newer.
firmware-native:
	$(PYTHON) -m tools.firmware.build simlib

# Black Pill over USB DFU. A board running our firmware: make flash URL=/dev/ttyACM0 (it is
# asked into its ROM bootloader first); otherwise hold BOOT0 and tap NRST before. Brown-out
# level 3 once per board: spectratac flash --set-bor (ST-Link). See firmware/README.md.
URL ?=
flash: firmware
	$(BIN)/spectratac flash $(FW_BIN) $(if $(URL),--device $(URL))

clean:
	rm -rf $(VENV) .pytest_cache build
