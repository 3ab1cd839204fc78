# SPDX-License-Identifier: MIT
# The EtherNet/IP client as a firmware component (docs/firmware.md):
#   check-firmware   (in the Makefile) every lib/ source but the POSIX ones
#                    builds for a Cortex-M4 with no OS symbol; size guard
#   check-lwip       the client on Debian's lwIP (user-space port) through
#                    port/lwip, against drsim across a TAP device in a
#                    network namespace; SKIPPED without root or /dev/net/tun
#   check-be-client  the client on s390x (qemu-user) against a native drsim
CHECK_STEPS += check-lwip check-be-client

FW_TEST_SRC := tests/firmware/drive.c
FW_TEST_OBJ := $(FW_TEST_SRC:%.c=$(B)/%.o)
LWIP_PORT_SRC := $(wildcard port/lwip/*.c)
LWIP_PORT_OBJ := $(LWIP_PORT_SRC:%.c=$(B)/%.o)
# Debian's liblwip-dev: headers under /usr/include/lwip, its lwipopts.h.
LWIP_INC    ?= /usr/include/lwip
LWIP_LIBS   ?= -llwip
LWIP_SECONDS ?= 5
# The lwIP program links only the firmware objects of the library: no
# POSIX transport, no malloc'ing constructors. The port includes the socket
# code it shares with the POSIX transport from lib/ (transport_bsd.h).
LIB_FW_OBJ  := $(LIB_FW_SRC:%.c=$(B)/%.o)

.PHONY: check-lwip check-be-client

LWIP_CFLAGS  = $(ALL_CPPFLAGS) $(PRIV_CPPFLAGS) -D_DEFAULT_SOURCE -I$(LWIP_INC) -Iport/lwip -Itests/firmware \
               $(ALL_CFLAGS)

$(FW_TEST_OBJ): $(B)/%.o: %.c $(B)/%.d
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Itests/firmware $(ALL_CFLAGS) $(DEPFLAGS) -c $< -o $@

$(LWIP_PORT_OBJ): $(B)/%.o: %.c $(B)/%.d
	@mkdir -p $(dir $@)
	$(CC) $(LWIP_CFLAGS) $(DEPFLAGS) -c $< -o $@

$(B)/tests/firmware/test_lwip: tests/firmware/test_lwip.c $(B)/tests/firmware/test_lwip.d $(FW_TEST_OBJ) $(LWIP_PORT_OBJ) \
        $(LIB_FW_OBJ)
	@mkdir -p $(dir $@)
	$(CC) $(LWIP_CFLAGS) $(DEPFLAGS) $(ALL_LDFLAGS) -o $@ $< $(FW_TEST_OBJ) \
	    $(LWIP_PORT_OBJ) $(LIB_FW_OBJ) $(LWIP_LIBS) -lm

check-lwip: $(SIM_BIN)
	@if [ ! -f $(LWIP_INC)/lwip/sockets.h ]; then \
	    sh tests/skip.sh check-lwip "no lwIP headers in $(LWIP_INC) (make deps)" \
	        "$(RESULTS)" lwip; \
	else \
	    $(MAKE) --no-print-directory $(B)/tests/firmware/test_lwip && \
	    sh tests/firmware/lwip.sh $(B)/tests/firmware/test_lwip $(SIM_BIN) \
	        "$(RESULTS)" $(LWIP_SECONDS); \
	fi

$(B)/tests/firmware/test_be_client: tests/firmware/test_be_client.c \
        $(B)/tests/firmware/test_be_client.d $(FW_TEST_OBJ) $(LIB_A)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Itests/firmware $(ALL_CFLAGS) $(DEPFLAGS) $(ALL_LDFLAGS) \
	    -o $@ $< $(FW_TEST_OBJ) $(LIB_A) -lm

check-be-client: $(SIM_BIN)
	$(MAKE) --no-print-directory B=$(B)/s390x CROSS_COMPILE=s390x-linux-gnu- \
	    PKG_CONFIG=true HARDEN= $(B)/s390x/tests/firmware/test_be_client
	@sh tests/firmware/be-client.sh "qemu-s390x -L /" \
	    $(B)/s390x/tests/firmware/test_be_client $(SIM_BIN) "$(RESULTS)"
