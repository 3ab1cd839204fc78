# SPDX-License-Identifier: MIT
# drgate: `make` builds, `make check` runs every test, `make demo` shows it
# working, `make install` installs. See README.md.

# 1.0.0: the client's API changed (docs/api-changes.md), so did the soname.
# 2.0.0: structures the caller allocates grew after 1.0.0 (the transport
# table, dr_conn_config_t, the client's storage) and the field table is no
# longer exported as data: soname 2, symbols versioned (lib/libdrgate.map),
# the ABI checked against lib/abi/ (make check-abi, mk/abi.mk).
VERSION      := 2.0.0
SOVERSION    := 2

PREFIX       ?= /usr/local
BINDIR       ?= $(PREFIX)/bin
LIBDIR       ?= $(PREFIX)/lib
INCLUDEDIR   ?= $(PREFIX)/include
MANDIR       ?= $(PREFIX)/share/man
DATADIR      ?= $(PREFIX)/share/drgate
UNITDIR      ?= $(PREFIX)/lib/systemd/system
DOCDIR       ?= $(PREFIX)/share/doc/drgate
# Where Wireshark looks for Lua plugins: with PREFIX=/usr on Debian, its
# global Lua plugin folder (tshark -G folders); elsewhere see docs/wireshark.md.
WIRESHARK_LUADIR ?= $(PREFIX)/lib/$(if $(MULTIARCH),$(MULTIARCH)/)wireshark/plugins
PKGCONFIGDIR ?= $(LIBDIR)/pkgconfig
# The CMake package (find_package(drgate)): lib/cmake/*.in, installed here.
CMAKEDIR     ?= $(LIBDIR)/cmake/drgate
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
# Debian's multiarch triplet of the target (x86_64-linux-gnu), for paths of
# other packages' plugin folders; empty where the compiler has none.
MULTIARCH  ?= $(shell $(CC) -print-multiarch 2>/dev/null)

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

# Every object and every program compiled from a source writes the list of
# the headers it read (-MMD) next to it, with an empty rule per header
# (-MP: a header deleted later does not break the build); the lists are
# read at the end of this file. So touching any header rebuilds exactly
# what includes it. mk/check-deps.py (make check-deps, in check-quick)
# checks that this holds for every header of the tree.
#
# Each compile rule also names its list as a prerequisite: a file whose
# list is missing (built before the lists existed, or by a rule that forgot
# DEPFLAGS) is made again, since a missing list is "remade" by the empty
# rule below (and is kept: .PRECIOUS).
DEPFLAGS := -MMD -MP
$(B)/%.d: ;
.PRECIOUS: $(B)/%.d

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
# What libdrgate.so exports, by version node; nothing else.
LIB_MAP       := lib/libdrgate.map
# The library's private headers (lib/*.h: the wire toolkit cip_internal.h,
# the client's and the codec's insides): never installed. drsim, the tests,
# the fuzzers and the benchmarks, which work on the wire themselves, see
# them with PRIV_CPPFLAGS; applications (cli/, gateway/) do not.
PRIV_CPPFLAGS := -Ilib

# ---- programs --------------------------------------------------------------
# Each program is linked from objects compiled once with its own flags
# (a static pattern rule per group below); what else links the same code
# (tests, fuzz replay, benchmarks) links those objects.
#
# What drsim and drgatewayd share (Linux only, so not in the library): the
# event loop, as an archive of its own.
COMMON_SRC  := $(sort $(wildcard common/*.c))
COMMON_OBJ  := $(COMMON_SRC:%.c=$(B)/%.o)
COMMON_A    := $(B)/common/libdrcommon.a
JSON_CFLAGS := $(call pc,--cflags,jansson)
JSON_LIBS   := $(call pc,--libs,jansson)
CLI_SRC     := $(sort $(wildcard cli/*.c))
CLI_OBJ     := $(CLI_SRC:%.c=$(B)/%.o)
CLI_BIN     := $(B)/drcli
CLI_CFLAGS   = $(ALL_CPPFLAGS) -DDRGATE_VERSION='"$(VERSION)"' $(JSON_CFLAGS) $(ALL_CFLAGS)
# drsim: the adapter logic (all of sim/ but main.c) is also linked into the
# tests/unit/test_sim_* unit tests and bench/enip_io.
SIM_SRC     := $(sort $(wildcard sim/*.c))
SIM_LIB_SRC := $(filter-out sim/main.c,$(SIM_SRC))
SIM_OBJ     := $(SIM_SRC:%.c=$(B)/%.o)
SIM_LIB_OBJ := $(SIM_LIB_SRC:%.c=$(B)/%.o)
SIM_BIN     := $(B)/drsim
SIM_CFLAGS   = $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) $(ALL_CFLAGS)

# ---- drgatewayd ------------------------------------------------------------
# The daemon is gateway/core/main.c linked with two archives: libgw.a (every
# other gateway/ source but the GPIO ones) and libgwgpio.a (the GPIO layer
# with one backend, libgpiod 1 or 2). The tests link the same archives.
# The pkg-config fallbacks cover builds where pkg-config is off (check-be
# runs with PKG_CONFIG=true).
# libmodbus: only the Modbus fuzzers compare against it (fuzz/fuzz.mk); the
# daemon has its own Modbus code and the specification's limits
# (gateway/modbus/mbproto.h), so its build needs no libmodbus-dev.
MODBUS_CFLAGS  := $(or $(call pc,--cflags,libmodbus),-I/usr/include/modbus)
MODBUS_LIBS    := $(or $(call pc,--libs,libmodbus),-lmodbus)
INIH_CFLAGS    := $(call pc,--cflags,inih)
INIH_LIBS      := $(or $(call pc,--libs,inih),-linih)
SYSTEMD_CFLAGS := $(call pc,--cflags,libsystemd)
SYSTEMD_LIBS   := $(or $(call pc,--libs,libsystemd),-lsystemd)
# GPIO backend: v2 when pkg-config finds libgpiod >= 2.0, else v1
# (bookworm). An empty version (no libgpiod, or PKG_CONFIG=true in cross
# builds) means v1, which is what bookworm has.
GPIO_VERSION  := $(call pc,--modversion,libgpiod)
ifeq ($(origin GPIO_BACKEND),undefined)
GPIO_BACKEND  := $(if $(GPIO_VERSION),$(if $(shell $(PKG_CONFIG) \
                   --atleast-version=2.0 libgpiod 2>/dev/null && echo y),v2,v1),v1)
endif
GPIO_CFLAGS   := $(call pc,--cflags,libgpiod)
GPIO_LIBS     := $(or $(call pc,--libs,libgpiod),-lgpiod)
# For a program that includes "gpio/gpio.h" and links $(GPIO_A) $(GPIO_LIBS).
GPIO_CPPFLAGS := -Igateway
GPIO_HDR      := gateway/gpio/gpio.h gateway/gpio/gpio_internal.h
GPIO_CORE_SRC := gateway/gpio/gpio_common.c gateway/gpio/gpio_debounce.c
GPIO_ALL_SRC  := $(GPIO_CORE_SRC) gateway/gpio/gpio_v1.c gateway/gpio/gpio_v2.c
GPIO_SRC      := $(GPIO_CORE_SRC) gateway/gpio/gpio_$(GPIO_BACKEND).c
GPIO_OBJ      := $(GPIO_SRC:%.c=$(B)/%.o)
GPIO_A        := $(B)/gateway/libgwgpio.a
GPIO_OBJ_CFLAGS = $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) $(GPIO_CFLAGS) $(ALL_CFLAGS) -fPIC

# OPC UA (gateway/opcua/, docs/opcua.md): built with open62541 1.4 when
# pkg-config finds it (Debian 13's libopen62541-1.4-dev; Debian 12 has
# none, and its daemon refuses an [opcua] section). Debian's open62541.pc
# names mbedTLS's libraries as -l/usr/lib/.../libmbedtls.so: those are
# passed as the files they are. libcrypt checks auth_file's passwords.
OPCUA_VERSION := $(call pc,--modversion,open62541)
ifneq ($(OPCUA_VERSION),)
OPCUA_CFLAGS  := -DGW_HAVE_OPCUA $(call pc,--cflags,open62541)
OPCUA_LIBS    := $(patsubst -l/%,/%,$(call pc,--libs,open62541)) -lcrypt
endif
# What only a build with open62541 compiles, and what one without does
# instead (the side that has nothing to do).
OPCUA_ONLY_SRC := gateway/opcua/north_opcua.c gateway/opcua/ua_crypto.c gateway/opcua/ua_model.c gateway/opcua/ua_robotics.c \
                  gateway/opcua/ua_sessions.c
OPCUA_NONE_SRC := gateway/opcua/north_opcua_none.c
GW_SRC      := $(filter-out $(GPIO_ALL_SRC) $(if $(OPCUA_VERSION),$(OPCUA_NONE_SRC),$(OPCUA_ONLY_SRC)),\
                 $(sort $(wildcard gateway/*/*.c)))
GW_HDR      := $(filter-out $(GPIO_HDR),$(wildcard gateway/*/*.h))
GW_LIB_SRC  := $(filter-out gateway/core/main.c,$(GW_SRC))
GW_LIB_OBJ  := $(GW_LIB_SRC:%.c=$(B)/%.o)
# The console's files (gateway/http/www/: pages, script, style sheet) built
# into the daemon as a C table (gateway/http/asset.h) that
# mk/gen-assets.sh writes with POSIX tools; it goes into libgw.a with the
# rest. Adding, removing or changing a file of www/ writes it again.
GW_WWW        := $(sort $(wildcard gateway/http/www/*))
GW_ASSETS_C   := $(B)/gateway/http/assets_gen.c
GW_ASSETS_OBJ := $(B)/gateway/http/assets_gen.o
GW_A        := $(B)/gateway/libgw.a
GW_BIN      := $(B)/drgatewayd
GW_CFLAGS    = $(ALL_CPPFLAGS) -Igateway -DDRGATE_VERSION='"$(VERSION)"' \
               $(INIH_CFLAGS) $(SYSTEMD_CFLAGS) $(NANOPB_CFLAGS) $(OPCUA_CFLAGS) $(ALL_CFLAGS)
# Sparkplug B payloads (gateway/mqtt/sparkplug.c): nanopb's runtime, the
# static archive of Debian's libnanopb-dev (no .pc file; position
# independent, so it links into the PIE daemon). The generated
# sparkplug_b.pb.[ch] are committed: `make proto` writes them again,
# check-proto checks them (mk/proto.mk).
NANOPB_LIBS := -lprotobuf-nanopb
# nanopb's headers: the generated code includes <pb.h>. Debian's 0.4.7
# (bookworm) puts it in /usr/include, 0.4.9 (trixie) in /usr/include/nanopb,
# and neither ships a .pc file. So: nanopb.pc's flags if one turns up, else
# the folder that has pb.h, as -isystem (as /usr/include would be: nanopb's
# own header is not held to our warnings). NANOPB_H is that header
# (cppcheck includes it first, mk/static.mk); both can be set by hand.
NANOPB_H      ?= $(firstword $(wildcard /usr/include/pb.h /usr/include/nanopb/pb.h) \
                             /usr/include/pb.h)
ifeq ($(origin NANOPB_CFLAGS),undefined)
NANOPB_CFLAGS := $(or $(call pc,--cflags,nanopb),$(if $(filter-out /usr/include/,$(dir \
                   $(NANOPB_H))),-isystem $(dir $(NANOPB_H))))
endif
# libmosquitto is loaded with dlopen only when the configuration has an
# [mqtt] section (gateway/mqtt/mqtt_lib.c, docs/mqtt.md): the daemon is compiled
# against its header but does not link it. glibc 2.34 and later have
# dlopen in libc; -ldl is an empty stub there and keeps older C libraries
# linking. The console's libmicrohttpd and libcrypt are loaded the same
# way, only with [http] (gateway/http/mhd_lib.c, docs/http.md).
GW_LIBS     := $(INIH_LIBS) $(GPIO_LIBS) $(SYSTEMD_LIBS) $(NANOPB_LIBS) $(OPCUA_LIBS) \
               -ldl -lm
GW_DEP_LIBS := $(GW_A) $(GPIO_A) $(COMMON_A) $(LIB_A) $(GW_LIBS)

BINS        := $(CLI_BIN) $(SIM_BIN) $(GW_BIN)

# ---- tests -----------------------------------------------------------------
CMOCKA_CFLAGS := $(call pc,--cflags,cmocka)
CMOCKA_LIBS   := $(call pc,--libs,cmocka)
# The OPC UA side's own unit tests (tests/unit/test_gw_ua_*.c) need
# open62541: built where the side is (OPCUA_ONLY_SRC), left out elsewhere.
OPCUA_TEST_SRC := $(wildcard tests/unit/test_gw_ua_*.c)
NO_TEST_SRC   := $(if $(OPCUA_VERSION),,$(OPCUA_TEST_SRC))
TEST_SRC      := $(filter-out $(NO_TEST_SRC),$(wildcard tests/unit/test_*.c))
TEST_BIN      := $(TEST_SRC:%.c=$(B)/%)
TEST_SUPPORT  := $(wildcard tests/support/*.c)
TEST_SUPPORT_OBJ := $(TEST_SUPPORT:%.c=$(B)/%.o)
TEST_CFLAGS    = $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) -Itests $(CMOCKA_CFLAGS) $(ALL_CFLAGS)
# A test of gateway code (the gateway's tests/unit/test_gw_*.c, the GPIO
# layer's tests/gpio/test_*.c and tests/gpio/gateway/test_*.c) is one
# source: it links the daemon's archives and the fakes (a GPIO backend
# without hardware; whatever the test defines itself, such as a fake event
# loop, takes the place of the archive member that would define it). Only
# the libraries of what the tests reach are linked (no libgpiod, no
# libsystemd), so that check-be links them for s390x too.
GW_TEST_SRC   := $(filter-out $(NO_TEST_SRC),$(sort $(wildcard tests/unit/test_gw_*.c \
                   tests/gpio/test_*.c tests/gpio/gateway/test_*.c)))
GW_TEST_BIN   := $(GW_TEST_SRC:%.c=$(B)/%)
GW_TEST_FAKES := tests/gpio/gpio_fake.c
GW_TEST_FAKE_OBJ := $(GW_TEST_FAKES:%.c=$(B)/%.o)
GW_TEST_CFLAGS = $(ALL_CPPFLAGS) -Igateway -Itests -Itests/gpio -DGW_TEST_TOP='"$(CURDIR)"' \
                 $(INIH_CFLAGS) $(NANOPB_CFLAGS) $(OPCUA_CFLAGS) $(CMOCKA_CFLAGS) \
                 $(ALL_CFLAGS)
GW_TEST_LIBS  := $(INIH_LIBS) $(CMOCKA_LIBS) $(OPCUA_LIBS) -ldl -lm

.PHONY: all lib gateway clean install eds check-eds uninstall check check-unit check-cli check-docs \
        check-cm4 check-firmware check-be check-asan demo deps docs bench \
        check-summary check-quick check-deps check-gw-config test-deps deps-measure \
        check-dep-split check-demo check-install dissector check-dissector deb check-deb \
        deb-arm64 check-arm64 check-abi abi-baseline check-cmake
.DEFAULT_GOAL := all

all: lib $(BINS)
lib: $(LIB_A) $(LIB_SO)
gateway: $(GW_BIN)

# ---- compiling -------------------------------------------------------------
$(LIB_OBJ): $(B)/%.o: %.c $(B)/%.d
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(ALL_CFLAGS) -fPIC $(DEPFLAGS) -c $< -o $@

$(CLI_OBJ): $(B)/%.o: %.c $(B)/%.d
	@mkdir -p $(dir $@)
	$(CC) $(CLI_CFLAGS) -fPIE $(DEPFLAGS) -c $< -o $@

$(SIM_OBJ) $(COMMON_OBJ): $(B)/%.o: %.c $(B)/%.d
	@mkdir -p $(dir $@)
	$(CC) $(SIM_CFLAGS) -fPIE $(DEPFLAGS) -c $< -o $@

$(GW_LIB_OBJ) $(B)/gateway/core/main.o: $(B)/%.o: %.c $(B)/%.d
	@mkdir -p $(dir $@)
	$(CC) $(GW_CFLAGS) -fPIE $(DEPFLAGS) -c $< -o $@

# (The folder is a prerequisite too: its time changes when a file is added
# or removed, so a removed file leaves the table as well.)
$(GW_ASSETS_C): mk/gen-assets.sh $(GW_WWW) gateway/http/www
	sh mk/gen-assets.sh $@ $(GW_WWW)

$(GW_ASSETS_OBJ): $(GW_ASSETS_C) $(B)/gateway/http/assets_gen.d
	$(CC) $(GW_CFLAGS) -fPIE $(DEPFLAGS) -c $< -o $@

$(GPIO_OBJ): $(B)/%.o: %.c $(B)/%.d
	@mkdir -p $(dir $@)
	$(CC) $(GPIO_OBJ_CFLAGS) $(DEPFLAGS) -c $< -o $@

$(TEST_SUPPORT_OBJ) $(GW_TEST_FAKE_OBJ): $(B)/%.o: %.c $(B)/%.d
	@mkdir -p $(dir $@)
	$(CC) $(TEST_CFLAGS) -Itests/gpio -Igateway $(DEPFLAGS) -c $< -o $@

# ---- linking ---------------------------------------------------------------
$(LIB_A): $(LIB_OBJ)
	rm -f $@
	$(AR) rcs $@ $^

$(LIB_SO): $(LIB_OBJ) $(LIB_MAP)
	$(CC) $(ALL_CFLAGS) -shared -Wl,-soname,$(LIB_SO_NAME) \
	    -Wl,--version-script=$(LIB_MAP) -Wl,--no-undefined-version \
	    $(filter-out $(PIE_LDFLAGS),$(ALL_LDFLAGS)) -o $@ $(LIB_OBJ) -lm
	ln -sf $(notdir $@) $(B)/$(LIB_SO_NAME)
	ln -sf $(LIB_SO_NAME) $(B)/libdrgate.so

$(CLI_BIN): $(CLI_OBJ) $(COMMON_A) $(LIB_A)
	$(CC) $(ALL_CFLAGS) -fPIE -pie $(ALL_LDFLAGS) -o $@ $(CLI_OBJ) $(COMMON_A) $(LIB_A) $(JSON_LIBS) -lm

$(SIM_BIN): $(SIM_OBJ) $(COMMON_A) $(LIB_A)
	$(CC) $(ALL_CFLAGS) -fPIE -pie $(ALL_LDFLAGS) -o $@ $(SIM_OBJ) $(COMMON_A) $(LIB_A) -lm

$(COMMON_A): $(COMMON_OBJ)
	rm -f $@
	$(AR) rcs $@ $^

$(GW_A): $(GW_LIB_OBJ) $(GW_ASSETS_OBJ)
	rm -f $@
	$(AR) rcs $@ $^

$(GPIO_A): $(GPIO_OBJ)
	rm -f $@
	$(AR) rcs $@ $^

$(GW_BIN): $(B)/gateway/core/main.o $(GW_A) $(GPIO_A) $(COMMON_A) $(LIB_A)
	$(CC) $(ALL_CFLAGS) -fPIE -pie $(ALL_LDFLAGS) -o $@ $(B)/gateway/core/main.o $(GW_DEP_LIBS)

# $(call GW_VARIANT,NAME,FLAGS[,SOURCES]): drgatewayd's sources and the
# event loop's, and SOURCES, compiled again with FLAGS into $(B)/bench/NAME/
# (the benchmarks' instrumented daemons); the objects, main.o among them,
# are $(GW_OBJ_NAME).
define GW_VARIANT
GW_OBJ_$(1) := $$(patsubst %.c,$$(B)/bench/$(1)/%.o,$$(GW_SRC) $$(COMMON_SRC) $(3))
$$(GW_OBJ_$(1)): $$(B)/bench/$(1)/%.o: %.c $$(B)/bench/$(1)/%.d
	@mkdir -p $$(dir $$@)
	$$(CC) $$(GW_CFLAGS) $(2) -fPIE $$(DEPFLAGS) -c $$< -o $$@
GW_OBJ_$(1) += $$(GW_ASSETS_OBJ)
endef

# A test is one source, compiled and linked in one step.
SIM_TEST_BIN := $(filter $(B)/tests/unit/test_sim_%,$(TEST_BIN))
$(SIM_TEST_BIN): $(B)/%: %.c $(B)/%.d $(SIM_LIB_OBJ) $(TEST_SUPPORT_OBJ) $(LIB_A)
	@mkdir -p $(dir $@)
	$(CC) $(TEST_CFLAGS) -Isim $(DEPFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(SIM_LIB_OBJ) $(TEST_SUPPORT_OBJ) $(LIB_A) $(CMOCKA_LIBS) -lm

$(GW_TEST_BIN): $(B)/%: %.c $(B)/%.d $(GW_TEST_FAKE_OBJ) $(GW_A) $(GPIO_A) $(COMMON_A) $(LIB_A)
	@mkdir -p $(dir $@)
	$(CC) $(GW_TEST_CFLAGS) $(DEPFLAGS) $(ALL_LDFLAGS) -o $@ $< $(GW_TEST_FAKE_OBJ) \
	    $(GW_A) $(GPIO_A) $(COMMON_A) $(LIB_A) $(GW_TEST_LIBS)

# (The other tests link the event loop's archive too: tests/unit/test_ev.c
# needs it, the others take nothing from it.)
$(filter-out $(SIM_TEST_BIN) $(GW_TEST_BIN),$(TEST_BIN)): $(B)/%: %.c $(B)/%.d $(TEST_SUPPORT_OBJ) \
        $(COMMON_A) $(LIB_A)
	@mkdir -p $(dir $@)
	$(CC) $(TEST_CFLAGS) $(DEPFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(TEST_SUPPORT_OBJ) $(COMMON_A) $(LIB_A) $(CMOCKA_LIBS) -lm

# ---- dependencies ----------------------------------------------------------
# mk/deps.sh installs the missing Debian packages (as root), names every
# package it installs and every installed one the install needs upgraded,
# and goes on only when accepted (a terminal asks; DEPS_YES=1 or CI=true
# accept; docs/deployment.md "Dependencies"):
#   deps           build and run (make, make demo): compiler, -dev libraries,
#                  mbpoll; no test tool
#   test-deps      deps + the test toolchain (cross compilers, the s390x
#                  runtime, qemu, sanitizers, tshark, ...) and the Python
#                  test peers (tests/requirements.txt, pinned) into .venv;
#                  make check runs it
#   deps-measure   what each set installs on a fresh bookworm, in packages
#                  and bytes (docs/deployment.md quotes it; ~20 s)
#   check-dep-split  (in make check, ~7 s) the demo set names no test tool
#                  and plans none, here and on a fresh bookworm
deps:
	@sh mk/deps.sh demo

test-deps:
	@sh mk/deps.sh test

deps-measure:
	@sh mk/deps-measure.sh

check-dep-split:
	@sh mk/check-dep-split.sh "$(RESULTS)"

# ---- tests -----------------------------------------------------------------
RESULTS := $(B)/check-results
# Seconds per step of the last `make check`; the summary prints them.
CHECK_TIMES := $(B)/check-times

# make check: every step (mk/*.mk add theirs to CHECK_STEPS), each run
# even if an earlier one failed (mk/check-steps.sh), then the time per
# step and the closing line "check: N passed, M failed". check-deps comes
# last, when every file of the run has been built.
# CHECK_BG_STEPS run beside them (mk/check-steps.sh: BG_STEPS).
CHECK_BG_STEPS :=
CHECK_STEPS := check-unit check-cli check-docs check-eds check-cm4 check-firmware check-be \
               check-asan check-fuzz check-dep-split check-demo \
               check-install check-abi check-cmake check-dissector check-deb check-arm64
#
# The dependencies first, then everything else in new makes (the steps run
# as `$(MAKE) STEP`): pkg-config's flags are read when a make starts, so a
# make that started before deps.sh installed pkg-config and the -dev
# packages has none of them. Not prerequisites either: `make -j2` would
# build beside the install.
check:
	@sh mk/deps.sh test
	@rm -f $(RESULTS) $(CHECK_TIMES)
	@MAKE="$(MAKE)" BG_STEPS="$(CHECK_BG_STEPS)" sh mk/check-steps.sh $(RESULTS) $(CHECK_TIMES) \
	    all $(CHECK_STEPS) check-deps || true
	@$(MAKE) --no-print-directory check-summary

check-summary:
	@sh mk/check-steps.sh --summary $(RESULTS) $(CHECK_TIMES)

# make check-quick: the everyday loop, well under a minute once built (and
# nothing here needs the network, qemu or root): the unit tests (codec,
# client against a scripted transport and against drsim, drsim's adapter,
# the gateway's configuration loader, register map, robot, GPIO layer and
# GPIO map), drcli's offline commands, the configuration's command line
# (drgatewayd --check-config), the generated docs, and the dependency check
# of the build. Same summary as make check, its own results file.
QUICK_RESULTS := $(B)/check-quick-results
QUICK_TIMES   := $(B)/check-quick-times
QUICK_STEPS   := check-unit check-cli check-gateway-config check-gpio-unit check-docs \
                 check-regmap-docs check-deps
check-quick: all $(TEST_BIN) $(GW_TEST_BIN)
	@rm -f $(QUICK_RESULTS) $(QUICK_TIMES)
	@MAKE="$(MAKE) RESULTS=$(QUICK_RESULTS)" sh mk/check-steps.sh $(QUICK_RESULTS) \
	    $(QUICK_TIMES) $(QUICK_STEPS) || true
	@sh mk/check-steps.sh --summary $(QUICK_RESULTS) $(QUICK_TIMES)

# The client tests run drsim next to them; cross builds skip those.
check-unit: $(TEST_BIN) $(if $(CROSS_COMPILE),,$(SIM_BIN))
	@sh tests/run-tests.sh "$(RESULTS)" "$(TEST_RUNNER)" $(TEST_BIN)

# The configuration loader's unit test alone (also in check-unit).
check-gw-config: $(B)/tests/unit/test_gw_config
	@sh tests/run-tests.sh "$(RESULTS)" "$(TEST_RUNNER)" $<

# Every header of the tree is a prerequisite of what includes it, so that
# touching it rebuilds them (mk/check-deps.py says how it is checked).
DEPS_CHECK_TARGETS = all $(TEST_BIN) $(GW_TEST_BIN)
check-deps: $(DEPS_CHECK_TARGETS)
	@MAKE="$(MAKE)" $(PYTHON) mk/check-deps.py "$(RESULTS)" $(B) $(DEPS_CHECK_TARGETS)

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

# (A list named as a target here, not only by the pattern rule: make does
# not remake a file for a missing prerequisite that only a chain of
# pattern rules names.)
$(patsubst bench/%.c,$(B)/bench/%.d,$(wildcard bench/*.c)):
$(B)/bench/%: bench/%.c $(B)/bench/%.d $(LIB_A)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) $(WARN) -O2 -g $(DEPFLAGS) $(ALL_LDFLAGS) -o $@ $< $(LIB_A) -lm

# (deps.sh first, then the build in a new make: see check.)
demo:
	@sh mk/deps.sh demo
	@$(MAKE) --no-print-directory all
	@sh mk/demo.sh $(B)

# The commands make demo prints run as printed against its gateway
# (mk/check-demo.sh; about 5 s, on the demo's fixed ports).
check-demo: $(CLI_BIN) $(SIM_BIN) $(GW_BIN)
	@sh mk/check-demo.sh $(B) "$(RESULTS)"

# ---- install ---------------------------------------------------------------
# Beside the programs: the daemon's systemd unit (ExecStart= pointed at
# $(BINDIR)), the example configurations, the manual pages and the docs.
# The manual pages name the installed paths: their sources say docs/NAME.md
# and /usr/local/..., which MAN_SED turns into $(DOCDIR)/NAME.md, $(DATADIR)
# and $(UNITDIR) (check-install looks at the result of a PREFIX=/usr install).
GW_EXAMPLES := $(wildcard gateway/examples/*.ini)
DOCS        := $(wildcard docs/*.md)
MAN_SED     := -e 's|docs/\([A-Za-z0-9_-]*\.md\)|$(DOCDIR)/\1|g' \
               -e 's|/usr/local/share/drgate|$(DATADIR)|g' \
               -e 's|/usr/local/lib/systemd/system|$(UNITDIR)|g'

# make eds: drsim's EDS (default layout, per_assembly) from the field
# table, by drcli eds --write, into sim/drsim.eds, which is committed (as
# the dissector is: a cross build cannot run its own drcli) and installed
# with drsim (docs/commissioning.md); check-eds (in make check) fails when
# it is stale.
EDS_FILE    := sim/drsim.eds
eds: $(CLI_BIN)
	$(CLI_BIN) eds --write > $(EDS_FILE).tmp && mv $(EDS_FILE).tmp $(EDS_FILE)

check-eds: $(CLI_BIN)
	@if $(CLI_BIN) eds --write | cmp -s - $(EDS_FILE); then \
	    echo "eds: $(EDS_FILE) is what drcli eds --write makes"; echo "1 0 check-eds" >> $(RESULTS); \
	else \
	    echo "eds: $(EDS_FILE) is stale: make eds"; echo "0 1 check-eds ($(EDS_FILE) stale)" >> $(RESULTS); exit 1; \
	fi

install: all
	install -d $(DESTDIR)$(LIBDIR) $(DESTDIR)$(INCLUDEDIR)/drgate \
	    $(DESTDIR)$(PKGCONFIGDIR) $(DESTDIR)$(BINDIR) $(DESTDIR)$(MANDIR)/man1 \
	    $(DESTDIR)$(MANDIR)/man8 $(DESTDIR)$(UNITDIR) $(DESTDIR)$(DATADIR)/examples \
	    $(DESTDIR)$(DOCDIR) $(DESTDIR)$(WIRESHARK_LUADIR)
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
	# The CMake package finds the library and headers from its own place
	# (relocatable): INCLUDEDIR as a path from LIBDIR.
	install -d $(DESTDIR)$(CMAKEDIR)
	install -m 644 lib/cmake/drgateBounds.cmake $(DESTDIR)$(CMAKEDIR)/
	sed -e "s|@INCLUDEDIR_FROM_LIBDIR@|$$(realpath -m --relative-to=$(LIBDIR) $(INCLUDEDIR))|" \
	    lib/cmake/drgateConfig.cmake.in > $(DESTDIR)$(CMAKEDIR)/drgateConfig.cmake
	sed -e "s|@VERSION@|$(VERSION)|g; s|@SOVERSION@|$(SOVERSION)|g; s|@SIZEOF_VOID_P@|$$(echo | \
	    $(CC) -dM -E - | sed -n 's/^#define __SIZEOF_POINTER__ //p')|g" \
	    lib/cmake/drgateConfigVersion.cmake.in > $(DESTDIR)$(CMAKEDIR)/drgateConfigVersion.cmake
	chmod 644 $(DESTDIR)$(CMAKEDIR)/drgateConfig.cmake $(DESTDIR)$(CMAKEDIR)/drgateConfigVersion.cmake
	install -m 755 $(BINS) $(DESTDIR)$(BINDIR)/
	for m in $(wildcard man/*.[18]); do \
	    sed $(MAN_SED) $$m > $(DESTDIR)$(MANDIR)/man$${m##*.}/$${m##*/} && \
	    chmod 644 $(DESTDIR)$(MANDIR)/man$${m##*.}/$${m##*/} || exit 1; done
	install -m 644 $(DOCS) $(DESTDIR)$(DOCDIR)/
	install -m 644 dissector/drgate.lua $(DESTDIR)$(WIRESHARK_LUADIR)/
	sed -e 's|/usr/local/bin/drgatewayd|$(BINDIR)/drgatewayd|' gateway/drgatewayd.service \
	    > $(DESTDIR)$(UNITDIR)/drgatewayd.service
	chmod 644 $(DESTDIR)$(UNITDIR)/drgatewayd.service
	install -m 644 $(GW_EXAMPLES) $(DESTDIR)$(DATADIR)/examples/
	install -m 644 $(EDS_FILE) $(DESTDIR)$(DATADIR)/drsim.eds

# ---- Wireshark dissector ---------------------------------------------------
# dissector/drgate.lua is generated from the field table (drcli list
# --json) by mk/gen-dissector.py: `make dissector` writes it again;
# check-dissector (in make check, ~10 s) fails when it is stale, and runs
# tshark with it on a capture of drsim, drgatewayd, mbpoll and drcli
# (tests/dissector/check_dissector.py).
dissector: $(CLI_BIN)
	python3 mk/gen-dissector.py $(CLI_BIN) dissector/drgate.lua

check-dissector: $(CLI_BIN) $(SIM_BIN) $(GW_BIN)
	@python3 tests/dissector/check_dissector.py $(B) "$(RESULTS)"

# ---- Debian packages ---------------------------------------------------------
# make deb: the packages in $(B)/deb (mk/deb.sh), lintian on them;
# make deb-arm64: the same cross-built for arm64 in $(B)/deb-arm64.
deb:
	@sh mk/deb.sh $(B)

deb-arm64:
	@DEB_HOST_ARCH=arm64 sh mk/deb.sh $(B)

# check-deb (in make check, ~60 s: the package build runs the unit tests): make deb, lintian (no error, no
# warning), the packages installed, run and purged in a clean bookworm root
# made with mmdebstrap. check-arm64 (in make check): the packages
# cross-built for arm64, their programs run under qemu-aarch64 in an arm64
# root. Both need root and the network; SKIPPED with a banner without them.
check-deb:
	@sh mk/check-deb.sh $(B) "$(RESULTS)"

check-arm64:
	@sh mk/check-arm64.sh $(B) "$(RESULTS)"

# make install PREFIX=/usr into a staging root: paths follow the prefix,
# what the manual pages name is installed, uninstall removes it all
# (mk/check-install.sh; about 2 s once built).
check-install: all
	@MAKE="$(MAKE)" CC="$(CC)" sh mk/check-install.sh "$(abspath $(RESULTS))"

# check-cmake (in make check, 3 to 12 s warm): the library as a CMake component
# (lib/CMakeLists.txt, lib/cmake/): a consumer project with
# add_subdirectory, with find_package against a staged make install, and
# examples/firmware-cm4 cross-built for a Cortex-M4 (mk/check-cmake.sh).
check-cmake: all
	@MAKE="$(MAKE)" CC="$(CC)" $(FW_CM4) sh mk/check-cmake.sh "$(RESULTS)" $(B) $(VERSION) \
	    "$(LIB_CODEC_SRC)" "$(LIB_FW_SRC)"

# check-abi (in make check, ~3 s): libdrgate.so against the ABI of its
# last release, lib/abi/ (abidiff; mk/check-abi.sh says what fails);
# abi-baseline writes lib/abi/ from this build (at a release, after a
# soname bump). docs/api-changes.md, "ABI".
check-abi: $(LIB_SO)
	@CC="$(CC)" sh mk/check-abi.sh "$(RESULTS)" $(LIB_SO)

abi-baseline: $(LIB_SO)
	@CC="$(CC)" sh mk/check-abi.sh --write $(LIB_SO)

uninstall:
	rm -f $(DESTDIR)$(LIBDIR)/libdrgate.* $(DESTDIR)$(PKGCONFIGDIR)/drgate.pc
	rm -rf $(DESTDIR)$(CMAKEDIR)
	-rmdir $(DESTDIR)$(LIBDIR)/cmake 2>/dev/null
	rm -rf $(DESTDIR)$(INCLUDEDIR)/drgate
	rm -f $(addprefix $(DESTDIR)$(BINDIR)/,$(notdir $(BINS)))
	rm -f $(addprefix $(DESTDIR)$(MANDIR)/man1/,$(notdir $(wildcard man/*.1)))
	rm -f $(addprefix $(DESTDIR)$(MANDIR)/man8/,$(notdir $(wildcard man/*.8)))
	rm -f $(DESTDIR)$(UNITDIR)/drgatewayd.service
	rm -f $(addprefix $(DESTDIR)$(DATADIR)/examples/,$(notdir $(GW_EXAMPLES)))
	rm -f $(DESTDIR)$(DATADIR)/drsim.eds
	rm -f $(addprefix $(DESTDIR)$(DOCDIR)/,$(notdir $(DOCS)))
	rm -f $(DESTDIR)$(WIRESHARK_LUADIR)/drgate.lua
	-rmdir $(DESTDIR)$(DATADIR)/examples $(DESTDIR)$(DATADIR) $(DESTDIR)$(DOCDIR) 2>/dev/null

clean:
	rm -rf build

# ---- module fragments ------------------------------------------------------
# Each mk/*.mk adds the tests, checks and benchmarks of one part (GPIO,
# coverage, interop, ...) and may add to CHECK_STEPS and BENCH_STEPS. Every
# program and archive they use is defined above, so the order in which
# they are read does not matter.
include $(sort $(wildcard mk/*.mk))

# The header lists written by -MMD (see DEPFLAGS), of this build and of
# the builds nested in it ($(B)/asan, $(B)/cov, ...): each only names
# targets in its own directory.
# (Not $(B)/deb and $(B)/deb-arm64: make deb's copies of the tree, whose own build and package
# directories, drgatewayd.service.d among them, are none of this build's; nor
# $(B)/bench/noconsole, the tree before the console, mk/console.mk.)
-include $(shell find $(B) \( -path $(B)/deb -o -path $(B)/deb-arm64 -o -path $(B)/bench/noconsole \) \
    -prune -o -name '*.d' -type f -print 2>/dev/null)
