# SPDX-License-Identifier: MIT
# Sourced by mk/cross-cm4.sh and mk/check-cmake.sh: what a Cortex-M4 build
# of the library may leave undefined. <string.h> and libgcc's
# soft-float/long helpers, and what CM4_ALLOW adds (check-firmware: the
# text conversions of lib/text.c); anything else (socket, timerfd_*,
# epoll_*, clock_gettime, malloc, dr_transport_posix, ...) is refused.
# CROSS: the tool prefix (arm-none-eabi-).

# cm4_disallowed DIR FILE...: the symbols the objects or archives FILE...
# leave undefined, that none of them defines and that are not allowed,
# one a line (none: empty); DIR holds the lists (undef, defined).
cm4_disallowed() {
    _dir=$1; shift
    _allowed="^(memcpy|memset|memmove|memcmp|strlen|strcmp|strncmp|__aeabi_[a-z0-9_]+${CM4_ALLOW:+|$CM4_ALLOW})\$"
    "${CROSS}nm" -u "$@" | awk 'NF == 2 && $1 == "U" { print $2 }' | sort -u >"$_dir/undef"
    "${CROSS}nm" --defined-only "$@" | awk 'NF == 3 { print $3 }' | sort -u >"$_dir/defined"
    comm -23 "$_dir/undef" "$_dir/defined" | grep -Ev "$_allowed" || true
}
