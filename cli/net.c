/* SPDX-License-Identifier: MIT */
/*
 * drcli network plumbing shared by get, dump, set, watch, identity and
 * probe: the common options, the client's configuration, the session,
 * reading assemblies and the one way failures are reported (host:port,
 * step, status in words, exit code 3 or 4).
 */
#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "net.h"
#include "util.h"

const char cli_net_help[] =
    "  -H, --host HOST     the robot (name or IPv4 address); default\n"
    "                      $DRCLI_HOST\n"
    "      --port N        encapsulation TCP port (default 44818)\n"
    "      --timeout MS    limit for connecting and for each request\n"
    "                      (default 2000)\n"
    "      --instance ASSEMBLY=N\n"
    "                      assembly instance to use for ASSEMBLY (name or\n"
    "                      alias); repeatable; defaults 101..110; with\n"
    "                      --layout combined or gpr_only: input=N, output=N\n"
    "                      (defaults 100 and 150)\n"
    "      --layout NAME   how the robot offers the assemblies: per_assembly\n"
    "                      (default), combined (the six T->O assemblies in one\n"
    "                      476-byte instance, the four O->T ones in one of 212),\n"
    "                      gpr_only (the registers, 200 bytes each way)\n"
    "      --route         wrap requests in Unconnected Send (route 1/0),\n"
    "                      for devices that want a routed request\n"
    "      --json          JSON output (commands that print values)\n"
    "      --raw           hex dump of the bytes next to the decode\n";

size_t cli_net_optv(cli_net_opts_t *o, cli_opt_t *out)
{
    const cli_opt_t opts[CLI_NET_NOPTS] = {
        {"host", 'H', NULL, &o->host, NULL},
        {"port", 0, NULL, &o->port, NULL},
        {"timeout", 0, NULL, &o->timeout, NULL},
        {"instance", 0, NULL, NULL, &o->instance},
        {"layout", 0, NULL, &o->layout, NULL},
        {"route", 0, &o->route, NULL, NULL},
        {"json", 0, &o->json, NULL, NULL},
        {"raw", 0, &o->raw, NULL, NULL},
    };
    memcpy(out, opts, sizeof opts);
    return CLI_NET_NOPTS;
}

bool cli_net_any(const cli_net_opts_t *o)
{
    return o->host != NULL || o->port != NULL || o->timeout != NULL ||
           o->instance.n > 0 || o->layout != NULL || o->json || o->raw || o->route;
}

int cli_net_refuse(const char *cmd, const cli_net_opts_t *o, bool json_ok,
                   bool raw_ok)
{
    if (o->json && !json_ok)
        return cli_error(CLI_EXIT_USAGE, cmd, "--json does not apply to %s", cmd);
    if (o->raw && !raw_ok)
        return cli_error(CLI_EXIT_USAGE, cmd, "--raw does not apply to %s", cmd);
    return CLI_EXIT_OK;
}

/* ---- configuration ------------------------------------------------------ */

bool cli_parse_ulong(const char *text, unsigned long min, unsigned long max,
                     unsigned long *out)
{
    if (text[0] < '0' || text[0] > '9')
        return false;
    char *end;
    errno = 0;
    unsigned long v = strtoul(text, &end, 10);
    if (errno != 0 || *end != '\0' || v < min || v > max)
        return false;
    *out = v;
    return true;
}

/* The layout cli_net_config checked, for cli_net_connect: drcli runs
 * one command per process. */
static dr_layout_t net_layout;

/* --instance ASSEMBLY=N */
static bool parse_instance(const char *cmd, const char *text,
                           dr_client_config_t *cfg)
{
    const char *eq = strchr(text, '=');
    char name[32];
    unsigned long n;
    size_t len = eq != NULL ? (size_t)(eq - text) : 0;
    if (eq == NULL || len == 0 || len >= sizeof name) {
        cli_error(CLI_EXIT_USAGE, cmd, "--instance '%s': expected ASSEMBLY=N", text);
        return false;
    }
    memcpy(name, text, len);
    name[len] = '\0';
    if (!cli_parse_ulong(eq + 1, 1, 65535, &n)) {
        cli_error(CLI_EXIT_USAGE, cmd,
                  "--instance '%s': the instance must be a number in 1..65535", text);
        return false;
    }
    bool in = strcmp(name, "input") == 0, out = strcmp(name, "output") == 0;
    if ((in || out) != (net_layout.kind != DR_LAYOUT_PER_ASSEMBLY)) {
        cli_error(CLI_EXIT_USAGE, cmd,
                  "--instance '%s': %s", text,
                  in || out ? "input= and output= need --layout combined or gpr_only"
                            : "with --layout combined or gpr_only, name input or output");
        return false;
    }
    if (in || out) {
        (in ? &net_layout.input : &net_layout.output)->instance = (uint16_t)n;
        return true;
    }
    dr_asm_t a;
    if (!cli_lookup_asm(cmd, name, &a))
        return false;
    cfg->instance[a] = (uint16_t)n;
    return true;
}

int cli_net_config(const char *cmd, const cli_net_opts_t *o,
                   dr_client_config_t *cfg)
{
    unsigned long n;
    memset(cfg, 0, sizeof *cfg);
    cfg->host = o->host != NULL ? o->host : getenv("DRCLI_HOST");
    if (cfg->host == NULL || cfg->host[0] == '\0')
        return cli_error(CLI_EXIT_USAGE, cmd,
                         "no robot given: use -H HOST or set DRCLI_HOST");
    if (strlen(cfg->host) > 255)
        return cli_error(CLI_EXIT_USAGE, cmd, "host name longer than 255 characters");
    cfg->tcp_port = DR_ENIP_TCP_PORT;
    if (o->port != NULL) {
        if (!cli_parse_ulong(o->port, 1, 65535, &n))
            return cli_error(CLI_EXIT_USAGE, cmd,
                             "--port '%s': expected a port number in 1..65535", o->port);
        cfg->tcp_port = (uint16_t)n;
    }
    cfg->timeout_ms = 2000;
    if (o->timeout != NULL) {
        if (!cli_parse_ulong(o->timeout, 1, 3600000, &n))
            return cli_error(CLI_EXIT_USAGE, cmd,
                             "--timeout '%s': expected milliseconds in 1..3600000",
                             o->timeout);
        cfg->timeout_ms = (uint32_t)n;
    }
    dr_layout_kind_t kind = DR_LAYOUT_PER_ASSEMBLY;
    if (o->layout != NULL && dr_layout_lookup(o->layout, &kind) != DR_OK)
        return cli_error(CLI_EXIT_USAGE, cmd,
                         "--layout '%s': expected per_assembly, combined or gpr_only",
                         o->layout);
    dr_layout_default(&net_layout, kind);
    for (size_t i = 0; i < o->instance.n; i++)
        if (!parse_instance(cmd, o->instance.v[i], cfg))
            return CLI_EXIT_USAGE;
    cfg->route = o->route;
    /* drcli sends a Forward Open only in probe --open's trial, where the
     * originator serial counts; a stable one, as drgatewayd has, rather
     * than the library's clock fallback. */
    cfg->serial = dr_originator_serial_local(cfg->host);
    return CLI_EXIT_OK;
}

/* ---- session and failures ------------------------------------------------- */

int cli_net_exit_code(dr_status_t st)
{
    return DR_IS_CIP(st) ? CLI_EXIT_CIP : CLI_EXIT_NETWORK;
}

int cli_net_fail(cli_net_t *net, dr_status_t st, const char *what)
{
    const char *step = net->client != NULL ? dr_client_last_step(net->client) : "";
    char detail[64] = "";
    if (DR_IS_CIP(st) && DR_CIP_EXTENDED(st) != 0)
        snprintf(detail, sizeof detail, " (CIP status 0x%02x, extended 0x%04x)",
                 DR_CIP_GENERAL(st), DR_CIP_EXTENDED(st));
    else if (DR_IS_CIP(st))
        snprintf(detail, sizeof detail, " (CIP status 0x%02x)", DR_CIP_GENERAL(st));
    else if (DR_IS_ENCAP(st))
        snprintf(detail, sizeof detail, " (encapsulation status 0x%04x)",
                 (unsigned)(st & 0xFFFF));
    else if (st == DR_ETIMEDOUT || st == DR_ENOANSWER || st == DR_ENOREGISTER)
        snprintf(detail, sizeof detail, " after %" PRIu32 " ms", net->timeout_ms);
    return cli_error(cli_net_exit_code(st), net->cmd, "%s: %s%s%s: %s%s",
                     net->where, step[0] != '\0' ? step : "request",
                     what != NULL ? " " : "", what != NULL ? what : "",
                     dr_strerror(st), detail);
}

int cli_net_connect(const char *cmd, const dr_client_config_t *cfg,
                    cli_net_t *net)
{
    memset(net, 0, sizeof *net);
    net->cmd = cmd;
    net->layout = net_layout;
    net->host = cfg->host;
    net->tcp_port = cfg->tcp_port;
    net->timeout_ms = cfg->timeout_ms;
    snprintf(net->where, sizeof net->where, "%s:%u", cfg->host,
             (unsigned)cfg->tcp_port);
    dr_status_t err;
    net->client = dr_client_new(cfg, &err);
    if (net->client == NULL)
        return cli_error(CLI_EXIT_FAIL, cmd, "%s: cannot set up the client: %s",
                         net->where, dr_strerror(err));
    dr_status_t st = dr_client_connect_sync(net->client);
    if (st != DR_OK) {
        int rc = cli_net_fail(net, st, NULL);
        cli_net_close(net);
        return rc;
    }
    return CLI_EXIT_OK;
}

void cli_net_close(cli_net_t *net)
{
    dr_client_free(net->client); /* closes within the client's timeout */
    net->client = NULL;
}

/* ---- reading assemblies --------------------------------------------------- */

/* The combined layout's point that carries a; NULL in layout
 * per_assembly or when no point carries it. */
static const dr_point_t *point_of(const cli_net_t *net, dr_asm_t a)
{
    if (net->layout.kind == DR_LAYOUT_PER_ASSEMBLY)
        return NULL;
    const dr_point_t *p = dr_asm_info(a)->dir == DR_DIR_T2O ? &net->layout.input
                                                             : &net->layout.output;
    return dr_point_has(p, a) ? p : NULL;
}

void cli_net_asm_label(const cli_net_t *net, dr_asm_t a, char *out, size_t size)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    const dr_point_t *p = point_of(net, a);
    if (net->layout.kind != DR_LAYOUT_PER_ASSEMBLY && p != NULL)
        snprintf(out, size, "%s (%s, bytes %d-%d of %s instance %u)", info->name, info->alias,
                 dr_point_offset(p, a), dr_point_offset(p, a) + info->size - 1,
                 p == &net->layout.input ? "input" : "output", (unsigned)p->instance);
    else if (net->layout.kind != DR_LAYOUT_PER_ASSEMBLY)
        snprintf(out, size, "%s (%s, not in layout %s)", info->name, info->alias,
                 dr_layout_name(net->layout.kind));
    else
        snprintf(out, size, "%s (%s, instance %u)", info->name, info->alias,
                 (unsigned)dr_client_instance(net->client, a));
}

/* Read the whole point p: exactly its size. */
static int read_point(cli_net_t *net, const dr_point_t *p, const char *label, uint8_t *img)
{
    uint8_t tmp[DR_ENCAP_MAX_LEN];
    size_t got = 0;
    dr_status_t st = dr_client_get_attr_sync(net->client, DR_CIP_CLASS_ASSEMBLY, p->instance,
                                             DR_CIP_ASM_ATTR_DATA, tmp, sizeof tmp, &got);
    if (st != DR_OK)
        return cli_net_fail(net, st, label);
    if (got != p->size)
        return cli_error(CLI_EXIT_NETWORK, net->cmd,
                         "%s: get %s: the device sent %zu bytes, layout %s says %u",
                         net->where, label, got, dr_layout_name(net->layout.kind),
                         (unsigned)p->size);
    memcpy(img, tmp, got);
    return CLI_EXIT_OK;
}

int cli_net_write_asm(cli_net_t *net, dr_asm_t a, const uint8_t *img)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    char label[96];
    cli_net_asm_label(net, a, label, sizeof label);
    const dr_point_t *p = point_of(net, a);
    uint8_t buf[DR_POINT_MAX_SIZE];
    const uint8_t *data = img;
    uint16_t inst = dr_client_instance(net->client, a), size = info->size;
    if (net->layout.kind != DR_LAYOUT_PER_ASSEMBLY) {
        if (p == NULL)
            return cli_error(CLI_EXIT_USAGE, net->cmd, "%s: set %s", net->where, label);
        int rc = read_point(net, p, label, buf);
        if (rc != CLI_EXIT_OK)
            return rc;
        (void)dr_point_put(p, buf, p->size, a, img, info->size);
        data = buf;
        inst = p->instance;
        size = p->size;
    }
    dr_status_t st = dr_client_set_attr_sync(net->client, DR_CIP_CLASS_ASSEMBLY, inst,
                                             DR_CIP_ASM_ATTR_DATA, data, size);
    return st == DR_OK ? CLI_EXIT_OK : cli_net_fail(net, st, label);
}

int cli_net_read_asm(cli_net_t *net, dr_asm_t a, uint8_t *img)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    if (net->layout.kind != DR_LAYOUT_PER_ASSEMBLY) {
        char label[96];
        cli_net_asm_label(net, a, label, sizeof label);
        const dr_point_t *p = point_of(net, a);
        uint8_t point_img[DR_POINT_MAX_SIZE];
        if (p == NULL)
            return cli_error(CLI_EXIT_USAGE, net->cmd, "%s: get %s", net->where, label);
        int rc = read_point(net, p, label, point_img);
        if (rc != CLI_EXIT_OK)
            return rc;
        uint8_t *out = img;
        return dr_point_slice(p, point_img, p->size, a, out, info->size) == DR_OK
                   ? CLI_EXIT_OK
                   : cli_error(CLI_EXIT_FAIL, net->cmd, "internal error slicing %s", label);
    }
    uint8_t tmp[DR_ENCAP_MAX_LEN];
    size_t got = 0;
    char label[64];
    cli_net_asm_label(net, a, label, sizeof label);
    dr_status_t st = dr_client_get_attr_sync(net->client, DR_CIP_CLASS_ASSEMBLY,
                                             dr_client_instance(net->client, a),
                                             DR_CIP_ASM_ATTR_DATA, tmp, sizeof tmp,
                                             &got);
    if (st != DR_OK)
        return cli_net_fail(net, st, label);
    if (got != info->size)
        return cli_error(CLI_EXIT_NETWORK, net->cmd,
                         "%s: get %s: the device sent %zu bytes, the "
                         "specification says %u", net->where, label, got,
                         (unsigned)info->size);
    memcpy(img, tmp, got);
    return CLI_EXIT_OK;
}

int cli_net_read(cli_net_t *net, cli_images_t *im)
{
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        if (!im->want[a])
            continue;
        int rc = cli_net_read_asm(net, (dr_asm_t)a, im->img[a]);
        if (rc != CLI_EXIT_OK)
            return rc;
    }
    return CLI_EXIT_OK;
}
