# R2P — the two commands a newcomer needs are `make` and `make test`; both set up the machine
# first (scripts/setup: seconds when nothing changed). `make help` lists every target.
.DEFAULT_GOAL := all
SHELL := /bin/bash
PY := scripts/py

.PHONY: all setup firmware fab enclosures check test bench mutants loom help clean flash probe-rs

all: setup ## Set up if needed, build every artifact (firmware images, fab packages, cases), print a summary
	@$(PY) -m r2ptools.build

setup: ## Install or update tools: apt (KiCad 9.0.8, OpenSCAD, QEMU…), Rust targets, Python venv
	@t0=$$(date +%s); scripts/setup; rc=$$?; mkdir -p .setup; \
	  echo $$(( $$(date +%s) - t0 )) > .setup/last-seconds; exit $$rc

firmware: setup ## Build the firmware images into firmware/images and print flash/RAM use
	@scripts/firmware build

fab: setup ## Regenerate each board's fab package (Gerbers, drill, BOM, CPL, PDF, renders, zip) in hardware/*/fab
	@scripts/fab

enclosures: setup ## Printable cases (STL), STEP assemblies and previews in enclosures/<m>, from each hardware/<m> board
	@scripts/enclosures generate

check: setup ## Lint all Rust (warnings denied); prove committed images and generated code are current
	@scripts/lint
	@scripts/msggen check
	@scripts/firmware verify

test: setup ## Run every test (Rust, QEMU Cortex-M3, lint, pytest) with one summary
	@scripts/run-tests

bench: setup ## Benchmarks: core instructions/message on a Cortex-M3 (QEMU) and msg/s on the host vs embassy-sync, footprint
	@scripts/bench

mutants: setup ## Mutation testing of the core crates (long: ~5 h): detected/viable per crate, goal 90 % (docs/mutants.md)
	@scripts/mutants

loom: setup ## Model-check the message pool's atomics with loom (host; its own build, ~1-4 min)
	@cd firmware && RUSTFLAGS="--cfg loom" CARGO_TARGET_DIR=target/loom cargo test --locked -q --release -p r2p-middleware --lib

flash: ## Write a module's committed image through an SWD probe: make flash M=<module> (docs/flashing.md)
	@test -n "$(M)" || { echo "make flash: name the module: make flash M=<module> (a module of modules.toml, e.g. M=motor)" >&2; exit 2; }
	@test -x .tools/probe-rs/bin/probe-rs || command -v probe-rs >/dev/null || $(MAKE) --no-print-directory probe-rs
	@scripts/r2p flash $(M)

PROBE_RS_VERSION = $(shell sed -n 's/^probe-rs = .*"=\([0-9.]*\)".*/\1/p' firmware/tools/probe-rs/Cargo.toml)
probe-rs: ## Install probe-rs (the pinned version, firmware/tools/probe-rs) into .tools/probe-rs: once, ~15 min on 2 cores
	@echo "probe-rs: building probe-rs-tools $(PROBE_RS_VERSION) into .tools/probe-rs (once; ~15 min on 2 cores)"
	cargo install probe-rs-tools --version $(PROBE_RS_VERSION) --locked --root .tools/probe-rs

help: ## List the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | sed -E 's/^([a-z-]+):.*## (.*)/  make \1\t\2/' | expand -t 20

clean: ## Remove build outputs (cargo target dirs, caches); keeps committed artifacts and the venv
	rm -rf firmware/target firmware/targets/*/target .cache
