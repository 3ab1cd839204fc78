/* SPDX-License-Identifier: MIT */
/* The Robotics companion view: see ua_robotics.h. */
#include "opcua/ua_robotics.h"

#include <stdio.h>
#include <string.h>

#include "opcua/ua_model.h"

/* The published NodeSets' numbers (Opc.Ua.Di.NodeSet2.xml 1.02,
 * Opc.Ua.Robotics.NodeSet2.xml 1.0). */
enum {
    DI_TOPOLOGY_ELEMENT_TYPE = 1001,
    DI_COMPONENT_TYPE = 15063,
    DI_SOFTWARE_TYPE = 15106,
    DI_DEVICE_SET = 5001,
    RB_MOTION_DEVICE_SYSTEM_TYPE = 1002,
    RB_CONTROLLER_TYPE = 1003,
    RB_MOTION_DEVICE_TYPE = 1004,
    RB_TASK_CONTROL_TYPE = 1011,
    RB_SAFETY_STATE_TYPE = 1013,
    RB_MOTOR_TYPE = 1019,
    RB_AXIS_TYPE = 16601,
    RB_POWER_TRAIN_TYPE = 16794,
    RB_USER_TYPE = 18175,
    RB_OPERATIONAL_MODE_ENUM = 3006,
    RB_AXIS_MOTION_PROFILE_ENUM = 3008,
    RB_MOTION_DEVICE_CATEGORY_ENUM = 18193
};
#define NS0_ANALOG_UNIT_TYPE 17497 /* AnalogUnitType: the spec's axis values */
#define RB_ARTICULATED_ROBOT 1     /* MotionDeviceCategoryEnumeration */
#define RB_ROTARY 1                /* AxisMotionProfileEnumeration */
#define RB_AXES 6u

typedef struct {
    UA_Server *s;
    const ua_robotics_t *v;
    unsigned r;
    const char *robot;
    UA_UInt16 di, rb;
    char *err;
    size_t errlen;
} build_t;

static UA_NodeId num(UA_UInt16 ns, UA_UInt32 id)
{
    return UA_NODEID_NUMERIC(ns, id);
}

static UA_QualifiedName qname(UA_UInt16 ns, const char *name)
{
    UA_QualifiedName q;
    q.namespaceIndex = ns;
    q.name = ua_model_text(name);
    return q;
}

static UA_LocalizedText text(const char *t)
{
    UA_LocalizedText l;
    l.locale = UA_STRING_NULL;
    l.text = ua_model_text(t);
    return l;
}

static UA_StatusCode add_type(UA_Server *s, UA_UInt16 ns, UA_UInt32 id, const char *name,
                              UA_NodeId super, bool abstract)
{
    UA_ObjectTypeAttributes a = UA_ObjectTypeAttributes_default;
    a.displayName = text(name);
    a.isAbstract = abstract;
    return UA_Server_addObjectTypeNode(s, num(ns, id), super, num(0, UA_NS0ID_HASSUBTYPE),
                                       qname(ns, name), a, NULL, NULL);
}

/* An enumeration with its EnumStrings (values 0..n-1). */
static UA_StatusCode add_enum(UA_Server *s, UA_UInt16 ns, UA_UInt32 id, const char *name,
                              const char *const *names, size_t n)
{
    UA_DataTypeAttributes a = UA_DataTypeAttributes_default;
    a.displayName = text(name);
    UA_StatusCode st = UA_Server_addDataTypeNode(s, num(ns, id), num(0, UA_NS0ID_ENUMERATION),
                                                 num(0, UA_NS0ID_HASSUBTYPE), qname(ns, name), a,
                                                 NULL, NULL);
    UA_LocalizedText lt[8];
    for (size_t i = 0; i < n && i < 8; i++)
        lt[i] = text(names[i]);
    UA_VariableAttributes va = UA_VariableAttributes_default;
    va.displayName = text("EnumStrings");
    UA_Variant_setArray(&va.value, lt, n < 8 ? n : 8, &UA_TYPES[UA_TYPES_LOCALIZEDTEXT]);
    va.dataType = UA_TYPES[UA_TYPES_LOCALIZEDTEXT].typeId;
    va.valueRank = UA_VALUERANK_ONE_DIMENSION;
    UA_UInt32 dims = 0; /* any length */
    va.arrayDimensions = &dims;
    va.arrayDimensionsSize = 1;
    if (st == UA_STATUSCODE_GOOD)
        st = UA_Server_addVariableNode(s, UA_NODEID_NULL, num(ns, id), num(0, UA_NS0ID_HASPROPERTY),
                                       qname(0, "EnumStrings"), num(0, UA_NS0ID_PROPERTYTYPE), va,
                                       NULL, NULL);
    return st;
}

UA_StatusCode ua_robotics_types(UA_Server *s)
{
    static const char *const category[] = {"OTHER", "ARTICULATED_ROBOT", "SCARA_ROBOT",
                                           "CARTESIAN_ROBOT", "SPHERICAL_ROBOT", "PARALLEL_ROBOT",
                                           "CYLINDRICAL_ROBOT"};
    static const char *const profile[] = {"OTHER", "ROTARY", "ROTARY_ENDLESS", "LINEAR",
                                          "LINEAR_ENDLESS"};
    static const char *const mode[] = {"OTHER", "MANUAL_REDUCED_SPEED", "MANUAL_HIGH_SPEED",
                                       "AUTOMATIC", "AUTOMATIC_EXTERNAL"};
    static const struct {
        UA_UInt32 id;
        const char *name;
    } rb_components[] = {
        {RB_MOTION_DEVICE_SYSTEM_TYPE, "MotionDeviceSystemType"},
        {RB_CONTROLLER_TYPE, "ControllerType"},
        {RB_MOTION_DEVICE_TYPE, "MotionDeviceType"},
        {RB_TASK_CONTROL_TYPE, "TaskControlType"},
        {RB_SAFETY_STATE_TYPE, "SafetyStateType"},
        {RB_MOTOR_TYPE, "MotorType"},
        {RB_AXIS_TYPE, "AxisType"},
        {RB_POWER_TRAIN_TYPE, "PowerTrainType"},
    };
    UA_UInt16 di = UA_Server_addNamespace(s, UA_NS_DI);
    UA_UInt16 rb = UA_Server_addNamespace(s, UA_NS_ROBOTICS);
    UA_StatusCode st = add_type(s, di, DI_TOPOLOGY_ELEMENT_TYPE, "TopologyElementType",
                                num(0, UA_NS0ID_BASEOBJECTTYPE), true);
    if (st == UA_STATUSCODE_GOOD)
        st = add_type(s, di, DI_COMPONENT_TYPE, "ComponentType", num(di, DI_TOPOLOGY_ELEMENT_TYPE),
                      true);
    if (st == UA_STATUSCODE_GOOD)
        st = add_type(s, di, DI_SOFTWARE_TYPE, "SoftwareType", num(di, DI_COMPONENT_TYPE), false);
    for (size_t i = 0; st == UA_STATUSCODE_GOOD && i < sizeof rb_components / sizeof rb_components[0];
         i++)
        st = add_type(s, rb, rb_components[i].id, rb_components[i].name, num(di, DI_COMPONENT_TYPE),
                      false);
    if (st == UA_STATUSCODE_GOOD)
        st = add_type(s, rb, RB_USER_TYPE, "UserType", num(0, UA_NS0ID_BASEOBJECTTYPE), false);
    if (st == UA_STATUSCODE_GOOD)
        st = add_enum(s, rb, RB_MOTION_DEVICE_CATEGORY_ENUM, "MotionDeviceCategoryEnumeration",
                      category, sizeof category / sizeof category[0]);
    if (st == UA_STATUSCODE_GOOD)
        st = add_enum(s, rb, RB_AXIS_MOTION_PROFILE_ENUM, "AxisMotionProfileEnumeration", profile,
                      sizeof profile / sizeof profile[0]);
    if (st == UA_STATUSCODE_GOOD)
        st = add_enum(s, rb, RB_OPERATIONAL_MODE_ENUM, "OperationalModeEnumeration", mode,
                      sizeof mode / sizeof mode[0]);
    if (st == UA_STATUSCODE_GOOD) {
        UA_ObjectAttributes a = UA_ObjectAttributes_default;
        a.displayName = text("DeviceSet");
        st = UA_Server_addObjectNode(s, num(di, DI_DEVICE_SET), num(0, UA_NS0ID_OBJECTSFOLDER),
                                     num(0, UA_NS0ID_ORGANIZES), qname(di, "DeviceSet"),
                                     num(0, UA_NS0ID_BASEOBJECTTYPE), a, NULL, NULL);
    }
    return st;
}

/* ---- one robot ------------------------------------------------------------------ */

static bool failed(build_t *b, UA_StatusCode st, const char *what)
{
    if (st == UA_STATUSCODE_GOOD)
        return false;
    snprintf(b->err, b->errlen, "%s/%s: %s", b->robot, what, UA_StatusCode_name(st));
    return true;
}

/* The instance's NodeId: ns;s=<robot>/rb/<path> into id[size]. */
static UA_NodeId inst_id(const build_t *b, const char *path, char *id, size_t size)
{
    snprintf(id, size, "%s/rb/%s", b->robot, path);
    return UA_NODEID_STRING(b->v->ns, id);
}

/* An object `name` (browse name in ns) at path under parent. */
static bool object(build_t *b, const char *parent, const char *path, UA_UInt16 ns,
                   const char *name, UA_NodeId type)
{
    char pid[160], id[160];
    UA_NodeId p = parent != NULL ? inst_id(b, parent, pid, sizeof pid) : num(b->di, DI_DEVICE_SET);
    UA_ObjectAttributes a = UA_ObjectAttributes_default;
    a.displayName = text(name);
    UA_StatusCode st = UA_Server_addObjectNode(b->s, inst_id(b, path, id, sizeof id), p,
                                               num(0, UA_NS0ID_HASCOMPONENT), qname(ns, name),
                                               type, a, NULL, NULL);
    return !failed(b, st, path);
}

static bool folder(build_t *b, const char *parent, const char *path, const char *name)
{
    return object(b, parent, path, b->rb, name, num(0, UA_NS0ID_FOLDERTYPE));
}

/* A variable read through the side's DataSource. property: HasProperty
 * and PropertyType, else HasComponent and `type`. */
static bool variable(build_t *b, const char *parent, const char *path, UA_UInt16 ns,
                     const char *name, const UA_DataType *dt, UA_NodeId datatype, bool property,
                     UA_NodeId type, ua_view_kind_t kind, const char *field)
{
    char pid[160], id[160];
    void *ctx = b->v->context(b->v->user, b->r, kind, field,
                              dt != NULL ? dt : &UA_TYPES[UA_TYPES_INT32]);
    if (ctx == NULL)
        return !failed(b, UA_STATUSCODE_BADOUTOFMEMORY, path);
    UA_VariableAttributes a = UA_VariableAttributes_default;
    a.displayName = text(name);
    a.dataType = dt != NULL ? dt->typeId : datatype;
    a.valueRank = UA_VALUERANK_SCALAR;
    a.accessLevel = UA_ACCESSLEVELMASK_READ;
    UA_StatusCode st = UA_Server_addDataSourceVariableNode(
        b->s, inst_id(b, path, id, sizeof id), inst_id(b, parent, pid, sizeof pid),
        num(0, property ? UA_NS0ID_HASPROPERTY : UA_NS0ID_HASCOMPONENT), qname(ns, name),
        property ? num(0, UA_NS0ID_PROPERTYTYPE) : type, a, b->v->source, ctx, NULL);
    return !failed(b, st, path);
}

/* The DataType of a property of one of the spec's enumerations: the
 * abstract Enumeration. open62541 1.4 takes an Int32 value only for an
 * enumeration it has a type descriptor of, and it has none of a type made
 * at run time; the enumeration types are there all the same (with their
 * EnumStrings) for a client to look up by the variable's browse name.
 * (OperationalMode, read through the DataSource, is refused even so: its
 * DataType is Int32, the enumerations' encoding; docs/opcua.md.) */
static UA_NodeId enum_type(const build_t *b, UA_UInt32 datatype)
{
    (void)b;
    (void)datatype;
    return num(0, UA_NS0ID_ENUMERATION);
}

/* An enumeration property with a value that is a fact of every robot this
 * gateway serves (a Doosan arm: articulated, rotary joints). */
static bool enum_property(build_t *b, const char *parent, const char *path, const char *name,
                          UA_UInt32 datatype, UA_Int32 value)
{
    char pid[160], id[160];
    UA_VariableAttributes a = UA_VariableAttributes_default;
    a.displayName = text(name);
    (void)datatype; /* see enum_type() */
    a.dataType = enum_type(b, datatype);
    a.valueRank = UA_VALUERANK_SCALAR;
    UA_Variant_setScalar(&a.value, &value, &UA_TYPES[UA_TYPES_INT32]);
    UA_StatusCode st = UA_Server_addVariableNode(
        b->s, inst_id(b, path, id, sizeof id), inst_id(b, parent, pid, sizeof pid),
        num(0, UA_NS0ID_HASPROPERTY), qname(b->rb, name), num(0, UA_NS0ID_PROPERTYTYPE), a, NULL,
        NULL);
    return !failed(b, st, path);
}

/* Manufacturer, Model (LocalizedText), ProductCode, SerialNumber (String):
 * DI's identification. The robot's Identity object names the EtherNet/IP
 * device, the controller, which is sold with its arm as one product: the
 * MotionDevice and the Controller show it (identity); a Motor has none
 * the assemblies carry (UA_VIEW_NONE, docs/opcua.md). */
static bool identification(build_t *b, const char *at, bool identity)
{
    static const char *const names[] = {"Manufacturer", "Model", "ProductCode", "SerialNumber"};
    static const ua_view_kind_t kinds[] = {UA_VIEW_MANUFACTURER, UA_VIEW_MODEL,
                                           UA_VIEW_PRODUCT_CODE, UA_VIEW_SERIAL};
    char path[160];
    for (unsigned i = 0; i < 4; i++) {
        snprintf(path, sizeof path, "%s/%s", at, names[i]);
        if (!variable(b, at, path, b->di, names[i],
                      &UA_TYPES[i < 2 ? UA_TYPES_LOCALIZEDTEXT : UA_TYPES_STRING], UA_NODEID_NULL,
                      true, UA_NODEID_NULL, identity ? kinds[i] : UA_VIEW_NONE, NULL))
            return false;
    }
    return true;
}

bool ua_robotics_is_identity(ua_view_kind_t kind)
{
    return kind == UA_VIEW_MANUFACTURER || kind == UA_VIEW_MODEL ||
           kind == UA_VIEW_PRODUCT_CODE || kind == UA_VIEW_SERIAL;
}

void ua_robotics_identity_read(ua_view_kind_t kind, const gw_robot_identity_t *id,
                               UA_DataValue *dv)
{
    if (id->state != GW_IDENTITY_KNOWN) {
        dv->hasStatus = true;
        dv->status = id->state == GW_IDENTITY_WAITING ? UA_STATUSCODE_BADWAITINGFORINITIALDATA
                                                      : UA_STATUSCODE_BADNOTSUPPORTED;
        return;
    }
    char s[GW_IDENTITY_NAME + 8];
    if (kind == UA_VIEW_MANUFACTURER)
        gw_identity_vendor_text(id->vendor_id, s, sizeof s);
    else if (kind == UA_VIEW_MODEL)
        snprintf(s, sizeof s, "%s", id->product_name);
    else if (kind == UA_VIEW_PRODUCT_CODE)
        snprintf(s, sizeof s, "%u", (unsigned)id->product_code);
    else
        gw_identity_serial_text(id->serial, s, sizeof s);
    UA_StatusCode st;
    if (kind == UA_VIEW_MANUFACTURER || kind == UA_VIEW_MODEL) {
        UA_LocalizedText lt = text(s);
        st = UA_Variant_setScalarCopy(&dv->value, &lt, &UA_TYPES[UA_TYPES_LOCALIZEDTEXT]);
    } else {
        UA_String str = ua_model_text(s);
        st = UA_Variant_setScalarCopy(&dv->value, &str, &UA_TYPES[UA_TYPES_STRING]);
    }
    dv->hasValue = st == UA_STATUSCODE_GOOD;
    if (st != UA_STATUSCODE_GOOD) {
        dv->hasStatus = true;
        dv->status = st;
    }
}

/* An analog value of the spec (AnalogUnitType, Double, EngineeringUnits
 * from the field's unit). */
static bool analog(build_t *b, const char *parent, const char *path, UA_UInt16 ns,
                   const char *name, const char *field)
{
    char id[160];
    if (!variable(b, parent, path, ns, name, &UA_TYPES[UA_TYPES_DOUBLE], UA_NODEID_NULL, false,
                  num(0, NS0_ANALOG_UNIT_TYPE), UA_VIEW_DOUBLE, field))
        return false;
    dr_ref_t ref;
    if (dr_path_parse(field, &ref) != DR_OK)
        return !failed(b, UA_STATUSCODE_BADINTERNALERROR, path);
    return !failed(b, ua_model_add_units(b->s, inst_id(b, path, id, sizeof id), ref.field), path);
}

static bool axis(build_t *b, unsigned i)
{
    char at[64], ps[80], path[128], field[64];
    snprintf(at, sizeof at, "MotionDevices/Manipulator/Axes/Axis%u", i);
    snprintf(ps, sizeof ps, "%s/ParameterSet", at);
    snprintf(path, sizeof path, "Axis%u", i);
    if (!object(b, "MotionDevices/Manipulator/Axes", at, b->rb, path, num(b->rb, RB_AXIS_TYPE)) ||
        !object(b, at, ps, b->di, "ParameterSet", num(0, UA_NS0ID_BASEOBJECTTYPE)))
        return false;
    snprintf(path, sizeof path, "%s/MotionProfile", at);
    if (!enum_property(b, at, path, "MotionProfile", RB_AXIS_MOTION_PROFILE_ENUM, RB_ROTARY))
        return false;
    snprintf(path, sizeof path, "%s/ActualPosition", ps);
    snprintf(field, sizeof field, "joint_state.position[%u]", i);
    if (!analog(b, ps, path, b->rb, "ActualPosition", field))
        return false;
    snprintf(path, sizeof path, "%s/ActualSpeed", ps);
    snprintf(field, sizeof field, "joint_state.velocity[%u]", i);
    return analog(b, ps, path, b->rb, "ActualSpeed", field);
}

/* PowerTrain<i> with its Motor: MotorTemperature (the spec's), and the
 * motor current and the joint torques the assemblies carry, which the
 * spec has no member for: in the instances' namespace (drgate's). */
static bool power_train(build_t *b, unsigned i)
{
    static const struct {
        const char *name, *field;
    } own[] = {{"MotorCurrent", "motor_current"}, {"Torque", "torque"},
               {"ExternalTorque", "external_torque"}};
    char at[80], motor[96], ps[112], path[160], field[64];
    snprintf(at, sizeof at, "MotionDevices/Manipulator/PowerTrains/PowerTrain%u", i);
    snprintf(motor, sizeof motor, "%s/Motor", at);
    snprintf(ps, sizeof ps, "%s/ParameterSet", motor);
    snprintf(path, sizeof path, "PowerTrain%u", i);
    if (!object(b, "MotionDevices/Manipulator/PowerTrains", at, b->rb, path,
                num(b->rb, RB_POWER_TRAIN_TYPE)) ||
        !object(b, at, motor, b->rb, "Motor", num(b->rb, RB_MOTOR_TYPE)) ||
        !identification(b, motor, false) ||
        !object(b, motor, ps, b->di, "ParameterSet", num(0, UA_NS0ID_BASEOBJECTTYPE)))
        return false;
    snprintf(path, sizeof path, "%s/MotorTemperature", ps);
    snprintf(field, sizeof field, "joint_state.motor_temperature[%u]", i);
    if (!analog(b, ps, path, b->rb, "MotorTemperature", field))
        return false;
    for (size_t k = 0; k < sizeof own / sizeof own[0]; k++) {
        snprintf(path, sizeof path, "%s/%s", ps, own[k].name);
        snprintf(field, sizeof field, "joint_state.%s[%u]", own[k].field, i);
        if (!analog(b, ps, path, b->v->ns, own[k].name, field))
            return false;
    }
    return true;
}

static bool motion_device(build_t *b)
{
    const char *md = "MotionDevices/Manipulator";
    if (!folder(b, "", "MotionDevices", "MotionDevices") ||
        !object(b, "MotionDevices", md, b->v->ns, "Manipulator",
                num(b->rb, RB_MOTION_DEVICE_TYPE)) ||
        !identification(b, md, true) ||
        !enum_property(b, md, "MotionDevices/Manipulator/MotionDeviceCategory",
                       "MotionDeviceCategory", RB_MOTION_DEVICE_CATEGORY_ENUM,
                       RB_ARTICULATED_ROBOT) ||
        !object(b, md, "MotionDevices/Manipulator/ParameterSet", b->di, "ParameterSet",
                num(0, UA_NS0ID_BASEOBJECTTYPE)) ||
        !variable(b, "MotionDevices/Manipulator/ParameterSet",
                  "MotionDevices/Manipulator/ParameterSet/SpeedOverride", b->rb, "SpeedOverride",
                  &UA_TYPES[UA_TYPES_DOUBLE], UA_NODEID_NULL, false,
                  num(0, UA_NS0ID_BASEDATAVARIABLETYPE), UA_VIEW_NONE, NULL) ||
        !folder(b, md, "MotionDevices/Manipulator/Axes", "Axes") ||
        !folder(b, md, "MotionDevices/Manipulator/PowerTrains", "PowerTrains"))
        return false;
    for (unsigned i = 1; i <= RB_AXES; i++)
        if (!axis(b, i) || !power_train(b, i))
            return false;
    return true;
}

static bool controller(build_t *b)
{
    const char *c = "Controllers/Controller";
    const char *sw = "Controllers/Controller/Software/Firmware";
    const char *tc = "Controllers/Controller/TaskControls/TaskControl";
    return folder(b, "", "Controllers", "Controllers") &&
           object(b, "Controllers", c, b->v->ns, "Controller", num(b->rb, RB_CONTROLLER_TYPE)) &&
           identification(b, c, true) &&
           object(b, c, "Controllers/Controller/CurrentUser", b->rb, "CurrentUser",
                  num(b->rb, RB_USER_TYPE)) &&
           variable(b, "Controllers/Controller/CurrentUser",
                    "Controllers/Controller/CurrentUser/Level", b->rb, "Level",
                    &UA_TYPES[UA_TYPES_STRING], UA_NODEID_NULL, true, UA_NODEID_NULL,
                    UA_VIEW_NONE, NULL) &&
           folder(b, c, "Controllers/Controller/Software", "Software") &&
           object(b, "Controllers/Controller/Software", sw, b->v->ns, "Firmware",
                  num(b->di, DI_SOFTWARE_TYPE)) &&
           variable(b, sw, "Controllers/Controller/Software/Firmware/Manufacturer", b->di,
                    "Manufacturer", &UA_TYPES[UA_TYPES_LOCALIZEDTEXT], UA_NODEID_NULL, true,
                    UA_NODEID_NULL, UA_VIEW_MANUFACTURER, NULL) &&
           variable(b, sw, "Controllers/Controller/Software/Firmware/Model", b->di, "Model",
                    &UA_TYPES[UA_TYPES_LOCALIZEDTEXT], UA_NODEID_NULL, true, UA_NODEID_NULL,
                    UA_VIEW_NONE, NULL) &&
           variable(b, sw, "Controllers/Controller/Software/Firmware/SoftwareRevision", b->di,
                    "SoftwareRevision", &UA_TYPES[UA_TYPES_STRING], UA_NODEID_NULL, true,
                    UA_NODEID_NULL, UA_VIEW_VERSION, NULL) &&
           folder(b, c, "Controllers/Controller/TaskControls", "TaskControls") &&
           object(b, "Controllers/Controller/TaskControls", tc, b->v->ns, "TaskControl",
                  num(b->rb, RB_TASK_CONTROL_TYPE)) &&
           variable(b, tc, "Controllers/Controller/TaskControls/TaskControl/ComponentName", b->di,
                    "ComponentName", &UA_TYPES[UA_TYPES_LOCALIZEDTEXT], UA_NODEID_NULL, true,
                    UA_NODEID_NULL, UA_VIEW_NONE, NULL) &&
           object(b, tc, "Controllers/Controller/TaskControls/TaskControl/ParameterSet", b->di,
                  "ParameterSet", num(0, UA_NS0ID_BASEOBJECTTYPE)) &&
           variable(b, "Controllers/Controller/TaskControls/TaskControl/ParameterSet",
                    "Controllers/Controller/TaskControls/TaskControl/ParameterSet/TaskProgramName",
                    b->rb, "TaskProgramName", &UA_TYPES[UA_TYPES_STRING], UA_NODEID_NULL, false,
                    num(0, UA_NS0ID_BASEDATAVARIABLETYPE), UA_VIEW_NONE, NULL) &&
           variable(b, "Controllers/Controller/TaskControls/TaskControl/ParameterSet",
                    "Controllers/Controller/TaskControls/TaskControl/ParameterSet/TaskProgramLoaded",
                    b->rb, "TaskProgramLoaded", &UA_TYPES[UA_TYPES_BOOLEAN], UA_NODEID_NULL, false,
                    num(0, UA_NS0ID_BASEDATAVARIABLETYPE), UA_VIEW_NONE, NULL);
}

static bool safety_state(build_t *b)
{
    const char *ss = "SafetyStates/SafetyState";
    const char *ps = "SafetyStates/SafetyState/ParameterSet";
    UA_NodeId bdv = num(0, UA_NS0ID_BASEDATAVARIABLETYPE);
    return folder(b, "", "SafetyStates", "SafetyStates") &&
           object(b, "SafetyStates", ss, b->v->ns, "SafetyState",
                  num(b->rb, RB_SAFETY_STATE_TYPE)) &&
           object(b, ss, ps, b->di, "ParameterSet", num(0, UA_NS0ID_BASEOBJECTTYPE)) &&
           variable(b, ps, "SafetyStates/SafetyState/ParameterSet/OperationalMode", b->rb,
                    "OperationalMode", &UA_TYPES[UA_TYPES_INT32], UA_NODEID_NULL, false, bdv,
                    UA_VIEW_NONE, NULL) &&
           variable(b, ps, "SafetyStates/SafetyState/ParameterSet/EmergencyStop", b->rb,
                    "EmergencyStop", &UA_TYPES[UA_TYPES_BOOLEAN], UA_NODEID_NULL, false, bdv,
                    UA_VIEW_FIELD, "io_state.emergency_stopped") &&
           variable(b, ps, "SafetyStates/SafetyState/ParameterSet/ProtectiveStop", b->rb,
                    "ProtectiveStop", &UA_TYPES[UA_TYPES_BOOLEAN], UA_NODEID_NULL, false, bdv,
                    UA_VIEW_FIELD, "io_state.safety_stopped");
}

UA_StatusCode ua_robotics_add(UA_Server *s, const ua_robotics_t *v, unsigned r, const char *name,
                              char *err, size_t errlen)
{
    build_t b = {s, v, r, name, UA_Server_addNamespace(s, UA_NS_DI),
                 UA_Server_addNamespace(s, UA_NS_ROBOTICS), err, errlen};
    /* the system: DeviceSet/<robot> (its NodeId: <robot>/rb/) */
    char id[160];
    UA_ObjectAttributes a = UA_ObjectAttributes_default;
    a.displayName = text(name);
    UA_StatusCode st = UA_Server_addObjectNode(
        s, inst_id(&b, "", id, sizeof id), num(b.di, DI_DEVICE_SET), num(0, UA_NS0ID_HASCOMPONENT),
        qname(v->ns, name), num(b.rb, RB_MOTION_DEVICE_SYSTEM_TYPE), a, NULL, NULL);
    if (failed(&b, st, "") || !motion_device(&b) || !controller(&b) || !safety_state(&b))
        return st != UA_STATUSCODE_GOOD ? st : UA_STATUSCODE_BADINTERNALERROR;
    return UA_STATUSCODE_GOOD;
}
