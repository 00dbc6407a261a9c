# bench/module.mk — benchmark programs (print tables; never pass/fail), and the
# cross-target fragment tests/targets/module.mk (the top Makefile includes only
# */module.mk, one level deep).
#   make bench         host benchmarks against the peers, AVR cycle counts, motion time
#   make bench-host    kernel vs double baseline vs npm peers (bench/run_bench.py)
#   make bench-avr     exact ATmega328P cycles under simavr (bench/avr_cycles.c)
include tests/targets/module.mk

BENCH_DIR := $(BUILD)/bench

# ---- AVR cycle counts (simavr) ----------------------------------------------
# The kernel for the ATmega328P twice (PK_AXES=2 for XY plotters, 3), then one
# ELF per build, run by the libsimavr harness bench/avr_cycles.
$(eval $(call tgt_fw_rule,avr-ax2,$(AVR_CC),$(TGT_FLAGS_avr) -DPK_AXES=2))
$(eval $(call tgt_fw_rule,avr-ax3,$(AVR_CC),$(TGT_FLAGS_avr) -DPK_AXES=3))
AVR_BENCH_FLAGS := $(TGT_FLAGS_avr) -Os -g -std=c11 -ffunction-sections -fdata-sections \
                   -Ifirmware -Ihal -Ibench/avr -I/usr/include/simavr/avr
$(BENCH_DIR)/avr-ax%/avr_refine_cycles.elf: bench/avr/avr_refine_cycles.c bench/avr/avr_mark.h $(TGT_DIR)/avr-ax%/libplotkin_fw.a
	@mkdir -p $(@D)
	$(AVR_CC) $(AVR_BENCH_FLAGS) -DPK_AXES=$* -Wl,--gc-sections \
	  -Wl,--undefined=_mmcu,--section-start=.mmcu=0x910000 -o $@ $< $(TGT_DIR)/avr-ax$*/libplotkin_fw.a
$(BENCH_DIR)/avr_cycles: bench/avr_cycles.c
	@mkdir -p $(@D)
	$(CC) -std=gnu11 -O2 -Wall -Wextra -Werror $$(pkg-config --cflags simavr) -o $@ $< $$(pkg-config --libs simavr) -lelf

# The step callback: the whole firmware (motion core + kernel) with small
# queues, on the ATmega1284P (same AVR core timings; the 328P lacks the RAM).
AVR_STEP_DEFS := -DPK_AXES=2 -DPK_MAX_DEPTH=4 -DPK_WIN=4 -DPK_CLOSE_MAX=3 -DPK_MQ_CAP=8 \
                 -DPK_SG_CHUNKS=4 -DPK_SG_MAX_EVENTS=16 -DPK_STROKE_DEC=8 -DPK_MACHINE_INQ=4
AVR_STEP_FLAGS := -mmcu=atmega1284p -DF_CPU=16000000UL $(AVR_STEP_DEFS)
$(eval $(call tgt_fw_rule,avr1284-step,$(AVR_CC),$(AVR_STEP_FLAGS)))
$(BENCH_DIR)/avr1284-step/avr_step_cycles.elf: bench/avr/avr_step_cycles.c bench/avr/avr_mark.h $(TGT_DIR)/avr1284-step/libplotkin_fw.a
	@mkdir -p $(@D)
	$(AVR_CC) $(subst $(TGT_FLAGS_avr),,$(AVR_BENCH_FLAGS)) $(AVR_STEP_FLAGS) -Wl,--gc-sections \
	  -Wl,--undefined=_mmcu,--section-start=.mmcu=0x910000 -o $@ $< $(TGT_DIR)/avr1284-step/libplotkin_fw.a

AVR_BENCH_ELFS := $(BENCH_DIR)/avr-ax2/avr_refine_cycles.elf $(BENCH_DIR)/avr-ax3/avr_refine_cycles.elf \
                  $(BENCH_DIR)/avr1284-step/avr_step_cycles.elf

# The measurement whose cycles are broken down by function (3-axis build).
AVR_PROFILE ?= chaikin d4
.PHONY: bench-avr
bench-avr: $(BENCH_DIR)/avr_cycles $(AVR_BENCH_ELFS)
	@echo "AVR ATmega328P @ 16 MHz under simavr: cycles per output point (one open stroke of 24 points;"
	@echo "init + push + pull + finish, divided by the points produced)"
	@printf '%-8s %-22s %12s %8s %12s\n' build measurement cycles points cyc/point
	@$(BENCH_DIR)/avr_cycles $(BENCH_DIR)/avr-ax2/avr_refine_cycles.elf "2 axes"
	@$(BENCH_DIR)/avr_cycles $(BENCH_DIR)/avr-ax3/avr_refine_cycles.elf "3 axes" "$(AVR_PROFILE)"
	@echo "Step timer callback (pk_machine_timer_cb) per motor step, smoothing off, 2 axes, 80 steps/mm,"
	@echo "3 feed moves at 3000 mm/min; ATmega1284P build (same core timings as the 328P)"
	@$(BENCH_DIR)/avr_cycles $(BENCH_DIR)/avr1284-step/avr_step_cycles.elf "1284P"
	@avr-size -A $(BENCH_DIR)/avr-ax2/avr_refine_cycles.elf | awk '$$1==".text"||$$1==".data"||$$1==".bss"{s=s" "$$1" "$$2} END{print "AVR bench image (2 axes):"s" bytes"}'

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
.PHONY: bench-host
bench-host: $(BENCH_DIR)/bench_refine $(BENCH_DIR)/baseline_double bench/node_modules/.plotkin-stamp
	@$(PYTHON3) bench/run_bench.py --build $(BENCH_DIR) $(BENCH_ARGS)

# The bench group is installed only when a tool is missing: where Node comes
# from NodeSource, its nodejs package carries npm and Debian's npm cannot be
# installed beside it (apt: "held broken packages").
bench:
	@bash .ci/deps.sh base targets
	@for t in valgrind node npm; do command -v $$t >/dev/null || { bash .ci/deps.sh bench; break; }; done
	@$(MAKE) --no-print-directory bench-host bench-avr

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
