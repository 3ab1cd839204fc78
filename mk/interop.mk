# SPDX-License-Identifier: MIT
# Interoperability: drsim and our client checked against implementations
# that are not ours (tests/interop/, docs/interop.md):
#   pycomm3     -> drsim   explicit messaging, every assembly
#   ethernetip  -> drsim   Class 1 I/O (on this host; and in two network
#                          namespaces on the standard ports when root)
#   our client  -> cpppo   explicit messaging against cpppo's server
#   tshark      decodes a capture of our client talking to drsim
# The Python peers come from .venv (make deps, tests/requirements.txt).
# Each part adds its "passed failed label" line(s) to $(RESULTS).
# check-interop-asan runs the peers again against drsim and our client built
# with ASan+UBSan (the Makefile's SAN_FLAGS, in $(B)/asan as check-asan).

CHECK_STEPS += check-interop check-interop-asan

INTEROP_PY      ?= .venv/bin/python
INTEROP_TIMEOUT ?= 900
INTEROP_BIN     := $(B)/tests/interop/test_client_cpppo $(B)/tests/interop/enip_session
INTEROP_ENV      = PYTHONDONTWRITEBYTECODE=1 DRGATE_BUILD=$(abspath $(B)) DRSIM=$(abspath $(SIM_BIN))
INTEROP_RUN      = $(INTEROP_ENV) timeout -k 10 $(INTEROP_TIMEOUT)

.PHONY: check-interop check-interop-asan

$(B)/tests/interop/test_client_cpppo: tests/interop/test_client_cpppo.c \
        $(B)/tests/interop/test_client_cpppo.d $(LIB_A)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) $(CMOCKA_CFLAGS) $(ALL_CFLAGS) $(DEPFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(LIB_A) $(CMOCKA_LIBS) -lm

$(B)/tests/interop/enip_session: tests/interop/enip_session.c \
        $(B)/tests/interop/enip_session.d $(LIB_A)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) $(ALL_CFLAGS) $(DEPFLAGS) $(ALL_LDFLAGS) -o $@ $< $(LIB_A) -lm

check-interop: $(SIM_BIN) $(INTEROP_BIN)
	@if [ ! -x "$(INTEROP_PY)" ]; then \
	    echo "check-interop: no $(INTEROP_PY) (run make deps)"; \
	    echo "0 1 interop (no Python peers: make deps)" >> $(RESULTS); exit 1; fi
	@st=0; \
	$(INTEROP_RUN) $(INTEROP_PY) tests/interop/pyrun.py $(RESULTS) \
	    "interop pycomm3 -> drsim" tests/interop/test_pycomm3.py || st=1; \
	$(INTEROP_RUN) $(INTEROP_PY) tests/interop/pyrun.py $(RESULTS) \
	    "interop ethernetip -> drsim (Class 1)" tests/interop/test_ethernetip.py || st=1; \
	$(INTEROP_RUN) $(INTEROP_PY) tests/interop/with_cpppo.py $(RESULTS) \
	    "interop client -> cpppo" -- \
	    sh tests/run-tests.sh $(RESULTS) "" $(B)/tests/interop/test_client_cpppo || st=1; \
	$(INTEROP_RUN) $(INTEROP_PY) tests/interop/pyrun.py $(RESULTS) \
	    "interop tshark decodes client <-> drsim" tests/interop/test_tshark.py || st=1; \
	exit $$st

INTEROP_ASAN_B := $(B)/asan
INTEROP_ASAN_ENV = PYTHONDONTWRITEBYTECODE=1 DRGATE_BUILD=$(abspath $(INTEROP_ASAN_B)) \
                   DRSIM=$(abspath $(INTEROP_ASAN_B))/drsim timeout -k 10 $(INTEROP_TIMEOUT)

check-interop-asan:
	@if [ ! -x "$(INTEROP_PY)" ]; then \
	    echo "check-interop-asan: no $(INTEROP_PY) (run make deps)"; \
	    echo "0 1 interop asan (no Python peers: make deps)" >> $(RESULTS); exit 1; fi
	$(MAKE) --no-print-directory B=$(INTEROP_ASAN_B) CFLAGS="$(SAN_FLAGS)" \
	    LDFLAGS="-fsanitize=address,undefined" HARDEN= \
	    $(INTEROP_ASAN_B)/drsim $(INTEROP_ASAN_B)/tests/interop/test_client_cpppo
	@st=0; \
	$(INTEROP_ASAN_ENV) $(INTEROP_PY) tests/interop/pyrun.py $(RESULTS) \
	    "interop pycomm3 -> drsim [asan]" tests/interop/test_pycomm3.py || st=1; \
	$(INTEROP_ASAN_ENV) $(INTEROP_PY) tests/interop/pyrun.py $(RESULTS) \
	    "interop ethernetip -> drsim (Class 1) [asan]" tests/interop/test_ethernetip.py || st=1; \
	$(INTEROP_ASAN_ENV) $(INTEROP_PY) tests/interop/with_cpppo.py $(RESULTS) \
	    "interop client -> cpppo [asan]" -- \
	    sh tests/run-tests.sh $(RESULTS) "env ASAN_OPTIONS=abort_on_error=0" \
	    $(INTEROP_ASAN_B)/tests/interop/test_client_cpppo || st=1; \
	exit $$st
