/* SPDX-License-Identifier: MIT */
/*
 * Sparkplug B commands as a host (or anyone on the broker) sends them
 * (gateway/mqtt/sparkplug.c): an edge node with one robot is born (NBIRTH,
 * DBIRTH), then the input is one message: its first byte chooses the
 * settings (writes on or off, a primary host) and the topic (NCMD, DCMD to
 * the robot, DCMD to an unknown device, the primary host's STATE, another
 * spBv1.0 topic), the rest is the payload, through spb_message; then the
 * node ticks again.
 *
 * Checks: the robot's T->O images never change, and with writes off no
 * image does; a write reaches the image only through the write hook,
 * only to an O->T field, only with a value the codec accepts for it
 * (dr_value_check), as the gateway's write path does; every payload the
 * node publishes (births, DDATA echoes of refusals) decodes with the same
 * decoder (protobuf the node writes is protobuf it reads); the node is
 * born before and after (a command never kills it; a STATE offline or
 * Next Server leaves the server at most once a message).
 */
#include <string.h>

#include "common/ev.h"
#include "core/log.h"
#include "fuzz.h"
#include "mqtt/sparkplug.h"

static gw_config_t C;
static gw_robot_t R[GW_MAX_ROBOTS];
static gw_robot_t before;
static unsigned published, writes, leaves;

static bool count_metric(void *ctx, const spb_metric_t *m)
{
    (void)m;
    ++*(unsigned *)ctx;
    return true;
}

/* What the gateway publishes keeps Sparkplug 3.0's rules: every metric
 * timestamped, Node Control/Rebirth never aliased. */
static bool check_metric(void *ctx, const spb_metric_t *m)
{
    FUZZ_CHECK(m->pb.has_timestamp);
    FUZZ_CHECK(!(m->has_name && strcmp(m->name, SPB_REBIRTH) == 0 && m->pb.has_alias));
    ++*(unsigned *)ctx;
    return true;
}

static bool io_publish(void *user, const char *topic, const void *p, size_t len, int qos,
                       bool retain)
{
    unsigned n = 0;
    (void)user;
    FUZZ_CHECK(strncmp(topic, "spBv1.0/g/", 10) == 0 && !retain);
    /* only NDEATH (at a stop, or leaving a server) at QoS 1 */
    FUZZ_CHECK(qos == 0 || (qos == 1 && strstr(topic, "/NDEATH/") != NULL));
    FUZZ_CHECK(spb_decode_cmd(p, len, check_metric, &n));
    published++;
    return true;
}

static bool io_subscribe(void *user, const char *topic, int qos)
{
    (void)user, (void)topic, (void)qos;
    return true;
}

static bool io_room(void *user)
{
    (void)user;
    return true;
}

/* The gateway's checks in short: the codec's (O->T only, range), on the
 * whole command (decoded first: every item passed the codec's checks). */
static bool io_write(void *user, unsigned robot, const gw_write_item_t *items, unsigned n,
                     gw_write_result_t *res, char *why, size_t whylen)
{
    (void)user;
    FUZZ_CHECK(robot == 0);
    FUZZ_CHECK(n >= 1 && n <= SPB_CMD_MAX);
    memset(res, 0, sizeof *res);
    for (unsigned i = 0; i < n; i++) {
        dr_ref_t ref = items[i].ref;
        dr_asm_t a = (dr_asm_t)ref.field->assembly;
        FUZZ_CHECK(dr_asm_info(a)->dir == DR_DIR_O2T);
        FUZZ_CHECK(dr_value_check(ref, &items[i].value, DR_SET_O2T_ONLY) == DR_OK);
        dr_status_t st = dr_field_set(R[0].img[a], dr_asm_info(a)->size, ref, &items[i].value,
                                      DR_SET_O2T_ONLY);
        FUZZ_CHECK(st == DR_OK);
        res->dirty |= 1u << a;
    }
    snprintf(why, whylen, "ok");
    writes++;
    return true;
}

/* As the MQTT side with one server: a born node leaves for the same
 * server again, one not born stays. */
static bool io_leave(void *user, bool born, const char *why)
{
    (void)user;
    FUZZ_CHECK(why != NULL && why[0] != '\0');
    leaves++;
    return born;
}

static bool link_up(void *user, unsigned robot)
{
    (void)user;
    return robot == 0;
}

static void outputs_changed(void *user, unsigned robot, unsigned dirty)
{
    (void)user, (void)robot, (void)dirty;
}

static const char *const topics[] = {
    "spBv1.0/g/NCMD/e", "spBv1.0/g/DCMD/e/r0", "spBv1.0/g/DCMD/e/r9",
    "spBv1.0/STATE/h",  "spBv1.0/g/NDATA/e",
};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    memset(&C, 0, sizeof C);
    C.robot_count = 1;
    snprintf(C.robot[0].name, sizeof C.robot[0].name, "r0");
    gw_robot_init(&R[0], "r0", 1);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        for (unsigned i = 0; i < dr_asm_info((dr_asm_t)a)->size; i++)
            R[0].img[a][i] = (uint8_t)(i * 37u + a);
    gw_mqtt_config_t q = C.side.mqtt;
    q.enabled = true;
    q.payload = GW_MQTT_SPARKPLUG;
    snprintf(q.group_id, sizeof q.group_id, "g");
    snprintf(q.edge_node_id, sizeof q.edge_node_id, "e");
    /* where nothing can be written: bdSeq is not kept (logged, once) */
    snprintf(q.bdseq_file, sizeof q.bdseq_file, "/nonexistent-drgate-fuzz/bdseq");
    q.writes = (data[0] & 1u) != 0;
    if (data[0] & 2u)
        snprintf(q.primary_host_id, sizeof q.primary_host_id, "h");
    gw_north_env_t env = {.epfd = -1, .cfg = &C, .robots = R, .outputs_changed = outputs_changed,
                          .link_up = link_up};
    spb_io_t io = {NULL, io_publish, io_subscribe, io_room, io_write, io_leave};
    char err[200];
    spb_t *s = spb_new(&q, &env, &io, "host", err, sizeof err);
    FUZZ_CHECK(s != NULL);
    published = writes = leaves = 0;

    const void *will;
    const char *wt;
    size_t wl;
    spb_will(s, &wt, &will, &wl);
    FUZZ_CHECK(spb_decode_cmd(will, wl, count_metric, &(unsigned){0}));
    spb_sync(s, true);
    spb_connected(s);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        spb_on_data(s, 0, (dr_asm_t)a);
    if (data[0] & 2u) /* births wait for the primary host */
        FUZZ_CHECK(spb_message(s, "spBv1.0/STATE/h", "{\"online\":true}", 15));
    spb_tick(s, ev_now_us());
    FUZZ_CHECK(published == 2); /* NBIRTH, DBIRTH */

    before = R[0];
    const char *topic = topics[(data[0] >> 2) % (sizeof topics / sizeof topics[0])];
    FUZZ_CHECK(spb_message(s, topic, data + 1, size - 1));
    spb_tick(s, ev_now_us());

    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        bool same = memcmp(before.img[a], R[0].img[a], sizeof R[0].img[a]) == 0;
        if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O || !q.writes)
            FUZZ_CHECK(same);
    }
    FUZZ_CHECK(q.writes || writes == 0);
    FUZZ_CHECK(leaves <= 1);
    spb_free(s);
    return 0;
}
