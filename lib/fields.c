/* SPDX-License-Identifier: MIT */
/*
 * The field table: the one place where offsets, bits and types of the
 * robot's assemblies are written down (spec/README.md, "Fields").
 */
#include <stddef.h>

#include "drgate/codec.h"

#define MEMBER_SIZE(T, m) sizeof(((T *)0)->m)

/* F(assembly, struct type, struct member, kind, byte offset, first bit,
 *   count, first index, indexed, path name, unit, help) */
#define F(A, T, M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)              \
    {(uint8_t)(A), (uint8_t)(K), (BIT), (N), (FIRST), (IDX), (OFF),           \
     (uint16_t)offsetof(T, M), (uint16_t)MEMBER_SIZE(T, M), NAME, UNIT, HELP}

#define IOS(M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)                   \
    F(DR_ASM_IO_STATE, dr_io_state_t, M, K, OFF, BIT, N, FIRST, IDX, NAME,    \
      UNIT, HELP)
#define JS(M, OFF, NAME, UNIT, HELP)                                          \
    F(DR_ASM_JOINT_STATE, dr_joint_state_t, M, DR_KIND_REAL, OFF, 0, 6, 1, 1, \
      NAME, UNIT, HELP)
#define TS(M, OFF, UNIT, HELP)                                                \
    F(DR_ASM_TASK_STATE, dr_task_state_t, M, DR_KIND_REAL, OFF, 0, 1, 0, 0,   \
      #M, UNIT, HELP)
#define IOC(M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)                   \
    F(DR_ASM_IO_CONTROL, dr_io_control_t, M, K, OFF, BIT, N, FIRST, IDX,      \
      NAME, UNIT, HELP)

const dr_field_t dr_field_table[] = {
    /* io_state (dr1), 36 bytes, T->O */
    IOS(cb_di, DR_KIND_BITS, 0, 0, 16, 1, 1, "cb_di", "", "ControlBox digital input 1-16"),
    IOS(cb_do, DR_KIND_BITS, 0, 16, 16, 1, 1, "cb_do", "", "ControlBox digital output 1-16"),
    IOS(aio_type.ai0, DR_KIND_BIT, 4, 0, 1, 0, 0, "aio_type.ai0", "", "analog input 0 type (0 current, 1 voltage)"),
    IOS(aio_type.ai1, DR_KIND_BIT, 4, 1, 1, 0, 0, "aio_type.ai1", "", "analog input 1 type (0 current, 1 voltage)"),
    IOS(aio_type.ao0, DR_KIND_BIT, 4, 2, 1, 0, 0, "aio_type.ao0", "", "analog output 0 type (0 current, 1 voltage)"),
    IOS(aio_type.ao1, DR_KIND_BIT, 4, 3, 1, 0, 0, "aio_type.ao1", "", "analog output 1 type (0 current, 1 voltage)"),
    IOS(ai, DR_KIND_REAL, 8, 0, 2, 0, 1, "ai", "", "analog input 0-1"),
    IOS(ao, DR_KIND_REAL, 16, 0, 2, 0, 1, "ao", "", "analog output 0-1"),
    IOS(tool_di, DR_KIND_BITS, 24, 0, 6, 1, 1, "tool_di", "", "tool flange digital input 1-6"),
    IOS(tool_do, DR_KIND_BITS, 24, 16, 6, 1, 1, "tool_do", "", "tool flange digital output 1-6"),
    IOS(version.major, DR_KIND_USINT, 28, 0, 1, 0, 0, "version.major", "", "controller major version"),
    IOS(version.minor, DR_KIND_USINT, 29, 0, 1, 0, 0, "version.minor", "", "controller minor version"),
    IOS(version.patch, DR_KIND_USINT, 30, 0, 1, 0, 0, "version.patch", "", "controller patch version"),
    IOS(robot_state, DR_KIND_ENUM, 32, 0, 1, 0, 0, "robot_state", "", "robot state (INITIALIZING..SAFE_OFF2)"),
    IOS(servo_on, DR_KIND_BIT, 32, 16, 1, 0, 0, "servo_on", "", "SO: servo on"),
    IOS(safety_stopped, DR_KIND_BIT, 32, 17, 1, 0, 0, "safety_stopped", "", "SS: safety stopped"),
    IOS(emergency_stopped, DR_KIND_BIT, 32, 18, 1, 0, 0, "emergency_stopped", "", "ES: emergency stopped"),
    IOS(direct_teach_pressed, DR_KIND_BIT, 32, 19, 1, 0, 0, "direct_teach_pressed", "", "DTBP: direct teach button pressed"),
    IOS(power_button_pressed, DR_KIND_BIT, 32, 20, 1, 0, 0, "power_button_pressed", "", "PBP: power button pressed"),

    /* joint_state (dr2), 144 bytes, T->O; joint j at base + 4*(j-1) */
    JS(position, 0, "position", "degree", "joint position"),
    JS(velocity, 24, "velocity", "degree/s", "joint velocity"),
    JS(motor_current, 48, "motor_current", "A", "joint motor current"),
    JS(motor_temperature, 72, "motor_temperature", "degC", "joint motor temperature"),
    JS(torque, 96, "torque", "Nm", "joint torque"),
    JS(external_torque, 120, "external_torque", "Nm", "joint external torque"),

    /* task_state (dr3), 96 bytes, T->O; base frame, A-B-C Euler Z-Y-Z */
    TS(position.x, 0, "mm", "task position X (base frame)"),
    TS(position.y, 4, "mm", "task position Y (base frame)"),
    TS(position.z, 8, "mm", "task position Z (base frame)"),
    TS(orientation.a, 12, "degree", "task orientation A (base frame)"),
    TS(orientation.b, 16, "degree", "task orientation B (base frame)"),
    TS(orientation.c, 20, "degree", "task orientation C (base frame)"),
    TS(velocity.x, 24, "mm/s", "task velocity X (base frame)"),
    TS(velocity.y, 28, "mm/s", "task velocity Y (base frame)"),
    TS(velocity.z, 32, "mm/s", "task velocity Z (base frame)"),
    TS(angular_velocity.rx, 36, "degree/s", "task angular velocity RX (base frame)"),
    TS(angular_velocity.ry, 40, "degree/s", "task angular velocity RY (base frame)"),
    TS(angular_velocity.rz, 44, "degree/s", "task angular velocity RZ (base frame)"),
    TS(tool_offset.x, 48, "mm", "tool offset length X (tool frame)"),
    TS(tool_offset.y, 52, "mm", "tool offset length Y (tool frame)"),
    TS(tool_offset.z, 56, "mm", "tool offset length Z (tool frame)"),
    TS(tool_offset.a, 60, "degree", "tool offset angle A (tool frame)"),
    TS(tool_offset.b, 64, "degree", "tool offset angle B (tool frame)"),
    TS(tool_offset.c, 68, "degree", "tool offset angle C (tool frame)"),
    TS(external_force.x, 72, "N", "task external force X (base frame)"),
    TS(external_force.y, 76, "N", "task external force Y (base frame)"),
    TS(external_force.z, 80, "N", "task external force Z (base frame)"),
    TS(external_moment.x, 84, "Nm", "task external moment X (base frame)"),
    TS(external_moment.y, 88, "Nm", "task external moment Y (base frame)"),
    TS(external_moment.z, 92, "Nm", "task external moment Z (base frame)"),

    /* general purpose registers produced by the robot (dr4..dr6) */
    F(DR_ASM_BIT_OUT, dr_bit_gpr_t, bits, DR_KIND_BITS, 0, 0, 64, 0, 1, "", "", "bit output register 0-63"),
    F(DR_ASM_INT_OUT, dr_int_gpr_t, reg, DR_KIND_DINT, 0, 0, 24, 0, 1, "", "", "int output register 00-23"),
    F(DR_ASM_FLOAT_OUT, dr_float_gpr_t, reg, DR_KIND_REAL, 0, 0, 24, 0, 1, "", "", "float output register 00-23"),

    /* io_control (dr7), 12 bytes, O->T */
    IOC(cb_do, DR_KIND_BITS, 0, 0, 16, 1, 1, "cb_do", "", "ControlBox digital output 1-16"),
    IOC(tool_do, DR_KIND_BITS, 0, 16, 6, 1, 1, "tool_do", "", "tool flange digital output 1-6"),
    IOC(ao_type.ao0, DR_KIND_BIT, 0, 24, 1, 0, 0, "ao_type.ao0", "", "analog output 0 type (0 current, 1 voltage)"),
    IOC(ao_type.ao1, DR_KIND_BIT, 0, 25, 1, 0, 0, "ao_type.ao1", "", "analog output 1 type (0 current, 1 voltage)"),
    IOC(ao, DR_KIND_REAL, 4, 0, 2, 0, 1, "ao", "", "analog output 0-1"),

    /* general purpose registers consumed by the robot (dr8..dr10) */
    F(DR_ASM_BIT_IN, dr_bit_gpr_t, bits, DR_KIND_BITS, 0, 0, 64, 0, 1, "", "", "bit input register 0-63"),
    F(DR_ASM_INT_IN, dr_int_gpr_t, reg, DR_KIND_DINT, 0, 0, 24, 0, 1, "", "", "int input register 00-23"),
    F(DR_ASM_FLOAT_IN, dr_float_gpr_t, reg, DR_KIND_REAL, 0, 0, 24, 0, 1, "", "", "float input register 00-23"),
};

const uint16_t dr_field_count =
    (uint16_t)(sizeof dr_field_table / sizeof dr_field_table[0]);

/* first_field/field_count follow the table above (checked by the tests). */
static const dr_asm_info_t asm_info[DR_ASM_COUNT] = {
    {"io_state", "dr1", "IO & Robot State", DR_DIR_T2O, 36, 0, 19, sizeof(dr_io_state_t)},
    {"joint_state", "dr2", "Joint State", DR_DIR_T2O, 144, 19, 6, sizeof(dr_joint_state_t)},
    {"task_state", "dr3", "Task State", DR_DIR_T2O, 96, 25, 24, sizeof(dr_task_state_t)},
    {"bit_out", "dr4", "Bit General Purpose Register (robot output)", DR_DIR_T2O, 8, 49, 1, sizeof(dr_bit_gpr_t)},
    {"int_out", "dr5", "Int General Purpose Register (robot output)", DR_DIR_T2O, 96, 50, 1, sizeof(dr_int_gpr_t)},
    {"float_out", "dr6", "Float General Purpose Register (robot output)", DR_DIR_T2O, 96, 51, 1, sizeof(dr_float_gpr_t)},
    {"io_control", "dr7", "IO Control", DR_DIR_O2T, 12, 52, 5, sizeof(dr_io_control_t)},
    {"bit_in", "dr8", "Bit General Purpose Register (robot input)", DR_DIR_O2T, 8, 57, 1, sizeof(dr_bit_gpr_t)},
    {"int_in", "dr9", "Int General Purpose Register (robot input)", DR_DIR_O2T, 96, 58, 1, sizeof(dr_int_gpr_t)},
    {"float_in", "dr10", "Float General Purpose Register (robot input)", DR_DIR_O2T, 96, 59, 1, sizeof(dr_float_gpr_t)},
};

const dr_asm_info_t *dr_asm_info(dr_asm_t a)
{
    return (unsigned)a < DR_ASM_COUNT ? &asm_info[a] : NULL;
}

static const char *const robot_state_names[] = {
    "INITIALIZING", "STANDBY",   "OPERATING", "SAFE_OFF",
    "TEACHING",     "SAFE_STOP", "EMERGENCY_STOP", "HOMING",
    "RECOVERY",     "SAFE_STOP2", "SAFE_OFF2",
};

const char *dr_robot_state_name(unsigned value)
{
    if (value >= sizeof robot_state_names / sizeof robot_state_names[0])
        return NULL;
    return robot_state_names[value];
}
