# SPDX-License-Identifier: MIT
# Fuzzing (docs/fuzzing.md), included by the Makefile:
#   make fuzz          each harness under libFuzzer+ASan+UBSan, FUZZ_SECONDS each
#   make check-fuzz    the same for FUZZ_CHECK_SECONDS each, counted in RESULTS;
#                      skipped (loudly) without a clang that links libFuzzer
#   make fuzz-replay   the harnesses built by $(CC) without libFuzzer, run over
#                      the committed seeds (no clang needed)
#   make fuzz-corpus   regenerate fuzz/corpus/ from the library's builders

FUZZ_TARGETS       := encap cip_reply cip_request io_frame path modbus rtu config \
                      sim_request cli usermap sparkplug http eds identity
FUZZ_SECONDS       ?= 60
# make check runs every harness this long: 10 x 7 s, two at a time
# (FUZZ_JOBS, fuzz/run-fuzz.sh), keeps check-fuzz,
# builds included, well under two minutes.
FUZZ_CHECK_SECONDS ?= 7
FUZZ_CC            ?= clang
FUZZ_DIR           := $(B)/fuzz
FUZZ_SAN           := -g -O1 -fno-sanitize-recover=all -fno-omit-frame-pointer \
                      -fsanitize-coverage-ignorelist=fuzz/coverage-ignore.txt
FUZZ_FLAGS         := -fsanitize=fuzzer,address,undefined $(FUZZ_SAN)
# Only what the harnesses call: other lib/ files in progress cannot break it.
# Compiled once (instrumented, no libFuzzer main) for all the harnesses.
FUZZ_LIB_SRC       := lib/cip.c lib/text.c lib/layout.c $(LIB_CODEC_SRC)
FUZZ_LIB_OBJ       := $(FUZZ_LIB_SRC:%.c=$(FUZZ_DIR)/obj/%.o)
FUZZ_BIN           := $(FUZZ_TARGETS:%=$(FUZZ_DIR)/fuzz_%)
FUZZ_REPLAY_BIN    := $(FUZZ_TARGETS:%=$(B)/fuzz-replay/fuzz_%)

# What a harness links beyond FUZZ_LIB_SRC: sources (FUZZ_SRC_T), compiled
# into objects of their own here (instrumented) and taken from the plain
# build for the replay programs, and libraries (FUZZ_LIBS_T).
# The register map and what it needs: the robot's images, the user's map
# (its views' names), the JSON text of the console's map, and the one
# write path (core/write.c) with a log that formats and does not print
# (fuzz/log_stub.c).
FUZZ_REGMAP_SRC      := gateway/modbus/regmap.c gateway/modbus/usermap.c gateway/core/robot.c \
                        gateway/core/json.c gateway/core/write.c fuzz/log_stub.c
FUZZ_SRC_modbus      := gateway/modbus/mbproto.c $(FUZZ_REGMAP_SRC)
FUZZ_LIBS_modbus     := $(MODBUS_LIBS)
FUZZ_SRC_rtu         := gateway/modbus/mbproto.c $(FUZZ_REGMAP_SRC)
FUZZ_LIBS_rtu        := $(MODBUS_LIBS)
# config_robot.c's `map` lines: the user's map parser and the default map;
# [http] auth_file: the password file parser
FUZZ_SRC_config      := $(sort $(wildcard gateway/*/config*.c)) $(FUZZ_REGMAP_SRC) \
                        gateway/core/passwd.c common/eds.c common/eds_plan.c
FUZZ_SRC_usermap     := $(FUZZ_REGMAP_SRC)
FUZZ_LIBS_config     := $(INIH_LIBS)
# Sparkplug B commands (gateway/mqtt/sparkplug.c) over nanopb: Debian's
# libprotobuf-nanopb.a, not instrumented (libFuzzer sees our callbacks'
# coverage, not the protobuf decoder's).
# The log formats and does not print (fuzz/log_stub.c).
FUZZ_SRC_sparkplug   := gateway/mqtt/sparkplug.c gateway/mqtt/sparkplug_b.pb.c \
                        gateway/mqtt/deadband.c gateway/core/robot.c common/ev.c fuzz/log_stub.c
FUZZ_LIBS_sparkplug  := $(NANOPB_LIBS)
FUZZ_SRC_sim_request := $(SIM_LIB_SRC)
# The console's login (its worker thread, a fake crypt), Host check, and
# the path as logged and quoted (gateway/core/auth.c, request.c).
FUZZ_SRC_http        := gateway/core/auth.c gateway/http/request.c gateway/core/passwd.c \
                        gateway/core/log.c gateway/core/json.c common/ev.c
# All of drcli but its main() (cli/drcli.c, on top of the rest).
FUZZ_SRC_cli         := $(filter-out cli/drcli.c,$(CLI_SRC)) common/eds.c common/eds_plan.c \
                        $(filter-out $(FUZZ_LIB_SRC),$(LIB_SRC))
FUZZ_LIBS_cli        := $(JSON_LIBS)
# The EDS reader and the plan it gives alone (no I/O, no jansson).
FUZZ_SRC_eds         := common/eds.c common/eds_plan.c
# The robot's Identity as the link takes it (gateway/core/robot.c).
FUZZ_SRC_identity    := gateway/core/robot.c
# Every harness and every object gets all the packages' flags: they only
# add include directories.
FUZZ_CPPFLAGS        := $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) -Igateway $(MODBUS_CFLAGS) $(INIH_CFLAGS) $(NANOPB_CFLAGS) $(JSON_CFLAGS)

.PHONY: fuzz fuzz-build check-fuzz fuzz-replay fuzz-corpus

$(FUZZ_DIR)/obj/%.o: %.c $(FUZZ_DIR)/obj/%.d fuzz/coverage-ignore.txt
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(FUZZ_CPPFLAGS) $(WARN) -fsanitize=fuzzer-no-link,address,undefined \
	    $(FUZZ_SAN) $(DEPFLAGS) -c $< -o $@

$(B)/fuzz/log_stub.o: fuzz/log_stub.c $(B)/fuzz/log_stub.d
	@mkdir -p $(dir $@)
	$(CC) $(FUZZ_CPPFLAGS) $(ALL_CFLAGS) $(DEPFLAGS) -c $< -o $@

$(B)/fuzz-replay/standalone.o: fuzz/standalone.c $(B)/fuzz-replay/standalone.d
	@mkdir -p $(dir $@)
	$(CC) $(FUZZ_CPPFLAGS) $(ALL_CFLAGS) $(DEPFLAGS) -c $< -o $@

# $(1): target name. The replay programs link the plain build's objects
# (the library through libdrgate.a).
define FUZZ_RULES
$$(FUZZ_DIR)/fuzz_$(1): fuzz/fuzz_$(1).c $$(FUZZ_DIR)/fuzz_$(1).d fuzz/coverage-ignore.txt $$(FUZZ_LIB_OBJ) \
        $$(FUZZ_SRC_$(1):%.c=$$(FUZZ_DIR)/obj/%.o)
	@mkdir -p $$(dir $$@)
	$$(FUZZ_CC) $$(FUZZ_CPPFLAGS) $$(WARN) $$(FUZZ_FLAGS) $$(DEPFLAGS) -o $$@ $$< \
	    $$(FUZZ_SRC_$(1):%.c=$$(FUZZ_DIR)/obj/%.o) $$(FUZZ_LIB_OBJ) $$(FUZZ_LIBS_$(1)) -lm

$$(B)/fuzz-replay/fuzz_$(1): fuzz/fuzz_$(1).c $$(B)/fuzz-replay/fuzz_$(1).d \
        $$(B)/fuzz-replay/standalone.o \
        $$(patsubst %.c,$$(B)/%.o,$$(filter-out $$(LIB_SRC),$$(FUZZ_SRC_$(1)))) $$(LIB_A)
	@mkdir -p $$(dir $$@)
	$$(CC) $$(FUZZ_CPPFLAGS) $$(ALL_CFLAGS) $$(DEPFLAGS) $$(ALL_LDFLAGS) -o $$@ $$< \
	    $$(B)/fuzz-replay/standalone.o \
	    $$(patsubst %.c,$$(B)/%.o,$$(filter-out $$(LIB_SRC),$$(FUZZ_SRC_$(1)))) $$(LIB_A) \
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

$(B)/fuzz-replay/gen_corpus: fuzz/gen_corpus.c $(B)/fuzz-replay/gen_corpus.d $(LIB_A)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) $(ALL_CFLAGS) $(DEPFLAGS) $(ALL_LDFLAGS) -o $@ $< $(LIB_A) -lm

fuzz-corpus: $(B)/fuzz-replay/gen_corpus
	rm -rf fuzz/corpus
	$(B)/fuzz-replay/gen_corpus fuzz/corpus
