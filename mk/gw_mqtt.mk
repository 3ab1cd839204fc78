# SPDX-License-Identifier: MIT
# The MQTT northbound side of drgatewayd (gateway/north_mqtt.c) is
# compiled against Debian's libmosquitto-dev header (<mosquitto.h>: types
# and constants) but does not link libmosquitto: gateway/mqtt_lib.c loads
# libmosquitto.so.1 with dlopen when the configuration has an [mqtt]
# section, so that a gateway without MQTT does not map it, nor the libssl
# and libcrypto it pulls in (docs/mqtt.md, docs/performance.md "Gateway").
# glibc 2.34 and later have dlopen in libc; -ldl is an empty stub there
# and keeps older C libraries linking. Included after mk/gw_daemon.mk,
# whose link line it extends.

MQTT_CFLAGS := $(call pc,--cflags,libmosquitto)
GW_DEP_LIBS += -ldl

# `make bench-mqtt`: robot change -> MQTT subscriber latency and the
# daemon's CPU with and without [mqtt] (bench/mqtt_bench.py; the figures in
# docs/performance.md "MQTT"). Not in BENCH_STEPS yet: it prints Markdown
# rows, the report of `make bench` does not take them.
.PHONY: bench-mqtt
bench-mqtt: $(GW_BIN) $(SIM_BIN)
	.venv/bin/python bench/mqtt_bench.py --build $(B)
