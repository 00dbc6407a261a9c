# bench/module.mk — `make bench` (host benchmarks against the peers, AVR cycle
# counts) and, below, the cross-target fragment tests/targets/module.mk (the
# top Makefile includes only */module.mk, one level deep).
include tests/targets/module.mk
