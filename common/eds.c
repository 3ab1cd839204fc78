/* SPDX-License-Identifier: MIT */
/*
 * The EDS reader (eds.h): one pass over the text, a field at a time.
 * Only the first KEEP fields of an entry are kept (EDS_FIELD bytes
 * each, longer ones cut); the members of an assembly, which may be many,
 * are added up as they come.
 */
#include "common/eds.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#define KEEP 16u
#define FIELD 128u
#define KEY 48u

typedef enum {
    S_NONE = 0, S_FILE, S_DEVICE, S_CLASS, S_PARAMS, S_ASSEM, S_CONN, S_OTHER, S_COUNT
} sect_t;

/* Required [Device] entries, as bits of ps_t.device_seen. */
enum { D_VEND = 1, D_CODE = 2, D_MAJ = 4, D_MIN = 8, D_NAME = 16, D_ALL = 31 };

typedef struct {
    const char *t;
    size_t len, pos;
    unsigned line;
    eds_t *out;
    char *err;
    size_t errsize;
    unsigned err_line;
    bool failed;
    sect_t sect;
    unsigned sect_line[S_COUNT]; /* 0: not seen */
    unsigned device_seen;
    /* the current entry */
    char key[KEY];
    unsigned key_line;
    unsigned nf;
    char f[KEEP][FIELD];
    /* assembly members, fields 7.. (size in bits, reference) */
    uint64_t member_bits;
    unsigned members;
    bool member_unknown, size_empty;
    unsigned member_line;
    bool params_full, assem_full, conn_full;
} ps_t;

static bool fail(ps_t *ps, unsigned line, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static bool fail(ps_t *ps, unsigned line, const char *fmt, ...)
{
    if (ps->failed)
        return false;
    ps->failed = true;
    ps->err_line = line;
    if (ps->errsize > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(ps->err, ps->errsize, fmt, ap);
        va_end(ap);
    }
    return false;
}

void eds_note(eds_t *eds, unsigned line, const char *fmt, ...)
{
    if (eds->n_note >= EDS_MAX_NOTES) {
        eds->lost_notes++;
        return;
    }
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(eds->note[eds->n_note], sizeof eds->note[0], fmt, ap);
    va_end(ap);
    eds->note_line[eds->n_note++] = line;
}

/* ---- small helpers ------------------------------------------------------ */

static char lower(char c)
{
    if (c >= 'A' && c <= 'Z')
        return (char)(c - 'A' + 'a');
    return c;
}

static bool ieq(const char *a, const char *b)
{
    for (; *a != '\0' && *b != '\0'; a++, b++)
        if (lower(*a) != lower(*b))
            return false;
    return *a == *b;
}

static int hexval(char c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    c = lower(c);
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    return -1;
}

/* A whole unsigned number: decimal or 0x hex, at most 0xFFFFFFFF. */
static bool num(const char *s, uint32_t *v)
{
    uint64_t x = 0;
    unsigned base = 10;
    if (s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) {
        base = 16;
        s += 2;
    }
    if (*s == '\0')
        return false;
    for (; *s != '\0'; s++) {
        int d = base == 16 ? hexval(*s) : (*s >= '0' && *s <= '9' ? *s - '0' : -1);
        if (d < 0)
            return false;
        x = x * base + (unsigned)d;
        if (x > 0xFFFFFFFFu)
            return false;
    }
    *v = (uint32_t)x;
    return true;
}

/* "ParamN" / "AssemN" (prefix case-insensitive): N. */
static bool keyed(const char *s, const char *prefix, uint32_t *n)
{
    size_t k = strlen(prefix);
    for (size_t i = 0; i < k; i++)
        if (lower(s[i]) != lower(prefix[i]))
            return false;
    if (s[k] < '0' || s[k] > '9')
        return false;
    return num(s + k, n);
}

static void copy(char *dst, size_t size, const char *src)
{
    size_t n = strlen(src);
    if (n >= size)
        n = size - 1;
    memcpy(dst, src, n);
    dst[n] = '\0';
}

/* ---- the text ------------------------------------------------------------ */

static bool at_end(const ps_t *ps)
{
    return ps->pos >= ps->len;
}

static char cur(const ps_t *ps)
{
    return ps->t[ps->pos];
}

/* A byte no EDS has: NUL and control characters but tab, CR, LF. */
static bool bad_byte(ps_t *ps)
{
    unsigned char c = (unsigned char)cur(ps);
    if ((c < 0x20 && c != '\t' && c != '\r' && c != '\n') || c == 0x7F)
        return !fail(ps, ps->line, "byte 0x%02X is not text", (unsigned)c);
    return false;
}

/* Skip blanks, line ends and $ comments. False on a bad byte. */
static bool skip(ps_t *ps)
{
    while (!at_end(ps)) {
        char c = cur(ps);
        if (bad_byte(ps))
            return false;
        if (c == '\n') {
            ps->line++;
        } else if (c == '$') {
            while (!at_end(ps) && cur(ps) != '\n') {
                if (bad_byte(ps))
                    return false;
                ps->pos++;
            }
            continue;
        } else if (c != ' ' && c != '\t' && c != '\r') {
            return true;
        }
        ps->pos++;
    }
    return true;
}

/* Append c to buf[FIELD] at *n, dropping what does not fit. */
static void put(char *buf, size_t *n, char c)
{
    if (*n + 1 < FIELD)
        buf[(*n)++] = c;
    buf[*n] = '\0';
}

/* One field into buf[FIELD]: quoted strings (joined), or bare text up to
 * ',' ';' '$' or the line's end, with { } groups. Cut to fit. */
static bool read_field(ps_t *ps, char *buf)
{
    size_t n = 0;
    buf[0] = '\0';
    if (!skip(ps))
        return false;
    if (!at_end(ps) && cur(ps) == '"') {
        while (!at_end(ps) && cur(ps) == '"') {
            unsigned start = ps->line;
            ps->pos++;
            for (;;) {
                if (at_end(ps) || cur(ps) == '\n')
                    return fail(ps, start, "%s: string not closed on its line", ps->key);
                if (bad_byte(ps))
                    return false;
                char c = cur(ps);
                ps->pos++;
                if (c == '"')
                    break;
                if (c == '\\') {
                    if (at_end(ps) || cur(ps) == '\n')
                        return fail(ps, start, "%s: string not closed on its line", ps->key);
                    c = cur(ps);
                    ps->pos++;
                    if (c == 'n' || c == 't')
                        c = ' ';
                }
                /* A tab kept would reach a message or a name shown on a
                 * terminal as it is: one space, as the escape gives. */
                if (c == '\t')
                    c = ' ';
                if (c != '\r')
                    put(buf, &n, c);
            }
            if (!skip(ps))
                return false;
        }
        return true;
    }
    unsigned depth = 0, start = ps->line;
    while (!at_end(ps)) {
        char c = cur(ps);
        if (bad_byte(ps))
            return false;
        if (depth == 0 && (c == ',' || c == ';' || c == '$' || c == '\n'))
            break;
        if (c == '"' && depth == 0)
            return fail(ps, ps->line, "%s: a string in the middle of a value", ps->key);
        if (c == '[' || c == '=')
            return fail(ps, ps->line, "%s (line %u): ';' missing at its end", ps->key,
                        ps->key_line);
        if (c == '{')
            depth++;
        if (c == '}') {
            if (depth == 0)
                return fail(ps, ps->line, "%s: '}' without '{'", ps->key);
            depth--;
        }
        if (c == '\n')
            ps->line++;
        if (c == '\n' || c == '\r' || c == '\t')
            c = ' ';
        put(buf, &n, c);
        ps->pos++;
    }
    if (depth != 0)
        return fail(ps, start, "%s: '{' not closed", ps->key);
    while (n > 0 && buf[n - 1] == ' ')
        buf[--n] = '\0';
    return true;
}

/* ---- what the entries mean ---------------------------------------------- */

static const char *field(const ps_t *ps, unsigned i)
{
    return i < ps->nf && i < KEEP ? ps->f[i] : "";
}

static bool need_num(ps_t *ps, unsigned i, uint32_t max, uint32_t *v)
{
    const char *s = field(ps, i);
    if (!num(s, v) || *v > max)
        return fail(ps, ps->key_line, "%s: '%s' is not a number 0..%lu", ps->key, s,
                    (unsigned long)max);
    return true;
}

static bool ref(ps_t *ps, unsigned i, eds_ref_t *r)
{
    const char *s = field(ps, i);
    r->kind = 0;
    r->value = 0;
    if (*s == '\0')
        return true;
    if (num(s, &r->value))
        r->kind = 'n';
    else if (keyed(s, "Param", &r->value))
        r->kind = 'P';
    else if (keyed(s, "Assem", &r->value))
        r->kind = 'A';
    else
        return fail(ps, ps->key_line, "%s: field %u '%s' is not a number, ParamN or AssemN",
                    ps->key, i + 1, s);
    return true;
}

/* An EPATH in hex bytes ("20 04 24 64 30 03"): the instance and the
 * connection points. False if it is not plain hex bytes or has a
 * segment this reader does not know. */
static bool epath(const char *s, uint32_t *inst, uint32_t pts[2], unsigned *npts)
{
    uint8_t b[64];
    size_t n = 0;
    *inst = 0;
    *npts = 0;
    while (*s != '\0') {
        if (*s == ' ') {
            s++;
            continue;
        }
        int hi = hexval(s[0]), lo = hi >= 0 ? hexval(s[1]) : -1;
        if (hi < 0 || lo < 0 || (s[2] != ' ' && s[2] != '\0') || n >= sizeof b)
            return false;
        b[n++] = (uint8_t)(hi << 4 | lo);
        s += 2;
    }
    for (size_t i = 0; i < n;) {
        uint8_t seg = b[i];
        uint32_t v;
        size_t w;
        if ((seg & 0xE0u) != 0x20u)
            return false; /* only logical segments */
        switch (seg & 0x03u) {
        case 0: w = 2; break;
        case 1: w = 4; break;
        default: return false;
        }
        if (i + w > n)
            return false;
        v = w == 2 ? b[i + 1] : (uint32_t)b[i + 2] | (uint32_t)b[i + 3] << 8;
        switch (seg & 0x1Cu) {
        case 0x00: break;                     /* class */
        case 0x04: if (*inst == 0) *inst = v; break; /* instance */
        case 0x0C:                            /* connection point */
            if (*npts < 2)
                pts[*npts] = v;
            (*npts)++;
            break;
        case 0x10: break;                     /* attribute */
        default: return false;
        }
        i += w;
    }
    return *npts <= 2;
}

static bool end_device(ps_t *ps)
{
    eds_t *e = ps->out;
    const char *k = ps->key;
    if (ieq(k, "VendCode")) {
        ps->device_seen |= D_VEND;
        return need_num(ps, 0, 0xFFFFu, &e->vendor);
    }
    if (ieq(k, "ProdType"))
        return need_num(ps, 0, 0xFFFFu, &e->product_type);
    if (ieq(k, "ProdCode")) {
        ps->device_seen |= D_CODE;
        return need_num(ps, 0, 0xFFFFu, &e->product_code);
    }
    if (ieq(k, "MajRev")) {
        ps->device_seen |= D_MAJ;
        return need_num(ps, 0, 0xFFu, &e->major_rev);
    }
    if (ieq(k, "MinRev")) {
        ps->device_seen |= D_MIN;
        return need_num(ps, 0, 0xFFu, &e->minor_rev);
    }
    if (ieq(k, "ProdName")) {
        ps->device_seen |= D_NAME;
        copy(e->product_name, sizeof e->product_name, field(ps, 0));
    } else if (ieq(k, "VendName")) {
        copy(e->vendor_name, sizeof e->vendor_name, field(ps, 0));
    } else if (ieq(k, "Catalog")) {
        copy(e->catalog, sizeof e->catalog, field(ps, 0));
    }
    return true;
}

static bool end_param(ps_t *ps)
{
    eds_t *e = ps->out;
    uint32_t n;
    if (!keyed(ps->key, "Param", &n))
        return true;
    if (eds_param(e, n) != NULL)
        return fail(ps, ps->key_line, "%s twice", ps->key);
    if (e->n_param >= EDS_MAX_PARAM) {
        if (!ps->params_full)
            eds_note(e, ps->key_line, "%s and later parameters not read (%u kept)",
                         ps->key, (unsigned)EDS_MAX_PARAM);
        ps->params_full = true;
        return true;
    }
    eds_param_t *p = &e->param[e->n_param++];
    memset(p, 0, sizeof *p);
    p->number = n;
    p->line = ps->key_line;
    p->has_min = num(field(ps, 9), &p->min);
    p->has_max = num(field(ps, 10), &p->max);
    p->has_def = num(field(ps, 11), &p->def);
    copy(p->units, sizeof p->units, field(ps, 7));
    return true;
}

static bool end_assem(ps_t *ps)
{
    eds_t *e = ps->out;
    uint32_t n, pts[2], npts, size;
    if (!keyed(ps->key, "Assem", &n))
        return true;
    if (eds_assem(e, n) != NULL)
        return fail(ps, ps->key_line, "%s twice", ps->key);
    if (ps->nf < 3)
        return fail(ps, ps->key_line, "%s: %u fields, at least 3 expected (name, path, size)",
                    ps->key, ps->nf);
    if (e->n_assem >= EDS_MAX_ASSEM) {
        if (!ps->assem_full)
            eds_note(e, ps->key_line, "%s and later assemblies not read (%u kept)",
                         ps->key, (unsigned)EDS_MAX_ASSEM);
        ps->assem_full = true;
        return true;
    }
    eds_assem_t *a = &e->assem[e->n_assem];
    memset(a, 0, sizeof *a);
    a->number = n;
    a->line = ps->key_line;
    a->instance = n;
    a->members = ps->members;
    copy(a->name, sizeof a->name, field(ps, 0));
    const char *path = field(ps, 1);
    if (*path != '\0') {
        uint32_t inst;
        if (!epath(path, &inst, pts, &npts) || inst == 0)
            eds_note(e, ps->key_line, "%s: path \"%s\" has no instance this reader "
                         "knows; instance %lu assumed", ps->key, path, (unsigned long)n);
        else
            a->instance = inst;
    }
    const char *s = field(ps, 2);
    a->size = -1;
    if (*s != '\0') {
        if (!num(s, &size) || size > 0xFFFFu)
            return fail(ps, ps->key_line, "%s: size '%s' is not a number 0..65535", ps->key, s);
        a->size = (int32_t)size;
    }
    if (ps->members > 0 && !ps->member_unknown) {
        if (ps->member_bits % 8u != 0)
            return fail(ps, ps->member_line, "%s: members add up to %lu bits, not whole bytes",
                        ps->key, (unsigned long)ps->member_bits);
        if (a->size < 0)
            a->size = ps->member_bits / 8u > 0xFFFFu ? -1 : (int32_t)(ps->member_bits / 8u);
        else if (ps->member_bits != (uint64_t)a->size * 8u)
            return fail(ps, ps->member_line, "%s: members add up to %lu bits, the size is "
                        "%ld bytes (%ld bits)", ps->key, (unsigned long)ps->member_bits,
                        (long)a->size, (long)a->size * 8);
    }
    e->n_assem++;
    return true;
}

/* Assembly members as they come: (size in bits, reference) pairs from
 * field 7 on. */
static bool member(ps_t *ps, unsigned i, const char *s)
{
    if (ps->sect != S_ASSEM || i < 6)
        return true;
    if ((i - 6) % 2 != 0) { /* the reference: a member without a size? */
        if (ps->size_empty && *s != '\0') {
            ps->members++;
            ps->member_unknown = true;
        }
        ps->size_empty = false;
        return true;
    }
    uint32_t bits;
    ps->member_line = ps->line;
    if (*s == '\0') { /* a member only if a reference follows */
        ps->size_empty = true;
        return true;
    }
    ps->members++;
    if (!num(s, &bits) || bits > 0xFFFFu * 8u)
        return fail(ps, ps->line, "%s: member size '%s' is not a number of bits", ps->key, s);
    ps->member_bits += bits;
    return true;
}

static bool end_conn(ps_t *ps)
{
    eds_t *e = ps->out;
    uint32_t n;
    if (!keyed(ps->key, "Connection", &n))
        return true;
    for (unsigned i = 0; i < e->n_conn; i++)
        if (e->conn[i].number == n)
            return fail(ps, ps->key_line, "%s twice", ps->key);
    if (ps->nf < 15)
        return fail(ps, ps->key_line, "%s: %u fields, 15 expected", ps->key, ps->nf);
    if (e->n_conn >= EDS_MAX_CONN) {
        if (!ps->conn_full)
            eds_note(e, ps->key_line, "%s and later connections not read (%u kept)",
                         ps->key, (unsigned)EDS_MAX_CONN);
        ps->conn_full = true;
        return true;
    }
    eds_conn_t *c = &e->conn[e->n_conn];
    memset(c, 0, sizeof *c);
    c->number = n;
    c->line = ps->key_line;
    if (!need_num(ps, 0, 0xFFFFFFFFu, &c->trigger) ||
        !need_num(ps, 1, 0xFFFFFFFFu, &c->params) || !ref(ps, 2, &c->ot_rpi) ||
        !ref(ps, 3, &c->ot_size) || !ref(ps, 4, &c->ot_format) || !ref(ps, 5, &c->to_rpi) ||
        !ref(ps, 6, &c->to_size) || !ref(ps, 7, &c->to_format) || !ref(ps, 8, &c->cfg_size) ||
        !ref(ps, 9, &c->cfg_format))
        return false;
    copy(c->name, sizeof c->name, field(ps, 12));
    uint32_t pts[2] = {0, 0};
    uint32_t npts = 0;
    c->path_ok = epath(field(ps, 14), &c->path_config, pts, &npts);
    if (c->path_ok && npts == 2) {
        c->path_ot = pts[0];
        c->path_to = pts[1];
    } else if (c->path_ok && npts == 1) {
        if (c->ot_format.kind == 0 && (c->ot_size.kind == 0 || c->ot_size.value == 0))
            c->path_to = pts[0];
        else
            c->path_ot = pts[0];
    }
    e->n_conn++;
    return true;
}

static bool end_entry(ps_t *ps)
{
    switch (ps->sect) {
    case S_DEVICE: return end_device(ps);
    case S_CLASS:
        if (ieq(field(ps, 0), "EtherNetIP"))
            ps->out->ethernetip = true;
        return true;
    case S_PARAMS: return end_param(ps);
    case S_ASSEM: return end_assem(ps);
    case S_CONN: return end_conn(ps);
    default: return true;
    }
}

/* ---- sections and entries ----------------------------------------------- */

static bool section(ps_t *ps)
{
    static const struct {
        const char *name;
        sect_t s;
    } known[] = {
        {"File", S_FILE}, {"Device", S_DEVICE}, {"Device Classification", S_CLASS},
        {"Params", S_PARAMS}, {"Assembly", S_ASSEM}, {"Assem", S_ASSEM},
        {"Connection Manager", S_CONN},
    };
    char name[64];
    size_t n = 0;
    unsigned line = ps->line;
    ps->pos++; /* '[' */
    while (!at_end(ps) && cur(ps) != ']') {
        if (cur(ps) == '\n')
            return fail(ps, line, "section name not closed by ']'");
        if (bad_byte(ps))
            return false;
        if (n + 1 >= sizeof name)
            return fail(ps, line, "section name longer than %u bytes",
                        (unsigned)sizeof name - 1);
        name[n++] = cur(ps);
        ps->pos++;
    }
    if (at_end(ps))
        return fail(ps, line, "section name not closed by ']'");
    ps->pos++;
    while (n > 0 && (name[n - 1] == ' ' || name[n - 1] == '\t'))
        n--;
    name[n] = '\0';
    char *s = name;
    while (*s == ' ' || *s == '\t')
        s++;
    if (*s == '\0')
        return fail(ps, line, "empty section name");
    ps->sect = S_OTHER;
    for (size_t i = 0; i < sizeof known / sizeof known[0]; i++)
        if (ieq(s, known[i].name))
            ps->sect = known[i].s;
    if (ps->sect != S_OTHER) {
        if (ps->sect_line[ps->sect] != 0)
            return fail(ps, line, "section [%s] twice (first on line %u)", s,
                        ps->sect_line[ps->sect]);
        ps->sect_line[ps->sect] = line;
    }
    return true;
}

static bool key_char(char c)
{
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
           c == '_';
}

static bool entry(ps_t *ps)
{
    size_t n = 0;
    ps->key_line = ps->line;
    while (!at_end(ps) && key_char(cur(ps))) {
        if (n + 1 >= KEY)
            return fail(ps, ps->line, "keyword longer than %u bytes", KEY - 1);
        ps->key[n++] = cur(ps);
        ps->pos++;
    }
    ps->key[n] = '\0';
    if (n == 0) {
        char c = cur(ps);
        if (c == '=')
            return fail(ps, ps->line, "'=' without a keyword");
        return fail(ps, ps->line, "a keyword expected, not '%c'",
                    c >= 0x21 && c < 0x7F ? c : '?');
    }
    if (ps->sect == S_NONE)
        return fail(ps, ps->line, "%s before any [section]", ps->key);
    while (!at_end(ps) && (cur(ps) == ' ' || cur(ps) == '\t'))
        ps->pos++;
    if (at_end(ps) || cur(ps) != '=')
        return fail(ps, ps->line, "%s: '=' expected after the keyword", ps->key);
    ps->pos++;
    ps->nf = 0;
    ps->member_bits = 0;
    ps->members = 0;
    ps->member_unknown = false;
    ps->size_empty = false;
    for (;;) {
        char tmp[FIELD];
        char *buf = ps->nf < KEEP ? ps->f[ps->nf] : tmp;
        if (!read_field(ps, buf))
            return false;
        if (!member(ps, ps->nf, buf))
            return false;
        if (ps->nf < 0xFFFFu)
            ps->nf++;
        unsigned end_line = ps->line;
        if (!skip(ps))
            return false;
        if (at_end(ps))
            return fail(ps, end_line, "%s (line %u): ';' missing at its end", ps->key,
                        ps->key_line);
        char c = cur(ps);
        ps->pos++;
        if (c == ';')
            return end_entry(ps);
        if (c != ',')
            return fail(ps, end_line, "%s (line %u): ';' missing at its end", ps->key,
                        ps->key_line);
    }
}

bool eds_parse(const char *text, size_t len, eds_t *out, unsigned *line,
                   char *err, size_t errsize)
{
    ps_t ps;
    memset(&ps, 0, sizeof ps);
    memset(out, 0, sizeof *out);
    ps.t = text;
    ps.len = len;
    ps.line = 1;
    ps.out = out;
    ps.err = err;
    ps.errsize = errsize;
    if (errsize > 0)
        err[0] = '\0';
    bool ok = true;
    while (ok) {
        ok = skip(&ps);
        if (!ok || at_end(&ps))
            break;
        ok = cur(&ps) == '[' ? section(&ps) : entry(&ps);
    }
    out->lines = ps.line;
    if (ok && ps.sect_line[S_FILE] == 0)
        ok = fail(&ps, ps.line, "no [File] section: not an EDS");
    if (ok && ps.sect_line[S_DEVICE] == 0)
        ok = fail(&ps, ps.line, "no [Device] section");
    if (ok && (ps.device_seen & D_ALL) != D_ALL)
        ok = fail(&ps, ps.sect_line[S_DEVICE],
                  "[Device] lacks %s", !(ps.device_seen & D_VEND)  ? "VendCode"
                                       : !(ps.device_seen & D_CODE) ? "ProdCode"
                                       : !(ps.device_seen & D_MAJ)  ? "MajRev"
                                       : !(ps.device_seen & D_MIN)  ? "MinRev"
                                                                    : "ProdName");
    for (unsigned i = 0; ok && i < out->n_conn; i++) {
        const eds_conn_t *c = &out->conn[i];
        const eds_ref_t *r[] = {&c->ot_rpi, &c->ot_size, &c->ot_format, &c->to_rpi,
                                    &c->to_size, &c->to_format, &c->cfg_size, &c->cfg_format};
        for (unsigned k = 0; ok && k < sizeof r / sizeof r[0]; k++) {
            if (r[k]->kind == 'A' && eds_assem(out, r[k]->value) == NULL && !ps.assem_full)
                ok = fail(&ps, c->line, "Connection%lu: Assem%lu is not in [Assembly]",
                          (unsigned long)c->number, (unsigned long)r[k]->value);
            if (r[k]->kind == 'P' && eds_param(out, r[k]->value) == NULL &&
                !ps.params_full)
                ok = fail(&ps, c->line, "Connection%lu: Param%lu is not in [Params]",
                          (unsigned long)c->number, (unsigned long)r[k]->value);
        }
    }
    if (line != NULL)
        *line = ps.err_line;
    return ok && !ps.failed;
}

const eds_assem_t *eds_assem(const eds_t *eds, uint32_t n)
{
    for (unsigned i = 0; i < eds->n_assem && i < EDS_MAX_ASSEM; i++)
        if (eds->assem[i].number == n)
            return &eds->assem[i];
    return NULL;
}

const eds_param_t *eds_param(const eds_t *eds, uint32_t n)
{
    for (unsigned i = 0; i < eds->n_param && i < EDS_MAX_PARAM; i++)
        if (eds->param[i].number == n)
            return &eds->param[i];
    return NULL;
}

int32_t eds_size(const eds_t *eds, eds_ref_t size, eds_ref_t format)
{
    if (size.kind == 'n')
        return size.value <= 0xFFFFu ? (int32_t)size.value : -1;
    if (size.kind == 'P') {
        const eds_param_t *p = eds_param(eds, size.value);
        return p != NULL && p->has_def && p->def <= 0xFFFFu ? (int32_t)p->def : -1;
    }
    if (format.kind == 'A') {
        const eds_assem_t *a = eds_assem(eds, format.value);
        return a != NULL ? a->size : -1;
    }
    return -1;
}

uint32_t eds_instance(const eds_t *eds, eds_ref_t format, uint32_t from_path)
{
    if (format.kind == 'A') {
        const eds_assem_t *a = eds_assem(eds, format.value);
        if (a != NULL)
            return a->instance;
    }
    return from_path;
}
