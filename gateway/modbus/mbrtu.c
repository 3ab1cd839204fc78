/* SPDX-License-Identifier: MIT */
/* Modbus RTU slave on a serial line: see mbrtu.h. */
#define _DEFAULT_SOURCE /* cfmakeraw, CRTSCTS */
#include <errno.h>
#include <fcntl.h>
#include <linux/serial.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include "common/ev.h"
#include "core/log.h"
#include "modbus/mbproto.h"
#include "modbus/mbrtu.h"

struct gw_rtu {
    gw_rtu_config_t cfg;
    uint8_t unit_of[248]; /* slave address -> unit ID; 0: not ours */
    gw_mbs_hooks_t hooks;
    int epfd, fd;
    ev_t ev;
    gw_rtu_rx_t rx;
    uint64_t last_rx_us; /* when the last bytes came */
    uint64_t t35_us;
    gw_rtu_counters_t n;
    gw_mb_result_t result;
    gw_log_limit_t write_log;
    gw_log_limit_t wrote_log; /* the master's accepted writes (rate-limited) */
    uint64_t reopen_us; /* port lost: when to try it again; 0: open */
    gw_reqlog_t log;    /* the master's last requests (reqlog.h) */
};

#define REOPEN_US 1000000u

static bool port_open(gw_rtu_t *t, char *err, size_t errlen);

uint64_t gw_rtu_t35_us(unsigned baud, unsigned bits_per_char)
{
    if (baud > 19200)
        return 1750; /* the specification's fixed value */
    return (uint64_t)bits_per_char * 3500000u / baud; /* 3.5 characters */
}

/* ---- requests ------------------------------------------------------------------ */

static gw_unit_t *line_unit(void *obj, uint8_t addr)
{
    gw_rtu_t *t = obj;
    if (addr == 0 || addr > 247 || t->unit_of[addr] == 0)
        return NULL;
    return t->hooks.unit_for(t->hooks.user, t->unit_of[addr]);
}

static bool line_may_write(void *obj)
{
    const gw_rtu_t *t = obj;
    return !t->cfg.read_only;
}

static void line_wrote(void *obj)
{
    (void)obj; /* one master per line: no owner to take */
}

static bool is_write(uint8_t fc)
{
    return fc == 0x05 || fc == 0x06 || fc == 0x0F || fc == 0x10;
}

static void send_reply(gw_rtu_t *t, uint8_t addr)
{
    uint8_t out[GW_RTU_MAX];
    size_t n = gw_rtu_reply(addr, &t->result, out);
    /* The port's kernel buffer holds far more than one frame: a short
     * write means the line is gone (logged, limited). */
    ssize_t w = write(t->fd, out, n);
    if (w != (ssize_t)n)
        gw_log_limited(GW_LOG_WARNING, &t->write_log, "modbus_rtu %s: write to %s failed: %s",
                       t->cfg.name, t->cfg.device, w < 0 ? strerror(errno) : "short write");
}

/* One request for `addr` (0: broadcast). */
static void handle_one(gw_rtu_t *t, uint8_t addr, const uint8_t *pdu, size_t pdu_len)
{
    char who[GW_NAME_MAX + 32];
    snprintf(who, sizeof who, "modbus_rtu %s unit %u", t->cfg.name, t->unit_of[addr]);
    const gw_mb_env_t env = {line_unit, t, line_may_write, line_wrote, t, t->hooks.version,
                             GW_ORIGIN_MODBUS_RTU, who, &t->wrote_log, NULL};
    int ex = gw_mb_handle(addr, pdu, pdu_len, &env, &t->result);
    if (ex < 0)
        return;
    if (ex == 0 && t->result.write && t->result.dirty != 0)
        t->hooks.on_write(t->hooks.user, t->result.unit, t->result.dirty);
#ifndef GW_MB_NO_REQLOG
    gw_reqlog_add(&t->log, ev_now_us(), &t->result, ex);
#endif
    if (t->hooks.on_request != NULL)
        t->hooks.on_request(t->hooks.user, &t->result, ex, who, &t->wrote_log);
    if (t->result.reset)
        gw_log(GW_LOG_INFO, "modbus_rtu %s: the master reset the write fault of unit %u",
               t->cfg.name, t->unit_of[addr]);
}

static void handle_frame(gw_rtu_t *t, const uint8_t *frame, size_t n)
{
    uint8_t addr = frame[0];
    const uint8_t *pdu = frame + 1;
    size_t pdu_len = n - 3; /* address and CRC off */
    if (addr == 0) {
        /* Broadcast: writes only, to every robot on the line, no reply. */
        t->n.requests++;
        if (is_write(pdu[0]))
            for (unsigned a = 1; a <= 247; a++)
                if (t->unit_of[a] != 0)
                    handle_one(t, (uint8_t)a, pdu, pdu_len);
        return;
    }
    if (addr > 247 || t->unit_of[addr] == 0) {
        t->n.other++; /* another slave's request, or its reply */
        return;
    }
    t->n.requests++;
    handle_one(t, addr, pdu, pdu_len);
    if (t->result.pdu[0] & 0x80u)
        t->n.exceptions++;
    send_reply(t, addr);
}

static void drain(gw_rtu_t *t, bool silence)
{
    uint8_t frame[GW_RTU_MAX];
    size_t n;
    for (;;) {
        switch (gw_rtu_rx_next(&t->rx, silence, frame, &n)) {
        case GW_RTU_NONE: return;
        case GW_RTU_BAD: t->n.crc_errors++; break;
        case GW_RTU_FRAME: handle_frame(t, frame, n); break;
        }
    }
}

static void port_close(gw_rtu_t *t)
{
    ev_unwatch(t->epfd, &t->ev);
    if (t->fd >= 0)
        close(t->fd);
    t->fd = -1;
    t->rx.len = 0;
    t->rx.overflow = false;
}

static void on_port(void *obj, uint32_t events)
{
    gw_rtu_t *t = obj;
    uint8_t buf[GW_RTU_MAX];
    ssize_t got = read(t->fd, buf, sizeof buf);
    if (got < 0 && (errno == EAGAIN || errno == EINTR))
        return;
    if (got <= 0 || (events & (EPOLLHUP | EPOLLERR)) != 0) {
        /* A USB adapter unplugged, a pty whose other side closed: the
         * port would be reported at every turn. Tried again each second. */
        gw_log(GW_LOG_WARNING, "modbus_rtu %s: %s lost (%s): trying again every second",
               t->cfg.name, t->cfg.device, got < 0 ? strerror(errno) : "hang-up");
        port_close(t);
        t->reopen_us = ev_now_us() + REOPEN_US;
        return;
    }
    uint64_t now = ev_now_us();
    /* Bytes after t3.5 of silence start a new frame: what came before is
     * whole (the loop was late to look at it). */
    if (t->rx.len > 0 && now - t->last_rx_us >= t->t35_us)
        drain(t, true);
    t->last_rx_us = now;
    gw_rtu_rx_add(&t->rx, buf, (size_t)got);
    drain(t, false);
}

/* ---- port set-up ----------------------------------------------------------------- */

static speed_t baud_const(unsigned baud)
{
    switch (baud) {
    case 1200: return B1200;
    case 2400: return B2400;
    case 4800: return B4800;
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    default: return B230400; /* the config allows no other */
    }
}

static bool set_termios(int fd, const gw_rtu_config_t *cfg, char *err, size_t errlen)
{
    struct termios tio;
    if (tcgetattr(fd, &tio) != 0) {
        snprintf(err, errlen, "modbus_rtu %s: %s is not a serial port: %s", cfg->name,
                 cfg->device, strerror(errno));
        return false;
    }
    cfmakeraw(&tio);
    tio.c_cflag &= ~(tcflag_t)(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS);
    tio.c_cflag |= CS8 | CLOCAL | CREAD;
    if (cfg->parity != GW_PARITY_NONE)
        tio.c_cflag |= PARENB | (cfg->parity == GW_PARITY_ODD ? PARODD : 0);
    if (cfg->stop_bits == 2)
        tio.c_cflag |= CSTOPB;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    if (cfsetispeed(&tio, baud_const(cfg->baud)) != 0 ||
        cfsetospeed(&tio, baud_const(cfg->baud)) != 0 || tcsetattr(fd, TCSANOW, &tio) != 0) {
        snprintf(err, errlen, "modbus_rtu %s: cannot set up %s (%u baud): %s", cfg->name,
                 cfg->device, cfg->baud, strerror(errno));
        return false;
    }
    (void)tcflush(fd, TCIOFLUSH); /* nothing from before we listened */
    return true;
}

/* RS-485 mode: the driver drives RTS (the transceiver's direction) around
 * each frame. A port without it (a pty, many USB adapters) is logged:
 * such an adapter switches direction itself, or the line cannot work. */
static void set_rs485(int fd, const gw_rtu_config_t *cfg)
{
    struct serial_rs485 rs;
    memset(&rs, 0, sizeof rs);
    rs.flags = SER_RS485_ENABLED |
               (cfg->rts_on_send_low ? SER_RS485_RTS_AFTER_SEND : SER_RS485_RTS_ON_SEND);
    rs.delay_rts_before_send = cfg->rts_before_ms;
    rs.delay_rts_after_send = cfg->rts_after_ms;
    if (ioctl(fd, TIOCSRS485, &rs) != 0)
        gw_log(GW_LOG_WARNING,
               "modbus_rtu %s: %s refuses RS-485 mode (TIOCSRS485: %s): the adapter must "
               "switch the transceiver itself",
               cfg->name, cfg->device, strerror(errno));
    else
        gw_log(GW_LOG_INFO, "modbus_rtu %s: RS-485 mode on (RTS %s while sending)", cfg->name,
               cfg->rts_on_send_low ? "low" : "high");
}

static bool port_open(gw_rtu_t *t, char *err, size_t errlen)
{
    const gw_rtu_config_t *cfg = &t->cfg;
    t->fd = open(cfg->device, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (t->fd < 0) {
        snprintf(err, errlen, "modbus_rtu %s: cannot open %s: %s", cfg->name, cfg->device,
                 strerror(errno));
        return false;
    }
    if (!set_termios(t->fd, cfg, err, errlen)) {
        port_close(t);
        return false;
    }
    if (cfg->rs485)
        set_rs485(t->fd, cfg);
    t->ev.fn = on_port;
    t->ev.obj = t;
    if (!ev_watch(t->epfd, &t->ev, t->fd, EPOLLIN)) {
        snprintf(err, errlen, "epoll: %s", strerror(errno));
        port_close(t);
        return false;
    }
    return true;
}

gw_rtu_t *gw_rtu_new(const gw_rtu_config_t *cfg, const gw_robot_config_t *robots, int epfd,
                     const gw_mbs_hooks_t *hooks, char *err, size_t errlen)
{
    gw_rtu_t *t = calloc(1, sizeof *t);
    if (t == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    t->cfg = *cfg;
    t->hooks = *hooks;
    t->epfd = epfd;
    t->ev.fd = -1;
    for (unsigned s = 0; s < cfg->slave_count; s++)
        t->unit_of[cfg->slave_addr[s]] = robots[cfg->slave_robot[s]].side.modbus.unit_id;
    /* start bit, 8 data bits, parity, stop bits */
    unsigned bits = 1u + 8u + (cfg->parity != GW_PARITY_NONE) + cfg->stop_bits;
    t->t35_us = gw_rtu_t35_us(cfg->baud, bits);
    t->fd = -1;
    if (!port_open(t, err, errlen)) {
        gw_rtu_free(t);
        return NULL;
    }
    static const char par[] = {'N', 'E', 'O'};
    gw_log(GW_LOG_INFO, "modbus_rtu %s: slave on %s (%u %u%c%u, %u robot(s), t3.5 %llu us)",
           cfg->name, cfg->device, cfg->baud, cfg->data_bits, par[cfg->parity], cfg->stop_bits,
           cfg->slave_count, (unsigned long long)t->t35_us);
    return t;
}

void gw_rtu_free(gw_rtu_t *t)
{
    if (t == NULL)
        return;
    port_close(t);
    free(t);
}

void gw_rtu_tick(gw_rtu_t *t, uint64_t now)
{
    if (t->reopen_us != 0 && now >= t->reopen_us) {
        char err[256];
        t->reopen_us = 0;
        if (port_open(t, err, sizeof err))
            gw_log(GW_LOG_INFO, "modbus_rtu %s: %s open again", t->cfg.name, t->cfg.device);
        else
            t->reopen_us = now + REOPEN_US; /* quietly: the loss was logged */
    }
    if (t->rx.len > 0 && now - t->last_rx_us >= t->t35_us)
        drain(t, true);
}

uint64_t gw_rtu_next_deadline(const gw_rtu_t *t)
{
    if (t->reopen_us != 0)
        return t->reopen_us;
    return t->rx.len > 0 ? t->last_rx_us + t->t35_us : UINT64_MAX;
}

const gw_rtu_counters_t *gw_rtu_counters(const gw_rtu_t *t)
{
    return &t->n;
}

const gw_reqlog_t *gw_rtu_reqlog(const gw_rtu_t *t)
{
    return &t->log;
}

bool gw_rtu_serves(const gw_rtu_t *t, uint8_t unit_id)
{
    for (unsigned a = 1; a <= 247; a++)
        if (t->unit_of[a] == unit_id && unit_id != 0)
            return true;
    return false;
}
