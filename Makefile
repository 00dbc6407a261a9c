# plotkin — top-level build.
#
#   make            build the host tool build/plotkin (and the test programs)
#   make example    install what is missing, smooth the bundled example, write build/example.svg
#   make test       install what is missing, build, run every test plainly and under ASan+UBSan
#   make bench      print the benchmark tables (bench/)
#
# Sources are discovered by wildcard so that adding a module needs no edit here:
#   firmware/*.c           portable core (no OS, no heap, no float)
#   hal/*.c hal/*/*.c      HAL helpers and host backends (not hal/avr, hal/arm:
#                          board backends, built by `make firmware`, hal/firmware.mk)
#   host-sim/*.c           simulator and host tools (host-sim/main.c is the CLI entry)
#   tests/test_*.c         one test program each, built twice (plain, sanitized)
# Area-specific rules live in */module.mk fragments, included at the end.

CC      ?= cc
BUILD   ?= build
SAN     := $(BUILD)/san

WARN    := -std=c11 -Wall -Wextra -Werror -Wshadow -Wvla -Wstrict-prototypes \
           -Wmissing-prototypes -Wpointer-arith -Wundef
# firmware/ must also compile without any float type in sight: -Wdouble-promotion
# catches accidental promotions, and tests/test_symbols.c checks the objects.
FW_WARN := $(WARN) -Wdouble-promotion -Wfloat-conversion
CPPFLAGS_COMMON := -Ifirmware -Ihal -Ihost-sim -Itests -D_POSIX_C_SOURCE=200809L
OPT     := -O2 -g
SANFLAGS := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined \
            -fno-sanitize-recover=all

FW_SRC   := $(sort $(wildcard firmware/*.c))
HAL_SRC  := $(sort $(filter-out hal/avr/% hal/arm/%,$(wildcard hal/*.c) $(wildcard hal/*/*.c)))
SIM_SRC  := $(sort $(filter-out host-sim/main.c,$(wildcard host-sim/*.c)))
TH_SRC   := tests/th.c tests/th_host.c
TEST_SRC := $(sort $(wildcard tests/test_*.c))
TEST_NAMES := $(patsubst tests/%.c,%,$(TEST_SRC))

HOST_LIBS := -lm

# Object lists for one flavour: $(call objs,DIR,SRCS)
objs = $(patsubst %.c,$(1)/obj/%.o,$(2))

FW_OBJ      := $(call objs,$(BUILD),$(FW_SRC))
HAL_OBJ     := $(call objs,$(BUILD),$(HAL_SRC))
SIM_OBJ     := $(call objs,$(BUILD),$(SIM_SRC))
TH_OBJ      := $(call objs,$(BUILD),$(TH_SRC))
FW_OBJ_S    := $(call objs,$(SAN),$(FW_SRC))
HAL_OBJ_S   := $(call objs,$(SAN),$(HAL_SRC))
SIM_OBJ_S   := $(call objs,$(SAN),$(SIM_SRC))
TH_OBJ_S    := $(call objs,$(SAN),$(TH_SRC))

TESTS       := $(addprefix $(BUILD)/tests/,$(TEST_NAMES))
TESTS_S     := $(addprefix $(SAN)/tests/,$(TEST_NAMES))

.PHONY: all deps test test-build example bench clean FORCE
.SECONDARY:
all: $(BUILD)/plotkin

# ---- compile rules -------------------------------------------------------
$(BUILD)/obj/firmware/%.o: firmware/%.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_COMMON) $(FW_WARN) $(OPT) $(EXTRA_CFLAGS) -MMD -MP -c $< -o $@
$(SAN)/obj/firmware/%.o: firmware/%.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_COMMON) $(FW_WARN) $(SANFLAGS) $(EXTRA_CFLAGS) -MMD -MP -c $< -o $@
$(BUILD)/obj/%.o: %.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_COMMON) $(WARN) $(OPT) $(EXTRA_CFLAGS) -MMD -MP -c $< -o $@
$(SAN)/obj/%.o: %.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_COMMON) $(WARN) $(SANFLAGS) $(EXTRA_CFLAGS) -MMD -MP -c $< -o $@

# ---- libraries and programs ----------------------------------------------
$(BUILD)/libplotkin_fw.a: $(FW_OBJ)
	@mkdir -p $(@D); rm -f $@; ar rcs $@ $^
$(SAN)/libplotkin_fw.a: $(FW_OBJ_S)
	@mkdir -p $(@D); rm -f $@; ar rcs $@ $^
$(BUILD)/libplotkin_host.a: $(HAL_OBJ) $(SIM_OBJ)
	@mkdir -p $(@D); rm -f $@; ar rcs $@ $^
$(SAN)/libplotkin_host.a: $(HAL_OBJ_S) $(SIM_OBJ_S)
	@mkdir -p $(@D); rm -f $@; ar rcs $@ $^

$(BUILD)/plotkin: $(BUILD)/obj/host-sim/main.o $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a
	$(CC) $(OPT) -o $@ $< $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a $(HOST_LIBS)
$(SAN)/plotkin: $(SAN)/obj/host-sim/main.o $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a
	$(CC) $(SANFLAGS) -o $@ $< $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a $(HOST_LIBS)

$(BUILD)/tests/%: $(BUILD)/obj/tests/%.o $(TH_OBJ) $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a
	@mkdir -p $(@D)
	$(CC) $(OPT) -o $@ $< $(TH_OBJ) $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a $(HOST_LIBS)
$(SAN)/tests/%: $(SAN)/obj/tests/%.o $(TH_OBJ_S) $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a
	@mkdir -p $(@D)
	$(CC) $(SANFLAGS) -o $@ $< $(TH_OBJ_S) $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a $(HOST_LIBS)

# ---- the two README commands ----------------------------------------------
deps:
	@bash .ci/deps.sh base

test-build: $(BUILD)/plotkin $(SAN)/plotkin $(TESTS) $(TESTS_S)

# Every test program prints "N passed, N failed" as its last line; the runner
# adds them up, runs the end-to-end scripts, and ends non-zero on any failure.
test: deps
	@$(MAKE) --no-print-directory test-build
	@bash tests/run_tests.sh $(BUILD) $(SAN)

EXAMPLE_IN ?= host-sim/examples/flower.gcode
example: deps $(BUILD)/plotkin
	$(BUILD)/plotkin sim $(EXAMPLE_IN) --tolerance 0.02 --svg $(BUILD)/example.svg > $(BUILD)/example.out; \
	  rc=$$?; cat $(BUILD)/example.out; exit $$rc
	@echo "wrote $(BUILD)/example.svg (commanded path light, executed path from the decoded step pulses dark) and $(BUILD)/example.out"

clean:
	rm -rf $(BUILD)

-include $(sort $(wildcard */module.mk))
-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
