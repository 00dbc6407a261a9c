# hal/module.mk — the board build: build/plotkin-gpiod, the firmware on real
# GPIO lines through libgpiod (hal/gpiod/) and real time (hal/posix/).
#
# The simulator links host-sim/gpiod_mock.c in place of libgpiod; the board
# must not. libplotkin_host.a contains the mock, and an archive member is
# pulled in for any symbol still undefined — gpiod_* included — so the board
# links its own archive without the mock, followed by -lgpiod.

GPIOD_LIBS := $(shell pkg-config --libs libgpiod 2>/dev/null || echo -lgpiod)
# Only hal/gpiod/gpiod_v1.c names libgpiod functions (the 1.x API of Debian 12
# and Raspberry Pi OS bookworm). A gpiod_v2.c implementing pk_gpiod_port.h on
# the 2.x API would sit beside it, and this fragment would keep the one that
# matches `pkg-config --modversion libgpiod` (out of the wildcard lists).
BOARD_OBJ  := $(filter-out $(BUILD)/obj/host-sim/gpiod_mock.o,$(HAL_OBJ) $(SIM_OBJ))

.PHONY: board-gpiod
board-gpiod: $(BUILD)/plotkin-gpiod

$(BUILD)/libplotkin_board.a: $(BOARD_OBJ)
	@mkdir -p $(@D); rm -f $@; ar rcs $@ $^

$(BUILD)/plotkin-gpiod: $(BUILD)/obj/hal/posix/board/plotkin_gpiod.o $(BUILD)/libplotkin_board.a $(BUILD)/libplotkin_fw.a
	$(CC) $(OPT) -o $@ $< $(BUILD)/libplotkin_board.a $(BUILD)/libplotkin_fw.a $(GPIOD_LIBS) $(HOST_LIBS)

# `make test` builds the board binary too, so a change that breaks it fails CI.
test-build: $(BUILD)/plotkin-gpiod

# Flashable images of the bare-metal boards (hal/avr/, hal/arm/): `make firmware`.
include hal/firmware.mk

# ---- the test variant: build/plotkin-gpiod-mock ------------------------------
# The same board program compiled with -DPLOTKIN_GPIOD_MOCK and linked with
# the simulator's archive, whose host-sim/gpiod_mock.o stands in for -lgpiod;
# hal/posix/board/board_mock.c registers an in-memory chip that records every
# edge on the real clock (--mock-trace FILE). Out of the wildcard lists, like
# the board binary. tests/e2e_gpiod_serve.sh and bench-gpiod run it.
BOARD_MOCK_CFLAGS := -DPLOTKIN_GPIOD_MOCK -Ihal/posix/board
$(BUILD)/obj/hal/posix/board/plotkin_gpiod_mock.o: hal/posix/board/plotkin_gpiod.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_COMMON) $(BOARD_MOCK_CFLAGS) $(WARN) $(OPT) $(EXTRA_CFLAGS) -MMD -MP -c $< -o $@
$(SAN)/obj/hal/posix/board/plotkin_gpiod_mock.o: hal/posix/board/plotkin_gpiod.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_COMMON) $(BOARD_MOCK_CFLAGS) $(WARN) $(SANFLAGS) $(EXTRA_CFLAGS) -MMD -MP -c $< -o $@
$(BUILD)/plotkin-gpiod-mock: $(BUILD)/obj/hal/posix/board/plotkin_gpiod_mock.o $(BUILD)/obj/hal/posix/board/board_mock.o $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a
	$(CC) $(OPT) -o $@ $(filter %.o,$^) $(BUILD)/libplotkin_host.a $(BUILD)/libplotkin_fw.a $(HOST_LIBS)
$(SAN)/plotkin-gpiod-mock: $(SAN)/obj/hal/posix/board/plotkin_gpiod_mock.o $(SAN)/obj/hal/posix/board/board_mock.o $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a
	$(CC) $(SANFLAGS) -o $@ $(filter %.o,$^) $(SAN)/libplotkin_host.a $(SAN)/libplotkin_fw.a $(HOST_LIBS)
test-build: $(BUILD)/plotkin-gpiod-mock $(SAN)/plotkin-gpiod-mock

# Step timing error of the board loop on this machine (a table; not a test).
.PHONY: bench-gpiod
bench-gpiod: $(BUILD)/plotkin-gpiod-mock
	@$(PYTHON3) bench/gpiod_timing.py $(BUILD)/plotkin-gpiod-mock
bench: bench-gpiod
