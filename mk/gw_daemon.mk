# SPDX-License-Identifier: MIT
# drgatewayd: the Modbus TCP / GPIO gateway daemon (gateway/). Named so it
# is included after gpio.mk and gw_config.mk, whose variables it uses.
# The GPIO backend comes from mk/gpio.mk ($(GPIO_A)), the configuration
# loader's flags from mk/gw_config.mk.

MODBUS_CFLAGS  := $(call pc,--cflags,libmodbus)
MODBUS_LIBS    := $(or $(call pc,--libs,libmodbus),-lmodbus)
SYSTEMD_CFLAGS := $(call pc,--cflags,libsystemd)
SYSTEMD_LIBS   := $(or $(call pc,--libs,libsystemd),-lsystemd)

GW_SRC  := $(filter-out $(GPIO_ALL_SRC),$(sort $(wildcard gateway/*.c)))
GW_HDR  := $(filter-out $(GPIO_HDR),$(wildcard gateway/*.h))
GW_LIB_SRC := $(filter-out gateway/main.c,$(GW_SRC))
GW_LIB_OBJ := $(GW_LIB_SRC:%.c=$(B)/%.o)
GW_A    := $(B)/gateway/libgw.a
GW_BIN  := $(B)/drgatewayd
GW_DEP_LIBS := $(GW_A) $(GPIO_A) $(LIB_A) $(MODBUS_LIBS) $(INIH_LIBS) $(GPIO_LIBS) \
               $(SYSTEMD_LIBS) -lm
BINS    += $(GW_BIN)
# `all` was read before this fragment: name the daemon as its prerequisite.
all: $(GW_BIN)

$(GW_LIB_OBJ): $(B)/gateway/%.o: gateway/%.c $(GW_HDR) $(GPIO_HDR) $(LIB_HDR)
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CPPFLAGS) -Igateway $(MODBUS_CFLAGS) $(INIH_CFLAGS) $(SYSTEMD_CFLAGS) \
	    $(ALL_CFLAGS) -fPIE -c $< -o $@

$(GW_A): $(GW_LIB_OBJ) $(COMMON_OBJ)
	rm -f $@
	$(AR) rcs $@ $^

$(GW_BIN): gateway/main.c $(GW_A) $(GPIO_A) $(LIB_A) $(GW_HDR) $(LIB_HDR)
	$(CC) $(ALL_CPPFLAGS) -Igateway -DDRGATE_VERSION='"$(VERSION)"' $(SYSTEMD_CFLAGS) \
	    $(ALL_CFLAGS) -fPIE -pie $(ALL_LDFLAGS) -o $@ gateway/main.c $(GW_DEP_LIBS)

# The register map in the docs is printed by the daemon from the field table.
.PHONY: check-regmap-docs
check-regmap-docs: $(GW_BIN)
	@sh mk/gen-regmap-doc.sh --check $(GW_BIN) "$(RESULTS)"

# So are the key tables of docs/configuration.md, from the sections' tables.
.PHONY: check-config-docs
check-config-docs: $(GW_BIN)
	@sh mk/gen-config-doc.sh --check $(GW_BIN) "$(RESULTS)"

# ---- install -----------------------------------------------------------------
# The daemon itself is in $(BINS) (the Makefile's install); these add the
# systemd unit (ExecStart= pointed at $(BINDIR)), the example
# configurations and the manual page.
.PHONY: install-gateway uninstall-gateway
install: install-gateway
uninstall: uninstall-gateway

GW_EXAMPLES := $(wildcard gateway/examples/*.ini)

install-gateway: $(GW_BIN)
	install -d $(DESTDIR)$(UNITDIR) $(DESTDIR)$(DATADIR)/examples $(DESTDIR)$(MANDIR)/man8
	sed -e 's|/usr/local/bin/drgatewayd|$(BINDIR)/drgatewayd|' gateway/drgatewayd.service \
	    > $(DESTDIR)$(UNITDIR)/drgatewayd.service
	chmod 644 $(DESTDIR)$(UNITDIR)/drgatewayd.service
	install -m 644 $(GW_EXAMPLES) $(DESTDIR)$(DATADIR)/examples/
	install -m 644 man/drgatewayd.8 $(DESTDIR)$(MANDIR)/man8/

uninstall-gateway:
	rm -f $(DESTDIR)$(UNITDIR)/drgatewayd.service $(DESTDIR)$(MANDIR)/man8/drgatewayd.8
	rm -f $(addprefix $(DESTDIR)$(DATADIR)/examples/,$(notdir $(GW_EXAMPLES)))
	-rmdir $(DESTDIR)$(DATADIR)/examples $(DESTDIR)$(DATADIR) 2>/dev/null
