# SPDX-License-Identifier: MIT
# The MQTT northbound side of drgatewayd (gateway/north_mqtt.c) links
# libmosquitto (Debian's libmosquitto-dev; docs/mqtt.md). Included after
# mk/gw_daemon.mk, whose link line it extends.

MQTT_CFLAGS := $(call pc,--cflags,libmosquitto)
MQTT_LIBS   := $(or $(call pc,--libs,libmosquitto),-lmosquitto)
GW_DEP_LIBS += $(MQTT_LIBS)

# `make bench-mqtt`: robot change -> MQTT subscriber latency and the
# daemon's CPU with and without [mqtt] (bench/mqtt_bench.py; the figures in
# docs/performance.md "MQTT"). Not in BENCH_STEPS yet: it prints Markdown
# rows, the report of `make bench` does not take them.
.PHONY: bench-mqtt
bench-mqtt: $(GW_BIN) $(SIM_BIN)
	.venv/bin/python bench/mqtt_bench.py --build $(B)
