/* SPDX-License-Identifier: MIT */
/* drcli's error messages (error.h). */
#include <stdarg.h>
#include <stdio.h>

#include "error.h"

int cli_error(int code, const char *cmd, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "drcli%s%s: ", cmd != NULL ? " " : "", cmd != NULL ? cmd : "");
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return code;
}
