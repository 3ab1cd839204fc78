# SPDX-License-Identifier: MIT
# The register map's unit test (tests/test_gw_regmap.c) links
# gateway/regmap.c (and robot.c, for the last_error table). An explicit rule, so it wins over the generic
# $(B)/tests/% rule, which also makes check-unit, check-be (big-endian,
# under qemu) and check-asan build and run it.

$(B)/tests/test_gw_regmap: tests/test_gw_regmap.c gateway/regmap.c gateway/robot.c gateway/regmap.h gateway/robot.h \
                           gateway/config.h $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Igateway -Itests $(CMOCKA_CFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< gateway/regmap.c gateway/robot.c $(LIB_A) $(CMOCKA_LIBS) -lm

# gw_robot_t's unit test (tests/test_gw_robot.c) links gateway/robot.c, the
# same way. The robot knows nothing of Modbus: mk/gw-boundary.sh checks it
# (make check-gw-boundary, also run by check-gateway).
$(B)/tests/test_gw_robot: tests/test_gw_robot.c gateway/robot.c gateway/robot.h \
                          gateway/config.h $(LIB_A) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Igateway -Itests $(CMOCKA_CFLAGS) $(ALL_CFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< gateway/robot.c $(LIB_A) $(CMOCKA_LIBS) -lm
