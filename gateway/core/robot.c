/* SPDX-License-Identifier: MIT */
/* One robot's images and link facts: see robot.h. */
#include "core/robot.h"

#include <stdio.h>
#include <string.h>
#include <time.h>

void gw_robot_init(gw_robot_t *r, const char *name, uint32_t serial)
{
    memset(r, 0, sizeof *r);
    snprintf(r->name, sizeof r->name, "%s", name != NULL ? name : "");
    r->serial = serial;
}

void gw_robot_carry_over(gw_robot_t *r, const gw_robot_t *old)
{
    r->heartbeat = old->heartbeat;
    r->link.rx_packets = old->link.rx_packets;
    r->link.lost_packets = old->link.lost_packets;
    r->link.reconnects = old->link.reconnects;
    r->link.timeouts = old->link.timeouts;
    r->link.sets_refused = old->link.sets_refused;
    r->last_write = old->last_write;
}

void gw_robot_wrote(gw_robot_t *r, const char *client)
{
    struct timespec ts;
    gw_robot_write_t *w = &r->last_write;
    w->time_us = clock_gettime(CLOCK_REALTIME, &ts) == 0
                     ? (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u
                     : 1;
    snprintf(w->client, sizeof w->client, "%s", client);
    w->nfields = 0;
}

void gw_robot_write_field(gw_robot_t *r, const char *path)
{
    gw_robot_write_t *w = &r->last_write;
    for (unsigned i = 0; i < w->nfields && i < GW_WRITE_FIELDS; i++)
        if (strcmp(w->fields[i], path) == 0)
            return;
    if (w->nfields < GW_WRITE_FIELDS)
        snprintf(w->fields[w->nfields], sizeof w->fields[0], "%s", path);
    w->nfields++;
}

void gw_robot_write_fields_text(const gw_robot_t *r, char *buf, size_t size)
{
    const gw_robot_write_t *w = &r->last_write;
    size_t n = 0;
    buf[0] = '\0';
    for (unsigned i = 0; i < w->nfields && i < GW_WRITE_FIELDS && n < size; i++) {
        int k = snprintf(buf + n, size - n, "%s%s", i > 0 ? ", " : "", w->fields[i]);
        n = k < 0 ? size : n + (size_t)k;
    }
    if (w->nfields > GW_WRITE_FIELDS && n < size)
        snprintf(buf + n, size - n, " (+%u more)", w->nfields - GW_WRITE_FIELDS);
}

uint16_t gw_robot_error_code(dr_status_t why, uint16_t *general)
{
    *general = 0;
    if (DR_IS_CIP(why)) {
        *general = DR_CIP_GENERAL(why);
        return DR_CIP_EXTENDED(why) != 0 ? DR_CIP_EXTENDED(why) : DR_CIP_GENERAL(why);
    }
    if (DR_IS_ENCAP(why)) {
        uint16_t st = (uint16_t)(why & 0xFFFF);
        return st < GW_ERROR_OTHER - GW_ERROR_ENCAP ? (uint16_t)(GW_ERROR_ENCAP + st)
                                                    : (uint16_t)GW_ERROR_OTHER;
    }
    /* a plain code; DR_OK stays 0 */
    return why >= 0 && why < (dr_status_t)GW_ERROR_ENCAP ? (uint16_t)why : (uint16_t)DR_EIO;
}

/* Kept for every failure, not only the ones that change the link's state:
 * an adapter that refuses every Forward Open never brings the link up. */
void gw_robot_record_error(gw_robot_t *r, dr_status_t why)
{
    if (why == DR_OK)
        return;
    r->link.last_status = why;
    r->link.last_error = gw_robot_error_code(why, &r->link.last_cip_general);
}

void gw_robot_error_text(dr_status_t why, char *buf, size_t size)
{
    if (why == DR_OK)
        snprintf(buf, size, "%s", "");
    else if (DR_IS_CIP(why) && DR_CIP_EXTENDED(why) != 0)
        snprintf(buf, size, "CIP 0x%02X/0x%04X %s", (unsigned)DR_CIP_GENERAL(why),
                 (unsigned)DR_CIP_EXTENDED(why), dr_strerror(why));
    else if (DR_IS_CIP(why))
        snprintf(buf, size, "CIP 0x%02X %s", (unsigned)DR_CIP_GENERAL(why), dr_strerror(why));
    else if (DR_IS_ENCAP(why))
        snprintf(buf, size, "%s (0x%04X)", dr_strerror(why), (unsigned)(why & 0xFFFF));
    else
        snprintf(buf, size, "%s", dr_strerror(why));
}

void gw_robot_cause(const gw_robot_t *r, char *buf, size_t size)
{
    if (r->link.last_status == DR_ENODATA)
        snprintf(buf, size, "%s to %s: a firewall, or the robot answers another address",
                 dr_strerror(DR_ENODATA), r->link.t2o_to[0] ? r->link.t2o_to : "this host");
    else
        gw_robot_error_text(r->link.last_status, buf, size);
}

const char *gw_machine_id_problem(const char *line)
{
    size_t n = line != NULL ? strcspn(line, " \t\r\n") : 0;
    if (n == 0)
        return "missing or empty";
    if (n == 13 && strncmp(line, "uninitialized", 13) == 0)
        return "uninitialized";
    if (strspn(line, "0") >= n)
        return "all zeros";
    return NULL;
}

/* The causes of a link failure an integrator meets, and where to look. */
static const struct {
    dr_status_t st;
    const char *hint;
} hints[] = {
    {DR_ECONNREFUSED, "the address answered, but nothing listens on `tcp_port`: the robot's "
                      "EtherNet/IP adapter is disabled or still starting, or the port is wrong"},
    {DR_EHOSTUNREACH, "no route to the robot's address, or nothing answered ARP on its subnet: "
                      "wrong `host`, robot switched off, cable"},
    {DR_ENETUNREACH, "this host has no route to the robot's network (or a blackhole route): "
                     "wrong `host`, or this host's address and routes"},
    {DR_ENOANSWER, "nothing answered the TCP connection within `timeout_ms`: robot switched "
                   "off, wrong `host`, or a firewall that drops packets"},
    {DR_ENOREGISTER, "something accepted the TCP connection on `tcp_port` but does not speak "
                     "EtherNet/IP there (wrong port or device), or the adapter hangs"},
    {DR_ECLOSED, "the robot closed or reset the TCP connection (its adapter refuses sessions, "
                 "or restarted)"},
    {DR_ENOTFOUND, "`host` does not resolve (names are resolved at start and at reload)"},
    {DR_EADDRINUSE, "`local_address`:`local_udp_port` is taken by another program: set "
                    "`local_address` or `local_udp_port`"},
    {DR_EADDRNOTAVAIL, "`local_address` is not an address of this host"},
    {DR_EACCES, "a firewall rule or a prohibit route on this host refuses the traffic"},
    {DR_ETIMEDOUT, "an EtherNet/IP request, or a Class 1 connection's data, did not come in "
                   "time (the robot stopped producing, or the network loses packets)"},
    {DR_ENODATA, "the robot accepted the Class 1 connection, but no T->O packet came within "
                 "the first packet's grace (2 s + the timeout): a firewall drops UDP towards "
                 "this host, or the robot sends to another address (one that takes the address "
                 "from the TCP peer while `local_address` is another; docs/interop.md)"},
    {DR_ESESSION, "explicit mode: no EtherNet/IP session for the poll"},
    {DR_ELENGTH, "explicit mode: the robot's assembly has another size than the "
                 "specification's"},
    {DR_EMALFORMED, "the robot sent a frame that is not valid EtherNet/IP"},
    {DR_ELONG, "the robot sent a frame longer than the protocol allows"},
    {DR_EIO, "another network error"},
};

const char *gw_robot_error_hint(dr_status_t why)
{
    for (size_t i = 0; i < sizeof hints / sizeof hints[0]; i++)
        if (hints[i].st == why)
            return hints[i].hint;
    return NULL;
}

void gw_robot_link_down(gw_robot_t *r)
{
    if (!r->clear_while_down)
        return;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O)
            memset(r->img[a], 0, DR_ASM_MAX_SIZE);
}

bool gw_robot_takes_data(const gw_robot_t *r, bool link_up)
{
    return link_up || !r->clear_while_down;
}

dr_status_t gw_robot_get(const gw_robot_t *r, dr_ref_t ref, dr_value_t *v)
{
    if (ref.field == NULL || ref.field->assembly >= DR_ASM_COUNT)
        return DR_EINVAL;
    dr_asm_t a = (dr_asm_t)ref.field->assembly;
    return dr_field_get(r->img[a], dr_asm_info(a)->size, ref, v);
}

/* ---- the Identity ---------------------------------------------------------------- */

/* Identity attributes 1-6 (vendor, device type, product code, revision,
 * status, serial) and the name's length byte: the least a reply carries. */
#define IDENTITY_FIXED 15u

/* ODVA's vendor IDs of the robots this gateway serves, as ODVA's vendor
 * list names them (pycomm3 1.2.14's copy of it, cip/status_info.py). */
static const struct {
    uint16_t id;
    const char *name;
} vendors[] = {
    {1573, "Doosan Robotics"},
};

void gw_identity_vendor_text(uint16_t vendor, char *buf, size_t size)
{
    for (size_t i = 0; i < sizeof vendors / sizeof vendors[0]; i++)
        if (vendors[i].id == vendor) {
            snprintf(buf, size, "%s", vendors[i].name);
            return;
        }
    snprintf(buf, size, "vendor %u", (unsigned)vendor);
}

void gw_identity_serial_text(uint32_t serial, char *buf, size_t size)
{
    snprintf(buf, size, "0x%08lx", (unsigned long)serial);
}

dr_status_t gw_robot_identity_answer(gw_robot_t *r, dr_status_t st, const uint8_t *data,
                                     size_t len)
{
    gw_robot_identity_t *id = &r->identity;
    if (st == DR_OK && (data == NULL || len < IDENTITY_FIXED ||
                        len < IDENTITY_FIXED + (size_t)data[IDENTITY_FIXED - 1]))
        st = DR_ESHORT; /* not the seven attributes the service returns */
    /* an answer that refuses (CIP, encapsulation) or is not one (a reply
     * malformed or to another service); anything else is no answer */
    bool answered = DR_IS_CIP(st) || DR_IS_ENCAP(st) || st == DR_ESHORT ||
                    st == DR_EMALFORMED || st == DR_EMISMATCH;
    if (st != DR_OK && !answered)
        return st; /* the next session asks again */
    if (st != DR_OK) {
        memset(id, 0, sizeof *id);
        id->state = GW_IDENTITY_REFUSED;
        id->why = st;
        return st;
    }
    id->state = GW_IDENTITY_KNOWN;
    id->why = DR_OK;
    id->vendor_id = dr_get_le16(data);
    id->device_type = dr_get_le16(data + 2);
    id->product_code = dr_get_le16(data + 4);
    id->rev_major = data[6];
    id->rev_minor = data[7];
    /* data + 8: the status word, the robot's state now, not who it is */
    id->serial = dr_get_le32(data + 10);
    size_t n = data[IDENTITY_FIXED - 1], k = 0;
    for (; k < n && k + 1 < sizeof id->product_name; k++) {
        uint8_t c = data[IDENTITY_FIXED + k];
        id->product_name[k] = (char)(c >= 0x20 && c < 0x7F ? c : '?');
    }
    id->product_name[k] = '\0';
    return DR_OK;
}

bool gw_robot_identity_same(const gw_robot_identity_t *a, const gw_robot_identity_t *b)
{
    return a->state == b->state && a->why == b->why && a->vendor_id == b->vendor_id &&
           a->device_type == b->device_type && a->product_code == b->product_code &&
           a->rev_major == b->rev_major && a->rev_minor == b->rev_minor &&
           a->serial == b->serial && strcmp(a->product_name, b->product_name) == 0;
}

void gw_robot_identity_refusal(const gw_robot_identity_t *id, char *buf, size_t size)
{
    if (id->why == DR_ESHORT)
        snprintf(buf, size, "a reply too short for an Identity");
    else
        gw_robot_error_text(id->why, buf, size);
}

void gw_robot_identity_text(const gw_robot_identity_t *id, char *buf, size_t size)
{
    char vendor[32], serial[16], why[120];
    if (id->state == GW_IDENTITY_WAITING) {
        snprintf(buf, size, "not read yet");
    } else if (id->state == GW_IDENTITY_REFUSED) {
        gw_robot_identity_refusal(id, why, sizeof why);
        snprintf(buf, size, "refused: %s", why);
    } else {
        gw_identity_vendor_text(id->vendor_id, vendor, sizeof vendor);
        gw_identity_serial_text(id->serial, serial, sizeof serial);
        snprintf(buf, size, "%s, '%s' (product code %u, revision %u.%u, serial %s)", vendor,
                 id->product_name, (unsigned)id->product_code, (unsigned)id->rev_major,
                 (unsigned)id->rev_minor, serial);
    }
}
