# SPDX-License-Identifier: MIT
# drgate_read_bounds(CONFIG_H OUT): the compile-time bounds of
# drgate/config.h as NAME=DEFAULT items ("DR_CLIENT_MAX_CONNS=16", ...), so
# that the CMake package takes their names and defaults from the header
# rather than from a second list. Used by lib/CMakeLists.txt and by the
# installed drgateConfig.cmake.
function(drgate_read_bounds config_h out)
    file(STRINGS "${config_h}" lines REGEX "^#define DR_[A-Z0-9_]+ [0-9]+$")
    set(pairs "")
    foreach(line IN LISTS lines)
        string(REGEX REPLACE "^#define (DR_[A-Z0-9_]+) ([0-9]+)$" "\\1=\\2" pair "${line}")
        list(APPEND pairs "${pair}")
    endforeach()
    if(NOT pairs)
        message(FATAL_ERROR "drgate: no DR_* bound found in ${config_h}")
    endif()
    set(${out} "${pairs}" PARENT_SCOPE)
endfunction()
