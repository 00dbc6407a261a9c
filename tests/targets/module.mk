# tests/targets/module.mk — the firmware on real instruction sets.
# (Included from bench/module.mk: the top Makefile only picks up */module.mk.)
#
#   make targets   cross-compile firmware/*.c for Cortex-M0+, Cortex-M4 and the
#                  ATmega328P (-Os, freestanding), fail on heap/stdio/float/
#                  mutable statics (and software divide on the step path), print
#                  the size tables, the kernel state sizes and the flash of a
#                  minimal Chaikin+limit image on Cortex-M0+ (the full kernel
#                  and the Chaikin+clamped+limit build, to depth 8 and 5).
#   make qemu-images
#                  on-target test images (Cortex-M3, mps2-an385, semihosting);
#                  run by tests/extra/qemu_cortexm.sh inside `make test`.
#
# Every firmware/*.c is picked up by wildcard, so the motion core and the
# protocol join the cross builds and the checks when they are merged.

TGT_DIR    := $(BUILD)/targets
TGT_FW_SRC := $(sort $(wildcard firmware/*.c))
ARM_PREFIX := arm-none-eabi-
AVR_PREFIX := avr-
ARM_CC     := $(ARM_PREFIX)gcc
AVR_CC     := $(AVR_PREFIX)gcc
PYTHON3    ?= /usr/bin/python3

# Step path: objects (basename, e.g. pk_step.o) and functions that must not
# call a software divide (or float). The functions are followed through their
# direct calls across all firmware objects: the step timer callback
# pk_machine_timer_cb (pk_motion.c) and the step generator's ISR work
# pk_sg_isr (pk_stepgen.c), listed as soon as their files exist. fwcheck fails
# if a listed name does not exist, so a rename cannot silently switch the
# check off.
TARGETS_STEP_OBJS  ?=
TARGETS_STEP_FUNCS ?= $(if $(wildcard firmware/pk_motion.c),pk_machine_timer_cb) \
                      $(if $(wildcard firmware/pk_stepgen.c),pk_sg_isr)

TGT_CPPFLAGS := -Ifirmware -Ihal
TGT_OPT      := -Os -g -ffreestanding -ffunction-sections -fdata-sections -fno-common
TGT_FLAGS_m0plus := -mcpu=cortex-m0plus -mthumb -mfloat-abi=soft
TGT_FLAGS_m4     := -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16
TGT_FLAGS_m3     := -mcpu=cortex-m3 -mthumb -mfloat-abi=soft
TGT_FLAGS_avr    := -mmcu=atmega328p -DF_CPU=16000000UL
TGT_CC_m0plus := $(ARM_CC)
TGT_CC_m4     := $(ARM_CC)
TGT_CC_m3     := $(ARM_CC)
TGT_CC_avr    := $(AVR_CC)

HAVE_ARM_TOOLS := $(shell command -v $(ARM_CC) >/dev/null 2>&1 && command -v qemu-system-arm >/dev/null 2>&1 && echo yes)

# firmware objects per target: $(call tgt_fw_objs,TARGET[-VARIANT])
tgt_fw_objs = $(patsubst firmware/%.c,$(TGT_DIR)/$(1)/obj/firmware/%.o,$(TGT_FW_SRC))

# $(call tgt_fw_rule,DIR,CC,FLAGS)
define tgt_fw_rule
$(TGT_DIR)/$(1)/obj/firmware/%.o: firmware/%.c
	@mkdir -p $$(@D)
	$(2) $$(TGT_CPPFLAGS) $$(FW_WARN) $$(TGT_OPT) $(3) -MMD -MP -c $$< -o $$@
$(TGT_DIR)/$(1)/libplotkin_fw.a: $$(call tgt_fw_objs,$(1))
	@mkdir -p $$(@D); rm -f $$@; $(if $(findstring avr,$(2)),$(AVR_PREFIX),$(ARM_PREFIX))ar rcs $$@ $$^
endef
$(foreach t,m0plus m4 m3 avr,$(eval $(call tgt_fw_rule,$(t),$(TGT_CC_$(t)),$(TGT_FLAGS_$(t)))))
# The Chaikin-only configuration (2 points of history per level).
# TGT_WIN2_EXTRA: extra flags for that build (none needed: the kernel guards
# the emitters a 2-point window cannot run at compile time).
TGT_WIN2_EXTRA ?=
$(eval $(call tgt_fw_rule,m0plus-win2,$(ARM_CC),$(TGT_FLAGS_m0plus) -DPK_WIN=2 $(TGT_WIN2_EXTRA)))
# The Chaikin + clamped + limit kernel build (compile-time selection, see
# firmware/pk_refine.h; bench/kernel_sizes.py has every build), 2 axes, to depth
# 8 and to depth 5 (32-bit values).
TGT_CHAIKIN_FLAGS := -DPK_AXES=2 -DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02 -DPK_BUILD_CLOSED=0
$(eval $(call tgt_fw_rule,m0plus-chaikin,$(ARM_CC),$(TGT_FLAGS_m0plus) $(TGT_CHAIKIN_FLAGS)))
$(eval $(call tgt_fw_rule,m0plus-chaikin-d5,$(ARM_CC),$(TGT_FLAGS_m0plus) $(TGT_CHAIKIN_FLAGS) -DPK_MAX_DEPTH=5))

TGT_CHECKED := m0plus m4 avr

# ---- kernel state size, read back from objects (target ABI, not the host's) --
# name:compiler:flags
TGT_STATE_CFGS := ax3:-DPK_AXES=3 ax2:-DPK_AXES=2 ax3-win2:-DPK_AXES=3%-DPK_WIN=2 ax2-win2:-DPK_AXES=2%-DPK_WIN=2
TGT_STATE_OBJS :=
define tgt_state_rule
$(TGT_DIR)/state/$(1)-$(2).o: tests/targets/state_size.c firmware/pk_refine.h firmware/pk_fixed.h
	@mkdir -p $$(@D)
	$(if $(filter host,$(1)),$(CC),$(TGT_CC_$(1))) $$(TGT_CPPFLAGS) -std=c11 $(if $(filter host,$(1)),,$(TGT_FLAGS_$(1))) $(subst %, ,$(3)) -c $$< -o $$@
TGT_STATE_OBJS += $(TGT_DIR)/state/$(1)-$(2).o
endef
$(foreach t,m0plus avr host,$(foreach c,$(TGT_STATE_CFGS),\
  $(eval $(call tgt_state_rule,$(t),$(word 1,$(subst :, ,$(c))),$(word 2,$(subst :, ,$(c)))))))

# ---- minimal Chaikin + limit image on Cortex-M0+ (--gc-sections) -------------
TGT_IMG_LDFLAGS := -nostdlib -nostartfiles -Wl,--gc-sections -T tests/targets/cortexm.ld
define tgt_img_rule
$(TGT_DIR)/$(1)/obj/img/%.o: tests/targets/%.c tests/th.h
	@mkdir -p $$(@D)
	$(ARM_CC) $$(TGT_CPPFLAGS) -Itests $$(WARN) $$(TGT_OPT) $(2) -fno-builtin -fno-tree-loop-distribute-patterns -c $$< -o $$@
$(TGT_DIR)/$(1)/chaikin_limit.elf: $(TGT_DIR)/$(1)/obj/img/chaikin_image.o $(TGT_DIR)/$(1)/obj/img/cm_start.o $(TGT_DIR)/$(1)/obj/img/cm_mini_libc.o $(TGT_DIR)/$(1)/libplotkin_fw.a tests/targets/cortexm.ld
	$(ARM_CC) $(2) $$(TGT_IMG_LDFLAGS) -Wl,-Map=$$(@:.elf=.map) -o $$@ $$(filter %.o %.a,$$^) -lgcc
endef
$(eval $(call tgt_img_rule,m0plus,$(TGT_FLAGS_m0plus)))
$(eval $(call tgt_img_rule,m0plus-win2,$(TGT_FLAGS_m0plus) -DPK_WIN=2))
$(eval $(call tgt_img_rule,m0plus-chaikin,$(TGT_FLAGS_m0plus) $(TGT_CHAIKIN_FLAGS)))
$(eval $(call tgt_img_rule,m0plus-chaikin-d5,$(TGT_FLAGS_m0plus) $(TGT_CHAIKIN_FLAGS) -DPK_MAX_DEPTH=5))

.PHONY: targets targets-build qemu-images
targets:
	@bash .ci/deps.sh targets
	@$(MAKE) --no-print-directory targets-build

targets-build: $(foreach t,$(TGT_CHECKED),$(call tgt_fw_objs,$(t))) $(TGT_STATE_OBJS) \
               $(TGT_DIR)/m0plus/chaikin_limit.elf $(TGT_DIR)/m0plus-win2/chaikin_limit.elf \
               $(TGT_DIR)/m0plus-chaikin/chaikin_limit.elf $(TGT_DIR)/m0plus-chaikin-d5/chaikin_limit.elf
	@$(PYTHON3) tests/targets/fwcheck.py \
	  $(addprefix --step-obj ,$(TARGETS_STEP_OBJS)) $(addprefix --step-func ,$(TARGETS_STEP_FUNCS)) \
	  --target m0plus:$(ARM_PREFIX):no $(call tgt_fw_objs,m0plus) \
	  --target m4:$(ARM_PREFIX):yes $(call tgt_fw_objs,m4) \
	  --target avr:$(AVR_PREFIX):no $(call tgt_fw_objs,avr)
	@$(PYTHON3) tests/targets/report.py state $(TGT_STATE_OBJS)
	@$(PYTHON3) tests/targets/report.py image \
	  "Cortex-M0+ Chaikin+limit image, PK_WIN=5 (default)=$(TGT_DIR)/m0plus/chaikin_limit.map" \
	  "Cortex-M0+ Chaikin+limit image, PK_WIN=2 (Chaikin-only)=$(TGT_DIR)/m0plus-win2/chaikin_limit.map" \
	  "Cortex-M0+ Chaikin+limit image, Chaikin+clamped+limit build, 2 axes=$(TGT_DIR)/m0plus-chaikin/chaikin_limit.map" \
	  "Cortex-M0+ Chaikin+limit image, the same to depth 5=$(TGT_DIR)/m0plus-chaikin-d5/chaikin_limit.map"

# ---- on-target tests (Cortex-M3 under QEMU) ---------------------------------
# Test programs that read host files cannot run on target: list them here.
QEMU_SKIP ?=
QEMU_PROGS := test_th_selftest \
  $(filter-out $(QEMU_SKIP),$(patsubst tests/%.c,%,$(sort $(wildcard tests/test_refine*.c))))
QEMU_IMAGES := $(addprefix $(TGT_DIR)/m3/tests/,$(addsuffix .elf,$(QEMU_PROGS))) \
               $(TGT_DIR)/m3/tests/deliberate_fail.elf $(TGT_DIR)/m3/tests/deliberate_fault.elf
TGT_M3_TESTFLAGS := $(TGT_FLAGS_m3) -Os -g -ffunction-sections -fdata-sections
TGT_M3_SUPPORT := $(TGT_DIR)/m3/obj/tests/th.o $(TGT_DIR)/m3/obj/img/cm_start.o $(TGT_DIR)/m3/obj/img/cm_mini_libc.o

$(TGT_DIR)/m3/obj/tests/%.o: tests/%.c
	@mkdir -p $(@D)
	$(ARM_CC) $(TGT_CPPFLAGS) -Itests $(WARN) $(TGT_M3_TESTFLAGS) -MMD -MP -c $< -o $@
$(TGT_DIR)/m3/obj/tests/deliberate_fail.o: tests/test_th_selftest.c
	@mkdir -p $(@D)
	$(ARM_CC) $(TGT_CPPFLAGS) -Itests $(WARN) $(TGT_M3_TESTFLAGS) -DTH_SELFTEST_DELIBERATE_FAIL -c $< -o $@
$(TGT_DIR)/m3/obj/tests/deliberate_fault.o: tests/test_th_selftest.c
	@mkdir -p $(@D)
	$(ARM_CC) $(TGT_CPPFLAGS) -Itests $(WARN) $(TGT_M3_TESTFLAGS) -DTH_SELFTEST_DELIBERATE_FAULT -c $< -o $@
$(eval $(call tgt_img_rule,m3,$(TGT_FLAGS_m3)))
$(TGT_DIR)/m3/tests/%.elf: $(TGT_DIR)/m3/obj/tests/%.o $(TGT_M3_SUPPORT) $(TGT_DIR)/m3/libplotkin_fw.a tests/targets/cortexm.ld
	@mkdir -p $(@D)
	$(ARM_CC) $(TGT_FLAGS_m3) $(TGT_IMG_LDFLAGS) -o $@ $(filter %.o %.a,$^) -lgcc

qemu-images: $(QEMU_IMAGES)

ifeq ($(HAVE_ARM_TOOLS),yes)
test-build: qemu-images
endif
