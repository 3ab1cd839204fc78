/* SPDX-License-Identifier: MIT */
/*
 * Inside the configuration loader (private to gateway/config*.c).
 *
 * Every section is described by data, as lib/fields_internal.h describes
 * the assemblies: a gw_cfg_side_t per section (keyword, how many, where
 * its struct lives in gw_config_t, its keys, its checks) and a table of
 * gw_cfg_key_t, one line per key (name, type, where the value goes, range
 * or names, default, what is allowed, help). One generic parser
 * (config.c) reads every key through its line; the docs' key tables are
 * printed from the same lines (`drgatewayd --help-config SECTION`).
 *
 * Who owns what:
 *   config.c         the sections (the core's and, through the side list
 *                    gateway/sides.h, every side's), the generic key
 *                    parser, the did-you-mean, defaults, the public API,
 *                    [daemon]
 *   config_ini.c     reading the file through libinih (its workarounds)
 *   config_check.c   the robots against each other, once the file is read
 *   config_robot.c   [robot NAME] (core): table, instance.* and open.*,
 *                    and the sides' keys of it merged into the table
 *   NAME/config_NAME.c  each side's sections, keys and whole-file checks:
 *                    modbus/ [modbus] and [modbus_rtu NAME] (and its keys
 *                    of [robot NAME]: gw_cfg_robot_keys_t), gpio/ [gpio
 *                    NAME], mqtt/ [mqtt], http/ [http]
 *   config_doc.c     the docs' key tables, printed from the tables
 *
 * A new key is one line in its side's table. A new side's sections are
 * its gw_cfg_side_t's, listed in its gw_side_cfg_NAME (config_NAME.c,
 * config.h), which the side list brings here, and its keys of [robot
 * NAME] its gw_cfg_robot_keys_t (.robot): nothing in core/ changes.
 */
#ifndef DRGATE_GW_CONFIG_INTERNAL_H
#define DRGATE_GW_CONFIG_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#include "common/eds.h"
#include "core/config.h"

#include "core/log.h" /* GW_PRINTF */

#define GW_CFG_COUNT(a) (sizeof(a) / sizeof((a)[0]))

typedef struct gw_cfg_ctx gw_cfg_ctx_t;
typedef struct gw_cfg_key gw_cfg_key_t;
typedef struct gw_cfg_side gw_cfg_side_t;

/* What a value is, which says how it is parsed (unless the key has a
 * parse hook), stored, defaulted and documented. */
typedef enum {
    GW_CFG_HOOK = 0, /* only the parse hook knows (no generic store) */
    GW_CFG_BOOL,     /* yes | no, into a bool; def: 1 = yes */
    GW_CFG_UINT,     /* decimal lo..hi, into an unsigned of 1, 2 or 4 bytes */
    GW_CFG_ENUM,     /* one of names: its index into an enum, unsigned or
                        bool (1, 2 or 4 bytes); def: the index */
    GW_CFG_WORD,     /* one of names, copied as text; def_text */
    GW_CFG_TEXT,     /* text shorter than the field, accepted by `valid` */
    GW_CFG_IPV4,     /* an IPv4 address, copied as text */
    GW_CFG_HOST,     /* an IPv4 address or a DNS name, copied as text */
    GW_CFG_PREFIX    /* a family of keys "PREFIX<item>" (instance.io_state):
                        the parse hook does all, repeats included */
} gw_cfg_type_t;

enum {
    GW_CFG_REQUIRED = 1u << 0, /* "NAME has no KEY" when missing */
    GW_CFG_LIST = 1u << 1,     /* may be given more than once */
    GW_CFG_LINK = 1u << 2,     /* [robot]: a change reconnects the robot
                                  (gw_robot_config_same_link) */
};

typedef void gw_cfg_parse_fn(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                             const char *name, const char *v);

struct gw_cfg_key {
    const char *name;         /* PREFIX: "instance.<assembly>", as listed */
    gw_cfg_type_t type;
    unsigned flags;           /* GW_CFG_REQUIRED, ... */
    size_t off, size;         /* the value in the section's struct: GW_CFG_AT */
    unsigned long lo, hi;     /* UINT: the range */
    unsigned long def;        /* UINT: the value; BOOL: 1 = yes; ENUM: index */
    const char *const *names; /* ENUM, WORD: NULL-terminated (GW_CFG_NAMES) */
    const char *def_text;     /* WORD, TEXT, IPV4, HOST: the default */
    const char *allowed;      /* "(allowed: ...)" of messages and docs;
                                 NULL: from the range or the names */
    bool (*valid)(const char *v); /* TEXT: false refuses the value */
    const char *invalid;      /* TEXT: what a refused value is told is
                                 allowed (NULL: `allowed`) */
    gw_cfg_parse_fn *parse;   /* instead of the type's parser */
    const char *(*item)(unsigned i); /* PREFIX: the i-th item (NULL past
                                        the last), for did-you-mean */
    const char *doc_default;  /* docs: when not the plain default value */
    const char *doc_allowed;  /* docs: when not `allowed` */
    const char *help;         /* docs: what the key does (Markdown) */
    /* A side's key of [robot NAME] (gw_cfg_robot_keys_t): the core's key
     * it comes after in "allowed:" lists, did-you-mean and the docs (a
     * side's keys after one core key keep their table's order; NULL or
     * a name the core does not have: after the core's plain keys). */
    const char *after;
};

/* The value `m` of section struct T: .off and .size of a key. */
#define GW_CFG_AT(T, m) .off = offsetof(T, m), .size = sizeof(((T *)0)->m)
/* An ENUM's or WORD's names, in index order. */
#define GW_CFG_NAMES(...) .names = (const char *const[]){ __VA_ARGS__, NULL }
#define GW_CFG_NONE ((size_t)-1)
#define GW_CFG_MAX_KEYS 32 /* per side (what "allowed:" lists can hold) */
/* Sections of one side (gw_cfg_NAME_sections[]), and of the whole daemon:
 * the core's two and every listed side's. */
#define GW_CFG_SIDE_SECTIONS 4u
#define GW_CFG_MAX_SECTIONS (2u + GW_CFG_SIDE_SECTIONS * GW_SIDE_COUNT)

struct gw_cfg_side {
    const char *kw;           /* [kw], [kw NAME], [kw.NAME] */
    /* Where the section comes in "allowed:" lists, did-you-mean, the
     * docs and the checks once the file is read: lowest first ([daemon]
     * 10, [modbus] 20, [robot] 30, [gpio] 40, [modbus_rtu] 50, [mqtt] 60,
     * [http] 70; a new side's next, 80, ...). */
    unsigned rank;
    bool named;               /* one section per NAME (else one, no name) */
    unsigned max;             /* named: how many at most */
    const char *lone_name;    /* named: the name of a bare [kw] (NULL: a
                                 name is required) */
    size_t base, stride;      /* section i: (char *)cfg + base + i * stride */
    size_t count_off;         /* named: the unsigned count in gw_config_t */
    size_t name_off, line_off; /* in the section struct, or GW_CFG_NONE */
    const gw_cfg_key_t *keys;
    unsigned nkeys;
    size_t scratch;           /* bytes the hooks keep per section */
    void (*defaults)(void *sec); /* what the keys' defaults do not cover */
    void (*begin)(void *sec);    /* the section is in the file */
    void (*check)(gw_cfg_ctx_t *c); /* once the whole file is read */
};

/* The place in gw_config_t of a named side: array `arr` of T (members
 * name and line), counted by `count`. */
#define GW_CFG_NAMED(arr, count, T)                                           \
    .named = true, .max = sizeof(((gw_config_t *)0)->arr) / sizeof(T),         \
    .base = offsetof(gw_config_t, arr), .stride = sizeof(T),                  \
    .count_off = offsetof(gw_config_t, count), .name_off = offsetof(T, name), \
    .line_off = offsetof(T, line)
/* A side's key table. */
#define GW_CFG_KEYS(table) .keys = (table), .nkeys = GW_CFG_COUNT(table)

/* A side's keys of [robot NAME] (gw_side_cfg_t.robot). Their values are
 * in the side's member of the robot's struct: GW_CFG_AT(gw_robot_config_t,
 * side.NAME.m); a hook's `sec` is the robot's gw_robot_config_t. */
typedef struct gw_cfg_robot_keys {
    const gw_cfg_key_t *keys;
    unsigned nkeys;
    /* Robot i against robot j (j < i), once the whole file is read and
     * robot i's own keys are checked, before the core's address check;
     * false after the message. */
    bool (*pair)(gw_cfg_ctx_t *c, unsigned i, unsigned j);
} gw_cfg_robot_keys_t;

/* The core's sections. [robot NAME]'s key table is the core's keys with
 * the sides' merged in (gw_cfg_all_sections does it, once). */
extern const gw_cfg_side_t gw_cfg_daemon;
extern gw_cfg_side_t gw_cfg_robot;
void gw_cfg_robot_merge(void);

/* Every section, the core's and the sides', in rank order, into
 * out[GW_CFG_MAX_SECTIONS]; how many. */
unsigned gw_cfg_all_sections(const gw_cfg_side_t **out);

/* The parse state. */
struct gw_cfg_ctx {
    FILE *fp;
    const char *path;
    unsigned lineno; /* lines read so far = the line being parsed */
    gw_config_t cfg; /* the temporary */

    /* The section being read, as the reader saw it start. */
    const gw_cfg_side_t *side; /* NULL: none (or a refused header) */
    unsigned idx;              /* which one of its kind */
    void *sec;                 /* its struct in cfg */
    char sec_raw[64];          /* exactly as libinih reports it */
    char sec_text[64];         /* trimmed, for messages: "robot arm1" */

    /* Every section kind (gw_cfg_all_sections). */
    const gw_cfg_side_t *sides[GW_CFG_MAX_SECTIONS];
    unsigned nsides;

    /* Per section of every kind: where each key was set (0: not set),
     * the header's line, then the side's scratch. */
    unsigned char *record;
    size_t record_off[GW_CFG_MAX_SECTIONS], record_size[GW_CFG_MAX_SECTIONS];

    unsigned bad_header_line; /* a '[' line libinih will reject */
    unsigned err_line;        /* 0: no error yet; the first one wins */
    char err[1024];   /* the message, without FILE:LINE */
};

/* ---- config.c: for the sides' hooks and checks -------------------------- */

/* Record the first error: "message" at `line` (0: line 1). */
void gw_cfg_fail(gw_cfg_ctx_t *c, unsigned line, const char *fmt, ...)
    GW_PRINTF(3, 4);

/* Locale-independent character classes. */
bool gw_cfg_is_digit(char ch);
bool gw_cfg_is_alnum(char ch);
bool gw_cfg_is_space(char ch);
/* Section and robot names: letters, digits, '_', '-', < GW_NAME_MAX. */
bool gw_cfg_valid_name(const char *s);
/* No blank and no control character. */
bool gw_cfg_no_blank(const char *s);
/* An IPv4 address or a DNS name (a HOST key's check). */
bool gw_cfg_valid_host(const char *h);

/* Did-you-mean: feed candidates; `best` is the closest one close enough
 * to `typed` (a third of its length, at least 2 edits), "" if none. */
typedef struct {
    const char *typed;
    char best[64];
    unsigned dist;
} gw_cfg_guess_t;
#define GW_CFG_GUESS(typed) { (typed), "", ~0u }
void gw_cfg_guess(gw_cfg_guess_t *g, const char *cand);

/* "did you mean <open>best<close>? " into buf, or "" without a best. */
const char *gw_cfg_did_you_mean(const gw_cfg_guess_t *g, const char *open,
                                const char *close, char *buf, size_t size);

/* "a, b, c" into buf (cut if it does not fit; messages only). */
void gw_cfg_join(const char *const *names, size_t n, char *buf, size_t size);

/* A decimal number in lo..hi (digits only: "10ms" is refused, the unit is
 * part of the key's name); false after the message. */
bool gw_cfg_get_uint(gw_cfg_ctx_t *c, const char *key, const char *v,
                     unsigned long lo, unsigned long hi, unsigned long *out);
/* Copy into a fixed field; false after the message if too long. */
bool gw_cfg_copy(gw_cfg_ctx_t *c, const char *key, const char *v, char *dst,
                 size_t size);
/* One allow entry "a.b.c.d/len [ro|rw]" (v, at c->lineno) appended to
 * allow[*count], its line to lines[*count]; refused (with the message)
 * when it is malformed, has host bits set, is shadowed by an earlier one
 * or is one too many (GW_MAX_ALLOW). [modbus] and [http] share it. */
void gw_cfg_allow(gw_cfg_ctx_t *c, const char *v, gw_allow_t *allow, unsigned *count,
                  unsigned *lines);
/* Store x into key k's value in sec (a UINT's or ENUM's integer). */
void gw_cfg_store(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                  unsigned long x);

/* Key k's default into its value in sec (its side's defaults hook does
 * the rest). */
void gw_cfg_key_default(const gw_cfg_key_t *k, void *sec);
/* Section i of side s in cfg. */
void *gw_cfg_at(gw_config_t *cfg, const gw_cfg_side_t *s, unsigned i);
/* Where key `key` of section i of side s was set (0: not set); an unknown
 * key name is reported as an internal error. */
unsigned gw_cfg_line(gw_cfg_ctx_t *c, const gw_cfg_side_t *s, unsigned i,
                     const char *key);
/* Section i's header line. */
unsigned gw_cfg_section_line(gw_cfg_ctx_t *c, const gw_cfg_side_t *s,
                             unsigned i);
/* The scratch bytes of section i of side s (s->scratch of them). */
void *gw_cfg_scratch(gw_cfg_ctx_t *c, const gw_cfg_side_t *s, unsigned i);
/* Every GW_CFG_REQUIRED key of section i is set; false after the
 * message. */
bool gw_cfg_require(gw_cfg_ctx_t *c, const gw_cfg_side_t *s, unsigned i);

/* The reader (config_ini.c) calls these two. */
void gw_cfg_begin_section(gw_cfg_ctx_t *c, const char *raw);
void gw_cfg_key(gw_cfg_ctx_t *c, const char *name, const char *value);

/* ---- config_ini.c ------------------------------------------------------- */

/* Parse c->path into c->cfg. False on an error about the file itself
 * (written into err); errors at a line are left in c. */
bool gw_cfg_ini_read(gw_cfg_ctx_t *c, char *err, size_t errlen);
/* "PATH: what[: detail]" into err. */
void gw_cfg_file_error(char *err, size_t errlen, const char *path,
                       const char *what, const char *detail);

/* ---- config_check.c ----------------------------------------------------- */

void gw_cfg_check_robots(gw_cfg_ctx_t *c);
/* key_line if the key was set, else section_line. */
unsigned gw_cfg_line_or(unsigned key_line, unsigned section_line);

/* ---- config_robot.c: one robot's own checks ------------------------------- */

/* Robot i's instances and connection plan; false after the message. */
bool gw_cfg_robot_check(gw_cfg_ctx_t *c, unsigned i);

/* ---- config_eds.c: the `eds` key of [robot NAME] ------------------------- */

/* Read the EDS at `path` (relative: to the configuration file's folder;
 * the name used in file[file_size]) into *plan (common/eds.h). False
 * after the message: at config line `line`, with the EDS's FILE:LINE
 * for a malformed one. */
bool gw_cfg_eds_load(gw_cfg_ctx_t *c, unsigned line, const char *name, const char *path,
                     eds_plan_t *plan, char *file, size_t file_size);

/* ---- config_doc.c --------------------------------------------------------- */

/* Side s's keys as a Markdown table (docs/configuration.md). */
void gw_cfg_print_keys(FILE *out, const gw_cfg_side_t *s);

#endif /* DRGATE_GW_CONFIG_INTERNAL_H */
