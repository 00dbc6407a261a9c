# bench/corpus/module.mk — the corpus of real G-code files (included from
# bench/module.mk; the top Makefile includes only */module.mk one level deep).
#   make bench-corpus                       every file, --exact and tolerance 0.01/0.02/0.05 mm
#   make bench-corpus CORPUS_ARGS=--quick   a handful of small files (seconds)
# A benchmark: it prints a table and fails only when it cannot measure. Not
# part of `make test`.
CORPUS_ARGS ?=
.PHONY: bench-corpus
bench-corpus: $(BUILD)/plotkin
	@$(PYTHON3) bench/corpus/run_corpus.py --plotkin $(BUILD)/plotkin $(CORPUS_ARGS)
