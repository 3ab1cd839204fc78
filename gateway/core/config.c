/* SPDX-License-Identifier: MIT */
/*
 * drgatewayd configuration loader (config.h, docs/configuration.md): the
 * list of sections, one generic parser over their key tables, and the
 * public API. How the tables are laid out: config_internal.h.
 *
 * libinih does the INI syntax (config_ini.c feeds it the file and calls
 * gw_cfg_begin_section and gw_cfg_key here); each key's line in its side's
 * table gives its meaning and checks its value; config_check.c then checks
 * what spans sections (unique unit IDs, one GPIO line used once, ...).
 *
 * Everything is parsed into a heap temporary and checked to the end before
 * *out is written: a bad file, or a bad reload, never half-applies.
 */
#include "core/config_internal.h"
#include "core/write.h"

#include <arpa/inet.h>
#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* ---- the sections ----------------------------------------------------------- */

/* The sides, from the side list (gateway/sides.h): the core names no
 * side. */
#define GW_SIDE_CFG_ENTRY(name) &gw_side_cfg_##name,
const gw_side_cfg_t *const gw_side_cfgs[GW_SIDE_COUNT] = {
    GW_SIDES(GW_SIDE_CFG_ENTRY)
};
#undef GW_SIDE_CFG_ENTRY

/* Every section kind, in rank order: the order of "allowed:" lists, of
 * did-you-mean and of the checks once the file is read. A side with more
 * than GW_CFG_SIDE_SECTIONS sections has the rest left out (its unit
 * test, test_gw_sides.c, says so). */
unsigned gw_cfg_all_sections(const gw_cfg_side_t **out)
{
    unsigned n = 0;
    gw_cfg_robot_merge();
    out[n++] = &gw_cfg_daemon;
    out[n++] = &gw_cfg_robot;
    for (unsigned j = 0; j < GW_SIDE_COUNT; j++)
        for (unsigned k = 0; k < GW_CFG_SIDE_SECTIONS && gw_side_cfgs[j]->sections[k] != NULL;
             k++)
            out[n++] = gw_side_cfgs[j]->sections[k];
    for (unsigned i = 1; i < n; i++) /* insertion sort: stable, a dozen */
        for (unsigned k = i; k > 0 && out[k - 1]->rank > out[k]->rank; k--) {
            const gw_cfg_side_t *t = out[k];
            out[k] = out[k - 1];
            out[k - 1] = t;
        }
    return n;
}

/* [daemon]: the core's own section; its struct is gw_config_t itself. */
static const gw_cfg_key_t daemon_keys[] = {
    { .name = "log_level", .type = GW_CFG_WORD, GW_CFG_AT(gw_config_t, log_level), GW_CFG_NAMES("error", "warning", "info", "debug"), .def_text = "info", .help = "least severe message logged (stderr / journal)" },
};

const gw_cfg_side_t gw_cfg_daemon = {
    .kw = "daemon",
    .rank = 10,
    .name_off = GW_CFG_NONE,
    .line_off = GW_CFG_NONE,
    GW_CFG_KEYS(daemon_keys),
};

/* ---- messages ------------------------------------------------------------ */

void gw_cfg_fail(gw_cfg_ctx_t *c, unsigned line, const char *fmt, ...)
{
    if (c->err_line != 0)
        return;
    c->err_line = line != 0 ? line : 1;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->err, sizeof c->err, fmt, ap);
    va_end(ap);
    /* Messages quote what the file says; a stray CR or escape byte must
     * not split the log line or reach the terminal. */
    for (char *p = c->err; *p; p++)
        if ((unsigned char)*p < 0x20 || *p == 0x7f)
            *p = '?';
}

/* ---- small helpers ------------------------------------------------------ */

/* Locale-independent character classes (isalpha() would follow LC_CTYPE). */
bool gw_cfg_is_digit(char ch)
{
    return ch >= '0' && ch <= '9';
}

bool gw_cfg_is_alnum(char ch)
{
    return gw_cfg_is_digit(ch) || (ch >= 'a' && ch <= 'z') ||
           (ch >= 'A' && ch <= 'Z');
}

bool gw_cfg_is_space(char ch)
{
    return ch == ' ' || ch == '\t' || ch == '\r' || ch == '\n' || ch == '\f' ||
           ch == '\v';
}

bool gw_cfg_no_blank(const char *s)
{
    for (; *s; s++)
        if (gw_cfg_is_space(*s) || (unsigned char)*s < 0x20 || *s == 0x7f)
            return false;
    return true;
}

bool gw_cfg_valid_name(const char *s)
{
    size_t n = strlen(s);
    if (n == 0 || n >= GW_NAME_MAX)
        return false;
    for (; *s; s++)
        if (!gw_cfg_is_alnum(*s) && *s != '_' && *s != '-')
            return false;
    return true;
}

/* Close enough to suggest: a third of the length, at least 2 edits:
 * "wordorder" -> "word_order", not "foo" -> "port". The first of equally
 * close candidates wins. */
void gw_cfg_guess(gw_cfg_guess_t *g, const char *cand)
{
    size_t n = strlen(cand);
    unsigned limit = n / 3 > 2 ? (unsigned)(n / 3) : 2u;
    unsigned d = dr_edit_distance(g->typed, cand);
    if (d <= limit && d < n && d < g->dist) {
        g->dist = d;
        snprintf(g->best, sizeof g->best, "%s", cand);
    }
}

const char *gw_cfg_did_you_mean(const gw_cfg_guess_t *g, const char *open,
                                const char *close, char *buf, size_t size)
{
    if (g->best[0] == '\0')
        return "";
    snprintf(buf, size, "did you mean %s%s%s? ", open, g->best, close);
    return buf;
}

void gw_cfg_join(const char *const *names, size_t n, char *buf, size_t size)
{
    size_t len = 0;
    buf[0] = '\0';
    for (size_t i = 0; i < n && len < size; i++) {
        int w =
            snprintf(buf + len, size - len, "%s%s", i ? ", " : "", names[i]);
        if (w < 0)
            break;
        len += (size_t)w;
    }
}

static size_t count_names(const char *const *names)
{
    size_t n = 0;
    while (names[n] != NULL)
        n++;
    return n;
}

bool gw_cfg_copy(gw_cfg_ctx_t *c, const char *key, const char *v, char *dst,
                 size_t size)
{
    size_t n = strlen(v);
    if (n >= size) {
        gw_cfg_fail(c, c->lineno, "%s too long (at most %zu characters)", key,
                    size - 1);
        return false;
    }
    memcpy(dst, v, n + 1);
    return true;
}

bool gw_cfg_get_uint(gw_cfg_ctx_t *c, const char *key, const char *v,
                     unsigned long lo, unsigned long hi, unsigned long *out)
{
    if (!gw_cfg_is_digit(v[0])) {
        gw_cfg_fail(c, c->lineno,
                    "%s '%s' invalid: not a number (allowed: %lu..%lu)", key, v,
                    lo, hi);
        return false;
    }
    errno = 0;
    char *end;
    unsigned long x = strtoul(v, &end, 10);
    if (*end != '\0') {
        gw_cfg_fail(c, c->lineno,
                    "%s '%s' invalid: trailing '%s' after the number (allowed: "
                    "%lu..%lu)",
                    key, v, end, lo, hi);
        return false;
    }
    if (errno == ERANGE || x < lo || x > hi) {
        gw_cfg_fail(c, c->lineno, "%s %s out of range (allowed: %lu..%lu)", key,
                    v, lo, hi);
        return false;
    }
    *out = x;
    return true;
}

/* One of `names` exactly (lower case); the index goes to *out. */
static bool get_enum(gw_cfg_ctx_t *c, const char *key, const char *v,
                     const char *const *names, unsigned *out)
{
    for (size_t i = 0; names[i] != NULL; i++) {
        if (strcmp(v, names[i]) == 0) {
            *out = (unsigned)i;
            return true;
        }
    }
    char allowed[128];
    gw_cfg_join(names, count_names(names), allowed, sizeof allowed);
    gw_cfg_fail(c, c->lineno, "%s '%s' invalid (allowed: %s)", key, v,
                allowed);
    return false;
}

static bool valid_ipv4(const char *v)
{
    struct in_addr a;
    return inet_pton(AF_INET, v, &a) == 1;
}

/* An IPv4 address, or a DNS name (letters, digits, '-', dot-separated
 * labels). All digits and dots but not an address is a typo ("10.0.0.256"),
 * not a name to look up. */
bool gw_cfg_valid_host(const char *h)
{
    if (valid_ipv4(h))
        return true;
    bool numeric = true;
    for (const char *p = h; *p; p++)
        if (!gw_cfg_is_digit(*p) && *p != '.')
            numeric = false;
    if (numeric)
        return false;
    size_t label = 0;
    for (const char *p = h;; p++) {
        if (*p == '.' || *p == '\0') {
            if (label == 0 || label > 63 || p[-1] == '-')
                return false;
            if (*p == '\0')
                return true;
            label = 0;
        } else if (gw_cfg_is_alnum(*p) || (*p == '-' && label > 0)) {
            label++;
        } else {
            return false;
        }
    }
}

/* Whether a TEXT, IPV4 or HOST value passes its check, and what a
 * refused one is told is allowed (NULL: no check). */
static bool text_valid(const gw_cfg_key_t *k, const char *v)
{
    if (k->type == GW_CFG_IPV4)
        return valid_ipv4(v);
    if (k->type == GW_CFG_HOST)
        return gw_cfg_valid_host(v);
    return k->valid == NULL || k->valid(v);
}

static const char *text_allowed(const gw_cfg_key_t *k)
{
    if (k->type == GW_CFG_IPV4)
        return "an IPv4 address such as 192.168.1.10";
    if (k->type == GW_CFG_HOST)
        return "an IPv4 address or a host name";
    if (k->valid == NULL)
        return NULL;
    return k->invalid != NULL ? k->invalid : k->allowed;
}

/* x into an integer of `size` bytes (a UINT's or ENUM's value, or a
 * bool: 0 and 1 are a bool's representations). */
static bool store_uint(void *dst, size_t size, unsigned long x)
{
    if (size == 1) {
        uint8_t v = (uint8_t)x;
        memcpy(dst, &v, sizeof v);
    } else if (size == 2) {
        uint16_t v = (uint16_t)x;
        memcpy(dst, &v, sizeof v);
    } else if (size == 4) {
        uint32_t v = (uint32_t)x;
        memcpy(dst, &v, sizeof v);
    } else {
        return false;
    }
    return true;
}

void gw_cfg_store(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                  unsigned long x)
{
    if (!store_uint((char *)sec + k->off, k->size, x))
        gw_cfg_fail(c, c->lineno, "internal error: %s is %zu bytes", k->name,
                    k->size);
}

/* ---- allow lists ([modbus], [http]) ------------------------------------- */

/* Up to n blank-separated words of buf, each cut in place; how many
 * there were (n + 1 when there are more). */
static size_t split_words(char *buf, char **word, size_t n)
{
    size_t nw = 0;
    for (char *p = buf; *p != '\0';) {
        while (gw_cfg_is_space(*p))
            *p++ = '\0';
        if (*p == '\0')
            break;
        if (nw == n)
            return n + 1;
        word[nw++] = p;
        while (*p != '\0' && !gw_cfg_is_space(*p))
            p++;
    }
    return nw;
}

/* "/len" of an allow entry: 0..32 into *prefix; false after the message. */
static bool allow_prefix(gw_cfg_ctx_t *c, const char *v, const char *p,
                         unsigned long *prefix)
{
    size_t digits = strspn(p, "0123456789");
    *prefix = digits > 0 ? strtoul(p, NULL, 10) : 99;
    if (digits == 0 || p[digits] != '\0' || *prefix > 32) {
        gw_cfg_fail(c, c->lineno,
                    "allow '%s' invalid: prefix length '%s' (allowed: 0..32)", v,
                    p);
        return false;
    }
    return true;
}

/* An allow entry, "a.b.c.d/len [ro|rw]" ([modbus] and [http]): the network must be given exactly (no host bits),
 * and must not be shadowed by an earlier entry, since the first match
 * decides (mbserver.c, north_http.c) and a shadowed line would silently do
 * nothing. */
void gw_cfg_allow(gw_cfg_ctx_t *c, const char *v, gw_allow_t *allow, unsigned *count,
                  unsigned *lines)
{
    if (*count >= GW_MAX_ALLOW) {
        gw_cfg_fail(c, c->lineno, "too many allow entries (at most %d)",
                    GW_MAX_ALLOW);
        return;
    }
    /* The value itself is ours to split: libinih has already stripped it
     * and removed comments. */
    char buf[128];
    if (strlen(v) >= sizeof buf) {
        gw_cfg_fail(c, c->lineno, "allow too long (at most %zu characters)",
                    sizeof buf - 1);
        return;
    }
    memcpy(buf, v, strlen(v) + 1);
    char *word[3] = { NULL, NULL, NULL };
    size_t nw = split_words(buf, word, 3);
    if (nw > 2) {
        gw_cfg_fail(c, c->lineno,
                    "allow '%s' invalid: trailing '%s' (allowed: a.b.c.d/len "
                    "[ro|rw])",
                    v, word[2]);
        return;
    }
    if (nw == 0) { /* not reached: an empty value is refused before */
        gw_cfg_fail(c, c->lineno,
                    "allow has no value (allowed: a.b.c.d/len [ro|rw])");
        return;
    }
    bool rw = false; /* least privilege: writing must be asked for */
    if (nw == 2) {
        if (strcmp(word[1], "rw") == 0) {
            rw = true;
        } else if (strcmp(word[1], "ro") != 0) {
            gw_cfg_fail(c, c->lineno,
                        "allow '%s' invalid: access '%s' (allowed: ro, rw)", v,
                        word[1]);
            return;
        }
    }
    char *slash = strchr(word[0], '/');
    unsigned long prefix = 32;
    if (slash != NULL) {
        *slash = '\0';
        if (!allow_prefix(c, v, slash + 1, &prefix))
            return;
    }
    struct in_addr a;
    if (inet_pton(AF_INET, word[0], &a) != 1) {
        gw_cfg_fail(c, c->lineno,
                    "allow '%s' invalid: '%s' is not an IPv4 address (allowed: "
                    "a.b.c.d/len [ro|rw])",
                    v, word[0]);
        return;
    }
    uint32_t addr = ntohl(a.s_addr);
    /* A shift by 32 is undefined, hence the /0 case. */
    uint32_t mask = prefix == 0 ? 0u : 0xFFFFFFFFu << (32u - (unsigned)prefix);
    if ((addr & ~mask) != 0) {
        uint32_t n = addr & mask;
        gw_cfg_fail(c, c->lineno,
                    "allow '%s' invalid: host bits set in %s/%lu (did you mean "
                    "%u.%u.%u.%u/%lu?)",
                    v, word[0], prefix, (unsigned)(n >> 24),
                    (unsigned)(n >> 16 & 0xFF), (unsigned)(n >> 8 & 0xFF),
                    (unsigned)(n & 0xFF), prefix);
        return;
    }
    for (unsigned i = 0; i < *count; i++) {
        const gw_allow_t *e = &allow[i];
        if ((addr & e->mask) == e->net && mask >= e->mask) {
            gw_cfg_fail(c, c->lineno,
                        "allow '%s' never matches: line %u already covers it "
                        "(the first matching entry decides; put narrower "
                        "networks first)",
                        v, lines[i]);
            return;
        }
    }
    lines[*count] = c->lineno;
    allow[*count] = (gw_allow_t){ addr, mask, rw };
    (*count)++;
}

/* ---- where sections and their key lines are ----------------------------- */

static unsigned *uint_at(void *base, size_t off)
{
    return (unsigned *)(void *)((char *)base + off);
}

void *gw_cfg_at(gw_config_t *cfg, const gw_cfg_side_t *s, unsigned i)
{
    return (char *)cfg + s->base + (size_t)i * s->stride;
}

static unsigned side_index(const gw_cfg_ctx_t *c, const gw_cfg_side_t *s)
{
    unsigned j = 0;
    while (j + 1 < c->nsides && c->sides[j] != s)
        j++;
    return j;
}

static size_t round16(size_t n)
{
    return (n + 15u) & ~(size_t)15u;
}

/* One block for every section's record: the key lines, the header line,
 * the scratch. */
static bool alloc_records(gw_cfg_ctx_t *c)
{
    size_t total = 0;
    for (unsigned j = 0; j < c->nsides; j++) {
        const gw_cfg_side_t *s = c->sides[j];
        c->record_size[j] = round16((s->nkeys + 1u) * sizeof(unsigned)) +
                            round16(s->scratch);
        c->record_off[j] = total;
        total += c->record_size[j] * (s->named ? s->max : 1u);
    }
    c->record = calloc(1, total > 0 ? total : 1u);
    return c->record != NULL;
}

static unsigned char *record(gw_cfg_ctx_t *c, const gw_cfg_side_t *s,
                             unsigned i)
{
    unsigned j = side_index(c, s);
    return c->record + c->record_off[j] + (size_t)i * c->record_size[j];
}

static unsigned *key_lines(gw_cfg_ctx_t *c, const gw_cfg_side_t *s,
                           unsigned i)
{
    return uint_at(record(c, s, i), 0);
}

void *gw_cfg_scratch(gw_cfg_ctx_t *c, const gw_cfg_side_t *s, unsigned i)
{
    return record(c, s, i) + round16((s->nkeys + 1u) * sizeof(unsigned));
}

unsigned gw_cfg_section_line(gw_cfg_ctx_t *c, const gw_cfg_side_t *s,
                             unsigned i)
{
    return key_lines(c, s, i)[s->nkeys];
}

unsigned gw_cfg_line(gw_cfg_ctx_t *c, const gw_cfg_side_t *s, unsigned i,
                     const char *key)
{
    for (unsigned k = 0; k < s->nkeys; k++)
        if (strcmp(s->keys[k].name, key) == 0)
            return key_lines(c, s, i)[k];
    gw_cfg_fail(c, c->lineno, "internal error: no key '%s' in [%s]", key,
                s->kw);
    return 0;
}

/* What a key's value may be, for "(allowed: ...)". */
static const char *allowed_text(const gw_cfg_key_t *k, char *buf, size_t size)
{
    if (k->allowed != NULL)
        return k->allowed;
    if (k->type == GW_CFG_UINT)
        snprintf(buf, size, "%lu..%lu", k->lo, k->hi);
    else if (k->type == GW_CFG_BOOL)
        snprintf(buf, size, "yes, no");
    else if (k->names != NULL)
        gw_cfg_join(k->names, count_names(k->names), buf, size);
    else
        snprintf(buf, size, "?");
    return buf;
}

bool gw_cfg_require(gw_cfg_ctx_t *c, const gw_cfg_side_t *s, unsigned i)
{
    const unsigned *lines = key_lines(c, s, i);
    void *sec = gw_cfg_at(&c->cfg, s, i);
    for (unsigned k = 0; k < s->nkeys; k++) {
        const gw_cfg_key_t *key = &s->keys[k];
        if (!(key->flags & GW_CFG_REQUIRED) || lines[k] != 0)
            continue;
        char buf[128];
        const char *allowed = allowed_text(key, buf, sizeof buf);
        if (s->named)
            gw_cfg_fail(c, lines[s->nkeys], "%s '%s' has no %s (allowed: %s)",
                        s->kw, (const char *)sec + s->name_off, key->name,
                        allowed);
        else
            gw_cfg_fail(c, lines[s->nkeys], "[%s] has no %s (allowed: %s)",
                        s->kw, key->name, allowed);
        return false;
    }
    return true;
}

/* ---- keys ------------------------------------------------------------------ */

/* The PREFIX of a key family "PREFIX<item>". */
static size_t prefix_len(const gw_cfg_key_t *k)
{
    return strcspn(k->name, "<");
}

static int find_key(const gw_cfg_side_t *s, const char *name)
{
    for (unsigned k = 0; k < s->nkeys; k++)
        if (s->keys[k].type != GW_CFG_PREFIX &&
            strcmp(s->keys[k].name, name) == 0)
            return (int)k;
    for (unsigned k = 0; k < s->nkeys; k++)
        if (s->keys[k].type == GW_CFG_PREFIX &&
            strncmp(s->keys[k].name, name, prefix_len(&s->keys[k])) == 0)
            return (int)k;
    return -1;
}

static void unknown_key(gw_cfg_ctx_t *c, const char *name)
{
    const gw_cfg_side_t *s = c->side;
    gw_cfg_guess_t g = GW_CFG_GUESS(name);
    const char *names[GW_CFG_MAX_KEYS];
    size_t n = 0;
    for (unsigned k = 0; k < s->nkeys; k++) {
        const gw_cfg_key_t *key = &s->keys[k];
        if (n < GW_CFG_COUNT(names)) /* test_key_tables: all of them */
            names[n++] = key->name;
        if (key->type != GW_CFG_PREFIX) {
            gw_cfg_guess(&g, key->name);
            continue;
        }
        /* "instanse.io_state" should point at "instance.io_state": each
         * member of a family is a candidate. */
        const char *item;
        for (unsigned i = 0; (item = key->item(i)) != NULL; i++) {
            char member[64];
            snprintf(member, sizeof member, "%.*s%s", (int)prefix_len(key),
                     key->name, item);
            gw_cfg_guess(&g, member);
        }
    }
    char allowed[768], hint[96];
    gw_cfg_join(names, n, allowed, sizeof allowed);
    gw_cfg_fail(c, c->lineno, "unknown key '%s' in [%s] (%sallowed: %s)", name,
                c->sec_text, gw_cfg_did_you_mean(&g, "'", "'", hint, sizeof hint),
                allowed);
}

/* The value by the key's type (a key with a parse hook has no call). */
static void parse_value(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                        const char *name, const char *v)
{
    static const char *const yes_no[] = { "yes", "no", NULL };
    char *dst = (char *)sec + k->off;
    unsigned long n;
    unsigned i;
    switch (k->type) {
    case GW_CFG_BOOL:
        if (get_enum(c, name, v, yes_no, &i))
            gw_cfg_store(c, k, sec, i == 0);
        break;
    case GW_CFG_UINT:
        if (gw_cfg_get_uint(c, name, v, k->lo, k->hi, &n))
            gw_cfg_store(c, k, sec, n);
        break;
    case GW_CFG_ENUM:
        if (get_enum(c, name, v, k->names, &i))
            gw_cfg_store(c, k, sec, i);
        break;
    case GW_CFG_WORD:
        if (get_enum(c, name, v, k->names, &i))
            gw_cfg_copy(c, name, k->names[i], dst, k->size);
        break;
    case GW_CFG_TEXT:
    case GW_CFG_IPV4:
    case GW_CFG_HOST: {
        const char *allowed = text_allowed(k);
        if (allowed != NULL && !text_valid(k, v))
            gw_cfg_fail(c, c->lineno, "%s '%s' invalid (allowed: %s)", name, v,
                        allowed);
        else
            gw_cfg_copy(c, name, v, dst, k->size);
        break;
    }
    case GW_CFG_HOOK:
    case GW_CFG_PREFIX:
        gw_cfg_fail(c, c->lineno, "internal error: %s has no parser", name);
        break;
    }
}

void gw_cfg_key(gw_cfg_ctx_t *c, const char *name, const char *v)
{
    if (c->side == NULL) {
        gw_cfg_fail(c, c->lineno,
                    "key '%s' outside any section (allowed sections: %s)", name,
                    gw_config_sections());
        return;
    }
    int ki = find_key(c->side, name);
    if (ki < 0) {
        unknown_key(c, name);
        return;
    }
    const gw_cfg_key_t *k = &c->side->keys[ki];
    if (k->type == GW_CFG_PREFIX) {
        k->parse(c, k, c->sec, name, v);
        return;
    }
    unsigned *line = &key_lines(c, c->side, c->idx)[ki];
    if (*line != 0 && !(k->flags & GW_CFG_LIST)) {
        gw_cfg_fail(c, c->lineno, "key '%s' repeated in [%s] (first at line %u)",
                    name, c->sec_text, *line);
        return;
    }
    if (*line == 0)
        *line = c->lineno;
    if (v[0] == '\0') {
        char buf[128];
        gw_cfg_fail(c, c->lineno, "%s has no value (allowed: %s)", name,
                    allowed_text(k, buf, sizeof buf));
        return;
    }
    if (k->parse != NULL)
        k->parse(c, k, c->sec, name, v);
    else
        parse_value(c, k, c->sec, name, v);
}

/* ---- sections -------------------------------------------------------------- */

const char *gw_config_sections(void)
{
    static char text[400];
    const gw_cfg_side_t *sides[GW_CFG_MAX_SECTIONS];
    unsigned n = gw_cfg_all_sections(sides);
    size_t len = 0;
    for (unsigned j = 0; j < n && len < sizeof text; j++) {
        int w = snprintf(text + len, sizeof text - len, "%s[%s%s]",
                         j ? ", " : "", sides[j]->kw,
                         sides[j]->named ? " NAME" : "");
        if (w < 0)
            break;
        len += (size_t)w;
    }
    return text;
}

static void unknown_section(gw_cfg_ctx_t *c, const char *kw, const char *rest)
{
    gw_cfg_guess_t g = GW_CFG_GUESS(kw);
    for (unsigned j = 0; j < c->nsides; j++)
        gw_cfg_guess(&g, c->sides[j]->kw);
    char close[80], hint[160];
    snprintf(close, sizeof close, "%s]", rest); /* [robto arm1]: [robot arm1] */
    gw_cfg_fail(c, c->lineno, "unknown section [%s] (%sallowed: %s)",
                c->sec_text, gw_cfg_did_you_mean(&g, "[", close, hint, sizeof hint),
                gw_config_sections());
}

/* Keys now go to section idx of s. */
static void enter(gw_cfg_ctx_t *c, const gw_cfg_side_t *s, unsigned idx)
{
    c->side = s;
    c->idx = idx;
    c->sec = gw_cfg_at(&c->cfg, s, idx);
    key_lines(c, s, idx)[s->nkeys] = c->lineno;
    if (s->line_off != GW_CFG_NONE)
        *uint_at(c->sec, s->line_off) = c->lineno;
    if (s->begin != NULL)
        s->begin(c->sec);
}

/* [daemon], [modbus], [mqtt]: once, without a name. */
static void begin_single(gw_cfg_ctx_t *c, const gw_cfg_side_t *s, bool named)
{
    unsigned first = gw_cfg_section_line(c, s, 0);
    if (named)
        gw_cfg_fail(c, c->lineno, "section [%s] takes no name (allowed: [%s])",
                    c->sec_text, s->kw);
    else if (first != 0)
        gw_cfg_fail(c, c->lineno, "section [%s] repeated (first at line %u)",
                    s->kw, first);
    else
        enter(c, s, 0);
}

/* [robot NAME], [gpio NAME], ...: each NAME once. */
static void begin_named(gw_cfg_ctx_t *c, const gw_cfg_side_t *s,
                        const char *name, bool named)
{
    const char *kw = s->kw;
    unsigned *count = uint_at(&c->cfg, s->count_off);
    if (!named && s->lone_name == NULL) {
        gw_cfg_fail(c, c->lineno,
                    "section [%s] needs a name (allowed: [%s NAME] or "
                    "[%s.NAME])",
                    kw, kw, kw);
        return;
    }
    if (!named) /* a lone [robot] is named "robot": log lines need a name */
        name = s->lone_name;
    if (!gw_cfg_valid_name(name)) {
        gw_cfg_fail(c, c->lineno,
                    "%s name '%s' invalid (allowed: letters, digits, '_' and "
                    "'-', at most %d characters)",
                    kw, name, GW_NAME_MAX - 1);
        return;
    }
    for (unsigned i = 0; i < *count; i++) {
        if (strcmp((char *)gw_cfg_at(&c->cfg, s, i) + s->name_off, name) == 0) {
            gw_cfg_fail(c, c->lineno, "%s '%s' defined twice (first at line %u)",
                        kw, name, gw_cfg_section_line(c, s, i));
            return;
        }
    }
    if (*count >= s->max) {
        gw_cfg_fail(c, c->lineno, "too many %s sections (at most %u)", kw,
                    s->max);
        return;
    }
    unsigned idx = (*count)++;
    memcpy((char *)gw_cfg_at(&c->cfg, s, idx) + s->name_off, name,
           strlen(name) + 1);
    enter(c, s, idx);
}

/* A section starts (raw: the name exactly as libinih will report it):
 * "kw", "kw NAME" or "kw.NAME". */
void gw_cfg_begin_section(gw_cfg_ctx_t *c, const char *raw)
{
    snprintf(c->sec_raw, sizeof c->sec_raw, "%s", raw);
    const char *s = raw;
    while (gw_cfg_is_space(*s))
        s++;
    size_t len = strlen(s);
    while (len > 0 && gw_cfg_is_space(s[len - 1]))
        len--;
    snprintf(c->sec_text, sizeof c->sec_text, "%.*s", (int)len, s);

    /* keyword, then '.' or blanks, then the name */
    char *t = c->sec_text;
    size_t kw_len = strcspn(t, " \t.");
    char kw[64];
    snprintf(kw, sizeof kw, "%.*s", (int)kw_len, t);
    const char *rest = t + kw_len; /* "" or the separator and name */
    const char *name = rest;
    if (*name == '.')
        name++;
    else
        while (gw_cfg_is_space(*name))
            name++;
    bool named = *rest != '\0';

    c->side = NULL;
    for (unsigned j = 0; j < c->nsides; j++) {
        if (strcmp(kw, c->sides[j]->kw) != 0)
            continue;
        if (c->sides[j]->named)
            begin_named(c, c->sides[j], name, named);
        else
            begin_single(c, c->sides[j], named);
        return;
    }
    unknown_section(c, kw, rest);
}

/* ---- defaults --------------------------------------------------------------- */

void gw_cfg_key_default(const gw_cfg_key_t *k, void *sec)
{
    char *dst = (char *)sec + k->off;
    switch (k->type) {
    case GW_CFG_BOOL:
    case GW_CFG_UINT:
    case GW_CFG_ENUM: (void)store_uint(dst, k->size, k->def); break;
    case GW_CFG_WORD:
    case GW_CFG_TEXT:
    case GW_CFG_IPV4:
    case GW_CFG_HOST:
        if (k->def_text != NULL && strlen(k->def_text) < k->size)
            memcpy(dst, k->def_text, strlen(k->def_text) + 1);
        break;
    case GW_CFG_HOOK:
    case GW_CFG_PREFIX: break;
    }
}

static void side_defaults(const gw_cfg_side_t *s, void *sec)
{
    for (unsigned k = 0; k < s->nkeys; k++)
        gw_cfg_key_default(&s->keys[k], sec);
    if (s->defaults != NULL)
        s->defaults(sec);
}

void gw_config_defaults(gw_config_t *cfg)
{
    const gw_cfg_side_t *sides[GW_CFG_MAX_SECTIONS];
    unsigned n = gw_cfg_all_sections(sides);
    memset(cfg, 0, sizeof *cfg);
    for (unsigned j = 0; j < n; j++)
        for (unsigned i = 0; i < (sides[j]->named ? sides[j]->max : 1u); i++)
            side_defaults(sides[j], gw_cfg_at(cfg, sides[j], i));
}

/* ---- public API --------------------------------------------------------- */

bool gw_config_load(const char *path, gw_config_t *out, char *err,
                    size_t errlen)
{
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (path == NULL || out == NULL) {
        gw_cfg_file_error(err, errlen, path ? path : "(null)",
                          "no configuration to load", NULL);
        return false;
    }
    gw_cfg_ctx_t *c = calloc(1, sizeof *c);
    if (c != NULL)
        c->nsides = gw_cfg_all_sections(c->sides);
    if (c == NULL || !alloc_records(c)) {
        gw_cfg_file_error(err, errlen, path, "out of memory", NULL);
        free(c);
        return false;
    }
    bool ok = false;
    gw_config_defaults(&c->cfg);
    if (strlen(path) >= sizeof c->cfg.path) {
        gw_cfg_file_error(err, errlen, path, "path too long", NULL);
    } else {
        memcpy(c->cfg.path, path, strlen(path) + 1);
        c->path = path;
        if (gw_cfg_ini_read(c, err, errlen)) {
            for (unsigned j = 0; j < c->nsides; j++)
                if (c->err_line == 0 && c->sides[j]->check != NULL)
                    c->sides[j]->check(c);
            if (c->err_line != 0) {
                if (err != NULL && errlen > 0)
                    snprintf(err, errlen, "%s:%u: %s", path, c->err_line,
                             c->err);
            } else {
                *out = c->cfg;
                ok = true;
            }
        }
    }
    free(c->record);
    free(c);
    return ok;
}

bool gw_config_print_keys(FILE *out, const char *section)
{
    const gw_cfg_side_t *sides[GW_CFG_MAX_SECTIONS];
    unsigned n = gw_cfg_all_sections(sides);
    for (unsigned j = 0; j < n; j++) {
        if (strcmp(section, sides[j]->kw) == 0) {
            gw_cfg_print_keys(out, sides[j]);
            return true;
        }
    }
    return false;
}

/* ---- what the daemon asks of the sides' configuration ------------------------- */

void gw_write_policy_set(gw_robot_t *r, const gw_config_t *cfg, unsigned index)
{
    memset(&r->write_policy, 0, sizeof r->write_policy);
    for (unsigned j = 0; j < GW_SIDE_COUNT; j++)
        if (gw_side_cfgs[j]->write_policy != NULL)
            gw_side_cfgs[j]->write_policy(cfg, index, &r->write_policy);
}

const char *gw_config_brief(const gw_config_t *cfg)
{
    static char text[256];
    snprintf(text, sizeof text, "%u robot(s)", cfg->robot_count);
    for (unsigned j = 0; j < GW_SIDE_COUNT; j++)
        if (gw_side_cfgs[j]->brief != NULL)
            gw_side_cfgs[j]->brief(cfg, text, sizeof text);
    return text;
}

const char *gw_config_robot_brief(const gw_robot_config_t *r, char *buf, size_t size)
{
    if (size > 0)
        buf[0] = '\0';
    for (unsigned j = 0; j < GW_SIDE_COUNT; j++)
        if (gw_side_cfgs[j]->robot_brief != NULL)
            gw_side_cfgs[j]->robot_brief(r, buf, size);
    return buf;
}

bool gw_config_keeps_log(const gw_config_t *cfg)
{
    for (unsigned j = 0; j < GW_SIDE_COUNT; j++)
        if (gw_side_cfgs[j]->keeps_log != NULL && gw_side_cfgs[j]->keeps_log(cfg))
            return true;
    return false;
}
