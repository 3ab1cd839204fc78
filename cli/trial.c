/* SPDX-License-Identifier: MIT */
/*
 * drcli probe --open: one Forward Open trial through the client's own
 * connection machinery (dr_conn_add), so that what a trial opens is
 * closed the way drgatewayd's connections are: dr_conn_remove sends the
 * Forward Close of an established connection, and the close by triad of
 * an open that got no answer (drgate/client.h, "Forward Opens nobody
 * waits for").
 */
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "error.h"
#include "trial.h"

/* What the connection's state callback saw. */
typedef struct {
    bool done;
    dr_status_t status;
} trial_state_t;

static void trial_on_state(dr_conn_t *conn, dr_conn_state_t state, dr_status_t reason,
                           void *user)
{
    trial_state_t *t = user;
    (void)conn;
    if (t->done)
        return;
    if (state == DR_CONN_ESTABLISHED) {
        t->done = true;
        t->status = DR_OK;
    } else if (state == DR_CONN_RECONNECTING || state == DR_CONN_TIMED_OUT) {
        /* refused (reason: the CIP status), or no answer */
        t->done = true;
        t->status = reason != DR_OK ? reason : DR_ETIMEDOUT;
    }
}

static uint64_t mono_ms(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0)
        return 0;
    return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

/* Run the client's loop until *until(arg) or timeout_ms have passed. */
static bool run_until(cli_net_t *net, bool (*until)(const void *), const void *arg,
                      uint32_t timeout_ms)
{
    uint64_t end = mono_ms() + timeout_ms;
    while (!until(arg)) {
        uint64_t now = mono_ms();
        if (now >= end)
            return false;
        uint64_t left = end - now;
        (void)dr_client_run_once(net->client, left < 50u ? (int)left : 50);
    }
    return true;
}

static bool trial_done(const void *arg)
{
    return ((const trial_state_t *)arg)->done;
}

int cli_trial(cli_net_t *net, const cli_trial_req_t *rq, uint32_t rpi_ms,
              cli_trial_res_t *res)
{
    memset(res, 0, sizeof *res);
    res->size = -1;
    trial_state_t t = {false, DR_OK};
    dr_conn_config_t cc;
    memset(&cc, 0, sizeof cc);
    cc.o2t_asm = rq->o2t_instance != 0 ? rq->o2t_asm : -1;
    cc.t2o_asm = rq->t2o_asm;
    cc.heartbeat_instance = CLI_TRIAL_HEARTBEAT;
    cc.rpi_us = rpi_ms * 1000u;
    cc.timeout_mult = 2;
    cc.on_state = trial_on_state;
    cc.user = &t;
    cc.t2o_instance = rq->t2o_instance;
    cc.t2o_size = rq->t2o_size;
    cc.o2t_instance = rq->o2t_instance;
    cc.o2t_size = rq->o2t_instance != 0 ? rq->o2t_size : 0;
    dr_status_t st = DR_OK;
    dr_conn_t *conn = dr_conn_add(net->client, &cc, &st);
    if (conn == NULL) {
        res->status = st;
        return CLI_EXIT_OK;
    }
    /* Idle from the first O->T packet: an adapter takes no output data
     * from an idle packet (drsim: sim/adapter.c, consume). */
    dr_conn_set_run(conn, false);
    /* The open's own timeout resets the session (client.h): one request
     * timeout and a little more is enough to see the answer or its lack. */
    (void)run_until(net, trial_done, &t, net->timeout_ms + 1000u);
    res->status = t.done ? t.status : DR_ETIMEDOUT;
    res->opened = t.done && t.status == DR_OK;
    /* only the adapter's own word (success or a CIP status) is an answer;
     * a timeout or a lost session leaves the open's fate unknown */
    res->answered = t.done && (t.status == DR_OK || DR_IS_CIP(t.status));
    res->wanted = dr_conn_stats(conn)->size_wanted;
    if (!res->answered)
        /* The adapter may have opened it, and the client reset the
         * session (client.h): a new one first, in which dr_conn_remove
         * closes the open by its triad before anything else is asked. */
        (void)dr_client_connect_sync(net->client);
    dr_conn_remove(conn); /* Forward Close (established), close by triad (unanswered) */
    bool owner = rq->o2t_instance != 0;
    uint16_t asked = owner ? rq->o2t_size : rq->t2o_size;
    /* network size = data + 2 (sequence count) + 4 (run/idle header, O->T
     * of an owner only; T->O is modeless) */
    unsigned hdr = owner ? 6u : 2u;
    if (res->opened)
        res->size = asked;
    /* an input-only trial's 6 may be the heartbeat's size with a run/idle
     * header rather than the T->O point's: not believed */
    else if (res->status == DR_CIP(0x01, 0x0109) && res->wanted >= hdr &&
             (owner || res->wanted != 6u))
        res->size = res->wanted - (int)hdr;
    if (!dr_client_ready(net->client) && !res->answered)
        return cli_net_fail(net, res->status, "(Forward Open trial: the session did not "
                            "come back to close what it may have opened)");
    return CLI_EXIT_OK;
}

void cli_trial_text(const cli_trial_req_t *rq, const cli_trial_res_t *res, char *out,
                    size_t size)
{
    char what[96], result[200];
    bool owner = rq->o2t_instance != 0;
    if (owner)
        snprintf(what, sizeof what, "O->T %u (exclusive owner, T->O %u), asked %u bytes",
                 (unsigned)rq->o2t_instance, (unsigned)rq->t2o_instance,
                 (unsigned)rq->o2t_size);
    else
        snprintf(what, sizeof what, "T->O %u (input-only, heartbeat %u), asked %u bytes",
                 (unsigned)rq->t2o_instance, CLI_TRIAL_HEARTBEAT, (unsigned)rq->t2o_size);
    if (res->opened)
        snprintf(result, sizeof result, "opened, closed by Forward Close: %d bytes",
                 res->size);
    else if (res->size >= 0)
        snprintf(result, sizeof result, "refused (%s), the adapter's size %u bytes with "
                 "headers: %d bytes", dr_strerror(res->status), (unsigned)res->wanted,
                 res->size);
    else if (!res->answered)
        snprintf(result, sizeof result, "no answer (%s), closed by its connection triad",
                 dr_strerror(res->status));
    else
        snprintf(result, sizeof result, "refused (%s)", dr_strerror(res->status));
    snprintf(out, size, "%s: %s", what, result);
}
