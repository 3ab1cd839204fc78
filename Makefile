# SPDX-License-Identifier: MIT
# drgate: `make` builds, `make check` runs every test, `make demo` shows it
# working, `make install` installs. See README.md.

# 1.0.0: the client's API changed (docs/api-changes.md), so did the soname.
VERSION      := 1.0.0
SOVERSION    := 1

PREFIX       ?= /usr/local
BINDIR       ?= $(PREFIX)/bin
LIBDIR       ?= $(PREFIX)/lib
INCLUDEDIR   ?= $(PREFIX)/include
MANDIR       ?= $(PREFIX)/share/man
DATADIR      ?= $(PREFIX)/share/drgate
UNITDIR      ?= $(PREFIX)/lib/systemd/system
PKGCONFIGDIR ?= $(LIBDIR)/pkgconfig
DESTDIR      ?=

CROSS_COMPILE ?=
ifeq ($(origin CC),default)
CC := $(CROSS_COMPILE)gcc
endif
ifeq ($(origin AR),default)
AR := $(CROSS_COMPILE)ar
endif
PKG_CONFIG ?= pkg-config
PYTHON     ?= python3

# Build directory: the sanitizer and cross builds use their own.
B ?= build

CFLAGS  ?= -O2 -g
WERROR  ?= -Werror
WARN    := -std=c99 -Wall -Wextra -Wpedantic $(WERROR) -Wshadow \
           -Wstrict-prototypes -Wmissing-prototypes -Wcast-align \
           -Wpointer-arith -Wformat=2 -Wvla
# Hardening, on by default (check-hardening in mk/static.mk verifies the
# programs): stack protector, glibc's checked calls (_FORTIFY_SOURCE needs
# the -O in CFLAGS), full RELRO, and position-independent programs (the
# library's objects add -fPIC after these; its link leaves out -pie).
HARDEN  ?= -fstack-protector-strong -D_FORTIFY_SOURCE=2
PIE_CFLAGS  ?= -fPIE
PIE_LDFLAGS ?= -pie
# -I.: the programs include what they share as "common/NAME.h".
ALL_CPPFLAGS := -Ilib/include -I. -D_POSIX_C_SOURCE=200809L $(CPPFLAGS)
ALL_CFLAGS   := $(WARN) $(HARDEN) $(PIE_CFLAGS) $(CFLAGS)
ALL_LDFLAGS  := $(PIE_LDFLAGS) -Wl,-z,relro,-z,now $(LDFLAGS)

pc = $(shell $(PKG_CONFIG) $(1) $(2) 2>/dev/null)

# ---- library -------------------------------------------------------------
LIB_CODEC_SRC := lib/fields.c lib/codec.c lib/path.c lib/status.c
LIB_SRC       := $(sort $(wildcard lib/*.c))
# What only Linux links: the POSIX transport and the malloc'ing
# constructors. Firmware takes the rest (docs/firmware.md).
LIB_OS_SRC    := lib/transport_posix.c lib/client_posix.c
LIB_FW_SRC    := $(filter-out $(LIB_OS_SRC),$(LIB_SRC))
LIB_OBJ       := $(LIB_SRC:%.c=$(B)/%.o)
LIB_A         := $(B)/libdrgate.a
LIB_SO_NAME   := libdrgate.so.$(SOVERSION)
LIB_SO        := $(B)/libdrgate.so.$(VERSION)
LIB_HDR       := $(wildcard lib/include/drgate/*.h)
# The library's private headers (lib/*.h: the wire toolkit cip_internal.h,
# the client's and the codec's insides): never installed. drsim, the tests,
# the fuzzers and the benchmarks, which work on the wire themselves, see
# them with PRIV_CPPFLAGS; applications (cli/, gateway/) do not.
LIB_PRIV_HDR  := $(wildcard lib/*.h)
PRIV_CPPFLAGS := -Ilib

# ---- programs --------------------------------------------------------------
# What drsim and drgatewayd share (Linux only, so not in the library): the
# event loop.
COMMON_SRC  := $(sort $(wildcard common/*.c))
COMMON_HDR  := $(wildcard common/*.h)
COMMON_OBJ  := $(COMMON_SRC:%.c=$(B)/%.o)
JSON_CFLAGS := $(call pc,--cflags,jansson)
JSON_LIBS   := $(call pc,--libs,jansson)
CLI_SRC     := $(sort $(wildcard cli/*.c))
CLI_HDR     := $(wildcard cli/*.h)
CLI_BIN     := $(B)/drcli
# drsim: the adapter logic (all of sim/ but main.c) is also linked into the
# tests/test_sim_* unit tests.
SIM_LIB_SRC := $(filter-out sim/main.c,$(wildcard sim/*.c))
SIM_HDR     := $(wildcard sim/*.h)
SIM_BIN     := $(B)/drsim
BINS        := $(CLI_BIN) $(SIM_BIN)

# ---- tests -----------------------------------------------------------------
CMOCKA_CFLAGS := $(call pc,--cflags,cmocka)
CMOCKA_LIBS   := $(call pc,--libs,cmocka)
TEST_SRC      := $(wildcard tests/test_*.c)
TEST_BIN      := $(TEST_SRC:tests/%.c=$(B)/tests/%)
TEST_SUPPORT  := $(wildcard tests/support/*.c)

.PHONY: all lib clean install uninstall check check-unit check-cli check-docs \
        check-cm4 check-firmware check-be check-asan demo deps docs bench \
        check-summary
.DEFAULT_GOAL := all

all: lib $(BINS)
lib: $(LIB_A) $(LIB_SO)

$(B)/%.o: %.c $(LIB_HDR) $(LIB_PRIV_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(ALL_CFLAGS) -fPIC -c $< -o $@

$(COMMON_OBJ): $(COMMON_HDR)

$(LIB_A): $(LIB_OBJ)
	rm -f $@
	$(AR) rcs $@ $^

$(LIB_SO): $(LIB_OBJ)
	$(CC) $(ALL_CFLAGS) -shared -Wl,-soname,$(LIB_SO_NAME) \
	    $(filter-out $(PIE_LDFLAGS),$(ALL_LDFLAGS)) -o $@ $^ -lm
	ln -sf $(notdir $@) $(B)/$(LIB_SO_NAME)
	ln -sf $(LIB_SO_NAME) $(B)/libdrgate.so

$(CLI_BIN): $(CLI_SRC) $(CLI_HDR) $(LIB_A) $(LIB_HDR)
	$(CC) $(ALL_CPPFLAGS) -DDRGATE_VERSION='"$(VERSION)"' $(JSON_CFLAGS) \
	    $(ALL_CFLAGS) -fPIE -pie $(ALL_LDFLAGS) \
	    -o $@ $(CLI_SRC) $(LIB_A) $(JSON_LIBS) -lm

$(SIM_BIN): sim/main.c $(SIM_LIB_SRC) $(SIM_HDR) $(COMMON_SRC) $(COMMON_HDR) $(LIB_A) $(LIB_HDR)
	$(CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) $(ALL_CFLAGS) -fPIE -pie $(ALL_LDFLAGS) \
	    -o $@ sim/main.c $(SIM_LIB_SRC) $(COMMON_SRC) $(LIB_A) -lm

$(B)/tests/test_sim_%: tests/test_sim_%.c $(SIM_LIB_SRC) $(SIM_HDR) $(TEST_SUPPORT) $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) -Itests -Isim $(CMOCKA_CFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(SIM_LIB_SRC) $(TEST_SUPPORT) $(LIB_A) $(CMOCKA_LIBS) -lm

# The event loop's test links the loop (an explicit rule wins over the
# generic one below).
$(B)/tests/test_ev: tests/test_ev.c $(COMMON_SRC) $(COMMON_HDR) $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Itests $(CMOCKA_CFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(COMMON_SRC) $(LIB_A) $(CMOCKA_LIBS) -lm

$(B)/tests/%: tests/%.c $(TEST_SUPPORT) $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) -Itests $(CMOCKA_CFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(TEST_SUPPORT) $(LIB_A) $(CMOCKA_LIBS) -lm

# ---- dependencies ----------------------------------------------------------
# Installs missing Debian packages (as root) and the Python test peers
# (tests/requirements.txt, pinned) into .venv. Says what it installs.
deps:
	@sh mk/deps.sh

# ---- tests -----------------------------------------------------------------
RESULTS := $(B)/check-results

# Every step runs even if an earlier one failed; a step that fails without
# recording its own result is recorded as one failure, so the summary line
# (and the exit status) can never miss it.
CHECK_STEPS := check-unit check-cli check-docs check-cm4 check-firmware check-be \
               check-asan check-fuzz
check: deps
	@rm -f $(RESULTS)
	$(MAKE) --no-print-directory all
	@for step in $(CHECK_STEPS); do \
	    $(MAKE) --no-print-directory $$step || \
	        echo "0 1 $$step (make $$step failed)" >> $(RESULTS); \
	done
	@$(MAKE) --no-print-directory check-summary

# The client tests run drsim next to them; cross builds skip those.
check-unit: $(TEST_BIN) $(if $(CROSS_COMPILE),,$(SIM_BIN))
	@sh tests/run-tests.sh "$(RESULTS)" "$(TEST_RUNNER)" $(TEST_BIN)

# drcli's offline commands end to end: golden transcripts, exit codes, and
# an independent Python decoder.
check-cli: $(CLI_BIN)
	@sh tests/cli/test_cli_offline.sh $(CLI_BIN) "$(RESULTS)" "drcli $(CLI_BIN)"

check-docs: $(CLI_BIN)
	@sh mk/gen-docs.sh --check $(CLI_BIN) "$(RESULTS)"

docs: $(CLI_BIN)
	@sh mk/gen-docs.sh --write $(CLI_BIN)
	@WARN="$(WARN)" sh mk/cross-cm4.sh --write-docs $(LIB_CODEC_SRC)
	@WARN="$(WARN)" $(FW_CM4) sh mk/cross-cm4.sh --write-docs $(LIB_FW_SRC)

# The codec must build for a Cortex-M4 with no OS; its size goes to docs.
check-cm4:
	@WARN="$(WARN)" sh mk/cross-cm4.sh "$(RESULTS)" $(LIB_CODEC_SRC)

# The whole client library but the POSIX objects, the same way: no OS
# symbol (socket, timerfd, epoll, clock_gettime, malloc,
# dr_transport_posix, ...); lib/text.c's conversions may call snprintf and
# strto*. Sizes of the codec and codec + client in docs/firmware.md.
FW_CM4 := CM4_NAME=firmware CM4_WHAT="client library" CM4_DOC=docs/firmware.md \
          CM4_ALLOW='snprintf|strtod|strtof|strtol|strtoul|strtoll|strtoull|__errno' \
          CM4_SUBTOTAL="$(notdir $(LIB_CODEC_SRC:.c=.o))"
check-firmware:
	@WARN="$(WARN)" $(FW_CM4) sh mk/cross-cm4.sh "$(RESULTS)" $(LIB_FW_SRC)

# The unit tests on a big-endian CPU (s390x under qemu-user). The programs
# run against Debian's multiarch s390x libc (libc6:s390x, which
# libcmocka0:s390x needs anyway), not the cross toolchain's copy under
# /usr/s390x-linux-gnu: mixing that copy's ld.so with the multiarch libc.so
# aborts every dynamically linked program ("stack smashing detected").
check-be:
	$(MAKE) --no-print-directory B=$(B)/s390x CROSS_COMPILE=s390x-linux-gnu- \
	    PKG_CONFIG=true CMOCKA_LIBS=-lcmocka HARDEN= \
	    TEST_RUNNER="qemu-s390x -L /" \
	    RESULTS=$(abspath $(RESULTS)) check-unit

# The whole suite again under AddressSanitizer + UBSan.
SAN_FLAGS := -O1 -g -fsanitize=address,undefined -fno-sanitize-recover=all \
             -fno-omit-frame-pointer
check-asan:
	$(MAKE) --no-print-directory -k B=$(B)/asan CFLAGS="$(SAN_FLAGS)" \
	    LDFLAGS="-fsanitize=address,undefined" HARDEN= \
	    RESULTS=$(abspath $(RESULTS)) all check-unit check-cli

check-summary:
	@awk '{p += $$1; f += $$2} END {printf "check: %d passed, %d failed\n", p, f; exit (f > 0)}' $(RESULTS)

# Fuzzing: fuzz, check-fuzz, fuzz-replay, fuzz-corpus (see fuzz/fuzz.mk).
-include fuzz/fuzz.mk

# ---- benchmarks and demo -------------------------------------------------
# mk/*.mk fragments add their own benchmark targets to BENCH_STEPS. Every
# benchmark runs, even after one missed a goal; then the status says so.
BENCH_STEPS :=
# Every benchmark runs (one that misses a goal does not stop the others);
# their output goes to $(B)/bench/out and a summary into docs/performance.md.
BENCH_OUT := $(B)/bench/out
bench: $(B)/bench/bench_codec
	@rm -rf $(BENCH_OUT); mkdir -p $(BENCH_OUT); st=0; \
	$(B)/bench/bench_codec > $(BENCH_OUT)/bench-codec.txt 2>&1 || st=1; \
	cat $(BENCH_OUT)/bench-codec.txt; \
	for step in $(BENCH_STEPS); do \
	    $(MAKE) --no-print-directory $$step GW_BENCH_ARGS=--write-doc \
	        > $(BENCH_OUT)/$$step.txt 2>&1 || st=1; \
	    cat $(BENCH_OUT)/$$step.txt; \
	done; \
	sh mk/bench-report.sh $(BENCH_OUT) docs/performance.md; exit $$st

$(B)/bench/%: bench/%.c $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) $(WARN) -O2 -g $(ALL_LDFLAGS) -o $@ $< $(LIB_A) -lm

demo: deps all
	@sh mk/demo.sh $(B)

# ---- install ---------------------------------------------------------------
install: all
	install -d $(DESTDIR)$(LIBDIR) $(DESTDIR)$(INCLUDEDIR)/drgate \
	    $(DESTDIR)$(PKGCONFIGDIR) $(DESTDIR)$(BINDIR) $(DESTDIR)$(MANDIR)/man1
	install -m 644 $(LIB_A) $(DESTDIR)$(LIBDIR)/
	install -m 755 $(LIB_SO) $(DESTDIR)$(LIBDIR)/
	ln -sf libdrgate.so.$(VERSION) $(DESTDIR)$(LIBDIR)/$(LIB_SO_NAME)
	ln -sf $(LIB_SO_NAME) $(DESTDIR)$(LIBDIR)/libdrgate.so
	# The public headers only (lib/*.h are private); cip.h was public up to
	# 0.1.0 and must not outlive it in an upgraded tree.
	install -m 644 $(LIB_HDR) $(DESTDIR)$(INCLUDEDIR)/drgate/
	rm -f $(DESTDIR)$(INCLUDEDIR)/drgate/cip.h
	sed -e 's|@PREFIX@|$(PREFIX)|; s|@LIBDIR@|$(LIBDIR)|; s|@INCLUDEDIR@|$(INCLUDEDIR)|; s|@VERSION@|$(VERSION)|' \
	    lib/drgate.pc.in > $(DESTDIR)$(PKGCONFIGDIR)/drgate.pc
	install -m 755 $(BINS) $(DESTDIR)$(BINDIR)/
	install -m 644 $(wildcard man/*.1) $(DESTDIR)$(MANDIR)/man1/

uninstall:
	rm -f $(DESTDIR)$(LIBDIR)/libdrgate.* $(DESTDIR)$(PKGCONFIGDIR)/drgate.pc
	rm -rf $(DESTDIR)$(INCLUDEDIR)/drgate
	rm -f $(addprefix $(DESTDIR)$(BINDIR)/,$(notdir $(BINS)))
	rm -f $(addprefix $(DESTDIR)$(MANDIR)/man1/,$(notdir $(wildcard man/*.1)))

clean:
	rm -rf build

# ---- module fragments ------------------------------------------------------
# Each mk/*.mk adds the rules of one part (gateway, GPIO, fuzzing, ...).
include $(sort $(wildcard mk/*.mk))
