# SPDX-License-Identifier: MIT
# The MQTT northbound side of drgatewayd (gateway/north_mqtt.c) links
# libmosquitto (Debian's libmosquitto-dev; docs/mqtt.md). Included after
# mk/gw_daemon.mk, whose link line it extends.

MQTT_CFLAGS := $(call pc,--cflags,libmosquitto)
MQTT_LIBS   := $(or $(call pc,--libs,libmosquitto),-lmosquitto)
GW_DEP_LIBS += $(MQTT_LIBS)
