# SPDX-License-Identifier: MIT
# drgatewayd's benchmark (issue 5, "Done when"), run by `make bench` through
# BENCH_STEPS, or alone with `make bench-gw`: Modbus throughput against a
# plain select-loop libmodbus server and a pymodbus 3.8 server, the latency
# from a robot packet's arrival to Modbus visibility, RSS and CPU share.
# The results go to docs/performance.md ("Gateway" section) with
# `make bench-gw GW_BENCH_ARGS=--write-doc`. See bench/gw_bench.py.
#
# This file is read before gpio.mk and gw_daemon.mk (mk/*.mk in name order),
# whose variables the prerequisites below need: they are written $$(VAR)
# and expanded in make's second expansion, after every file is read.
# (.SECONDEXPANSION only changes prerequisites that contain $$; no other
# rule has any.)

GW_BENCH_BIN := $(B)/bench/gw_load $(B)/bench/gw_plain_server $(B)/bench/drgatewayd-lat
GW_BENCH_PY  ?= .venv/bin/python
GW_BENCH_ARGS ?=

BENCH_STEPS += bench-gw
.PHONY: bench-gw
.SECONDEXPANSION:

$(B)/bench/gw_load: bench/gw_load.c
	@mkdir -p $(dir $@)
	$(CC) $(WARN) -O2 -g $(ALL_LDFLAGS) -o $@ $<

$(B)/bench/gw_plain_server: bench/gw_plain_server.c gateway/regmap.h $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Igateway $(MODBUS_CFLAGS) $(WARN) -O2 -g $(ALL_LDFLAGS) \
	    -o $@ $< $(MODBUS_LIBS)

# The daemon with the latency instrumentation: bench/gw_lat.c, which
# watches the links through their observer (gateway/link.h), and
# bench/gw_lat_hook.h, which notes when the loop wakes up; the
# throughput, RSS and CPU figures use the real one.
GW_LAT_SRC := bench/gw_lat.c
$(B)/bench/drgatewayd-lat: gateway/main.c $$(GW_LIB_SRC) $(GW_LAT_SRC) $(COMMON_SRC) $$(GPIO_A) $(LIB_A) \
                           $$(GW_HDR) $(COMMON_HDR) $(LIB_HDR) bench/gw_lat_hook.h
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Igateway -include bench/gw_lat_hook.h \
	    -DDRGATE_VERSION='"$(VERSION)"' \
	    $(MODBUS_CFLAGS) $(INIH_CFLAGS) $(SYSTEMD_CFLAGS) $(ALL_CFLAGS) -fPIE -pie \
	    $(ALL_LDFLAGS) -o $@ gateway/main.c $(GW_LIB_SRC) $(GW_LAT_SRC) $(COMMON_SRC) $(GPIO_A) $(LIB_A) \
	    $(MODBUS_LIBS) $(INIH_LIBS) $(GPIO_LIBS) $(SYSTEMD_LIBS) -ldl -lm

bench-gw: $$(GW_BIN) $(SIM_BIN) $(GW_BENCH_BIN)
	@if [ ! -x $(GW_BENCH_PY) ]; then \
	    echo "bench-gw: $(GW_BENCH_PY) missing (make deps installs pymodbus into .venv)" >&2; \
	    exit 1; fi
	$(GW_BENCH_PY) bench/gw_bench.py --build $(B) $(GW_BENCH_ARGS)

# Modbus RTU (issue 13): requests per second at 115200 8N1 over a socat
# pty pair against the line's theoretical limit (bench/gw_rtu_bench.py).
BENCH_STEPS += bench-gw-rtu
.PHONY: bench-gw-rtu
bench-gw-rtu: $$(GW_BIN) $(SIM_BIN)
	$(GW_BENCH_PY) bench/gw_rtu_bench.py
