# SPDX-License-Identifier: MIT
# EtherNet/IP benchmarks (issue 3, "Done when"), run by `make bench` through
# BENCH_STEPS, or alone with `make bench-enip`; method and results in
# docs/performance.md ("EtherNet/IP"). All figures are ratios to baselines
# measured in the same run:
#   explicit Get_Attribute_Single round trips/s of our client against drsim
#     vs a bare C TCP ping-pong of the same frame sizes (bench/pingpong.c)
#     and vs pycomm3 doing the same Gets;
#   6 Class 1 connections at RPI 1 ms, 5 runs of 3 s (bench/enip_io.c):
#     produced-packet intervals and p99 deviation vs a bare timerfd loop,
#     client CPU vs the same loop's, wake-ups per RPI of both; the goals are
#     judged on the medians of the per-run ratios.
# Exit status 1 if a goal is missed. BENCH_ROUNDS, BENCH_SECONDS,
# BENCH_IO_ROUNDS and BENCH_IO_SECONDS (environment) shorten or lengthen it.

BENCH_STEPS += bench-enip

ENIP_BENCH_PY  ?= .venv/bin/python
ENIP_BENCH_BIN := $(B)/bench/pingpong $(B)/bench/enip_gets $(B)/bench/enip_io

.PHONY: bench-enip

# pingpong and enip_gets build with the Makefile's $(B)/bench/% rule; the
# I/O bench links drsim's adapter logic (drsim's objects) as its measuring
# receiver.
$(B)/bench/enip_io: bench/enip_io.c $(B)/bench/enip_io.d $(SIM_LIB_OBJ) $(LIB_A)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) -Isim $(WARN) -O2 -g $(DEPFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(SIM_LIB_OBJ) $(LIB_A) -lm

bench-enip: $(ENIP_BENCH_BIN) $(SIM_BIN)
	@if [ ! -x "$(ENIP_BENCH_PY)" ]; then \
	    echo "bench-enip: no $(ENIP_BENCH_PY) (run make deps)"; exit 1; fi
	PYTHONDONTWRITEBYTECODE=1 DRSIM=$(abspath $(SIM_BIN)) \
	    timeout -k 10 600 $(ENIP_BENCH_PY) bench/bench_enip.py $(abspath $(B))
