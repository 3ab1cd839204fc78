/* SPDX-License-Identifier: MIT */
/*
 * The OPC UA side in a build without open62541 (Debian 12 has no package
 * of it; the Makefile compiles this file instead of north_opcua.c): the
 * configuration refuses an [opcua] section (config_opcua.c), so the side
 * never has anything to do.
 */
#include "core/north.h"

static char ua_none;

static void *op_create(const gw_north_env_t *env, char *err, size_t errlen)
{
    (void)env;
    (void)err;
    (void)errlen;
    return &ua_none;
}

static gw_north_reload_t op_prepare(void *self, const gw_config_t *next, const gw_north_env_t *env,
                                    void **out, char *err, size_t errlen)
{
    (void)next;
    (void)env;
    (void)err;
    (void)errlen;
    *out = self;
    return GW_NORTH_OK;
}

static void op_abort(void *self, void *out)
{
    (void)self;
    (void)out;
}

static void *op_commit(void *self, void *out, const gw_north_env_t *env)
{
    (void)self;
    (void)env;
    return out;
}

static void op_nothing(void *self)
{
    (void)self;
}

static void op_tick(void *self, uint64_t now)
{
    (void)self;
    (void)now;
}

static uint64_t op_deadline(const void *self)
{
    (void)self;
    return UINT64_MAX;
}

static void op_on_data(void *self, unsigned robot, dr_asm_t a)
{
    (void)self;
    (void)robot;
    (void)a;
}

static void op_on_flag(void *self, unsigned robot, bool on)
{
    (void)self;
    (void)robot;
    (void)on;
}

const gw_north_ops_t gw_north_opcua = {
    .name = "opcua",
    .create = op_create,
    .prepare = op_prepare,
    .abort = op_abort,
    .commit = op_commit,
    .tick = op_tick,
    .deadline = op_deadline,
    .on_data = op_on_data,
    .on_link = op_on_flag,
    .on_fault = op_on_flag,
    .refresh = op_nothing,
    .safe = op_nothing,
    .free = op_nothing,
};

