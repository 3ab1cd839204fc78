# SPDX-License-Identifier: MIT
# Line coverage (gcovr, docs/quality.md):
#
#   coverage        builds everything with --coverage in $(B)/cov, runs the
#                   tests of COV_STEPS with that build (unit tests, drcli
#                   offline and against drsim, the GPIO and gpiomap host
#                   tests, drgatewayd end to end), then reports line
#                   coverage per file and per directory:
#                     $(B)/cov/coverage.txt          per file, lines missed
#                     $(B)/cov/coverage-dirs.txt     per directory, floors
#                     $(B)/cov/html/index.html       annotated sources
#   check-coverage  `coverage`, then the floors of COV_FLOORS: one result
#                   line per directory, and one saying whether every test
#                   passed in the coverage build
#
# In make check, this run of the gateway's end-to-end suite is also the
# suite's result (check-gateway is not a step of make check): its line,
# "drgatewayd end to end (tests/gateway) [coverage build]", goes to make
# check's results as well (COV_GW_RESULTS, set by check-coverage). The
# daemon at -O0 with counters runs the same code as the installed one;
# what only the -O2 build could show (undefined behaviour the optimizer
# exploits, FORTIFY's checks) is what the ASan+UBSan run catches, and the
# -O2 daemon itself runs end to end in check-soak, check-valgrind and
# check-gpio-gateway (docs/quality.md, "What runs where").
#
# tests/, fuzz/ and bench/ are not measured. sim/ (drsim, test
# infrastructure) is reported without a floor. gcovr is Debian's (bookworm:
# 5.2), installed by `make deps`. The sanitizer reruns of check-cli-net and
# check-gpio are left out (CLI_NET_NO_ASAN, GPIO_NO_ASAN): they add time,
# not coverage.

CHECK_STEPS += check-coverage

GCOVR      ?= gcovr
COV_B      := $(B)/cov
COV_FLOORS ?= lib=90 gateway=80 cli=80
COV_STEPS  ?= check-unit check-cli check-cli-net check-gpio check-gpio-gateway-unit \
              check-gateway
COV_GW_RESULTS ?=
COV_MAKE    = GW_COVERAGE=1 $(MAKE) --no-print-directory B=$(COV_B) CFLAGS="-O0 -g --coverage" \
              LDFLAGS=--coverage HARDEN= CLI_NET_NO_ASAN=1 GPIO_NO_ASAN=1 \
              RESULTS=$(abspath $(COV_B))/test-results \
              $(if $(COV_GW_RESULTS),GW_EXTRA_RESULTS=$(abspath $(COV_GW_RESULTS)))
COV_GCOVR   = $(GCOVR) -r . -j 2 -e 'tests/' -e 'fuzz/' -e 'bench/' \
              --json-summary $(COV_B)/coverage-summary.json --json-summary-pretty \
              --txt $(COV_B)/coverage.txt --html-details $(COV_B)/html/index.html \
              $(COV_B)

.PHONY: coverage check-coverage

coverage:
	@if ! command -v $(GCOVR) >/dev/null 2>&1; then \
	    echo "coverage: no $(GCOVR) (make deps installs Debian's gcovr)"; exit 1; fi
	@t0=$$(date +%s); \
	$(COV_MAKE) all || exit 1; \
	find $(COV_B) -name '*.gcda' -delete; \
	rm -rf $(COV_B)/test-results $(COV_B)/html; mkdir -p $(COV_B)/html; \
	for step in $(COV_STEPS); do \
	    echo "coverage: $$step"; \
	    $(COV_MAKE) $$step || echo "0 1 $$step (make $$step failed)" >> $(COV_B)/test-results; \
	done; \
	$(COV_GCOVR) || exit 1; \
	awk '{p += $$1; f += $$2} END {printf "coverage: tests in the coverage build: %d passed, %d failed\n", p, f}' \
	    $(COV_B)/test-results; \
	python3 mk/coverage.py $(COV_B)/coverage-summary.json $(COV_B)/coverage-dirs.txt \
	    $(COV_FLOORS); \
	echo "coverage: $$(( $$(date +%s) - t0 )) s; per file: $(COV_B)/coverage.txt, annotated: $(COV_B)/html/index.html"

check-coverage:
	@if ! command -v $(GCOVR) >/dev/null 2>&1; then \
	    echo "check-coverage: no $(GCOVR) (make deps)"; \
	    echo "0 1 coverage (no gcovr: make deps)" >> $(RESULTS); exit 1; fi
	@rm -f $(COV_B)/coverage-summary.json
	@$(MAKE) --no-print-directory coverage COV_GW_RESULTS=$(RESULTS) || true
	@if [ ! -f $(COV_B)/coverage-summary.json ]; then \
	    echo "0 1 coverage (no report: see above)" >> $(RESULTS); exit 1; fi
	@awk '{p += $$1; f += $$2} END {ok = (f == 0 && p > 0); \
	    printf "%d %d coverage: the tests passed in the coverage build (%d passed, %d failed)\n", \
	    ok, !ok, p, f; exit !ok}' $(COV_B)/test-results >> $(RESULTS); st=$$?; \
	python3 mk/coverage.py $(COV_B)/coverage-summary.json $(COV_B)/coverage-dirs.txt \
	    --check $(abspath $(RESULTS)) $(COV_FLOORS) >/dev/null || st=1; \
	exit $$st
