# SPDX-License-Identifier: MIT
# The console's pages (gateway/http/www/, issue 21).
#
#   console-shots   docs/console-overview.png and docs/console-robot.png,
#                   and the same at 390 px (docs/console-*-phone.png),
#                   taken by the browser tests (tests/gateway/
#                   test_console_browser.py, test_console_commissioning.py
#                   with GW_CONSOLE_SHOTS) in
#                   headless chromium against drsim: run once after the
#                   pages change, and commit the pictures (README.md and
#                   docs/http.md show them); about a minute
#   bench-console   the daemon's CPU and the Modbus p99 with 10 live robot
#                   pages open, and the RSS and mapped libraries without
#                   [http]; then, in network namespaces (root), the Modbus
#                   p99 with a remote page logged in over TLS and during a
#                   wrong-password flood (bench/console_bench.py; in make
#                   bench)
#
# The browser test itself runs with the rest of tests/gateway (check-gateway,
# check-gateway-asan).

.PHONY: console-shots bench-console

console-shots: GW_TEST_JOBS = 1
console-shots: $(GW_BIN) $(SIM_BIN) $(CLI_BIN)
	@$(call GW_TEST_PEERS,console screenshots)
	@$(call GW_TEST_RUN,$(B),console screenshots (docs/console-*.png),\
	    GW_CONSOLE_SHOTS=$(CURDIR)/docs GW_LOGDIR=/tmp/drgate-console,\
	    tests/gateway/test_console_browser.py \
	    tests/gateway/test_console_commissioning.py::test_console_for_every_person)
	@ls -l docs/console-overview.png docs/console-robot.png docs/console-overview-phone.png \
	    docs/console-robot-phone.png

CONSOLE_BENCH_ARGS ?=
BENCH_STEPS += bench-console

# The daemon as it was just before the console (the parent of the first
# commit that added gateway/http/), built from `git archive` in its own
# tree under $(B)/bench/noconsole (the Makefile does not read the header
# lists there): the RSS the console must not add to without [http].
# Without git (a release tarball) the comparison is left out.
NOCONSOLE_GW := $(B)/bench/noconsole/drgatewayd
$(NOCONSOLE_GW):
	@rm -rf $(B)/bench/noconsole; mkdir -p $(B)/bench/noconsole/src
	@base=$$(git log --diff-filter=A --format=%H -- gateway/http 2>/dev/null | tail -n 1); \
	if [ -z "$$base" ]; then echo "bench-console: no git history: no daemon before the console"; \
	    exit 0; fi; \
	echo "bench-console: building drgatewayd of $$(git log -1 --format='%h %s' $$base^ | cut -c1-70)"; \
	git archive $$base^ | tar -x -C $(B)/bench/noconsole/src && \
	$(MAKE) --no-print-directory -C $(B)/bench/noconsole/src B=build build/drgatewayd >/dev/null && \
	cp $(B)/bench/noconsole/src/build/drgatewayd $@

bench-console: $(GW_BIN) $(SIM_BIN) $(B)/bench/gw_load $(NOCONSOLE_GW)
	$(GW_BENCH_PY) bench/console_bench.py --build $(B) \
	    $(if $(wildcard $(NOCONSOLE_GW)),--baseline $(NOCONSOLE_GW)) $(CONSOLE_BENCH_ARGS) \
	    $(if $(filter --write-doc,$(GW_BENCH_ARGS)),--write-doc)
