/* SPDX-License-Identifier: MIT */
/* drsim logging: one line per event to stderr, only with -v. */
#ifndef DRSIM_LOG_H
#define DRSIM_LOG_H

/* 0 quiet (errors only), 1 events, 2 every request and packet. */
extern int drsim_verbose;

#if defined(__GNUC__)
#define DRSIM_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define DRSIM_PRINTF(a, b)
#endif

/* Print "drsim: <message>\n" to stderr when drsim_verbose >= level. */
void drsim_log(int level, const char *fmt, ...) DRSIM_PRINTF(2, 3);

#endif /* DRSIM_LOG_H */
