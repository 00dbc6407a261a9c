# hal/firmware.mk — `make firmware`: flashable images of every board, ELF and
# Intel HEX, with their size table. (Included from hal/module.mk.)
#
#   make firmware          install the cross toolchains if missing, build every
#                          board's image, measure its stack on the emulated chip,
#                          print flash / RAM / fits per board and per module;
#                          fails if an image does not fit its part
#   make firmware-build    the same without the install step
#   make firmware-images   only the images (ELF always, HEX of those that fit)
#
# A board is a folder hal/<arch>/<board>/ with board.h (the only file naming
# its pins, timers and vectors) and board.mk, which sets
#   BOARD_ARCH BOARD_MCU|BOARD_CPU BOARD_F_CPU BOARD_SRC BOARD_DEFS
#   BOARD_FLASH_MAX BOARD_RAM_MAX BOARD_STEP_ISR BOARD_STATICS [BOARD_CFLAGS]
#   [BOARD_HOST_DEFS] [BOARD_LDSCRIPT] [BOARD_LTO]
#   [BOARD_COLD_CFLAGS] [BOARD_HOT_SRC] [BOARD_SELFTEST_FW]
# Every image's objects, firmware and board alike, pass tests/targets/fwcheck.py
# (no heap, stdio, float; no software divide on the step path, followed from
# the board's step-timer interrupt handler BOARD_STEP_ISR as well as from the
# core's step functions; static storage only for BOARD_STATICS, OBJ.o:SYMBOL).
# BOARD_HOST_DEFS: knobs that differ in $(FW_DIR)/<board>/host/plotkin, the
# host tool built with the board's knobs (the comparator of the whole-chip tests).
# BOARD_LTO = 1 links with link-time optimisation. The objects are then fat
# (-ffat-lto-objects: machine code beside the LTO bytecode), so the object
# gate reads the same code it reads without LTO; LTO only inlines and drops
# across files, it adds no call, divide or static the objects do not have.
# BOARD_COLD_CFLAGS (e.g. -fno-inline) apply to every source but those in
# BOARD_HOT_SRC (the step path and the interrupt handlers, which keep the
# speed of the plain flags).
# BOARD_SELFTEST_FW = 1: the backend's objects refer to the core's (a step
# interrupt that compiles the step path into itself, hal/avr's
# PK_AVR_STEP_INC), so the backend self test (tests/avr/hal_selftest.c) links
# the core's objects too (--gc-sections keeps only what is referenced).
# BOARD_SRC is the board's one source list (backend files + hal/pk_app.c +
# hal/pk_uart.c); every firmware/*.c is compiled with the board's knobs and
# linked with --gc-sections, so only what the image uses stays in it.
# Images: $(FW_DIR)/<board>/<board>.{elf,hex,map}. The ELF is linked with
# the part's memory regions relaxed, so that an image too big for its part is
# still measured; tests/targets/fwsize.py checks it against the board's
# budget and writes the HEX only for an image that fits.

FW_DIR     := $(BUILD)/firmware
FW_BOARDMK := $(sort $(wildcard hal/*/*/board.mk))
FW_BOARDS  := $(foreach f,$(FW_BOARDMK),$(notdir $(patsubst %/,%,$(dir $(f)))))
FW_OPT     := -Os -g -ffunction-sections -fdata-sections -fno-common -ffreestanding
FW_CC_avr   := $(AVR_PREFIX)gcc
FW_CC_arm   := $(ARM_PREFIX)gcc
FW_BIN_avr  := $(AVR_PREFIX)
FW_BIN_arm  := $(ARM_PREFIX)
# -mrelax: calls and jumps within reach become rcall/rjmp (smaller, a cycle faster)
FW_ARCH_CFLAGS_avr := -mrelax
FW_RELAX_avr := -Wl,--defsym=__TEXT_REGION_LENGTH__=0x40000 -Wl,--defsym=__DATA_REGION_LENGTH__=0xffa0
FW_RELAX_arm := -Wl,--defsym=__pk_flash_len=0x100000 -Wl,--defsym=__pk_ram_len=0x100000

# $(call fw_board,DIR,NAME): read DIR/board.mk into FWB_NAME_* and make rules
define fw_board
BOARD_ARCH :=
BOARD_MCU :=
BOARD_CPU :=
BOARD_F_CPU :=
BOARD_SRC :=
BOARD_DEFS :=
BOARD_CFLAGS :=
BOARD_HOST_DEFS :=
BOARD_LDSCRIPT :=
BOARD_LDFLAGS :=
BOARD_LTO := 0
BOARD_COLD_CFLAGS :=
BOARD_HOT_SRC :=
BOARD_SELFTEST_FW := 0
BOARD_STEP_ISR :=
BOARD_STATICS :=
include $(1)/board.mk
ifeq ($$(BOARD_LTO),1)
BOARD_CFLAGS += -flto -ffat-lto-objects
endif
FWB_$(2)_HOT := $$(patsubst %.c,$(FW_DIR)/$(2)/obj/%.o,$$(BOARD_HOT_SRC))
FWB_$(2)_COLD := $$(BOARD_COLD_CFLAGS)
FWB_$(2)_ARCH := $$(BOARD_ARCH)
FWB_$(2)_MCU := $$(BOARD_MCU)
FWB_$(2)_CC := $$(FW_CC_$$(BOARD_ARCH))
FWB_$(2)_BIN := $$(FW_BIN_$$(BOARD_ARCH))
FWB_$(2)_MFLAGS := $$(if $$(BOARD_MCU),-mmcu=$$(BOARD_MCU)) $$(BOARD_CPU) -DF_CPU=$$(BOARD_F_CPU) \
                   $$(FW_ARCH_CFLAGS_$$(BOARD_ARCH)) $$(BOARD_CFLAGS)
FWB_$(2)_CPPFLAGS := -Ifirmware -Ihal -Ihal/$$(BOARD_ARCH) -I$(1) $$(BOARD_DEFS)
FWB_$(2)_SRC := $$(BOARD_SRC)
FWB_$(2)_DEFS := $$(BOARD_DEFS) $$(BOARD_HOST_DEFS)
FWB_$(2)_FLASH_MAX := $$(BOARD_FLASH_MAX)
FWB_$(2)_RAM_MAX := $$(BOARD_RAM_MAX)
FWB_$(2)_LDSCRIPT := $$(BOARD_LDSCRIPT)
FWB_$(2)_LDFLAGS := $$(BOARD_LDFLAGS) $$(FW_RELAX_$$(BOARD_ARCH))
FWB_$(2)_CHECK := $$(foreach f,$$(TARGETS_STEP_FUNCS) $$(BOARD_STEP_ISR),--step-func $$(f)) \
                  $$(foreach x,$$(BOARD_STATICS),--allow-static $$(x)) \
                  --target $(2):$$(FW_BIN_$$(BOARD_ARCH)):no
FWB_$(2)_OBJ := $$(patsubst %.c,$(FW_DIR)/$(2)/obj/%.o,$(TGT_FW_SRC) $$(BOARD_SRC))
FWB_$(2)_SELFTEST_FW := $$(if $$(filter 1,$$(BOARD_SELFTEST_FW)),$$(patsubst %.c,$(FW_DIR)/$(2)/obj/%.o,$(TGT_FW_SRC)))

$(FW_DIR)/$(2)/obj/firmware/%.o: firmware/%.c $(1)/board.mk hal/firmware.mk
	@mkdir -p $$(@D)
	$$(FWB_$(2)_CC) $$(FWB_$(2)_CPPFLAGS) $$(FW_WARN) $$(FW_OPT) $$(FWB_$(2)_MFLAGS) \
	  $$(if $$(filter $$@,$$(FWB_$(2)_HOT)),,$$(FWB_$(2)_COLD)) -MMD -MP -c $$< -o $$@
$(FW_DIR)/$(2)/obj/hal/%.o: hal/%.c $(1)/board.mk hal/firmware.mk
	@mkdir -p $$(@D)
	$$(FWB_$(2)_CC) $$(FWB_$(2)_CPPFLAGS) $$(FW_WARN) $$(FW_OPT) $$(FWB_$(2)_MFLAGS) \
	  $$(if $$(filter $$@,$$(FWB_$(2)_HOT)),,$$(FWB_$(2)_COLD)) -MMD -MP -c $$< -o $$@
$(FW_DIR)/$(2)/$(2).elf: $$(FWB_$(2)_OBJ) $$(FWB_$(2)_LDSCRIPT)
	$$(FWB_$(2)_CC) $$(FWB_$(2)_MFLAGS) $$(FW_OPT) -Wl,--gc-sections -Wl,-Map=$$(@:.elf=.map) \
	  $$(if $$(FWB_$(2)_LDSCRIPT),-T $$(FWB_$(2)_LDSCRIPT)) $$(FWB_$(2)_LDFLAGS) -o $$@ $$(FWB_$(2)_OBJ) -lgcc
# The host tool built with the board's size knobs: `plotkin sim` for the same
# firmware configuration as the image, to compare the two run for run.
# (-Wno-array-bounds: with PK_AXES=2, gcc flags the third-axis branches that
# only run when the kernel was set up with 3 dimensions, e.g. in cmd_refine.c.)
$(FW_DIR)/$(2)/host/obj/%.o: %.c $(1)/board.mk hal/firmware.mk
	@mkdir -p $$(@D)
	$$(CC) $$(CPPFLAGS_COMMON) $$(WARN) -Wno-array-bounds $$(OPT) $$(FWB_$(2)_DEFS) -MMD -MP -c $$< -o $$@
FWB_$(2)_HOSTOBJ = $$(patsubst %.c,$(FW_DIR)/$(2)/host/obj/%.o,$$(FW_SRC) $$(HAL_SRC) $$(SIM_SRC))
$(FW_DIR)/$(2)/host/plotkin: $$(FWB_$(2)_HOSTOBJ) $(FW_DIR)/$(2)/host/obj/host-sim/main.o
	$$(CC) $$(OPT) -o $$@ $$^ $$(HOST_LIBS)
# The motion property test (tests/test_motion_limits.c: rates, accelerations
# and deviation over random programs) built with the board's knobs, so that
# what a board changes in the motion core (PK_SG_SEG_HZ, queue depths) is held
# to the same bounds as the default build (tests/extra/board_property.sh).
$(FW_DIR)/$(2)/host/test_motion_limits: $$(FWB_$(2)_HOSTOBJ) $$(patsubst %.c,$(FW_DIR)/$(2)/host/obj/%.o,$$(TH_SRC) tests/test_motion_limits.c)
	$$(CC) $$(OPT) -o $$@ $$^ $$(HOST_LIBS)
# The backend alone on the board's part (tests/avr/hal_selftest.c): runs even
# while the full image does not fit.
$(FW_DIR)/$(2)/obj/tests/avr/%.o: tests/avr/%.c $(1)/board.mk hal/firmware.mk
	@mkdir -p $$(@D)
	$$(FWB_$(2)_CC) $$(FWB_$(2)_CPPFLAGS) $$(FW_WARN) $$(FW_OPT) $$(FWB_$(2)_MFLAGS) -MMD -MP -c $$< -o $$@
$(FW_DIR)/$(2)/hal_selftest.hex: $(FW_DIR)/$(2)/obj/tests/avr/hal_selftest.o \
    $$(patsubst %.c,$(FW_DIR)/$(2)/obj/%.o,$$(filter-out %_main.c hal/pk_app.c,$$(BOARD_SRC))) \
    $$(FWB_$(2)_SELFTEST_FW)
	$$(FWB_$(2)_CC) $$(FWB_$(2)_MFLAGS) $$(FW_OPT) -Wl,--gc-sections -o $$(@:.hex=.elf) $$^
	$$(FWB_$(2)_BIN)objcopy -O ihex -R .eeprom $$(@:.hex=.elf) $$@
$(FW_DIR)/$(2)/obj/fw_structs.o: tests/targets/fw_structs.c $(1)/board.mk hal/firmware.mk
	@mkdir -p $$(@D)
	$$(FWB_$(2)_CC) $$(FWB_$(2)_CPPFLAGS) -std=c11 $$(FW_OPT) $$(FWB_$(2)_MFLAGS) -MMD -MP -c $$< -o $$@
endef
$(foreach f,$(FW_BOARDMK),$(eval $(call fw_board,$(patsubst %/,%,$(dir $(f))),$(notdir $(patsubst %/,%,$(dir $(f)))))))

FW_ELFS := $(foreach b,$(FW_BOARDS),$(FW_DIR)/$(b)/$(b).elf $(FW_DIR)/$(b)/obj/fw_structs.o)
FW_SIZE_ARGS = $(foreach b,$(FW_BOARDS),--board $(b):$(FWB_$(b)_ARCH):$(FWB_$(b)_BIN):$(FWB_$(b)_FLASH_MAX):$(FWB_$(b)_RAM_MAX):$(FW_DIR)/$(b)/$(b).elf:$(FW_DIR)/$(b)/obj/fw_structs.o)

.PHONY: firmware firmware-build firmware-images
firmware:
	@bash .ci/deps.sh base targets
	@$(MAKE) --no-print-directory firmware-build

# The object gate, per image.
FW_GATE = $(foreach b,$(FW_BOARDS),out=$$($(PYTHON3) tests/targets/fwcheck.py $(FWB_$(b)_CHECK) $(FWB_$(b)_OBJ)) \
            || { printf '%s\n' "$$out" | grep -v '^$(b) '; echo "fwcheck failed on the $(b) image"; exit 1; }; \
            printf '%s\n' "$$out" | grep -E '^(fwcheck|note: .*static)' | sed 's/^/  $(b): /';) true

firmware-build: $(FW_ELFS) $(BUILD)/plotkin
	@$(FW_GATE)
	@$(PYTHON3) tests/targets/fwsize.py --plotkin $(BUILD)/plotkin --workload tests/avr/workload.gcode \
	  --detail $(FW_SIZE_ARGS)

firmware-images: $(FW_ELFS)
	@$(FW_GATE)
	@$(PYTHON3) tests/targets/fwsize.py --hex-only $(FW_SIZE_ARGS)

# ---- the simavr whole-chip harness (host-sim/avr_chip.c, `plotkin avrsim`) ----
# Compiled with libsimavr where pkg-config finds it; elsewhere the subcommand
# says how to get it.
HAVE_SIMAVR := $(shell pkg-config --exists simavr 2>/dev/null && test -f /usr/include/libelf.h -o -f /usr/include/libelf/libelf.h && echo yes)
ifeq ($(HAVE_SIMAVR),yes)
SIMAVR_CFLAGS := -DPK_HAVE_SIMAVR $(patsubst -I%,-isystem %,$(shell pkg-config --cflags simavr))
SIMAVR_LIBS   := $(shell pkg-config --libs simavr) -lelf
$(BUILD)/obj/host-sim/avr_chip.o $(SAN)/obj/host-sim/avr_chip.o: EXTRA_CFLAGS += $(SIMAVR_CFLAGS)
$(BUILD)/plotkin $(SAN)/plotkin: HOST_LIBS += $(SIMAVR_LIBS)
endif
