# SPDX-License-Identifier: MIT
# check-valgrind: drsim and drgatewayd (and drcli) under valgrind memcheck
# for one integration scenario (tests/valgrind/scenario.py, docs/quality.md):
# drsim on 127.0.0.2, drgatewayd with Class 1 at RPI 20 ms and no GPIO,
# Modbus reads of every area and writes of every O->T kind through
# pymodbus, a session drop, a SIGHUP reload, then SIGTERM. Every program
# must exit 0 with 0 errors, 0 bytes definitely or indirectly lost and no
# descriptor of its own left open. One "passed failed label" line per
# program goes to $(RESULTS).
#
# The binaries are the plain build's ($(B)): -O2 -g, as installed.
# Suppressions (third-party noise only, one comment each) are in
# tests/valgrind/drgate.supp; the logs stay in $(B)/tests/valgrind.

CHECK_STEPS += check-valgrind

VALGRIND_PY      ?= .venv/bin/python
VALGRIND_TIMEOUT ?= 600
VALGRIND_LOGDIR  := $(B)/tests/valgrind

.PHONY: check-valgrind

check-valgrind: $(GW_BIN) $(SIM_BIN) $(CLI_BIN)
	@if ! command -v valgrind >/dev/null 2>&1 || \
	    ! $(VALGRIND_PY) -c 'import pymodbus' 2>/dev/null; then \
	    echo "check-valgrind: needs valgrind and pymodbus in $(VALGRIND_PY) (make test-deps)"; \
	    echo "0 1 valgrind (no valgrind or pymodbus: make test-deps)" >> $(RESULTS); exit 1; fi
	@PYTHONDONTWRITEBYTECODE=1 timeout -k 10 $(VALGRIND_TIMEOUT) \
	    $(VALGRIND_PY) tests/valgrind/scenario.py $(B) $(abspath $(RESULTS)) \
	    $(VALGRIND_LOGDIR) tests/valgrind/drgate.supp
