/* SPDX-License-Identifier: MIT */
/*
 * Reading the configuration file through libinih (config_internal.h).
 *
 * Debian bookworm's libinih (r55) is built without INI_HANDLER_LINENO and
 * without INI_CALL_HANDLER_ON_NEW_SECTION, so by itself it tells the handler
 * neither the line number nor that a section began. We parse through
 * ini_parse_stream() with our own line reader instead:
 *  - the reader counts lines; libinih calls the handler for a line before
 *    it reads the next one, so the count is the handler's line number;
 *  - when a line starts with '[', the reader asks libinih itself for the
 *    section name (ini_parse_string on that one line), so sections are
 *    seen when they start, even empty ones ("[robot arm2]" with no keys
 *    must not vanish), and a repeated "[modbus]" is told apart;
 *  - it refuses what r55 would otherwise do silently: an indented line
 *    continues the previous value (Python configparser style), so
 *    "  port = 502" would end up inside the key above it; and a line longer
 *    than libinih's buffer is split, its tail read as a line of its own.
 */
#include "core/config_internal.h"

#include <errno.h>
#include <string.h>

#include <ini.h>

/* libinih's own reading of a section line: the only handler call of
 * "<line>\n_=_\n" carries the section name exactly as the real parse will
 * report it (its whitespace, comments and length rules included). */
typedef struct {
    char name[64];
    bool seen;
} probe_t;

static int probe_handler(void *user, const char *section, const char *name,
                         const char *value)
{
    probe_t *p = user;
    (void)name;
    (void)value;
    snprintf(p->name, sizeof p->name, "%s", section);
    p->seen = true;
    return 1;
}

static void section_line(gw_cfg_ctx_t *c, const char *line)
{
    char text[300];
    size_t n = strcspn(line, "\n");
    probe_t p = { "", false };
    if (n + sizeof "\n_=_\n" <= sizeof text) {
        memcpy(text, line, n);
        memcpy(text + n, "\n_=_\n", sizeof "\n_=_\n");
        if (ini_parse_string(text, probe_handler, &p) != 0)
            p.seen = false;
    }
    if (!p.seen) {
        /* libinih refuses this line; its error (reported at the end) is
         * the one to show, so the current section stays as it is. */
        c->bad_header_line = c->lineno;
        return;
    }
    gw_cfg_begin_section(c, p.name);
}

/* ini_reader: one whole line into str[num], '\n'-terminated; counts lines
 * and looks at each before libinih parses it (see the top of the file). */
static char *read_line(char *str, int num, void *stream)
{
    gw_cfg_ctx_t *c = stream;
    if (num < 3)
        return NULL;
    size_t cap = (size_t)num - 2; /* room for '\n' and NUL */
    size_t len = 0;
    bool too_long = false, nul = false;
    int ch;
    while ((ch = getc(c->fp)) != EOF && ch != '\n') {
        if (ch == '\0')
            nul = true;
        if (len < cap)
            str[len++] = (char)ch;
        else
            too_long = true;
    }
    if (ch == EOF && len == 0)
        return NULL;
    str[len++] = '\n';
    str[len] = '\0';
    c->lineno++;
    if (c->err_line != 0)
        return str; /* the first error stands; libinih just runs out */
    if (nul) {
        gw_cfg_fail(c, c->lineno, "NUL byte in line (allowed: a text file)");
        return str;
    }
    if (too_long) {
        gw_cfg_fail(c, c->lineno, "line too long (at most %zu characters)",
                    cap);
        return str;
    }
    const char *p = str;
    if (c->lineno == 1 && strncmp(p, "\xEF\xBB\xBF", 3) == 0)
        p += 3; /* UTF-8 BOM, which libinih skips too */
    const char *q = p;
    while (gw_cfg_is_space(*q))
        q++;
    if (*q == '\0' || *q == ';' || *q == '#')
        return str; /* blank or comment: libinih's start-of-line prefixes */
    if (q != p) {
        gw_cfg_fail(c, c->lineno,
                    "line starts with whitespace (INI reads an indented line "
                    "as the continuation of the previous value; start keys "
                    "and sections in column 1)");
        return str;
    }
    if (*q == '[')
        section_line(c, q);
    return str;
}

static int on_key(void *user, const char *section, const char *name,
                  const char *value)
{
    gw_cfg_ctx_t *c = user;
    if (c->err_line != 0)
        return 0;
    if (strcmp(section, c->sec_raw) != 0) {
        /* The reader and libinih disagree on the section: a bug here. */
        gw_cfg_fail(c, c->lineno, "internal error: section [%s] not tracked",
                    section);
        return 0;
    }
    gw_cfg_key(c, name, value);
    return c->err_line == 0;
}

void gw_cfg_file_error(char *err, size_t errlen, const char *path,
                       const char *what, const char *detail)
{
    if (err != NULL && errlen > 0)
        snprintf(err, errlen, "%s: %s%s%s", path, what, detail ? ": " : "",
                 detail ? detail : "");
}

bool gw_cfg_ini_read(gw_cfg_ctx_t *c, char *err, size_t errlen)
{
    c->fp = fopen(c->path, "r");
    if (c->fp == NULL) {
        gw_cfg_file_error(err, errlen, c->path, "cannot open",
                          strerror(errno));
        return false;
    }
    int ret = ini_parse_stream(read_line, c, on_key, c);
    int read_errno = errno;
    bool read_error = ferror(c->fp) != 0;
    (void)fclose(c->fp); /* read only */
    c->fp = NULL;

    if (read_error) {
        gw_cfg_file_error(err, errlen, c->path, "cannot read",
                          strerror(read_errno));
        return false;
    }
    if (ret < 0) {
        gw_cfg_file_error(err, errlen, c->path, "libinih failed",
                          ret == -2 ? "out of memory" : NULL);
        return false;
    }
    if (ret > 0 && (c->err_line == 0 || (unsigned)ret < c->err_line)) {
        /* A line libinih refused without calling us, before any error of
         * ours. */
        c->err_line = 0;
        if ((unsigned)ret == c->bad_header_line)
            gw_cfg_fail(c, (unsigned)ret,
                        "section header without a closing ']' (allowed: %s)",
                        gw_config_sections());
        else
            gw_cfg_fail(c, (unsigned)ret,
                        "syntax error (allowed: [section], key = value, or a "
                        "comment starting with ; or #)");
    }
    return true;
}
