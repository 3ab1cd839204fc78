# SPDX-License-Identifier: MIT
# drgatewayd's configuration loader (gateway/config*.c: the generic parser,
# the libinih reader, the checks across sections and each side's key table;
# gateway/config_internal.h) and its tests.
#
# INIH_CFLAGS / INIH_LIBS are for every program that links the loader.
# The fallback -linih covers builds where pkg-config is off (check-be runs
# with PKG_CONFIG=true and needs Debian's libinih-dev:s390x).

INIH_CFLAGS    := $(call pc,--cflags,inih)
INIH_LIBS      := $(or $(call pc,--libs,inih),-linih)
GW_CONFIG_SRC  := $(sort $(wildcard gateway/config*.c))
GW_CONFIG_HDR  := gateway/config.h gateway/config_internal.h
GW_CONFIG_TEST := $(B)/tests/test_gw_config

# An explicit rule, so it wins over the generic $(B)/tests/% rule: that one
# would also claim this file (it matches tests/test_*.c, so check-unit,
# check-be and check-asan build and run it too) but links neither the
# loader nor libinih. GW_TEST_TOP lets the test find its fixtures and the
# examples wherever it is run from (they are read at run time, so they are
# not prerequisites).
$(GW_CONFIG_TEST): tests/test_gw_config.c $(GW_CONFIG_SRC) $(GW_CONFIG_HDR) \
                   $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Igateway -Itests -DGW_TEST_TOP='"$(CURDIR)"' \
	    $(INIH_CFLAGS) $(CMOCKA_CFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(GW_CONFIG_SRC) $(LIB_A) \
	    $(INIH_LIBS) $(CMOCKA_LIBS) -lm

.PHONY: check-gw-config
check-gw-config: $(GW_CONFIG_TEST)
	@sh tests/run-tests.sh "$(RESULTS)" "$(TEST_RUNNER)" $(GW_CONFIG_TEST)
