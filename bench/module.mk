# bench/module.mk — benchmark programs (print tables; never pass/fail), and the
# cross-target fragment tests/targets/module.mk (the top Makefile includes only
# */module.mk, one level deep).
#   make bench         host benchmarks against the peers, AVR cycle counts, motion time
#   make bench-host    kernel vs double baseline vs npm peers (bench/run_bench.py)
#   make bench-avr     exact cycles under simavr: the kernel on an ATmega328P, the board images
#   make bench-sizes   flash and state of every kernel build (bench/kernel_sizes.py)
#   make bench-corpus  real G-code files through plotkin sim (bench/corpus/module.mk)
include tests/targets/module.mk
include bench/corpus/module.mk

BENCH_DIR := $(BUILD)/bench

# ---- speed on the chip (simavr) ----------------------------------------------
# 1. The kernel alone on an ATmega328P (bench/avr/avr_refine_cycles.c, run by
#    bench/avr_cycles): cycles per output point, 2 and 3 axes, linked like the
#    board images (without the limit stage: -DPK_BUILD_LIMIT=0).
# 2. The board images themselves (bench/avr_bench.py on `plotkin avrsim`):
#    step interrupt per step, main-loop cost per chunk/block/line, the highest
#    sustained step rate, on-chip vs planned motion time.
$(eval $(call tgt_fw_rule,avr-ax2,$(AVR_CC),$(TGT_FLAGS_avr) -DPK_AXES=2 -DPK_BUILD_LIMIT=0))
$(eval $(call tgt_fw_rule,avr-ax3,$(AVR_CC),$(TGT_FLAGS_avr) -DPK_AXES=3 -DPK_BUILD_LIMIT=0))
AVR_BENCH_FLAGS := $(TGT_FLAGS_avr) -Os -g -std=c11 -ffunction-sections -fdata-sections \
                   -Ifirmware -Ihal -Ibench/avr -I/usr/include/simavr/avr
$(BENCH_DIR)/avr-ax%/avr_refine_cycles.elf: bench/avr/avr_refine_cycles.c bench/avr/avr_mark.h $(TGT_DIR)/avr-ax%/libplotkin_fw.a
	@mkdir -p $(@D)
	$(AVR_CC) $(AVR_BENCH_FLAGS) -DPK_AXES=$* -DPK_BUILD_LIMIT=0 -Wl,--gc-sections \
	  -Wl,--undefined=_mmcu,--section-start=.mmcu=0x910000 -o $@ $< $(TGT_DIR)/avr-ax$*/libplotkin_fw.a
# 4. The integer square root of the motion core (bench/avr/avr_arith_cycles.c),
#    on the 2-axis library: cycles per call, its results checked on the chip
#    (tests/extra/avr_arith.sh requires the "= wrong results" row to be 0).
$(BENCH_DIR)/avr-arith/avr_arith_cycles.elf: bench/avr/avr_arith_cycles.c bench/avr/avr_mark.h $(TGT_DIR)/avr-ax2/libplotkin_fw.a
	@mkdir -p $(@D)
	$(AVR_CC) $(AVR_BENCH_FLAGS) -Wall -Wextra -Werror -DPK_AXES=2 -DPK_BUILD_LIMIT=0 -Wl,--gc-sections \
	  -Wl,--undefined=_mmcu,--section-start=.mmcu=0x910000 -o $@ $< $(TGT_DIR)/avr-ax2/libplotkin_fw.a
$(BENCH_DIR)/avr_cycles: bench/avr_cycles.c
	@mkdir -p $(@D)
	$(CC) -std=gnu11 -O2 -Wall -Wextra -Werror $$(pkg-config --cflags simavr) -o $@ $< $$(pkg-config --libs simavr) -lelf

# 3. The kernel as a 328P board should carry it: Chaikin with clamped ends
#    only (pk_refine_chaikin.c), 2 axes, to depth 5 (32-bit values), no limit,
#    with the one-point pull's hot paths (PK_REFINE_FAST_PULL=1).
AVR_CHAIKIN_DEFS := -DPK_AXES=2 -DPK_MAX_DEPTH=5 -DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02 \
                    -DPK_BUILD_CLOSED=0 -DPK_BUILD_LIMIT=0 -DPK_REFINE_FAST_PULL=1
$(eval $(call tgt_fw_rule,avr-chaikin,$(AVR_CC),$(TGT_FLAGS_avr) $(AVR_CHAIKIN_DEFS)))
$(BENCH_DIR)/avr-chaikin/avr_refine_cycles.elf: bench/avr/avr_refine_cycles.c bench/avr/avr_mark.h $(TGT_DIR)/avr-chaikin/libplotkin_fw.a
	@mkdir -p $(@D)
	$(AVR_CC) $(AVR_BENCH_FLAGS) $(AVR_CHAIKIN_DEFS) -Wl,--gc-sections \
	  -Wl,--undefined=_mmcu,--section-start=.mmcu=0x910000 -o $@ $< $(TGT_DIR)/avr-chaikin/libplotkin_fw.a

AVR_BENCH_ELFS := $(BENCH_DIR)/avr-arith/avr_arith_cycles.elf $(BENCH_DIR)/avr-ax2/avr_refine_cycles.elf $(BENCH_DIR)/avr-ax3/avr_refine_cycles.elf \
                  $(BENCH_DIR)/avr-chaikin/avr_refine_cycles.elf
AVR_BOARDS := $(foreach f,$(sort $(wildcard hal/avr/*/board.mk)),$(notdir $(patsubst %/,%,$(dir $(f)))))

# The measurement whose cycles are broken down by function (3-axis build).
AVR_PROFILE ?= chaikin d4
.PHONY: bench-avr
bench-avr: $(BENCH_DIR)/avr_cycles $(AVR_BENCH_ELFS) firmware-images $(BUILD)/plotkin \
           $(foreach b,$(AVR_BOARDS),$(BUILD)/firmware/$(b)/host/plotkin)
	@echo "AVR ATmega328P @ 16 MHz under simavr: the kernel alone, cycles per output point (one open"
	@echo "stroke of 24 points; init + push + pull + finish, divided by the points produced)"
	@printf '%-8s %-22s %12s %8s %12s\n' build measurement cycles points cyc/point
	@$(BENCH_DIR)/avr_cycles $(BENCH_DIR)/avr-ax2/avr_refine_cycles.elf "2 axes"
	@$(BENCH_DIR)/avr_cycles $(BENCH_DIR)/avr-ax3/avr_refine_cycles.elf "3 axes" "$(AVR_PROFILE)"
	@echo "the Chaikin-only kernel (pk_refine_chaikin.c: clamped ends, 2 axes, depth <= 5, no limit stage,"
	@echo "PK_REFINE_FAST_PULL=1); \"block\": pk_refine_pull_block, 16 points a call; issue 14's goal for"
	@echo "chaikin d4: <= 300 cycles per output point"
	@$(BENCH_DIR)/avr_cycles $(BENCH_DIR)/avr-chaikin/avr_refine_cycles.elf "chaikin" | grep -v 'init failed' | grep .
	@echo "the motion core's integer square root on the 328P (bench/avr/avr_arith_cycles.c: 300 operands a row;"
	@echo "\"= wrong results\": roots checked on the chip)"
	@$(BENCH_DIR)/avr_cycles $(BENCH_DIR)/avr-arith/avr_arith_cycles.elf "helpers"
	@avr-size -A $(BENCH_DIR)/avr-ax2/avr_refine_cycles.elf | awk '$$1==".text"||$$1==".data"||$$1==".bss"{s=s" "$$1" "$$2} END{print "AVR kernel bench image (2 axes):"s" bytes"}'
	@$(PYTHON3) bench/avr_bench.py $(BUILD) $(AVR_BOARDS)

# ---- host benchmarks against the double baseline and the npm peers -----------
BENCH_CFLAGS := -std=c11 -O2 -g -Wall -Wextra -Werror -D_POSIX_C_SOURCE=200809L -Ifirmware -Ihal -Ibench
$(BENCH_DIR)/bench_refine: bench/bench_refine.c bench/bench_common.h $(BUILD)/libplotkin_fw.a
	@mkdir -p $(@D)
	$(CC) $(BENCH_CFLAGS) -o $@ $< $(BUILD)/libplotkin_fw.a
$(BENCH_DIR)/baseline_double: bench/baseline_double.c bench/bench_common.h
	@mkdir -p $(@D)
	$(CC) $(BENCH_CFLAGS) -o $@ $<

# npm peers: installed under bench/ from the pinned bench/package.json only
# (never a dependency of plotkin itself); bench/node_modules is git-ignored.
bench/node_modules/.plotkin-stamp: bench/package.json
	cd bench && npm install --no-audit --no-fund --loglevel=error
	@touch $@

BENCH_ARGS ?=
# Flash and state of every kernel build, Cortex-M0+ and AVR (bench/kernel_sizes.py)
.PHONY: bench-sizes
bench-sizes:
	@$(PYTHON3) bench/kernel_sizes.py --build $(BUILD)/kernel-sizes

.PHONY: bench-host
bench-host: $(BENCH_DIR)/bench_refine $(BENCH_DIR)/baseline_double bench/node_modules/.plotkin-stamp
	@$(PYTHON3) bench/run_bench.py --build $(BENCH_DIR) $(BENCH_ARGS)

# The bench group is installed only when a tool is missing: where Node comes
# from NodeSource, its nodejs package carries npm and Debian's npm cannot be
# installed beside it (apt: "held broken packages").
bench:
	@bash .ci/deps.sh base targets
	@for t in valgrind node npm; do command -v $$t >/dev/null || { bash .ci/deps.sh bench; break; }; done
	@$(MAKE) --no-print-directory bench-host bench-sizes bench-avr

# bench/module.mk — benchmark programs (print tables; never pass/fail).
#   make bench-motion   total motion time: smoothing off vs tolerance vs an ideal trapezoid
BENCH_MOTION := $(BUILD)/bench/motion_time

$(BENCH_MOTION): bench/motion_time.c $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_COMMON) $(WARN) $(OPT) -o $@ $< $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a $(HOST_LIBS)

.PHONY: bench-motion
bench-motion: $(BENCH_MOTION)
	@$(BENCH_MOTION)

bench: bench-motion

# ---- the step callback's cost of watching the inputs (callgrind) ------------
$(BENCH_DIR)/isr_inputs: bench/isr_inputs.c $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a
	@mkdir -p $(@D)
	$(CC) $(BENCH_CFLAGS) -Ihost-sim -o $@ $< $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a
.PHONY: bench-isr
bench-isr: $(BENCH_DIR)/isr_inputs
	@echo "Step callback (pk_machine_timer_cb) instructions, x86-64 -O2, callgrind; a 40 mm square, 2 axes, 80 steps/mm"
	@bash bench/isr_inputs.sh $(BENCH_DIR)/isr_inputs
bench: bench-isr
