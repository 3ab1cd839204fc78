# SPDX-License-Identifier: MIT
# Robots per core (issue 15): drgatewayd against N simulated robots (N = 1,
# 2, 4, 8, 16, 32; one drsim each, on its own 127.0.15.x address) with six
# Class 1 connections each at RPI 10 ms and 2 ms and a light Modbus poll:
# the daemon's CPU per robot, whether it grows linearly, and the goal (RPI
# 10 ms: 32 robots with no connection timeout, the daemon at most the 32
# drsims' CPU in the same window). Run by
# `make bench` through BENCH_STEPS, or alone with `make bench-scale`;
# `make bench-scale SCALE_BENCH_ARGS=--quick` measures N = 1, 2, 4 only.
# Method and results in docs/performance.md ("Robots per core").
#
# The daemon takes 32 robots (GW_MAX_ROBOTS, gateway/core/config.h); the bench
# builds it with -DGW_MAX_ROBOTS=32 all the same, so that it keeps measuring
# 32 robots should the default change.

SCALE_BENCH_PY   ?= python3
SCALE_BENCH_ARGS ?=
SCALE_GW         := $(B)/bench/drgatewayd-scale

BENCH_STEPS += bench-scale
.PHONY: bench-scale

$(eval $(call GW_VARIANT,scale,-DGW_MAX_ROBOTS=32))
$(SCALE_GW): $(GW_OBJ_scale) $(GPIO_A) $(LIB_A)
	$(CC) $(ALL_CFLAGS) -fPIE -pie $(ALL_LDFLAGS) -o $@ $(GW_OBJ_scale) $(GPIO_A) \
	    $(LIB_A) $(GW_LIBS)

# `make bench` passes GW_BENCH_ARGS=--write-doc to every step: the results
# go into docs/performance.md then too.
bench-scale: $(SCALE_GW) $(SIM_BIN)
	PYTHONDONTWRITEBYTECODE=1 timeout -k 10 900 $(SCALE_BENCH_PY) bench/gw_scale.py \
	    --build $(B) $(filter --write-doc,$(GW_BENCH_ARGS)) $(SCALE_BENCH_ARGS)
