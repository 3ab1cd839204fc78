# SPDX-License-Identifier: MIT
# check-soak: a bounded soak test of drgatewayd (tests/soak/soak.py,
# docs/quality.md): drsim with packet loss and session drops (--drop 10
# --drop-session-after 5), drgatewayd on Class 1 at RPI 10 ms, six Modbus
# clients (pymodbus from .venv) reading and writing for SOAK_SECONDS, drsim
# stopped and started again halfway. Afterwards: every acknowledged write
# reached drsim, the status block never contradicted itself, neither
# program crashed, and drgatewayd's descriptors and memory did not grow.
# Then the same, shorter (SOAK_EXPLICIT_SECONDS), with the robot in
# explicit mode (cyclic Get/Set over TCP, RPI 20 ms), whose requests are
# the ones a session drop cuts. One "passed failed label" line per check
# goes to $(RESULTS); the logs stay in $(B)/tests/soak and
# $(B)/tests/soak-explicit.
#
#   make check-soak SOAK_SECONDS=600            a longer run
#   make check-soak SOAK_EXPLICIT_SECONDS=0     Class 1 only
#   make check-soak SOAK_ARGS="--seed 7"        other random choices

CHECK_STEPS += check-soak

SOAK_PY      ?= .venv/bin/python
SOAK_SECONDS ?= 60
SOAK_EXPLICIT_SECONDS ?= 20
SOAK_ARGS    ?=
SOAK_LOGDIR  := $(B)/tests/soak
SOAK_RUN      = PYTHONDONTWRITEBYTECODE=1 timeout -k 10 $$(( $(1) + 300 )) \
                $(SOAK_PY) tests/soak/soak.py --build $(B) --results $(abspath $(RESULTS)) \
                --seconds $(1) $(SOAK_ARGS)

.PHONY: check-soak

check-soak: $(GW_BIN) $(SIM_BIN) $(CLI_BIN)
	@if ! $(SOAK_PY) -c 'import pymodbus' 2>/dev/null; then \
	    echo "check-soak: no pymodbus in $(SOAK_PY) (make test-deps)"; \
	    echo "0 1 soak (no pymodbus: make test-deps)" >> $(RESULTS); exit 1; fi
	@st=0; \
	$(call SOAK_RUN,$(SOAK_SECONDS)) --logdir $(SOAK_LOGDIR) || st=1; \
	if [ "$(SOAK_EXPLICIT_SECONDS)" -gt 0 ]; then \
	    $(call SOAK_RUN,$(SOAK_EXPLICIT_SECONDS)) --logdir $(SOAK_LOGDIR)-explicit \
	        --mode explicit --rpi-ms 20 || st=1; \
	fi; \
	exit $$st
