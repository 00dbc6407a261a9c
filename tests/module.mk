# tests/module.mk — fuzzing (libFuzzer) and the corpus replay run by `make test`.
#
#   make fuzz [FUZZ_SECONDS=30] [FUZZ_TARGETS="fuzz_refine ..."]
#       builds every tests/fuzz/fuzz_*.c with clang -fsanitize=fuzzer,address,undefined
#       and runs each for FUZZ_SECONDS, one after another, starting from the
#       committed seeds in tests/fuzz/corpus/<target>/ (new inputs go to
#       $(BUILD)/fuzz/work/<target>/, crashes to $(BUILD)/fuzz/artifacts/).
#   make fuzz-build   only build them.
#   make soak         the long runs kept out of `make test`: 100,000 lines flooded
#                     over a pty (tests/e2e_flood.sh) and 120 simulated minutes of
#                     plotting (tests/e2e_soak_sim.sh); PLOTKIN_FLOOD_LINES and
#                     PLOTKIN_SOAK_MINUTES override.
#
# `make test` needs no clang: each target is also linked with the ordinary
# compiler against tests/fuzz/replay_main.c (plain and ASan+UBSan), and
# tests/e2e_fuzz_corpus.sh replays every committed corpus input through it.
# Fuzz objects are compiled separately (with coverage instrumentation) under
# $(BUILD)/fuzz/obj so they never mix with the gcc objects.

FUZZ_CC      ?= clang
FUZZ_SECONDS ?= 30
FUZZ_SRC     := $(sort $(wildcard tests/fuzz/fuzz_*.c))
FUZZ_ALL     := $(patsubst tests/fuzz/%.c,%,$(FUZZ_SRC))
FUZZ_TARGETS ?= $(FUZZ_ALL)
FUZZ_SAN     := -fsanitize=address,undefined -fno-sanitize-recover=all
FUZZ_CFLAGS  := -g -O2 -fno-omit-frame-pointer $(FUZZ_SAN) -fsanitize=fuzzer-no-link \
                $(filter-out -Werror,$(WARN))
# Comparison tracing (trace-cmp: libFuzzer learns the constants the code
# compares input bytes with) only where input bytes meet constants: the G-code
# parser and the Grbl engine. In arithmetic code (kernel, motion core) and in
# the harnesses it guides nothing and its hooks took 75 % of the time
# (measured: fuzz_refine and fuzz_motion 4x faster without; tests/fuzz/README.md).
FUZZ_CMP_SRC := $(wildcard firmware/pk_gcode*.c firmware/pk_grbl*.c)
fuzz_cmp      = $(if $(filter $(1),$(FUZZ_CMP_SRC)),,-fno-sanitize-coverage=trace-cmp)
FUZZ_OBJDIR  := $(BUILD)/fuzz/obj
FUZZ_LIBSRC  := $(FW_SRC) $(HAL_SRC) $(SIM_SRC)
FUZZ_LIBOBJ  := $(patsubst %.c,$(FUZZ_OBJDIR)/%.o,$(FUZZ_LIBSRC))
FUZZ_BINS    := $(addprefix $(BUILD)/fuzz/,$(FUZZ_ALL))

# -MMD: the top Makefile includes every .d under $(BUILD), so a changed header
# (a struct layout) rebuilds the fuzz objects too; so does a change of the
# flags here (tests/module.mk)
$(FUZZ_OBJDIR)/%.o: %.c tests/module.mk
	@mkdir -p $(@D)
	$(FUZZ_CC) $(CPPFLAGS_COMMON) -Itests/fuzz $(FUZZ_CFLAGS) $(call fuzz_cmp,$<) $(EXTRA_CFLAGS) -MMD -MP -c $< -o $@
$(BUILD)/fuzz/libfuzzdeps.a: $(FUZZ_LIBOBJ)
	@mkdir -p $(@D); rm -f $@; ar rcs $@ $^
$(BUILD)/fuzz/fuzz_%: $(FUZZ_OBJDIR)/tests/fuzz/fuzz_%.o $(BUILD)/fuzz/libfuzzdeps.a
	$(FUZZ_CC) $(FUZZ_SAN) -fsanitize=fuzzer -o $@ $< $(BUILD)/fuzz/libfuzzdeps.a $(HOST_LIBS)

.PHONY: fuzz fuzz-build soak
fuzz-build: $(FUZZ_BINS)
fuzz: fuzz-build
	@bash tests/fuzz/run_fuzz.sh $(BUILD)/fuzz $(FUZZ_SECONDS) $(FUZZ_TARGETS)

# ---- corpus replay (part of make test) ------------------------------------
FUZZ_REPLAY   := $(addprefix $(BUILD)/fuzz-replay/,$(FUZZ_ALL))
FUZZ_REPLAY_S := $(addprefix $(SAN)/fuzz-replay/,$(FUZZ_ALL))
$(BUILD)/fuzz-replay/%: $(BUILD)/obj/tests/fuzz/%.o $(BUILD)/obj/tests/fuzz/replay_main.o $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a
	@mkdir -p $(@D)
	$(CC) $(OPT) -o $@ $< $(BUILD)/obj/tests/fuzz/replay_main.o $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a $(HOST_LIBS)
$(SAN)/fuzz-replay/%: $(SAN)/obj/tests/fuzz/%.o $(SAN)/obj/tests/fuzz/replay_main.o $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a
	@mkdir -p $(@D)
	$(CC) $(SANFLAGS) -o $@ $< $(SAN)/obj/tests/fuzz/replay_main.o $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a $(HOST_LIBS)
test-build: $(FUZZ_REPLAY) $(FUZZ_REPLAY_S)

# ---- long runs (not in make test) --------------------------------------------
# 100,000 lines flooded over a pty, and two hours of simulated plotting.
soak: $(BUILD)/plotkin
	PLOTKIN_FLOOD_LINES=$${PLOTKIN_FLOOD_LINES:-100000} bash tests/e2e_flood.sh
	PLOTKIN_SOAK_MINUTES=$${PLOTKIN_SOAK_MINUTES:-120} bash tests/e2e_soak_sim.sh

# ---- known findings (bugs in code this branch does not own) ---------------------
# tests/fuzz/findings/<target>/<ID>-<what> are inputs that reproduce a finding
# reported in tests/fuzz/README.md, and tests/fuzz/findings/findings_*.c unit
# tests of their own (failing while the finding is open, hence not in make
# test). `make fuzz-findings` runs those and replays each input through
# the target built with -DFZ_STRICT=255 (every allowance the fuzz targets make
# for known findings removed) and says REPRODUCED or FIXED for each; once the
# owner's fix makes every one FIXED, drop the allowance and move the inputs
# into tests/fuzz/corpus/ so `make test` keeps them fixed.
$(BUILD)/fuzz-strict/%: tests/fuzz/%.c tests/fuzz/replay_main.c $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_COMMON) -Itests/fuzz $(WARN) $(SANFLAGS) -DFZ_STRICT=255 -o $@ $< tests/fuzz/replay_main.c \
	    $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a $(HOST_LIBS)
$(BUILD)/fuzz/strict_%: $(FUZZ_OBJDIR)/tests/fuzz/strict_%.o $(BUILD)/fuzz/libfuzzdeps.a
	$(FUZZ_CC) $(FUZZ_SAN) -fsanitize=fuzzer -o $@ $< $(BUILD)/fuzz/libfuzzdeps.a $(HOST_LIBS)
$(FUZZ_OBJDIR)/tests/fuzz/strict_%.o: tests/fuzz/%.c
	@mkdir -p $(@D)
	$(FUZZ_CC) $(CPPFLAGS_COMMON) -Itests/fuzz $(FUZZ_CFLAGS) $(call fuzz_cmp,$<) -DFZ_STRICT=255 -MMD -MP -c $< -o $@

$(BUILD)/fuzz-strict/findings_%: tests/fuzz/findings/findings_%.c $(TH_OBJ_S) $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_COMMON) $(WARN) $(SANFLAGS) -o $@ $< $(TH_OBJ_S) $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a $(HOST_LIBS)

FINDING_DIRS  := $(patsubst %/,%,$(wildcard tests/fuzz/findings/*/))
FINDING_TESTS := $(patsubst tests/fuzz/findings/%.c,$(BUILD)/fuzz-strict/%,$(wildcard tests/fuzz/findings/findings_*.c))
.PHONY: fuzz-findings
fuzz-findings: $(addprefix $(BUILD)/fuzz-strict/,$(notdir $(FINDING_DIRS))) $(FINDING_TESTS)
	@[ -n "$(FINDING_DIRS)$(FINDING_TESTS)" ] || echo "no open finding (tests/fuzz/findings/ is empty)"
	@for d in $(FINDING_DIRS); do t=$$(basename $$d); for f in $$d/*; do \
	  if $(BUILD)/fuzz-strict/$$t $$f >/dev/null 2>$(BUILD)/fuzz-strict/last.err; then \
	    echo "FIXED       $$f"; else echo "REPRODUCED  $$f: $$(grep -m1 -E 'invariant broken|runtime error|ERROR: AddressSanitizer' $(BUILD)/fuzz-strict/last.err)"; fi; \
	done; done
	@for t in $(FINDING_TESTS); do $$t > $(BUILD)/fuzz-strict/last.out 2> $(BUILD)/fuzz-strict/last.err; rc=$$?; \
	  grep -E '^(ok|not ok)' $(BUILD)/fuzz-strict/last.out | sed 's/^ok /FIXED       /; s/^not ok /REPRODUCED  /'; \
	  if [ $$rc -ne 0 ] && ! grep -q '^not ok' $(BUILD)/fuzz-strict/last.out; then \
	    echo "REPRODUCED  $$(basename $$t) stopped (exit $$rc): $$(grep -m1 -E 'runtime error|ERROR: AddressSanitizer' $(BUILD)/fuzz-strict/last.err)"; fi; done
