# SPDX-License-Identifier: MIT
# Fuzzing (docs/fuzzing.md), included by the Makefile:
#   make fuzz          each harness under libFuzzer+ASan+UBSan, FUZZ_SECONDS each
#   make check-fuzz    the same for FUZZ_CHECK_SECONDS each, counted in RESULTS;
#                      skipped (loudly) without a clang that links libFuzzer
#   make fuzz-replay   the harnesses built by $(CC) without libFuzzer, run over
#                      the committed seeds (no clang needed)
#   make fuzz-corpus   regenerate fuzz/corpus/ from the library's builders

FUZZ_TARGETS       := encap cip_reply cip_request io_frame path modbus rtu config \
                      sim_request cli
FUZZ_SECONDS       ?= 60
# make check runs every harness this long: 10 x 7 s keeps check-fuzz,
# builds included, well under two minutes.
FUZZ_CHECK_SECONDS ?= 7
FUZZ_CC            ?= clang
FUZZ_DIR           := $(B)/fuzz
FUZZ_SAN           := -g -O1 -fno-sanitize-recover=all -fno-omit-frame-pointer \
                      -fsanitize-coverage-ignorelist=fuzz/coverage-ignore.txt
FUZZ_FLAGS         := -fsanitize=fuzzer,address,undefined $(FUZZ_SAN)
# Only what the harnesses call: other lib/ files in progress cannot break it.
# Compiled once (instrumented, no libFuzzer main) for all the harnesses.
FUZZ_LIB_SRC       := lib/cip.c lib/text.c $(LIB_CODEC_SRC)
FUZZ_LIB_OBJ       := $(FUZZ_LIB_SRC:%.c=$(FUZZ_DIR)/obj/%.o)
FUZZ_BIN           := $(FUZZ_TARGETS:%=$(FUZZ_DIR)/fuzz_%)
FUZZ_REPLAY_BIN    := $(FUZZ_TARGETS:%=$(B)/fuzz-replay/fuzz_%)

# What a harness needs beyond FUZZ_LIB_SRC: sources (FUZZ_SRC_T), headers
# (FUZZ_HDR_T), compiler flags (FUZZ_CFLAGS_T) and libraries (FUZZ_LIBS_T).
# Flags and libraries are expanded when the recipe runs: the variables
# they use come from mk/*.mk, included after this file.
FUZZ_SRC_modbus      := gateway/mbproto.c gateway/regmap.c gateway/robot.c
FUZZ_HDR_modbus      := gateway/mbproto.h gateway/regmap.h gateway/robot.h gateway/config.h
FUZZ_CFLAGS_modbus    = $(MODBUS_CFLAGS)
FUZZ_LIBS_modbus      = $(MODBUS_LIBS)
FUZZ_SRC_rtu         := gateway/mbproto.c gateway/regmap.c gateway/robot.c
FUZZ_HDR_rtu         := gateway/mbproto.h gateway/regmap.h gateway/robot.h gateway/config.h
FUZZ_CFLAGS_rtu       = $(MODBUS_CFLAGS)
FUZZ_LIBS_rtu         = $(MODBUS_LIBS)
FUZZ_SRC_config      := $(sort $(wildcard gateway/config*.c))
FUZZ_HDR_config      := gateway/config.h gateway/config_internal.h
FUZZ_CFLAGS_config    = $(INIH_CFLAGS)
FUZZ_LIBS_config      = $(INIH_LIBS)
FUZZ_SRC_sim_request := $(filter-out sim/main.c,$(wildcard sim/*.c))
FUZZ_HDR_sim_request := $(wildcard sim/*.h)
# All of drcli but its main() (cli/drcli.c, on top of the rest).
FUZZ_SRC_cli         := $(filter-out cli/drcli.c,$(sort $(wildcard cli/*.c))) \
                        $(filter-out $(FUZZ_LIB_SRC),$(sort $(wildcard lib/*.c)))
FUZZ_HDR_cli         := $(wildcard cli/*.h)
FUZZ_CFLAGS_cli       = $(JSON_CFLAGS)
FUZZ_LIBS_cli         = $(JSON_LIBS)

.PHONY: fuzz fuzz-build check-fuzz fuzz-replay fuzz-corpus

$(FUZZ_DIR)/obj/%.o: %.c fuzz/coverage-ignore.txt $(LIB_HDR) $(LIB_PRIV_HDR)
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) $(WARN) -fsanitize=fuzzer-no-link,address,undefined \
	    $(FUZZ_SAN) -c $< -o $@

# $(1): target name
define FUZZ_RULES
$$(FUZZ_DIR)/fuzz_$(1): fuzz/fuzz_$(1).c fuzz/fuzz.h fuzz/coverage-ignore.txt \
        $$(FUZZ_LIB_OBJ) $$(FUZZ_SRC_$(1)) $$(FUZZ_HDR_$(1)) $$(LIB_HDR) $$(LIB_PRIV_HDR)
	@mkdir -p $$(dir $$@)
	$$(FUZZ_CC) $$(ALL_CPPFLAGS) $$(PRIV_CPPFLAGS) $$(FUZZ_CFLAGS_$(1)) $$(WARN) $$(FUZZ_FLAGS) -o $$@ \
	    $$< $$(FUZZ_SRC_$(1)) $$(FUZZ_LIB_OBJ) $$(FUZZ_LIBS_$(1)) -lm

$$(B)/fuzz-replay/fuzz_$(1): fuzz/fuzz_$(1).c fuzz/standalone.c fuzz/fuzz.h \
        $$(FUZZ_SRC_$(1)) $$(FUZZ_HDR_$(1)) $$(LIB_A) $$(LIB_HDR)
	@mkdir -p $$(dir $$@)
	$$(CC) $$(ALL_CPPFLAGS) $$(PRIV_CPPFLAGS) $$(FUZZ_CFLAGS_$(1)) $$(ALL_CFLAGS) $$(ALL_LDFLAGS) -o $$@ \
	    $$< fuzz/standalone.c $$(filter-out $$(LIB_SRC),$$(FUZZ_SRC_$(1))) $$(LIB_A) \
	    $$(FUZZ_LIBS_$(1)) -lm
endef
$(foreach t,$(FUZZ_TARGETS),$(eval $(call FUZZ_RULES,$(t))))

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

fuzz-replay: $(FUZZ_REPLAY_BIN)
	@for t in $(FUZZ_TARGETS); do $(B)/fuzz-replay/fuzz_$$t fuzz/corpus/$$t || exit 1; done

$(B)/fuzz-replay/gen_corpus: fuzz/gen_corpus.c $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) -o $@ $< $(LIB_A) -lm

fuzz-corpus: $(B)/fuzz-replay/gen_corpus
	rm -rf fuzz/corpus
	$(B)/fuzz-replay/gen_corpus fuzz/corpus
