# SPDX-License-Identifier: MIT
# GPIO for drgatewayd (gateway/gpio*.c, docs/gpio.md): a static archive
# the gateway links, unit tests, and the tests against a real kernel GPIO
# chip in a qemu guest.
#
# For the gateway's link:   $(GPIO_A) $(GPIO_LIBS)   (and $(GPIO_CPPFLAGS)
# to include "gpio.h"). gateway/gpio_*.c are built here only: leave them
# out of any wildcard over gateway/*.c (they are listed in $(GPIO_ALL_SRC)).
#
# Targets:
#   check-gpio         unit tests (debouncer; common layer on a fake
#                      backend), plain and under ASan+UBSan
#   check-gpio-qemu    tests/gpio/gpio_selftest on a real kernel GPIO chip
#                      (gpio-mockup) in qemu; skipped loudly without qemu
#   check-gpio-qemu-asan  the same, built with ASan+UBSan (and LSan)
#   check-gpio-v2      the libgpiod 2 backend: built against the libgpiod
#                      sources in the gpiod sdist from PyPI, run in qemu
#   gpio-qemu-shell    (manual) the guest with the selftest, for poking
#   check-gpio-all     all four check-gpio* targets (~40 s once cached)

# Backend: v2 when pkg-config finds libgpiod >= 2.0, else v1 (bookworm).
# An empty version (no libgpiod, or PKG_CONFIG=true in cross builds)
# means v1, which is what bookworm has.
GPIO_VERSION  := $(call pc,--modversion,libgpiod)
ifeq ($(origin GPIO_BACKEND),undefined)
GPIO_BACKEND  := $(if $(GPIO_VERSION),$(if $(shell $(PKG_CONFIG) \
                   --atleast-version=2.0 libgpiod 2>/dev/null && echo y),v2,v1),v1)
endif
GPIO_CFLAGS   := $(call pc,--cflags,libgpiod)
GPIO_LIBS     := $(or $(call pc,--libs,libgpiod),-lgpiod)
GPIO_CPPFLAGS := -Igateway
GPIO_HDR      := gateway/gpio.h gateway/gpio_internal.h
GPIO_CORE_SRC := gateway/gpio_common.c gateway/gpio_debounce.c
GPIO_ALL_SRC  := $(GPIO_CORE_SRC) gateway/gpio_v1.c gateway/gpio_v2.c
GPIO_SRC      := $(GPIO_CORE_SRC) gateway/gpio_$(GPIO_BACKEND).c
GPIO_OBJ      := $(GPIO_SRC:%.c=$(B)/%.o)
GPIO_A        := $(B)/gateway/libgwgpio.a

# Kernel, module and the libgpiod 2 sources are cached across builds and
# `make clean`: the first qemu run downloads ~224 MB of Debian packages.
GPIO_CACHE    ?= $(if $(XDG_CACHE_HOME),$(XDG_CACHE_HOME),$(if $(HOME),$(HOME)/.cache,$(abspath $(B))/cache))/drgate
GPIO_QEMU     := tests/gpio/qemu/run.sh
GPIO_QEMU_TIMEOUT ?= 120

# `make check` runs each of its CHECK_STEPS (the Makefile's list) and
# counts a step that fails as a failure; these are the GPIO ones.
CHECK_STEPS += check-gpio check-gpio-qemu check-gpio-qemu-asan check-gpio-v2

.PHONY: gpio check-gpio check-gpio-qemu check-gpio-qemu-asan check-gpio-v2 \
        gpio-qemu-shell check-gpio-all

gpio: $(GPIO_A)

$(GPIO_OBJ): $(B)/gateway/%.o: gateway/%.c $(GPIO_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) $(GPIO_CFLAGS) $(ALL_CFLAGS) \
	    -fPIC -c $< -o $@

$(GPIO_A): $(GPIO_OBJ)
	rm -f $@
	$(AR) rcs $@ $^

# ---- unit tests: no hardware, no libgpiod ------------------------------------
GPIO_TEST_BIN := $(B)/tests/gpio/test_gpio_debounce $(B)/tests/gpio/test_gpio_common

$(B)/tests/gpio/test_gpio_debounce: tests/gpio/test_gpio_debounce.c \
        gateway/gpio_debounce.c $(GPIO_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) $(CMOCKA_CFLAGS) $(ALL_CFLAGS) \
	    $(ALL_LDFLAGS) -o $@ $< gateway/gpio_debounce.c $(CMOCKA_LIBS)

$(B)/tests/gpio/test_gpio_common: tests/gpio/test_gpio_common.c \
        tests/gpio/gpio_fake.c tests/gpio/gpio_fake.h $(GPIO_CORE_SRC) $(GPIO_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) -Itests/gpio $(CMOCKA_CFLAGS) \
	    $(ALL_CFLAGS) $(ALL_LDFLAGS) -o $@ $< tests/gpio/gpio_fake.c \
	    $(GPIO_CORE_SRC) $(CMOCKA_LIBS)

# Plain, then again under ASan+UBSan in their own build directory (the
# flags are the Makefile's SAN_FLAGS, as check-asan uses).
check-gpio: $(GPIO_TEST_BIN)
	@sh tests/run-tests.sh "$(RESULTS)" "$(TEST_RUNNER)" $(GPIO_TEST_BIN)
	@if [ -z "$(GPIO_NO_ASAN)" ]; then \
	    $(MAKE) --no-print-directory B=$(B)/asan CFLAGS="$(SAN_FLAGS)" \
	        LDFLAGS="-fsanitize=address,undefined" HARDEN= GPIO_NO_ASAN=1 \
	        RESULTS=$(abspath $(RESULTS)) check-gpio; fi

# ---- a real kernel GPIO chip under qemu -------------------------------------
GPIO_SELFTEST := $(B)/tests/gpio/gpio_selftest

$(GPIO_SELFTEST): tests/gpio/gpio_selftest.c $(GPIO_A) $(GPIO_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(GPIO_A) $(GPIO_LIBS)

check-gpio-qemu: $(GPIO_SELFTEST)
	@sh $(GPIO_QEMU) --cache "$(GPIO_CACHE)" --timeout $(GPIO_QEMU_TIMEOUT) \
	    --results "$(RESULTS)" --label gpio_qemu \
	    --bin $(GPIO_SELFTEST) --script tests/gpio/qemu/selftest.sh

# The selftest under sanitizers in the guest: leaks and UB on the paths
# only a real kernel takes (the runtime libraries go in with ldd's list).
check-gpio-qemu-asan:
	$(MAKE) --no-print-directory B=$(B)/asan CFLAGS="$(SAN_FLAGS)" \
	    LDFLAGS="-fsanitize=address,undefined" HARDEN= \
	    RESULTS=$(abspath $(RESULTS)) $(B)/asan/tests/gpio/gpio_selftest
	@sh $(GPIO_QEMU) --cache "$(GPIO_CACHE)" --timeout $(GPIO_QEMU_TIMEOUT) \
	    --results "$(RESULTS)" --label gpio_qemu_asan \
	    --bin $(B)/asan/tests/gpio/gpio_selftest --script tests/gpio/qemu/selftest.sh

check-gpio-all:
	$(MAKE) --no-print-directory check-gpio
	$(MAKE) --no-print-directory check-gpio-qemu
	$(MAKE) --no-print-directory check-gpio-qemu-asan
	$(MAKE) --no-print-directory check-gpio-v2

gpio-qemu-shell: $(GPIO_SELFTEST)
	@sh $(GPIO_QEMU) --cache "$(GPIO_CACHE)" --interactive \
	    --bin $(GPIO_SELFTEST) --script tests/gpio/qemu/selftest.sh

# ---- the libgpiod 2 backend ---------------------------------------------------
# libgpiod 2 is not in bookworm, but the gpiod Python bindings' sdist
# (pinned below) carries its C sources: build them into a static library,
# build gpio_v2.c and the selftest against it, and run the same qemu test.
GPIO_V2_PYPI  ?= gpiod==2.5.0
GPIO_V2_DIR   := $(B)/gpio-v2
GPIO_V2_OBJ   := $(patsubst %.c,$(GPIO_V2_DIR)/%.o,$(GPIO_CORE_SRC) gateway/gpio_v2.c)

check-gpio-v2:
	@if sh tests/gpio/libgpiod2.sh "$(GPIO_CACHE)" "$(GPIO_V2_PYPI)" \
	        "$(GPIO_V2_DIR)/libgpiod2" "$(CC)"; then \
	    $(MAKE) --no-print-directory GPIO_V2_READY=1 $(GPIO_V2_DIR)/gpio_selftest && \
	    sh $(GPIO_QEMU) --cache "$(GPIO_CACHE)" --timeout $(GPIO_QEMU_TIMEOUT) \
	        --results "$(RESULTS)" --label gpio_v2_qemu \
	        --bin $(GPIO_V2_DIR)/gpio_selftest --script tests/gpio/qemu/selftest.sh; \
	else \
	    sh tests/skip.sh check-gpio-v2 "no libgpiod 2 sources (see above)"; \
	fi

ifdef GPIO_V2_READY
$(GPIO_V2_OBJ): $(GPIO_V2_DIR)/%.o: %.c $(GPIO_HDR) $(GPIO_V2_DIR)/libgpiod2/libgpiod.a
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) -I$(GPIO_V2_DIR)/libgpiod2/include \
	    $(ALL_CFLAGS) -c $< -o $@

$(GPIO_V2_DIR)/gpio_selftest: tests/gpio/gpio_selftest.c $(GPIO_V2_OBJ) $(GPIO_HDR)
	$(CC) $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(GPIO_V2_OBJ) $(GPIO_V2_DIR)/libgpiod2/libgpiod.a
endif
