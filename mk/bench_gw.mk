# SPDX-License-Identifier: MIT
# drgatewayd's benchmark (issue 5, "Done when"), run by `make bench` through
# BENCH_STEPS, or alone with `make bench-gw`: Modbus throughput against a
# plain select-loop libmodbus server and a pymodbus 3.8 server, the latency
# from a robot packet's arrival to Modbus visibility, RSS, and the CPU
# share against drsim's (the other end of the same connections).
# The results go to docs/performance.md ("Gateway" section) with
# `make bench-gw GW_BENCH_ARGS=--write-doc`. See bench/gw_bench.py.

GW_BENCH_BIN := $(B)/bench/gw_load $(B)/bench/gw_plain_server $(B)/bench/drgatewayd-lat \
    $(B)/bench/lat_bare $(B)/bench/drgatewayd-noreqlog
GW_BENCH_PY  ?= .venv/bin/python
GW_BENCH_ARGS ?=

BENCH_STEPS += bench-gw
.PHONY: bench-gw bench-mqtt

$(B)/bench/gw_load: bench/gw_load.c $(B)/bench/gw_load.d
	@mkdir -p $(dir $@)
	$(CC) $(WARN) -O2 -g $(DEPFLAGS) $(ALL_LDFLAGS) -o $@ $<

$(B)/bench/gw_plain_server: bench/gw_plain_server.c $(B)/bench/gw_plain_server.d
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Igateway $(MODBUS_CFLAGS) $(WARN) -O2 -g $(DEPFLAGS) \
	    $(ALL_LDFLAGS) -o $@ $< $(MODBUS_LIBS)

# The daemon with the latency instrumentation: bench/gw_lat.c, which
# watches the links through their observer (gateway/core/link.h), and
# bench/gw_lat_hook.h, forced into every source (-include: the lists of
# headers name it all the same), which notes when the loop wakes up; the
# throughput, RSS and CPU figures use the real one.
$(eval $(call GW_VARIANT,lat,-include bench/gw_lat_hook.h,bench/gw_lat.c))
$(B)/bench/drgatewayd-lat: $(GW_OBJ_lat) $(GPIO_A) $(LIB_A)
	$(CC) $(ALL_CFLAGS) -fPIE -pie $(ALL_LDFLAGS) -o $@ $(GW_OBJ_lat) $(GPIO_A) \
	    $(LIB_A) $(GW_LIBS)

# The daemon without the Modbus request log (gateway/modbus/reqlog.h,
# issue 33): what the log costs, its req/s against the real one's.
$(eval $(call GW_VARIANT,noreqlog,-DGW_MB_NO_REQLOG))
$(B)/bench/drgatewayd-noreqlog: $(GW_OBJ_noreqlog) $(GPIO_A) $(LIB_A)
	$(CC) $(ALL_CFLAGS) -fPIE -pie $(ALL_LDFLAGS) -o $@ $(GW_OBJ_noreqlog) $(GPIO_A) \
	    $(LIB_A) $(GW_LIBS)

bench-gw: $(GW_BIN) $(SIM_BIN) $(GW_BENCH_BIN)
	@if [ ! -x $(GW_BENCH_PY) ]; then \
	    echo "bench-gw: $(GW_BENCH_PY) missing (make deps installs pymodbus into .venv)" >&2; \
	    exit 1; fi
	$(GW_BENCH_PY) bench/gw_bench.py --build $(B) $(GW_BENCH_ARGS)

# Modbus RTU (issue 13): requests per second at 115200 8N1 over a socat
# pty pair against the line's theoretical limit (bench/gw_rtu_bench.py).
BENCH_STEPS += bench-gw-rtu
.PHONY: bench-gw-rtu
bench-gw-rtu: $(GW_BIN) $(SIM_BIN)
	$(GW_BENCH_PY) bench/gw_rtu_bench.py

# `make bench-mqtt`: robot change -> MQTT subscriber latency against a
# Modbus client polling every millisecond, broker bytes per second per
# robot, JSON vs Sparkplug B, and the daemon's CPU with either payload
# (bench/mqtt_bench.py; the figures in docs/performance.md "MQTT"). Its
# goal lines (met / MISSED) go into make bench's report.
BENCH_STEPS += bench-mqtt
bench-mqtt: $(GW_BIN) $(SIM_BIN)
	$(GW_BENCH_PY) bench/mqtt_bench.py --build $(B) $(GW_BENCH_ARGS)

# The user's register map (issue 22): a 125-register read of it against
# the same read of the default map, in-process (bench/gw_umap_bench.c).
BENCH_STEPS += bench-gw-umap
.PHONY: bench-gw-umap
$(B)/bench/gw_umap_bench: bench/gw_umap_bench.c $(B)/bench/gw_umap_bench.d $(GW_A) $(LIB_A)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Igateway $(ALL_CFLAGS) $(DEPFLAGS) $(ALL_LDFLAGS) -o $@ $< \
	    $(GW_A) $(GPIO_A) $(COMMON_A) $(LIB_A) $(GW_LIBS)
bench-gw-umap: $(B)/bench/gw_umap_bench
	$(B)/bench/gw_umap_bench
