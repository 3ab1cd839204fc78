/* SPDX-License-Identifier: MIT */
/*
 * drcli probe --open: the Forward Open trial (trial.c). Where an adapter
 * does not answer Get_Attribute_Single on its assembly instances, the
 * size of a connection point shows in a Forward Open: the adapter accepts
 * the size asked for, or refuses it with 0x01/0x0109 (invalid connection
 * size) and names its own size in the second word of the extended status.
 * Every trial ends with what it opened closed: a Forward Close for an
 * accepted open, for one whose answer never came too (after the session
 * is back), before the next request of the session.
 */
#ifndef DRCLI_TRIAL_H
#define DRCLI_TRIAL_H

#include <stdbool.h>
#include <stdint.h>

#include "net.h"

/* The heartbeat connection point of an input-only trial (drgatewayd's
 * default input_only_heartbeat). */
#define CLI_TRIAL_HEARTBEAT 198u

/* One trial: an input-only connection to a T->O point (o2t_instance 0),
 * or an exclusive owner of an O->T point with a T->O point whose size is
 * known. Sizes are data bytes, without the headers the client adds. */
typedef struct {
    uint16_t t2o_instance, t2o_size;
    uint16_t o2t_instance, o2t_size; /* 0, 0: input-only */
    dr_asm_t t2o_asm; /* a T->O assembly, for the client's configuration */
    int o2t_asm;      /* an O->T assembly, or -1 (input-only) */
} cli_trial_req_t;

typedef struct {
    dr_status_t status; /* DR_OK: it opened; else the refusal, DR_ETIMEDOUT */
    int size;           /* data bytes of the point tried (O->T for an owner
                           trial, else T->O); -1: not learned */
    uint16_t wanted;    /* the adapter's network size from 0x0109; 0: none */
    bool opened;        /* the adapter accepted it: a Forward Close followed */
    bool answered;      /* false: no answer, closed by its triad once the
                           session was back (or, if it never came back,
                           left to the adapter's timeout: see *.status) */
} cli_trial_res_t;

/* Run one trial in net's session (rpi_ms both ways, idle O->T: the
 * adapter applies no output data). Returns an exit code for failures
 * that end the probe (the session lost for good); refusals land in res. */
int cli_trial(cli_net_t *net, const cli_trial_req_t *rq, uint32_t rpi_ms,
              cli_trial_res_t *res);

/* "T->O 100 (input-only, heartbeat 198), asked 476 bytes: refused ..."
 * into out[size], for the probe's report. */
void cli_trial_text(const cli_trial_req_t *rq, const cli_trial_res_t *res, char *out,
                    size_t size);

#endif /* DRCLI_TRIAL_H */
