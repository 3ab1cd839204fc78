# SPDX-License-Identifier: MIT
# Static analysis and hardening checks (docs/quality.md), both in `make check`:
#
#   check-static     cppcheck (mk/cppcheck-suppressions.txt) and clang-tidy
#                    (.clang-tidy) over lib/, cli/, common/, sim/, gateway/, port/,
#                    tests/ and fuzz/; any finding fails it
#   check-hardening  the built programs are PIE, full RELRO (BIND_NOW), with
#                    the stack protector and _FORTIFY_SOURCE's checked calls
#   compdb           $(B)/compile_commands.json: every source with the flags
#                    of the rule that builds it (clang-tidy, cppcheck and
#                    editors read it)
#
# The groups' flags are the variables of the rules that build them (the
# Makefile's, mk/firmware.mk's, fuzz/fuzz.mk's), used when the recipe runs.

CHECK_STEPS += check-static check-hardening

CPPCHECK    ?= cppcheck
CLANG_TIDY  ?= clang-tidy
STATIC_JOBS ?= 2
COMPDB      := $(B)/compile_commands.json

# ---- the compilation database ---------------------------------------------
# One group per Makefile rule shape: its sources and its flags.
STATIC_GROUPS :=

STATIC_GROUPS += lib
STATIC_SRC_lib   = $(LIB_SRC)
STATIC_FLAGS_lib = $(ALL_CPPFLAGS) $(ALL_CFLAGS) -fPIC

STATIC_GROUPS += cli
STATIC_SRC_cli   = $(CLI_SRC)
STATIC_FLAGS_cli = $(CLI_CFLAGS)

STATIC_GROUPS += common
STATIC_SRC_common   = $(COMMON_SRC)
STATIC_FLAGS_common = $(ALL_CPPFLAGS) $(ALL_CFLAGS)

STATIC_GROUPS += sim
STATIC_SRC_sim   = $(SIM_SRC)
STATIC_FLAGS_sim = $(SIM_CFLAGS)

STATIC_GROUPS += gw
STATIC_SRC_gw    = $(GW_SRC)
STATIC_FLAGS_gw  = $(GW_CFLAGS)

# gpio_v2.c needs libgpiod 2's headers, which bookworm does not have:
# cppcheck reads it (it does not need the headers), clang-tidy cannot.
STATIC_GROUPS += gpio
STATIC_SRC_gpio   = $(GPIO_ALL_SRC)
STATIC_FLAGS_gpio = $(GPIO_OBJ_CFLAGS)

STATIC_GROUPS += tests_sim
STATIC_SRC_tests_sim   = $(sort $(wildcard tests/unit/test_sim_*.c))
STATIC_FLAGS_tests_sim = $(TEST_CFLAGS) -Isim

# The tests of gateway code (the Makefile's GW_TEST_SRC) and their fakes.
STATIC_GROUPS += tests_gw
STATIC_SRC_tests_gw   = $(GW_TEST_SRC) $(GW_TEST_FAKES)
STATIC_FLAGS_tests_gw = $(GW_TEST_CFLAGS)

STATIC_GROUPS += tests
STATIC_SRC_tests   = $(filter-out $(STATIC_SRC_tests_sim) $(STATIC_SRC_tests_gw) $(NO_TEST_SRC), \
                       $(sort $(wildcard tests/unit/*.c tests/support/*.c)))
STATIC_FLAGS_tests = $(TEST_CFLAGS)

STATIC_GROUPS += tests_gpio
STATIC_SRC_tests_gpio   = tests/gpio/gpio_selftest.c
STATIC_FLAGS_tests_gpio = $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) $(ALL_CFLAGS)

STATIC_GROUPS += tests_interop
STATIC_SRC_tests_interop   = $(sort $(wildcard tests/interop/*.c))
STATIC_FLAGS_tests_interop = $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) $(CMOCKA_CFLAGS) $(ALL_CFLAGS)

# Some harnesses reach into gateway/ (the Modbus and configuration paths).
STATIC_GROUPS += fuzz
STATIC_SRC_fuzz   = $(sort $(wildcard fuzz/*.c))
STATIC_FLAGS_fuzz = $(FUZZ_CPPFLAGS) $(ALL_CFLAGS)

# The firmware scenario (mk/firmware.mk): the POSIX side, and the lwIP
# port with its test (lwIP's headers, from liblwip-dev).
STATIC_GROUPS += tests_firmware
STATIC_SRC_tests_firmware   = tests/firmware/drive.c tests/firmware/test_be_client.c
STATIC_FLAGS_tests_firmware = $(ALL_CPPFLAGS) -Itests/firmware $(ALL_CFLAGS)

STATIC_GROUPS += lwip
STATIC_SRC_lwip   = $(LWIP_PORT_SRC) tests/firmware/test_lwip.c
STATIC_FLAGS_lwip = $(LWIP_CFLAGS)

STATIC_SRC       = $(foreach g,$(STATIC_GROUPS),$(STATIC_SRC_$(g)))
# What clang-tidy cannot compile here (see above), and nanopb's generated
# code (its struct tags _Payload... are reserved identifiers; .clang-tidy's
# HeaderFilterRegex leaves out the generated *.pb.h the same way).
STATIC_TIDY_SKIP = gateway/gpio/gpio_v2.c gateway/mqtt/sparkplug_b.pb.c
STATIC_TIDY_SRC  = $(filter-out $(STATIC_TIDY_SKIP),$(STATIC_SRC))

define static_nl


endef

.PHONY: compdb check-static check-cppcheck check-clang-tidy check-hardening

# Always rewritten from the rules' flags (cheap); the file's time stamp
# changes only when its contents do.
compdb:
	@mkdir -p $(dir $(COMPDB))
	$(file >$(COMPDB).in,$(foreach g,$(STATIC_GROUPS),$(foreach f,$(STATIC_SRC_$(g)),$(f) $(STATIC_FLAGS_$(g))$(static_nl))))
	@$(PYTHON) mk/compdb.py "$(CURDIR)" "$(CC)" $(COMPDB).in $(COMPDB)
	@rm -f $(COMPDB).in

# ---- cppcheck ----------------------------------------------------------------
# Every file of the database with its own -I/-D; the system headers are not
# read (cppcheck's own library knowledge stands in for libc: std, posix).
# nanopb's pb.h (a system header, not given to cppcheck like the others)
# is included first: the generated sparkplug_b.pb.[ch] check its version
# with #error and use its macros (PB_BIND), so without it cppcheck would
# skip sparkplug.c and north_mqtt.c.
# (NANOPB_H: the Makefile finds it, with NANOPB_CFLAGS.)
CPPCHECK_FLAGS := --enable=warning,style,performance,portability --std=c99 \
    --library=posix --inline-suppr --error-exitcode=1 --quiet --include=$(NANOPB_H) \
    --suppressions-list=mk/cppcheck-suppressions.txt \
    --template='{file}:{line}:{column}: {severity}: {message} [{id}]'

check-cppcheck: compdb
	@mkdir -p $(B)/cppcheck $(dir $(RESULTS))
	@echo "cppcheck: $(words $(STATIC_SRC)) files"
	@if $(CPPCHECK) $(CPPCHECK_FLAGS) -j$(STATIC_JOBS) --cppcheck-build-dir=$(B)/cppcheck \
	        --project=$(COMPDB); then \
	    echo "1 0 static: cppcheck" >> $(RESULTS); \
	else echo "0 1 static: cppcheck" >> $(RESULTS); exit 1; fi

# ---- clang-tidy --------------------------------------------------------------
# .clang-tidy holds the checks; every warning is an error here. One file
# per clang-tidy process: clang-tidy 14 carries analyzer state from one file
# to the next in a run of several (a false "uninitialized va_list" in the
# second file that has va_start).
check-clang-tidy: compdb
	@mkdir -p $(dir $(RESULTS))
	@echo "clang-tidy: $(words $(STATIC_TIDY_SRC)) files, $(STATIC_JOBS) at a time"
	@st=0; printf '%s\n' $(STATIC_TIDY_SRC) | xargs -P $(STATIC_JOBS) -n 1 \
	    $(CLANG_TIDY) -p $(B) --quiet --warnings-as-errors='*' \
	    > $(B)/clang-tidy.log 2>&1 || st=1; \
	grep -v -e '^[0-9]* warnings\{0,1\} generated\.$$' \
	    -e '^[0-9]* warnings\{0,1\} treated as errors\{0,1\}$$' $(B)/clang-tidy.log; \
	if [ $$st = 0 ]; then echo "1 0 static: clang-tidy" >> $(RESULTS); \
	else echo "0 1 static: clang-tidy (see $(B)/clang-tidy.log)" >> $(RESULTS); exit 1; fi

# Both, even if the first fails.
check-static:
	@st=0; $(MAKE) --no-print-directory check-cppcheck || st=1; \
	$(MAKE) --no-print-directory check-clang-tidy || st=1; exit $$st

# ---- hardening -----------------------------------------------------------------
# The programs and tests as `make` builds them (the default HARDEN,
# PIE_CFLAGS/PIE_LDFLAGS and RELRO flags of the Makefile), and the shared
# library; READELF for cross builds.
HARDEN_CHECK_BIN = $(BINS) $(TEST_BIN) $(GPIO_TEST_BIN)

check-hardening: $(HARDEN_CHECK_BIN) $(LIB_SO)
	@READELF=$(CROSS_COMPILE)readelf sh mk/check-hardening.sh "$(RESULTS)" \
	    $(HARDEN_CHECK_BIN) --lib $(LIB_SO)
