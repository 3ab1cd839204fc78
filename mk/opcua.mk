# SPDX-License-Identifier: MIT
# The OPC UA side end to end (tests/opcua/, docs/opcua.md): drsim and
# drgatewayd with [opcua] on loopback, driven by an independent OPC UA
# client (python asyncua from .venv, pinned in tests/requirements.txt).
#
#   check-opcua        the suite against $(B)/drgatewayd and $(B)/drsim
#   check-opcua-asan   the same against both built with ASan+UBSan (as
#                      check-gateway-asan, in $(B)/asan)
#
# Only a drgatewayd built with open62541 has the side: Debian 13 (trixie)
# packages it, Debian 12 does not, so `make check` on bookworm does not run
# these; check-fresh runs check-opcua in its trixie root (mk/fresh-root.sh).
# Where the build has no open62541, check-opcua is SKIPPED with a banner
# (under CI a failure, tests/skip.sh).

.PHONY: check-opcua check-opcua-asan

# Its logs and configurations: beside the gateway suite's, not among them
# (that suite clears its folder when it starts).
OPCUA_ENV = GW_LOGDIR=$(abspath $(B))/tests/opcua

OPCUA_SKIP = sh tests/skip.sh $@ "this drgatewayd is built without open62541 (Debian 13's \
             libopen62541-1.4-dev, make test-deps there; make check-fresh runs it in a trixie \
             root)" "$(RESULTS)" "OPC UA side end to end"
OPCUA_PEERS = if ! $(GW_TEST_PY) -c 'import asyncua, pytest, xdist' 2>/dev/null; then \
                  echo "$@: no asyncua, pytest or pytest-xdist in $(GW_TEST_PY) (run make test-deps)"; \
                  echo "0 1 $(1) (no asyncua/pytest: make test-deps)" >> $(RESULTS); \
                  exit 1; fi

check-opcua: $(GW_BIN) $(SIM_BIN) $(CLI_BIN)
	@if [ -z "$(OPCUA_VERSION)" ]; then $(OPCUA_SKIP); exit $$?; fi; \
	$(call OPCUA_PEERS,OPC UA side end to end); \
	$(call GW_TEST_RUN,$(B),OPC UA side end to end (tests/opcua),$(OPCUA_ENV),tests/opcua)

# Slower under the sanitizers: the tests' deadlines are scaled.
check-opcua-asan:
	@if [ -z "$(OPCUA_VERSION)" ]; then $(OPCUA_SKIP); exit $$?; fi; \
	$(call OPCUA_PEERS,OPC UA side end to end [asan]); \
	$(MAKE) --no-print-directory B=$(B)/asan CFLAGS="$(SAN_FLAGS)" \
	    LDFLAGS="-fsanitize=address,undefined" HARDEN= \
	    $(B)/asan/drgatewayd $(B)/asan/drsim $(B)/asan/drcli || exit 1; \
	$(call GW_TEST_RUN,$(B)/asan,OPC UA side end to end (tests/opcua) [asan],\
	    $(OPCUA_ENV) GW_TIMEOUT_SCALE=3 ASAN_OPTIONS=detect_leaks=1:abort_on_error=0,tests/opcua)

# `make bench-opcua` (in make bench): issue 34's goals for the side
# (bench/opcua_bench.py, docs/opcua.md "Performance"): a subscriber's
# latency against a 1 ms Modbus poll, the daemon's CPU with ten clients
# subscribed to the joints, Class 1 timing with them. It takes the Class 1
# datagrams from an AF_PACKET socket (root) and asyncua from
# $(GW_BENCH_PY); SKIPPED with a banner without open62541 or root. In the
# trixie root: make B=build/trixie bench-opcua GW_BENCH_PY=/root/venv/bin/python
BENCH_STEPS += bench-opcua
.PHONY: bench-opcua
OPCUA_BENCH_NOLIB = this drgatewayd is built without open62541 (Debian 13's libopen62541-1.4-dev)
OPCUA_BENCH_NOROOT = not root (the Class 1 datagrams come from an AF_PACKET socket)
bench-opcua: $(GW_BIN) $(SIM_BIN)
	@if [ -z "$(OPCUA_VERSION)" ]; then sh tests/skip.sh $@ "$(OPCUA_BENCH_NOLIB)"; exit $$?; fi; \
	if [ "$$(id -u)" != 0 ]; then sh tests/skip.sh $@ "$(OPCUA_BENCH_NOROOT)"; exit $$?; fi; \
	if ! $(GW_BENCH_PY) -c 'import asyncua, pytest' 2>/dev/null; then \
	    echo "$@: no asyncua or pytest in $(GW_BENCH_PY) (run make test-deps)"; exit 1; fi; \
	PYTHONDONTWRITEBYTECODE=1 timeout -k 10 900 $(GW_BENCH_PY) bench/opcua_bench.py \
	    --build $(B) $(GW_BENCH_ARGS)
