# SPDX-License-Identifier: MIT
# drgatewayd end to end (tests/gateway/): drsim on 127.0.0.2 and the
# daemon on 127.0.0.1, each on free ports, driven by independent Modbus
# clients (pymodbus from .venv, Debian's mbpoll, and a framer of the
# tests' own) and checked against the robot's own view of its assemblies
# (an EtherNet/IP reader of the tests' own). pytest from .venv
# (tests/requirements.txt, `make test-deps`); one "passed failed label" line per
# run goes to $(RESULTS).
#
#   check-gateway        the suite against $(B)/drgatewayd and $(B)/drsim
#   check-gateway-asan   the same against both built with ASan+UBSan (the
#                        Makefile's SAN_FLAGS, in $(B)/asan as check-asan);
#                        a sanitizer report in any log is a failure
#   check-regmap-docs    docs/register-map.md equals --print-map --markdown
#   check-config-docs    the key tables of docs/configuration.md equal
#                        --help-config SECTION
#   check-gateway-config drgatewayd's command line and configuration errors
#                        only (tests/gateway/test_config.py: FILE:LINE, exit
#                        codes), for check-quick
#   check-gw-boundary    the robot (gateway/robot.[ch]) and its link know
#                        nothing of Modbus, GPIO and MQTT read gw_robot_t
#                        only (mk/gw-boundary.sh; check-gateway runs it first)
#   check-gateway-unit   gateway/drgatewayd.service as systemd-analyze
#                        verify reads it: any complaint is a failure
#                        (skipped loudly where systemd-analyze is missing);
#                        its DeviceAllow= lets in the GPIO chips and the
#                        serial ports [modbus_rtu] opens, nothing else
#   regmap-docs          regenerates docs/register-map.md (also `make docs`)
#   config-docs          regenerates docs/configuration.md's key tables
#                        (also `make docs`)
#
# The suite runs on GW_TEST_JOBS (2) pytest-xdist workers: its tests spend
# most of their time waiting (a drsim that boots, a link that times out),
# and each takes its own ports and files (tests/gateway/gwlib.py), so two
# run side by side in about half the time. GW_TEST_JOBS=1 runs them one
# after the other. GW_PYTEST_ARGS passes options to pytest (e.g. -k reload
# -x); the logs and the configurations written by the tests are kept in
# $(B)/tests/gateway (gw0/, gw1/: one folder per worker).
#
# In make check the suite runs twice, not three times (docs/quality.md):
# against the coverage build, for its result and its line counts at once
# (check-coverage, mk/coverage.mk: check-gateway is not a step of its own),
# and under ASan+UBSan (check-gateway-asan). The -O2 daemon as installed is
# run end to end by check-soak, check-valgrind and check-gpio-gateway.

CHECK_STEPS += check-gw-boundary check-gateway-asan check-regmap-docs check-config-docs \
               check-gateway-unit

GW_TEST_PY      ?= .venv/bin/python
GW_TEST_TIMEOUT ?= 1800
GW_TEST_JOBS    ?= 2
GW_PYTEST_ARGS  ?=
GW_PYTEST        = $(GW_TEST_PY) -m pytest -q -p no:cacheprovider \
                   $(if $(filter-out 0 1,$(GW_TEST_JOBS)),-n $(GW_TEST_JOBS)) \
                   $(GW_PYTEST_ARGS) $(or $(4),tests/gateway)
# Another results file for the run's line (make coverage: its own results).
GW_EXTRA_RESULTS ?=
# $(1): build directory, $(2): label, $(3): extra environment, $(4): the
# test files (default: all of tests/gateway)
GW_TEST_RUN      = PYTHONDONTWRITEBYTECODE=1 \
                   GW_RESULTS=$(abspath $(RESULTS))$(if $(GW_EXTRA_RESULTS),:$(abspath $(GW_EXTRA_RESULTS))) \
                   GW_BUILD=$(abspath $(1)) DRGATEWAYD=$(abspath $(1))/drgatewayd \
                   DRSIM=$(abspath $(1))/drsim GW_LOGDIR=$(abspath $(1))/tests/gateway \
                   GW_LABEL="$(2)" $(3) timeout -k 10 $(GW_TEST_TIMEOUT) $(GW_PYTEST)
GW_TEST_PEERS    = if ! $(GW_TEST_PY) -c 'import pytest, pymodbus, xdist' 2>/dev/null; then \
                       echo "$@: no pytest, pytest-xdist or pymodbus in $(GW_TEST_PY) (run make test-deps)"; \
                       echo "0 1 $(1) (no pytest/xdist/pymodbus: make test-deps)" >> $(RESULTS); \
                       exit 1; fi

.PHONY: check-gateway check-gateway-asan check-gateway-unit check-gw-boundary regmap-docs \
        check-regmap-docs check-config-docs config-docs check-gateway-config

check-gw-boundary:
	@sh mk/gw-boundary.sh "$(RESULTS)"

check-gateway: $(GW_BIN) $(SIM_BIN) $(CLI_BIN)
	@sh mk/gw-boundary.sh "$(RESULTS)"
	@$(call GW_TEST_PEERS,drgatewayd end to end)
	@$(call GW_TEST_RUN,$(B),drgatewayd end to end (tests/gateway)$(if $(GW_COVERAGE), [coverage build]))

# Slower under the sanitizers: the tests' deadlines are scaled.
check-gateway-asan:
	@$(call GW_TEST_PEERS,drgatewayd end to end [asan])
	$(MAKE) --no-print-directory B=$(B)/asan CFLAGS="$(SAN_FLAGS)" \
	    LDFLAGS="-fsanitize=address,undefined" HARDEN= \
	    $(B)/asan/drgatewayd $(B)/asan/drsim $(B)/asan/drcli
	@$(call GW_TEST_RUN,$(B)/asan,drgatewayd end to end (tests/gateway) [asan],\
	    GW_TIMEOUT_SCALE=3 ASAN_OPTIONS=detect_leaks=1:abort_on_error=0)

# verify, and the unit's devices: the GPIO chips and the serial ports
# [modbus_rtu] opens, nothing else (mk/check-unit.sh; under a second).
check-gateway-unit: $(GW_BIN)
	@sh mk/check-unit.sh $(abspath $(GW_BIN)) $(RESULTS)

# The register map in the docs is printed by the daemon from the field table.
check-regmap-docs: $(GW_BIN)
	@sh mk/gen-regmap-doc.sh --check $(GW_BIN) "$(RESULTS)"

regmap-docs: $(GW_BIN)
	@sh mk/gen-regmap-doc.sh --write $(GW_BIN)

# So are the key tables of docs/configuration.md, from the sections' tables.
check-config-docs: $(GW_BIN)
	@sh mk/gen-config-doc.sh --check $(GW_BIN) "$(RESULTS)"

config-docs: $(GW_BIN)
	@sh mk/gen-config-doc.sh --write $(GW_BIN)

# (a second of tests: no workers)
check-gateway-config: GW_TEST_JOBS = 1
check-gateway-config: $(GW_BIN) $(SIM_BIN)
	@$(call GW_TEST_PEERS,drgatewayd configuration errors)
	@$(call GW_TEST_RUN,$(B),drgatewayd configuration errors (tests/gateway/test_config.py),,\
	    tests/gateway/test_config.py)

docs: regmap-docs config-docs
