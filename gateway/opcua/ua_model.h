/* SPDX-License-Identifier: MIT */
/*
 * What the OPC UA side's nodes are (docs/opcua.md): each field's OPC UA
 * type, engineering units and enum names, the conversions between its
 * values and variants, and the Robotics companion view of the robots.
 */
#ifndef DRGATE_GW_UA_MODEL_H
#define DRGATE_GW_UA_MODEL_H

#include <open62541/server.h>

#include "core/north.h"
#include "drgate/codec.h"

/* One variable of the flat view. */
typedef struct {
    UA_NodeId id, parent;
    UA_QualifiedName name;
    dr_ref_t ref;
    bool writable;   /* an O->T field with [opcua] writes = yes */
    uint32_t rpi_ms; /* MinimumSamplingInterval */
    UA_DataSource source;
    void *context;
} ua_model_var_t;

/* The variable with its type (Boolean, Byte, Int32, Float), access level,
 * description, and EngineeringUnits (BaseAnalogType) or EnumStrings
 * (MultiStateDiscreteType, robot_state). */
UA_StatusCode ua_model_add_field(UA_Server *server, const ua_model_var_t *var);

/* Field f's unit as node's EngineeringUnits property (EUInformation,
 * UNECE code); nothing for a field without a unit. */
UA_StatusCode ua_model_add_units(UA_Server *server, UA_NodeId node, const dr_field_t *f);

/* v (of the field ref names) as a scalar variant (allocated). */
UA_StatusCode ua_model_value(dr_ref_t ref, const dr_value_t *v, UA_Variant *out);

/* A written scalar variant as the field's value: DR_OK, or DR_EINVAL for
 * a variant of another type or not a scalar. */
dr_status_t ua_model_from_variant(dr_ref_t ref, const UA_Variant *var, dr_value_t *out);

/* s as an open62541 string (not copied: s must outlive its use). */
UA_String ua_model_text(const char *s);

/* The UNECE code's UnitId (OPC UA Part 8, EUInformation): "DD" -> 17476. */
int32_t ua_model_unit_id(const char *code);

#endif /* DRGATE_GW_UA_MODEL_H */
