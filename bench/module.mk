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
