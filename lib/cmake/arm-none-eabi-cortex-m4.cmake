# SPDX-License-Identifier: MIT
# CMake toolchain file: Cortex-M4, bare metal, arm-none-eabi-gcc with newlib
# (Debian gcc-arm-none-eabi, libnewlib-arm-none-eabi; Arm GNU Toolchain
# likewise). The same target as make check-cm4 / check-firmware
# (mk/cross-cm4.sh): -mcpu=cortex-m4 -mthumb, soft-float calling
# convention; for a Cortex-M4F with hardware floats add
# -mfloat-abi=hard -mfpu=fpv4-sp-d16 to CMAKE_C_FLAGS (both the library
# and your code). DRGATE_POSIX is OFF here (no sockets in newlib).
#
#   cmake -S examples/firmware-cm4 -B build-cm4 -DCMAKE_BUILD_TYPE=MinSizeRel \
#         -DCMAKE_TOOLCHAIN_FILE=lib/cmake/arm-none-eabi-cortex-m4.cmake
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

set(DRGATE_CM4_PREFIX "arm-none-eabi-" CACHE STRING "cross tool prefix")
set(CMAKE_C_COMPILER "${DRGATE_CM4_PREFIX}gcc")
set(CMAKE_ASM_COMPILER "${DRGATE_CM4_PREFIX}gcc")

# Each function and object in a section of its own, so that the link
# (--gc-sections) keeps only what the image calls.
set(CMAKE_C_FLAGS_INIT "-mcpu=cortex-m4 -mthumb -ffunction-sections -fdata-sections")
# newlib's own headers first, as mk/cross-cm4.sh does: Debian's toolchain
# otherwise finds GCC's freestanding <stdint.h>, and newlib's <inttypes.h>
# then has no 64-bit PRI macros (lib/text.c uses PRIu64).
execute_process(COMMAND "${CMAKE_C_COMPILER}" -print-file-name=libc.a
                OUTPUT_VARIABLE _dr_libc OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
if(_dr_libc AND IS_ABSOLUTE "${_dr_libc}")
    get_filename_component(_dr_newlib "${_dr_libc}" DIRECTORY)
    get_filename_component(_dr_newlib "${_dr_newlib}/../include" ABSOLUTE)
    if(EXISTS "${_dr_newlib}/inttypes.h")
        string(APPEND CMAKE_C_FLAGS_INIT " -isystem ${_dr_newlib}")
    endif()
endif()
set(CMAKE_ASM_FLAGS_INIT "-mcpu=cortex-m4 -mthumb")
# newlib-nano's C library and stubs for the system calls nothing should
# reach (the library calls none; make check-cmake checks the image).
set(CMAKE_EXE_LINKER_FLAGS_INIT "--specs=nano.specs --specs=nosys.specs")

# No program can run on the build machine: try_compile builds archives.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
