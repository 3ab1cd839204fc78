# SPDX-License-Identifier: MIT
# Fuzzing (docs/fuzzing.md), included by the Makefile:
#   make fuzz          each harness under libFuzzer+ASan+UBSan, FUZZ_SECONDS each
#   make check-fuzz    the same for FUZZ_CHECK_SECONDS each, counted in RESULTS;
#                      skipped (loudly) without a clang that links libFuzzer
#   make fuzz-replay   the harnesses built by $(CC) without libFuzzer, run over
#                      the committed seeds (no clang needed)
#   make fuzz-corpus   regenerate fuzz/corpus/ from the library's builders

FUZZ_TARGETS       := encap cip_reply cip_request io_frame path
FUZZ_SECONDS       ?= 60
FUZZ_CHECK_SECONDS ?= 10
FUZZ_CC            ?= clang
FUZZ_DIR           := $(B)/fuzz
FUZZ_FLAGS         := -g -O1 -fsanitize=fuzzer,address,undefined \
                      -fno-sanitize-recover=all -fno-omit-frame-pointer \
                      -fsanitize-coverage-ignorelist=fuzz/coverage-ignore.txt
# Only what the harnesses call: other lib/ files in progress cannot break it.
FUZZ_LIB_SRC       := lib/cip.c lib/text.c $(LIB_CODEC_SRC)
FUZZ_BIN           := $(FUZZ_TARGETS:%=$(FUZZ_DIR)/fuzz_%)
FUZZ_REPLAY_BIN    := $(FUZZ_TARGETS:%=$(B)/fuzz-replay/fuzz_%)

.PHONY: fuzz fuzz-build check-fuzz fuzz-replay fuzz-corpus

$(FUZZ_DIR)/fuzz_%: fuzz/fuzz_%.c fuzz/fuzz.h fuzz/coverage-ignore.txt $(FUZZ_LIB_SRC) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(ALL_CPPFLAGS) $(WARN) $(FUZZ_FLAGS) -o $@ $< $(FUZZ_LIB_SRC) -lm

fuzz-build: $(FUZZ_BIN)

fuzz:
	@sh fuzz/run-fuzz.sh --probe $(FUZZ_CC)
	@$(MAKE) --no-print-directory fuzz-build
	@sh fuzz/run-fuzz.sh "$(FUZZ_DIR)/results" $(FUZZ_SECONDS) $(FUZZ_DIR) $(FUZZ_TARGETS)

check-fuzz:
	@if sh fuzz/run-fuzz.sh --probe $(FUZZ_CC); then \
	    if $(MAKE) --no-print-directory fuzz-build; then \
	        sh fuzz/run-fuzz.sh "$(RESULTS)" $(FUZZ_CHECK_SECONDS) $(FUZZ_DIR) $(FUZZ_TARGETS); \
	    else mkdir -p $(dir $(RESULTS)); echo "0 1 fuzz_build" >> $(RESULTS); exit 1; fi; \
	else sh fuzz/run-fuzz.sh --skip "$(RESULTS)" $(FUZZ_TARGETS); fi

$(B)/fuzz-replay/fuzz_%: fuzz/fuzz_%.c fuzz/standalone.c fuzz/fuzz.h $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) -o $@ $< fuzz/standalone.c $(LIB_A) -lm

fuzz-replay: $(FUZZ_REPLAY_BIN)
	@for t in $(FUZZ_TARGETS); do $(B)/fuzz-replay/fuzz_$$t fuzz/corpus/$$t || exit 1; done

$(B)/fuzz-replay/gen_corpus: fuzz/gen_corpus.c $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) -o $@ $< $(LIB_A) -lm

fuzz-corpus: $(B)/fuzz-replay/gen_corpus
	rm -rf fuzz/corpus
	$(B)/fuzz-replay/gen_corpus fuzz/corpus
