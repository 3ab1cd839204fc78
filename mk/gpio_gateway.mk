# SPDX-License-Identifier: MIT
# check-gpio-gateway: the whole gateway on a real kernel GPIO chip. Boots
# the qemu guest of tests/gpio/qemu/run.sh (mk/gpio.mk) with drgatewayd,
# drsim and mbpoll packed in, and runs tests/gpio/gateway/guest.sh there:
# outputs following robot bits, inputs driving O->T bits through drsim's
# echo, debounce, safe values on robot link loss, faults, reloads and
# SIGTERM (docs/gpio.md, "The gateway's lines end to end"). Before it, the
# host unit test of gateway/gpio/gpiomap.c. ~20-35 s once the kernel is cached;
# the qemu part is a loud skip where qemu cannot run.
# GPIO_GW_ARGS passes more options to run.sh (e.g. --log FILE).

GPIO_GW_BIN     := $(GW_BIN)
GPIO_GW_TIMEOUT ?= 150
GPIO_GW_DIR     := tests/gpio/gateway
GPIO_GW_TEST    := $(B)/tests/gpio/gateway/test_gpiomap

CHECK_STEPS += check-gpio-gateway

.PHONY: check-gpio-gateway check-gpio-gateway-unit gpio-gateway-shell

# $(GPIO_GW_TEST) is gateway/gpio/gpiomap.c on the fake GPIO backend and a fake
# event loop: no kernel, no libgpiod, no epoll (the test defines ev_watch
# & co.). It builds with the Makefile's rule for gateway tests.

# Plain, then under ASan+UBSan (the Makefile's SAN_FLAGS) in $(B)/asan.
check-gpio-gateway-unit: $(GPIO_GW_TEST)
	@sh tests/run-tests.sh "$(RESULTS)" "$(TEST_RUNNER)" $(GPIO_GW_TEST)
	@if [ -z "$(GPIO_NO_ASAN)" ]; then \
	    $(MAKE) --no-print-directory B=$(B)/asan CFLAGS="$(SAN_FLAGS)" \
	        LDFLAGS="-fsanitize=address,undefined" HARDEN= GPIO_NO_ASAN=1 \
	        RESULTS=$(abspath $(RESULTS)) check-gpio-gateway-unit; fi

# The unit test and the qemu test both run even if one fails. mbpoll
# (Debian's, from `make deps`) is the independent Modbus client in the
# guest; without it the qemu test cannot run: a failure, not a skip.
check-gpio-gateway: $(GPIO_GW_BIN) $(SIM_BIN) $(GPIO_GW_TEST)
	@st=0; \
	$(MAKE) --no-print-directory check-gpio-gateway-unit || st=1; \
	if mbpoll=$$(command -v mbpoll); then \
	    sh $(GPIO_QEMU) --cache "$(GPIO_CACHE)" --timeout $(GPIO_GW_TIMEOUT) \
	        --results "$(RESULTS)" --label gpio_gateway \
	        --bin $(GPIO_GW_BIN) --bin $(SIM_BIN) --bin "$$mbpoll" \
	        --file $(GPIO_GW_DIR)/gateway.ini:/etc/drgate/drgatewayd.ini \
	        --script $(GPIO_GW_DIR)/guest.sh $(GPIO_GW_ARGS) || st=1; \
	else \
	    echo "check-gpio-gateway: mbpoll is missing (make deps installs it)" >&2; \
	    mkdir -p $(dir $(RESULTS)); echo "0 1 gpio_gateway (no mbpoll)" >> $(RESULTS); \
	    st=1; \
	fi; \
	exit $$st

# (manual) the same guest with a shell on its console: `sh /test.sh` runs
# the test, `poweroff -f` leaves.
gpio-gateway-shell: $(GPIO_GW_BIN) $(SIM_BIN)
	@sh $(GPIO_QEMU) --cache "$(GPIO_CACHE)" --interactive \
	    --bin $(GPIO_GW_BIN) --bin $(SIM_BIN) --bin "$$(command -v mbpoll)" \
	    --file $(GPIO_GW_DIR)/gateway.ini:/etc/drgate/drgatewayd.ini \
	    --script $(GPIO_GW_DIR)/guest.sh
