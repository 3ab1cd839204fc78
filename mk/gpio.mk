# SPDX-License-Identifier: MIT
# GPIO for drgatewayd (gateway/gpio*.c, docs/gpio.md): unit tests, and
# the tests against a real kernel GPIO chip in a qemu guest. The archive
# the gateway links ($(GPIO_A), with the backend $(GPIO_BACKEND)) and the
# flags (GPIO_CPPFLAGS, GPIO_CFLAGS, GPIO_LIBS) are the Makefile's; the unit
# tests build with its generic rule for gateway tests (GW_TEST_BIN).
#
# Targets:
#   check-gpio         unit tests (debouncer; common layer on a fake
#                      backend), plain and under ASan+UBSan
#   check-gpio-unit    the GPIO and GPIO-map unit tests, plain only (for
#                      check-quick)
#   check-gpio-qemu    tests/gpio/gpio_selftest on a real kernel GPIO chip
#                      (gpio-mockup) in qemu; skipped loudly without qemu
#   check-gpio-qemu-asan  the same, built with ASan+UBSan (and LSan)
#   check-gpio-v2      the libgpiod 2 backend: built against the libgpiod
#                      sources in the gpiod sdist from PyPI, run in qemu
#   gpio-qemu-shell    (manual) the guest with the selftest, for poking
#   check-gpio-all     all four check-gpio* targets (~40 s once cached)

# Kernel, module and the libgpiod 2 sources are cached across builds and
# `make clean`: the first qemu run downloads ~224 MB of Debian packages.
GPIO_CACHE    ?= $(if $(XDG_CACHE_HOME),$(XDG_CACHE_HOME),$(if $(HOME),$(HOME)/.cache,$(abspath $(B))/cache))/drgate
GPIO_QEMU     := tests/gpio/qemu/run.sh
GPIO_QEMU_TIMEOUT ?= 120

# `make check` runs each of its CHECK_STEPS (the Makefile's list) and
# counts a step that fails as a failure; these are the GPIO ones.
CHECK_STEPS += check-gpio check-gpio-qemu check-gpio-qemu-asan check-gpio-v2

.PHONY: gpio check-gpio check-gpio-unit check-gpio-qemu check-gpio-qemu-asan check-gpio-v2 \
        gpio-qemu-shell check-gpio-all

gpio: $(GPIO_A)

# ---- unit tests: no hardware, no libgpiod ------------------------------------
GPIO_TEST_BIN := $(filter $(B)/tests/gpio/test_%,$(GW_TEST_BIN))
# with the GPIO map's test (tests/gpio/gateway/, mk/gpio_gateway.mk)
GPIO_UNIT_BIN := $(filter $(B)/tests/gpio/%,$(GW_TEST_BIN))

check-gpio-unit: $(GPIO_UNIT_BIN)
	@sh tests/run-tests.sh "$(RESULTS)" "$(TEST_RUNNER)" $(GPIO_UNIT_BIN)

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

$(GPIO_SELFTEST): tests/gpio/gpio_selftest.c $(GPIO_SELFTEST).d $(GPIO_A)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) $(ALL_CFLAGS) $(DEPFLAGS) $(ALL_LDFLAGS) \
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
GPIO_V2_OBJ   := $(patsubst %.c,$(GPIO_V2_DIR)/%.o,$(GPIO_CORE_SRC) gateway/gpio/gpio_v2.c)

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
$(GPIO_V2_OBJ): $(GPIO_V2_DIR)/%.o: %.c $(GPIO_V2_DIR)/%.d $(GPIO_V2_DIR)/libgpiod2/libgpiod.a
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) -I$(GPIO_V2_DIR)/libgpiod2/include \
	    $(ALL_CFLAGS) $(DEPFLAGS) -c $< -o $@

$(GPIO_V2_DIR)/gpio_selftest: tests/gpio/gpio_selftest.c $(GPIO_V2_DIR)/gpio_selftest.d \
        $(GPIO_V2_OBJ)
	$(CC) $(ALL_CPPFLAGS) $(GPIO_CPPFLAGS) $(ALL_CFLAGS) $(DEPFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(GPIO_V2_OBJ) $(GPIO_V2_DIR)/libgpiod2/libgpiod.a
endif
