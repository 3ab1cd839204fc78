/* SPDX-License-Identifier: MIT */
/*
 * `drgatewayd status [-c FILE]` (docs/http.md): the running daemon's
 * summary, asked of its console over loopback. The configuration says
 * where the console listens; the request is plain HTTP/1.0 to
 * /api/v1/status with "Accept: text/plain", for which the daemon answers
 * the summary it also sends to systemd, in words (api.c), and the number
 * of robots not linked in a header. A TLS console is asked on its plain
 * loopback listener (status_port). Every step has a timeout.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "core/config.h"
#include "http/http.h"

#define STATUS_TIMEOUT_MS 5000
#define STATUS_MAX 262144

static long long now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (long long)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* Wait for `ev` on fd until the deadline; false on timeout or error. */
static bool wait_fd(int fd, short ev, long long deadline)
{
    for (;;) {
        long long left = deadline - now_ms();
        if (left <= 0) {
            errno = ETIMEDOUT;
            return false;
        }
        struct pollfd p = {fd, ev, 0};
        int n = poll(&p, 1, (int)left);
        if (n > 0)
            return true;
        if (n < 0 && errno != EINTR)
            return false;
    }
}

/* The response to GET path from addr:port into buf (NUL-terminated);
 * false with why. */
static bool http_get(const char *addr, unsigned port, const char *path, bool json, char *buf,
                     size_t cap, char *why, size_t whylen)
{
    long long deadline = now_ms() + STATUS_TIMEOUT_MS;
    struct sockaddr_in sin;
    memset(&sin, 0, sizeof sin);
    sin.sin_family = AF_INET;
    sin.sin_port = htons((uint16_t)port);
    (void)inet_pton(AF_INET, addr, &sin.sin_addr);
    int fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        snprintf(why, whylen, "socket: %s", strerror(errno));
        return false;
    }
    bool ok = false;
    const char *step = "connect";
    if (connect(fd, (const struct sockaddr *)&sin, sizeof sin) != 0 && errno != EINPROGRESS)
        goto out;
    if (!wait_fd(fd, POLLOUT, deadline))
        goto out;
    int soerr = 0;
    socklen_t sl = sizeof soerr;
    if (getsockopt(fd, SOL_SOCKET, SO_ERROR, &soerr, &sl) != 0 || soerr != 0) {
        errno = soerr;
        goto out;
    }
    step = "send";
    char req[256];
    int n = snprintf(req, sizeof req,
                     "GET %s HTTP/1.0\r\nHost: %s:%u\r\nAccept: %s\r\n"
                     "User-Agent: drgatewayd-status\r\n\r\n",
                     path, addr, port, json ? "application/json" : "text/plain");
    for (int off = 0; off < n;) {
        ssize_t w = send(fd, req + off, (size_t)(n - off), MSG_NOSIGNAL);
        if (w < 0 && errno != EAGAIN && errno != EINTR)
            goto out;
        if (w < 0 && !wait_fd(fd, POLLOUT, deadline))
            goto out;
        off += w > 0 ? (int)w : 0;
    }
    step = "read the answer";
    size_t len = 0;
    for (;;) {
        if (len + 1 >= cap) {
            errno = EMSGSIZE;
            goto out;
        }
        ssize_t r = recv(fd, buf + len, cap - 1 - len, 0);
        if (r == 0)
            break;
        if (r < 0 && errno != EAGAIN && errno != EINTR)
            goto out;
        if (r < 0 && !wait_fd(fd, POLLIN, deadline))
            goto out;
        len += r > 0 ? (size_t)r : 0;
    }
    buf[len] = '\0';
    ok = true;
out:
    if (!ok)
        snprintf(why, whylen, "%s: %s", step,
                 errno == ETIMEDOUT ? "no answer within 5 s" : strerror(errno));
    (void)close(fd);
    return ok;
}

/* The value of header `name` in the head of `resp` (up to the blank
 * line), or NULL. */
static const char *header(const char *resp, const char *body, const char *name)
{
    size_t n = strlen(name);
    for (const char *p = strstr(resp, "\r\n"); p != NULL && p + 2 < body;
         p = strstr(p + 2, "\r\n"))
        if (strncasecmp(p + 2, name, n) == 0 && p[2 + n] == ':')
            return p + 3 + n + strspn(p + 3 + n, " \t");
    return NULL;
}

int gw_http_status_command(const char *config, bool json)
{
    static gw_config_t cfg;
    static char resp[STATUS_MAX];
    char err[GW_CONFIG_ERR_SIZE];
    if (!gw_config_load(config, &cfg, err, sizeof err)) {
        fprintf(stderr, "drgatewayd status: %s\n", err);
        return GW_HTTP_STATUS_UNREACHABLE;
    }
    const gw_http_config_t *h = &cfg.side.http;
    if (!h->enabled) {
        fprintf(stderr,
                "drgatewayd status: %s has no [http] section: the status is read from the "
                "console's API (docs/http.md)\n",
                config);
        return GW_HTTP_STATUS_UNREACHABLE;
    }
    const char *addr = h->listen;
    unsigned port = h->port;
    if (h->tls_cert[0] != '\0') {
        if (h->status_port == 0) {
            fprintf(stderr,
                    "drgatewayd status: the console in %s serves HTTPS only: add status_port "
                    "to [http] (a plain listener on 127.0.0.1 for this command)\n",
                    config);
            return GW_HTTP_STATUS_UNREACHABLE;
        }
        addr = "127.0.0.1";
        port = h->status_port;
    } else if (strcmp(addr, "0.0.0.0") == 0) {
        addr = "127.0.0.1"; /* loopback: no login asked */
    }
    char why[300];
    if (!http_get(addr, port, "/api/v1/status", json, resp, sizeof resp, why, sizeof why)) {
        fprintf(stderr, "drgatewayd status: cannot reach the daemon at http://%s:%u/ (%s): is "
                "it running with this configuration (%s)?\n", addr, port, why, config);
        return GW_HTTP_STATUS_UNREACHABLE;
    }
    char *body = strstr(resp, "\r\n\r\n");
    const char *sp = strchr(resp, ' ');
    unsigned long code = 0;
    if (body == NULL || strncmp(resp, "HTTP/1.", 7) != 0 || sp == NULL ||
        (code = strtoul(sp + 1, NULL, 10)) < 100 || code > 599) {
        fprintf(stderr, "drgatewayd status: http://%s:%u/ did not answer in HTTP\n", addr, port);
        return GW_HTTP_STATUS_UNREACHABLE;
    }
    body += 4;
    const char *down = header(resp, body, "X-Robots-Down");
    if (code != 200 || down == NULL) {
        fprintf(stderr, "drgatewayd status: http://%s:%u/api/v1/status answered %lu%s: %.200s\n",
                addr, port, code, code == 401 ? " (it asks a login of this address)" : "",
                body);
        return GW_HTTP_STATUS_UNREACHABLE;
    }
    fputs(body, stdout);
    return strtoul(down, NULL, 10) == 0 ? 0 : 1;
}
