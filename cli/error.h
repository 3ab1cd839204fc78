/* SPDX-License-Identifier: MIT */
/*
 * drcli's exit codes and its one way of saying what went wrong. Every
 * other part of drcli reports through cli_error; this header includes
 * nothing of drcli's.
 */
#ifndef DRCLI_ERROR_H
#define DRCLI_ERROR_H

/* Exit codes, the same for every command (documented in drcli(1)). */
enum {
    CLI_EXIT_OK = 0,      /* success */
    CLI_EXIT_FAIL = 1,    /* anything else: writing output failed, no memory */
    CLI_EXIT_USAGE = 2,   /* bad command line or bad input data */
    CLI_EXIT_NETWORK = 3, /* network error or timeout (network commands) */
    CLI_EXIT_CIP = 4      /* the device answered with a CIP error */
};

/* "drcli CMD: message" on stderr ("drcli: message" if cmd is NULL);
 * always returns `code` for `return cli_error(...)`. */
int cli_error(int code, const char *cmd, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

#endif /* DRCLI_ERROR_H */
