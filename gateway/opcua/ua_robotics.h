/* SPDX-License-Identifier: MIT */
/*
 * The Robotics companion view of the OPC UA side (OPC 40010-1 on OPC
 * 10000-100 DI; docs/opcua.md "Robotics view"): each robot a
 * MotionDeviceSystem under Objects/DeviceSet.
 *
 * No Debian package ships the DI or Robotics NodeSet2 files (open62541's
 * tools package has namespace 0 only), so the part of both models this
 * view uses is built here in code: the object types with the NodeIds,
 * browse names, namespace URIs and supertypes of the published NodeSets
 * (Robotics 1.0, DI 1.02), the three enumerations it needs, and per robot
 * the instance tree with every mandatory member. The types carry no
 * instance declarations of their own (a client reads the instances'
 * members, not the types').
 */
#ifndef DRGATE_GW_UA_ROBOTICS_H
#define DRGATE_GW_UA_ROBOTICS_H

#include <open62541/server.h>

#include "core/robot.h"
#include "drgate/codec.h"

#define UA_NS_DI "http://opcfoundation.org/UA/DI/"
#define UA_NS_ROBOTICS "http://opcfoundation.org/UA/Robotics/"

/* What a variable of the view reads (the side's DataSource tells them
 * apart by this, in its node context). */
typedef enum {
    UA_VIEW_FIELD,   /* a field, as its OPC UA type (the flat view's) */
    UA_VIEW_DOUBLE,  /* a REAL field as Double (the companion spec's type) */
    UA_VIEW_VERSION, /* io_state.version as "major.minor.patch" */
    UA_VIEW_NONE,    /* what the assemblies do not carry: BadNotSupported */
    /* DI's identification from the robot's Identity object (robot.h,
     * gw_robot_identity_t): ua_robotics_identity_read() */
    UA_VIEW_MANUFACTURER, /* the vendor's name (LocalizedText) */
    UA_VIEW_MODEL,        /* the product name (LocalizedText) */
    UA_VIEW_PRODUCT_CODE, /* the product code in decimal (String) */
    UA_VIEW_SERIAL        /* the serial number as drcli prints it (String) */
} ua_view_kind_t;

/* Is `kind` one of the identification's? */
bool ua_robotics_is_identity(ua_view_kind_t kind);

/* What a variable of identification kind `kind` reads of `id`: the value
 * once the link has read the robot's Identity, BadWaitingForInitialData
 * until its first read answers, BadNotSupported when the robot refused it
 * (docs/opcua.md). */
void ua_robotics_identity_read(ua_view_kind_t kind, const gw_robot_identity_t *id,
                               UA_DataValue *dv);

/* The side's maker of node contexts: robot r's variable of `kind` on
 * field `path` (NULL for UA_VIEW_NONE and UA_VIEW_VERSION), whose value
 * is of `type` (an enumeration's: Int32). NULL: out of memory. */
typedef void *(*ua_view_context_fn)(void *user, unsigned r, ua_view_kind_t kind,
                                    const char *path, const UA_DataType *type);

typedef struct {
    UA_UInt16 ns;           /* the instances' namespace (the flat view's) */
    UA_DataSource source;   /* reads (and refuses writes) of every variable */
    ua_view_context_fn context;
    void *user;
} ua_robotics_t;

/* The types (once per server). */
UA_StatusCode ua_robotics_types(UA_Server *s);

/* Robot `r` named `name` as a MotionDeviceSystem; err says where on
 * failure. */
UA_StatusCode ua_robotics_add(UA_Server *s, const ua_robotics_t *v, unsigned r, const char *name,
                              char *err, size_t errlen);

#endif /* DRGATE_GW_UA_ROBOTICS_H */
