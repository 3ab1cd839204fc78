/* SPDX-License-Identifier: MIT */
/* drsim logging: stderr, one line per call, prefixed so logs of several
 * processes (drsim and a client in `make demo`) stay readable. */
#include <stdarg.h>
#include <stdio.h>

#include "log.h"

int drsim_verbose;

void drsim_log(int level, const char *fmt, ...)
{
    if (drsim_verbose < level)
        return;
    char line[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    /* One fputs per line: lines from concurrent writers do not interleave. */
    fprintf(stderr, "drsim: %s\n", line);
}
