# SPDX-License-Identifier: MIT
# The register map's unit test (tests/test_gw_regmap.c) links
# gateway/regmap.c. An explicit rule, so it wins over the generic
# $(B)/tests/% rule, which also makes check-unit, check-be (big-endian,
# under qemu) and check-asan build and run it.

$(B)/tests/test_gw_regmap: tests/test_gw_regmap.c gateway/regmap.c gateway/regmap.h \
                           gateway/config.h $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Igateway -Itests $(CMOCKA_CFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< gateway/regmap.c $(LIB_A) $(CMOCKA_LIBS) -lm
