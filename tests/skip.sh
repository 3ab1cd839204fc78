#!/bin/sh
# SPDX-License-Identifier: MIT
# The SKIPPED banner of a check that cannot run on this machine (no qemu,
# not root, a package missing), one look for all of them.
#
# In a script:   . "$(dirname "$0")/../skip.sh"   (the path to this file)
#                skip_name=check-lwip             (what is skipped)
#                skip_results=FILE skip_label=L   (optional: see CI below)
#                skip_status=77                   (optional, default 0)
#                ...
#                skip "not root"                  (ends the script)
# From make:     sh tests/skip.sh NAME REASON [RESULTS LABEL]
#
# Under CI (CI set) a skip with a label is a failure, since CI machines
# are set up to run every check: "0 1 LABEL (skipped in CI: REASON)" goes
# to the results file (when there is one) and the exit status is 1.

skip_banner() { # NAME REASON
    echo "###################################################################"
    echo "### $1 SKIPPED: $2"
    echo "###################################################################"
}

skip() { # REASON...
    skip_banner "${skip_name:?skip_name not set}" "$*"
    if [ -n "${CI:-}" ] && [ -n "${skip_label:-}" ]; then
        if [ -n "${skip_results:-}" ]; then
            mkdir -p "$(dirname "$skip_results")"
            echo "0 1 $skip_label (skipped in CI: $*)" >>"$skip_results"
        fi
        exit 1
    fi
    exit "${skip_status:-0}"
}

# Run rather than sourced: $0 is this file.
if [ "${0##*/}" = skip.sh ]; then
    [ $# -ge 2 ] || { echo "usage: skip.sh NAME REASON [RESULTS LABEL]" >&2; exit 2; }
    skip_name=$1 skip_results=${3:-} skip_label=${4:-}
    skip "$2"
fi
