/* SPDX-License-Identifier: MIT */
/*
 * drcli's own parsers of what people type: the offline commands encode and
 * decode run whole (option parsing, assembly names, FIELD=VALUE, hex input;
 * their stdout and stderr are captured), drcli set's FIELD=VALUE check
 * (cli_parse_assignment), the FIELD arguments of get / dump / watch
 * (cli_items_add_arg) and the network options (cli_net_config). The
 * library's path and value parsers below them have their own harness,
 * fuzz_path.
 *
 * Input layout (gen_corpus.c writes seeds in it):
 *   [mode][flags] arg '\0' arg '\0' ...      (at most 16 arguments)
 * mode % 4:
 *   0  drcli encode ARG... --hex
 *   1  drcli decode [--hex if flags bit 0] [--json if bit 1] -- ARG FILE:
 *      only one argument, the assembly; FILE (a memfd) holds all the bytes
 *      after its NUL
 *   2  the first four ARGs: as an argument of drcli set if it has a '=',
 *      else of drcli get
 *   3  cli_net_config: host ARG1, --port ARG2, --timeout ARG3 (an empty
 *      argument: option not given), --instance ARG4...
 *
 * Properties: exit status 0 or 2 (usage) only; a failure prints one
 * message "drcli CMD: ..." ending in a newline on stderr and nothing on
 * stdout; a success prints nothing on stderr; encode prints hex of exactly
 * the assembly's size; decode prints one line per field and mask, or one
 * JSON object with one key per leaf; an assignment set accepts is an O->T
 * field whose value sets and reads back, and encode accepts it too,
 * producing the same bytes; get's arguments add one leaf or a whole
 * assembly; accepted network options are in their ranges.
 */
#define _GNU_SOURCE /* memfd_create */
#include <jansson.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "../cli/cmd.h"
#include "../cli/error.h"
#include "../cli/fields.h"
#include "../cli/net.h"
#include "../cli/util.h"
#include "drgate/text.h"
#include "fuzz.h"

#define MAX_ARGS 16
#define ARG_MAX 512

static char args[MAX_ARGS][ARG_MAX];
static int nargs;

/* Captured output of one call. */
typedef struct {
    char *out, *err;
    size_t out_len, err_len;
    FILE *saved_out, *saved_err;
} capture_t;

static void capture_begin(capture_t *c)
{
    memset(c, 0, sizeof *c);
    c->saved_out = stdout;
    c->saved_err = stderr;
    stdout = open_memstream(&c->out, &c->out_len);
    stderr = open_memstream(&c->err, &c->err_len);
    FUZZ_CHECK(stdout != NULL && stderr != NULL);
}

static void capture_end(capture_t *c)
{
    FUZZ_CHECK(fclose(stdout) == 0 && fclose(stderr) == 0);
    stdout = c->saved_out;
    stderr = c->saved_err;
}

static void capture_free(capture_t *c)
{
    free(c->out);
    free(c->err);
}

/* One message "drcli CMD: ..." ending in a newline. */
static void check_message(const capture_t *c, const char *cmd)
{
    char head[32];
    snprintf(head, sizeof head, "drcli %s: ", cmd);
    FUZZ_CHECK(c->err_len > strlen(head) && strncmp(c->err, head, strlen(head)) == 0);
    FUZZ_CHECK(c->err[c->err_len - 1] == '\n');
}

/* Lines of drcli decode for assembly a: each mask, then every leaf. */
static size_t decode_lines(dr_asm_t a, bool masks)
{
    uint16_t count;
    size_t n = 0;
    const dr_field_t *f = dr_asm_fields(a, &count);
    for (uint16_t i = 0; i < count; i++)
        n += (masks && f[i].kind == DR_KIND_BITS) + (f[i].indexed ? f[i].count : 1u);
    return n;
}

static bool is_help(const capture_t *c, const char *cmd)
{
    char head[48];
    snprintf(head, sizeof head, "usage: drcli %s", cmd);
    return c->out_len >= strlen(head) && strncmp(c->out, head, strlen(head)) == 0;
}

/* Hex text as encode --hex prints it, into img; returns the byte count. */
static size_t unhex(const capture_t *c, uint8_t *img, size_t cap)
{
    static uint8_t buf[4 * DR_ASM_MAX_SIZE];
    size_t len = c->out_len;
    FUZZ_CHECK(len <= sizeof buf);
    memcpy(buf, c->out, len);
    capture_t q;
    capture_begin(&q);
    bool ok = cli_parse_hex("fuzz", "-", buf, &len);
    capture_end(&q);
    capture_free(&q);
    FUZZ_CHECK(ok && len <= cap);
    memcpy(img, buf, len);
    return len;
}

/* drcli encode ARGV... --hex; returns the exit status, image in img. */
static int run_encode(char **argv, int argc, capture_t *c)
{
    static const cli_net_opts_t lead;
    char *av[MAX_ARGS + 4];
    char *copy[MAX_ARGS + 4];
    av[0] = (char *)"encode";
    for (int i = 0; i < argc; i++)
        av[1 + i] = argv[i];
    av[1 + argc] = (char *)"--hex";
    memcpy(copy, av, sizeof av);
    capture_begin(c);
    int rc = cli_cmd_encode.run("encode", argc + 2, av, &lead);
    capture_end(c);
    FUZZ_CHECK(rc == CLI_EXIT_OK || rc == CLI_EXIT_USAGE);
    if (rc != CLI_EXIT_OK) {
        check_message(c, "encode");
        FUZZ_CHECK(c->out_len == 0); /* never a half-built image */
        return rc;
    }
    FUZZ_CHECK(c->err_len == 0);
    if (is_help(c, "encode"))
        return rc;
    /* The positional arguments are now av[0..): av[0] names the assembly. */
    dr_asm_t a;
    FUZZ_CHECK(dr_asm_lookup(av[0], &a) == DR_OK);
    uint8_t img[DR_ASM_MAX_SIZE];
    FUZZ_CHECK(unhex(c, img, sizeof img) == dr_asm_info(a)->size);
    return rc;
}

static void mode_encode(void)
{
    char *argv[MAX_ARGS];
    for (int i = 0; i < nargs; i++)
        argv[i] = args[i];
    capture_t c;
    run_encode(argv, nargs, &c);
    capture_free(&c);
}

static void mode_decode(unsigned flags, const char *asm_name, const uint8_t *content,
                        size_t clen)
{
    static int fd = -1;
    static char path[64];
    static const cli_net_opts_t lead;
    if (fd < 0) {
        fd = memfd_create("fuzz_cli", MFD_CLOEXEC);
        FUZZ_CHECK(fd >= 0);
        snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
    }
    FUZZ_CHECK(ftruncate(fd, 0) == 0);
    FUZZ_CHECK(clen == 0 || pwrite(fd, content, clen, 0) == (ssize_t)clen);

    char *av[8];
    int ac = 0;
    av[ac++] = (char *)"decode";
    if (flags & 1u)
        av[ac++] = (char *)"--hex";
    if (flags & 2u)
        av[ac++] = (char *)"--json";
    av[ac++] = (char *)"--"; /* so that nothing here reads stdin */
    av[ac++] = (char *)asm_name;
    av[ac++] = path;
    dr_asm_t a;
    bool known = dr_asm_lookup(asm_name, &a) == DR_OK;

    capture_t c;
    capture_begin(&c);
    int rc = cli_cmd_decode.run("decode", ac, av, &lead);
    capture_end(&c);
    FUZZ_CHECK(rc == CLI_EXIT_OK || rc == CLI_EXIT_USAGE);
    if (!(flags & 1u) && known)
        FUZZ_CHECK((rc == CLI_EXIT_OK) == (clen == dr_asm_info(a)->size));
    if (rc != CLI_EXIT_OK) {
        check_message(&c, "decode");
        FUZZ_CHECK(c.out_len == 0);
        capture_free(&c);
        return;
    }
    FUZZ_CHECK(known && c.err_len == 0);
    if (flags & 2u) {
        json_error_t e;
        json_t *j = json_loadb(c.out, c.out_len, 0, &e);
        FUZZ_CHECK(j != NULL && json_is_object(j));
        FUZZ_CHECK(json_object_size(j) == decode_lines(a, false));
        json_decref(j);
    } else {
        size_t lines = 0;
        for (size_t i = 0; i < c.out_len; i++)
            lines += c.out[i] == '\n';
        FUZZ_CHECK(lines == decode_lines(a, true));
        FUZZ_CHECK(c.out[c.out_len - 1] == '\n');
    }
    capture_free(&c);
}

static int same_value(const dr_value_t *x, const dr_value_t *y)
{
    if (x->type != y->type)
        return 0;
    switch (x->type) {
    case DR_VAL_BOOL:
    case DR_VAL_UINT:
        return x->u == y->u;
    case DR_VAL_INT:
        return x->i == y->i;
    default: {
        /* bitwise on purpose: -0.0f and 0.0f differ on the wire */
        float fx = (float)x->f, fy = (float)y->f;
        return memcmp(&fx, &fy, sizeof fx) == 0; // NOLINT(bugprone-suspicious-memory-comparison,cert-exp42-c,cert-flp37-c)
    }
    }
}

/* An unknown field costs a dr_path_closest (~0.5 ms instrumented): each
 * argument goes to set if it has a '=', to get if not, and only the first
 * ARGS_CHECKED are looked at. */
#define ARGS_CHECKED 4

/* drcli set FIELD=VALUE */
static void set_arg(int i)
{
    dr_ref_t ref;
    dr_value_t v;
    capture_t c;
    capture_begin(&c);
    bool ok = cli_parse_assignment("set", i + 1, args[i], &ref, &v);
    capture_end(&c);
    if (!ok) {
        check_message(&c, "set");
        capture_free(&c);
        return;
    }
    FUZZ_CHECK(c.err_len == 0 && c.out_len == 0);
    capture_free(&c);
    dr_asm_t a = (dr_asm_t)ref.field->assembly;
    const dr_asm_info_t *info = dr_asm_info(a);
    FUZZ_CHECK(info->dir == DR_DIR_O2T);
    uint8_t img[DR_ASM_MAX_SIZE] = {0};
    dr_value_t back;
    FUZZ_CHECK(dr_field_set(img, info->size, ref, &v, DR_SET_O2T_ONLY) == DR_OK);
    FUZZ_CHECK(dr_field_get(img, info->size, ref, &back) == DR_OK);
    FUZZ_CHECK(same_value(&v, &back));
    /* encode takes the same assignment and builds the same image. */
    char *argv[2] = {(char *)info->name, args[i]};
    capture_t e;
    FUZZ_CHECK(run_encode(argv, 2, &e) == CLI_EXIT_OK);
    uint8_t enc[DR_ASM_MAX_SIZE];
    FUZZ_CHECK(unhex(&e, enc, sizeof enc) == info->size);
    FUZZ_CHECK(memcmp(enc, img, info->size) == 0);
    capture_free(&e);
}

/* drcli get FIELD|ASSEMBLY */
static void get_arg(int i)
{
    static cli_items_t items;
    size_t before = items.n = (size_t)i % 3u * 400u; /* also near the limit */
    capture_t c;
    capture_begin(&c);
    bool ok = cli_items_add_arg("get", &items, i + 1, args[i], true);
    capture_end(&c);
    if (!ok) {
        check_message(&c, "get");
        FUZZ_CHECK(items.n == before);
        capture_free(&c);
        return;
    }
    FUZZ_CHECK(c.err_len == 0);
    capture_free(&c);
    dr_asm_t a;
    if (dr_asm_lookup(args[i], &a) == DR_OK)
        FUZZ_CHECK(items.n == before + decode_lines(a, true));
    else
        FUZZ_CHECK(items.n == before + 1);
    for (size_t k = before; k < items.n; k++) {
        char path[64];
        FUZZ_CHECK(dr_ref_path(items.ref[k], path, sizeof path) == DR_OK);
    }
}

/* An unknown field costs a dr_path_closest (~0.5 ms instrumented): each
 * argument goes to set if it has a '=', to get if not, and only the first
 * ARGS_CHECKED are looked at. */
#define ARGS_CHECKED 4

static void mode_args(void)
{
    for (int i = 0; i < nargs && i < ARGS_CHECKED; i++) {
        if (strchr(args[i], '=') != NULL)
            set_arg(i);
        else
            get_arg(i);
    }
}

static void mode_net(void)
{
    cli_net_opts_t o;
    memset(&o, 0, sizeof o);
    o.host = nargs > 0 && args[0][0] ? args[0] : NULL;
    o.port = nargs > 1 && args[1][0] ? args[1] : NULL;
    o.timeout = nargs > 2 && args[2][0] ? args[2] : NULL;
    for (int i = 3; i < nargs; i++)
        o.instance.v[o.instance.n++] = args[i];
    dr_client_config_t cfg;
    capture_t c;
    capture_begin(&c);
    int rc = cli_net_config("get", &o, &cfg);
    capture_end(&c);
    FUZZ_CHECK(rc == CLI_EXIT_OK || rc == CLI_EXIT_USAGE);
    if (rc != CLI_EXIT_OK) {
        check_message(&c, "get");
    } else {
        FUZZ_CHECK(c.err_len == 0);
        FUZZ_CHECK(o.host != NULL && cfg.host == o.host && strlen(cfg.host) <= 255);
        FUZZ_CHECK(cfg.tcp_port >= 1);
        FUZZ_CHECK(o.port != NULL || cfg.tcp_port == DR_ENIP_TCP_PORT);
        FUZZ_CHECK(cfg.timeout_ms >= 1 && cfg.timeout_ms <= 3600000u);
        FUZZ_CHECK(o.timeout != NULL || cfg.timeout_ms == 2000);
    }
    capture_free(&c);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static bool init;
    if (!init) {
        unsetenv("DRCLI_HOST"); /* cli_net_config's default host */
        init = true;
    }
    if (size < 2)
        return 0;
    unsigned mode = data[0] % 4u, flags = data[1];
    const uint8_t *p = data + 2, *end = data + size;
    if (mode == 1) {
        const uint8_t *z = memchr(p, 0, (size_t)(end - p));
        size_t n = (size_t)((z != NULL ? z : end) - p);
        if (n >= ARG_MAX)
            n = ARG_MAX - 1;
        memcpy(args[0], p, n);
        args[0][n] = '\0';
        p = z != NULL ? z + 1 : end;
        mode_decode(flags, args[0], p, (size_t)(end - p));
        return 0;
    }
    nargs = 0;
    while (p < end && nargs < MAX_ARGS) {
        const uint8_t *z = memchr(p, 0, (size_t)(end - p));
        size_t n = (size_t)((z != NULL ? z : end) - p);
        if (n >= ARG_MAX)
            n = ARG_MAX - 1;
        memcpy(args[nargs], p, n);
        args[nargs][n] = '\0';
        nargs++;
        p = z != NULL ? z + 1 : end;
    }
    switch (mode) {
    case 0: mode_encode(); break;
    case 2: mode_args(); break;
    default: mode_net(); break;
    }
    return 0;
}
