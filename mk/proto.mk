# SPDX-License-Identifier: MIT
# Sparkplug B's protobuf (gateway/mqtt/sparkplug_b.proto and its nanopb
# options): the generated sparkplug_b.pb.[ch] are committed, since the
# generator (Debian's `nanopb`, a test dependency) is not needed to build.
#   make proto        writes them again
#   make check-proto  checks that the generator makes exactly the committed
#                     files of the .proto and .options (in make check)

PROTO_DIR  := gateway/mqtt
PROTO_GEN  ?= nanopb_generator.py
PROTO_SRC  := $(PROTO_DIR)/sparkplug_b.proto $(PROTO_DIR)/sparkplug_b.options

CHECK_STEPS += check-proto
.PHONY: proto check-proto

proto: $(PROTO_SRC)
	cd $(PROTO_DIR) && $(PROTO_GEN) -q -D . -f sparkplug_b.options sparkplug_b.proto

check-proto: $(PROTO_SRC)
	@if ! command -v $(PROTO_GEN) >/dev/null 2>&1; then \
	    sh tests/skip.sh check-proto "no $(PROTO_GEN) (Debian package nanopb: make test-deps)" \
	        "$(RESULTS)" "sparkplug_b.pb.[ch] as generated"; exit $$?; fi
	@rm -rf $(B)/proto && mkdir -p $(B)/proto
	@cd $(PROTO_DIR) && $(PROTO_GEN) -q -D $(abspath $(B))/proto -f sparkplug_b.options \
	    sparkplug_b.proto
	@if cmp -s $(B)/proto/sparkplug_b.pb.c $(PROTO_DIR)/sparkplug_b.pb.c && \
	    cmp -s $(B)/proto/sparkplug_b.pb.h $(PROTO_DIR)/sparkplug_b.pb.h; then \
	    echo "check-proto: sparkplug_b.pb.[ch] are what the generator makes"; \
	    echo "1 0 sparkplug_b.pb.[ch] as generated" >> $(RESULTS); \
	else \
	    diff -u $(PROTO_DIR)/sparkplug_b.pb.h $(B)/proto/sparkplug_b.pb.h; \
	    diff -u $(PROTO_DIR)/sparkplug_b.pb.c $(B)/proto/sparkplug_b.pb.c; \
	    echo "check-proto: the committed files differ from the generator's: make proto" >&2; \
	    echo "0 1 sparkplug_b.pb.[ch] as generated" >> $(RESULTS); exit 1; fi
