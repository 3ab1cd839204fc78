/* SPDX-License-Identifier: MIT */
/* Node types, units and values of the OPC UA side: see ua_model.h. */
#include "opcua/ua_model.h"

#include <stdio.h>
#include <string.h>

/* The codec's units (lib/fields_internal.h) as UNECE Recommendation 20
 * codes, the namespace OPC UA Part 8 gives EUInformation. */
typedef struct {
    const char *unit, *code, *display, *description;
} ua_unit_t;

static const ua_unit_t units[] = {
    {"degree", "DD", "\xc2\xb0", "degree [unit of angle]"},
    {"degree/s", "E96", "\xc2\xb0/s", "degree per second"},
    {"A", "AMP", "A", "ampere"},
    {"degC", "CEL", "\xc2\xb0""C", "degree Celsius"},
    {"Nm", "NU", "N\xc2\xb7m", "newton metre"},
    {"N", "NEW", "N", "newton"},
    {"mm", "MMT", "mm", "millimetre"},
    {"mm/s", "C16", "mm/s", "millimetre per second"},
};
#define UNECE_NAMESPACE "http://www.opcfoundation.org/UA/units/un/cefact"

int32_t ua_model_unit_id(const char *code)
{
    uint32_t id = 0;
    for (const char *p = code; *p != '\0' && p < code + 4; p++)
        id = (id << 8) | (uint8_t)*p;
    return (int32_t)id;
}

static const ua_unit_t *unit_of(const dr_field_t *f)
{
    for (size_t i = 0; f->unit != NULL && i < sizeof units / sizeof units[0]; i++)
        if (strcmp(units[i].unit, f->unit) == 0)
            return &units[i];
    return NULL;
}

static const UA_DataType *type_of(const dr_field_t *f)
{
    switch ((dr_kind_t)f->kind) {
    case DR_KIND_BIT:
    case DR_KIND_BITS: return &UA_TYPES[UA_TYPES_BOOLEAN];
    case DR_KIND_USINT:
    case DR_KIND_ENUM: return &UA_TYPES[UA_TYPES_BYTE];
    case DR_KIND_DINT: return &UA_TYPES[UA_TYPES_INT32];
    case DR_KIND_REAL: return &UA_TYPES[UA_TYPES_FLOAT];
    }
    return &UA_TYPES[UA_TYPES_BYTE];
}

UA_StatusCode ua_model_value(dr_ref_t ref, const dr_value_t *v, UA_Variant *out)
{
    const UA_DataType *ty = type_of(ref.field);
    UA_Boolean b;
    UA_Byte u8;
    UA_Int32 i32;
    UA_Float f32;
    const void *p;
    if (ty == &UA_TYPES[UA_TYPES_BOOLEAN]) {
        b = v->u != 0;
        p = &b;
    } else if (ty == &UA_TYPES[UA_TYPES_BYTE]) {
        u8 = (UA_Byte)(v->u & 0xFFu);
        p = &u8;
    } else if (ty == &UA_TYPES[UA_TYPES_INT32]) {
        i32 = (UA_Int32)v->i;
        p = &i32;
    } else {
        f32 = (UA_Float)v->f;
        p = &f32;
    }
    return UA_Variant_setScalarCopy(out, p, ty);
}

dr_status_t ua_model_from_variant(dr_ref_t ref, const UA_Variant *var, dr_value_t *out)
{
    const UA_DataType *ty = type_of(ref.field);
    if (!UA_Variant_isScalar(var) || var->type != ty || var->data == NULL)
        return DR_EINVAL;
    if (ty == &UA_TYPES[UA_TYPES_BOOLEAN])
        *out = dr_value_uint(*(const UA_Boolean *)var->data ? 1u : 0u);
    else if (ty == &UA_TYPES[UA_TYPES_BYTE])
        *out = dr_value_uint(*(const UA_Byte *)var->data);
    else if (ty == &UA_TYPES[UA_TYPES_INT32])
        *out = dr_value_int(*(const UA_Int32 *)var->data);
    else
        *out = dr_value_real((double)*(const UA_Float *)var->data);
    return DR_OK;
}

/* Constant text as open62541's strings, which are not const but are only
 * read where these go (attributes are copied into the nodes). */
UA_String ua_model_text(const char *s)
{
    UA_String u;
    u.length = strlen(s);
    memcpy((void *)&u.data, (const void *)&s, sizeof u.data); /* drop the const: never written */
    return u;
}

static UA_LocalizedText lt(const char *locale, const char *text)
{
    UA_LocalizedText l;
    l.locale = ua_model_text(locale);
    l.text = ua_model_text(text);
    return l;
}

/* A property (HasProperty, PropertyType) named `name` of node `parent`. */
static UA_StatusCode add_property(UA_Server *s, UA_NodeId parent, const char *name,
                                  const UA_Variant *value)
{
    UA_VariableAttributes va = UA_VariableAttributes_default;
    va.displayName = lt("", name);
    va.value = *value;
    va.dataType = value->type->typeId;
    va.valueRank = UA_Variant_isScalar(value) ? UA_VALUERANK_SCALAR : UA_VALUERANK_ONE_DIMENSION;
    va.accessLevel = UA_ACCESSLEVELMASK_READ;
    return UA_Server_addVariableNode(s, UA_NODEID_NULL, parent,
                                     UA_NODEID_NUMERIC(0, UA_NS0ID_HASPROPERTY),
                                     (UA_QualifiedName){0, ua_model_text(name)},
                                     UA_NODEID_NUMERIC(0, UA_NS0ID_PROPERTYTYPE), va, NULL, NULL);
}

UA_StatusCode ua_model_add_units(UA_Server *s, UA_NodeId node, const dr_field_t *f)
{
    const ua_unit_t *u = unit_of(f);
    if (u == NULL)
        return UA_STATUSCODE_GOOD;
    UA_EUInformation eu;
    UA_EUInformation_init(&eu);
    eu.namespaceUri = ua_model_text(UNECE_NAMESPACE);
    eu.unitId = ua_model_unit_id(u->code);
    eu.displayName = lt("", u->display);
    eu.description = lt("en", u->description);
    UA_Variant v;
    UA_Variant_setScalar(&v, &eu, &UA_TYPES[UA_TYPES_EUINFORMATION]);
    /* a type whose EngineeringUnits is mandatory (AnalogUnitType) made it
     * with the node: its value is written; else the property is added */
    UA_QualifiedName qn = UA_QUALIFIEDNAME(0, "EngineeringUnits");
    UA_BrowsePathResult bp = UA_Server_browseSimplifiedBrowsePath(s, node, 1, &qn);
    UA_StatusCode st = bp.statusCode == UA_STATUSCODE_GOOD && bp.targetsSize > 0
                           ? UA_Server_writeValue(s, bp.targets[0].targetId.nodeId, v)
                           : add_property(s, node, "EngineeringUnits", &v);
    UA_BrowsePathResult_clear(&bp);
    return st;
}

/* MultiStateDiscreteType's EnumStrings (instantiated with the variable):
 * robot_state's names, value i the name of state i. */
static UA_StatusCode set_enum_strings(UA_Server *s, UA_NodeId node)
{
    UA_LocalizedText names[32];
    size_t n = 0;
    for (; n < sizeof names / sizeof names[0]; n++) {
        const char *name = dr_robot_state_name((unsigned)n);
        if (name == NULL || name[0] == '\0' || strchr(name, '(') != NULL)
            break;
        names[n] = lt("en", name);
    }
    UA_QualifiedName qn = UA_QUALIFIEDNAME(0, "EnumStrings");
    UA_BrowsePathResult bp = UA_Server_browseSimplifiedBrowsePath(s, node, 1, &qn);
    UA_StatusCode st = bp.statusCode;
    if (st == UA_STATUSCODE_GOOD && bp.targetsSize > 0) {
        UA_Variant v;
        UA_Variant_setArray(&v, names, n, &UA_TYPES[UA_TYPES_LOCALIZEDTEXT]);
        st = UA_Server_writeValue(s, bp.targets[0].targetId.nodeId, v);
    } else if (st == UA_STATUSCODE_GOOD) {
        st = UA_STATUSCODE_BADNOTFOUND;
    }
    UA_BrowsePathResult_clear(&bp);
    return st;
}

UA_StatusCode ua_model_add_field(UA_Server *s, const ua_model_var_t *var)
{
    const dr_field_t *f = var->ref.field;
    const ua_unit_t *u = unit_of(f);
    bool t2o = dr_asm_info((dr_asm_t)f->assembly)->dir == DR_DIR_T2O;
    UA_VariableAttributes va = UA_VariableAttributes_default;
    va.displayName.locale = UA_STRING_NULL;
    va.displayName.text = var->name.name;
    va.description = lt("en", f->help != NULL ? f->help : "");
    va.dataType = type_of(f)->typeId;
    va.valueRank = UA_VALUERANK_SCALAR;
    va.accessLevel = UA_ACCESSLEVELMASK_READ;
    if (!t2o && var->writable)
        va.accessLevel |= UA_ACCESSLEVELMASK_WRITE;
    va.userAccessLevel = va.accessLevel;
    va.minimumSamplingInterval = (UA_Double)var->rpi_ms;
    UA_NodeId type = UA_NODEID_NUMERIC(0, UA_NS0ID_BASEDATAVARIABLETYPE);
    if (f->kind == DR_KIND_ENUM)
        type = UA_NODEID_NUMERIC(0, UA_NS0ID_MULTISTATEDISCRETETYPE);
    else if (u != NULL)
        type = UA_NODEID_NUMERIC(0, UA_NS0ID_BASEANALOGTYPE);
    UA_StatusCode st = UA_Server_addDataSourceVariableNode(
        s, var->id, var->parent, UA_NODEID_NUMERIC(0, UA_NS0ID_HASCOMPONENT), var->name, type, va,
        var->source, var->context, NULL);
    if (st == UA_STATUSCODE_GOOD)
        st = ua_model_add_units(s, var->id, f);
    if (st == UA_STATUSCODE_GOOD && f->kind == DR_KIND_ENUM)
        st = set_enum_strings(s, var->id);
    return st;
}
