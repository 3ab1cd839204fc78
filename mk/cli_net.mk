# SPDX-License-Identifier: MIT
# drcli's network commands end to end (tests/cli/test_cli_net.sh): golden
# transcripts of get, dump, set, watch, identity and probe against drsim
# (started by the script on 127.0.0.2) and against cpppo's EtherNet/IP
# server (127.0.0.4, from .venv: `make test-deps`), every error path with its
# exit status. Run plain, then again with drcli and drsim built under
# ASan+UBSan in their own build directory (the Makefile's SAN_FLAGS, as
# check-asan uses).
#
#   check-cli-net      both runs; results go to $(RESULTS)
#   cli-net-golden     rewrite tests/cli/golden-net/ (review with git diff)

CHECK_STEPS += check-cli-net

CLI_NET_PYTHON ?= .venv/bin/python

.PHONY: check-cli-net cli-net-golden

check-cli-net: $(CLI_BIN) $(SIM_BIN)
	@sh tests/cli/test_cli_net.sh $(CLI_BIN) $(SIM_BIN) "$(RESULTS)" \
	    "drcli-net $(CLI_BIN)" "$(CLI_NET_PYTHON)"
	@if [ -z "$(CLI_NET_NO_ASAN)" ]; then \
	    $(MAKE) --no-print-directory B=$(B)/asan CFLAGS="$(SAN_FLAGS)" \
	        LDFLAGS="-fsanitize=address,undefined" HARDEN= CLI_NET_NO_ASAN=1 \
	        RESULTS=$(abspath $(RESULTS)) check-cli-net; fi

cli-net-golden: $(CLI_BIN) $(SIM_BIN)
	@sh tests/cli/test_cli_net.sh --update $(CLI_BIN) $(SIM_BIN) "$(CLI_NET_PYTHON)"
