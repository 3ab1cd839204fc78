#!/bin/sh
# SPDX-License-Identifier: MIT
# Check that built ELF files carry the Makefile's hardening (docs/quality.md):
#   programs:   ELF type DYN with the PIE flag (DF_1_PIE), a GNU_RELRO
#               segment, BIND_NOW (full RELRO), __stack_chk_fail (stack
#               protector) and, if it calls a libc function that has a
#               checked variant, at least one __*_chk call (_FORTIFY_SOURCE)
#   --lib FILE: a shared library: DYN, GNU_RELRO, BIND_NOW, __stack_chk_fail
# One "passed failed label" line per file goes to RESULTS; a missing
# property is named on stdout and in the label.
# usage: check-hardening.sh RESULTS [--lib] FILE... [--lib FILE ...]
set -u
results=$1; shift
READELF=${READELF:-readelf}
mkdir -p "$(dirname "$results")"
# libc functions that have a __*_chk variant under _FORTIFY_SOURCE=2.
FORTIFIABLE='printf|fprintf|sprintf|snprintf|vprintf|vfprintf|vsprintf|vsnprintf'
FORTIFIABLE="$FORTIFIABLE|memcpy|memmove|memset|mempcpy|strcpy|stpcpy|strncpy"
FORTIFIABLE="$FORTIFIABLE|strcat|strncat|read|pread|recv|recvfrom|fgets|fread"
FORTIFIABLE="$FORTIFIABLE|poll|ppoll|realpath|getcwd|readlink|gethostname"
ALWAYS_CHK='printf|fprintf|vprintf|vfprintf|dprintf|vdprintf'
status=0
lib=0
for f in "$@"; do
    if [ "$f" = --lib ]; then lib=1; continue; fi
    missing=""
    if [ ! -f "$f" ]; then
        missing=" not-built"
    else
        hdr=$($READELF -h "$f" 2>/dev/null)
        dyn=$($READELF -d "$f" 2>/dev/null)
        phdr=$($READELF -lW "$f" 2>/dev/null)
        syms=$($READELF --dyn-syms -W "$f" 2>/dev/null)
        printf '%s\n' "$hdr" | grep -q 'Type:[[:space:]]*DYN' || missing="$missing DYN"
        if [ $lib = 0 ]; then
            printf '%s\n' "$dyn" | grep -q 'FLAGS_1.*PIE' || missing="$missing PIE-flag"
        fi
        printf '%s\n' "$phdr" | grep -q 'GNU_RELRO' || missing="$missing GNU_RELRO"
        printf '%s\n' "$dyn" | grep -Eq '\(FLAGS\).*BIND_NOW|FLAGS_1.* NOW' ||
            missing="$missing BIND_NOW"
        printf '%s\n' "$syms" | grep -q '__stack_chk_fail' ||
            missing="$missing __stack_chk_fail"
        # FORTIFY where it applies: a program that calls a libc function
        # with a checked variant must call at least one checked variant
        # (the compiler keeps a plain call where the size is unknown or the
        # call is proven safe), and no plain printf-family call (fortified,
        # those always become __*printf_chk).
        if [ $lib = 0 ] &&
           printf '%s\n' "$syms" | grep -Eq " ($FORTIFIABLE)(@|\$)"; then
            printf '%s\n' "$syms" | grep -Eq ' __[a-z0-9_]+_chk(@|$)' ||
                missing="$missing __*_chk(FORTIFY)"
            printf '%s\n' "$syms" | grep -Eq " ($ALWAYS_CHK)(@|\$)" &&
                missing="$missing plain-printf(FORTIFY)"
        fi
    fi
    name=$(basename "$f")
    if [ -z "$missing" ]; then
        echo "hardening: $name ok"
        echo "1 0 hardening: $name" >> "$results"
    else
        echo "hardening: $name MISSING:$missing"
        echo "0 1 hardening: $name (missing:$missing)" >> "$results"
        status=1
    fi
    lib=0
done
exit $status
