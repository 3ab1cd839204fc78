/* SPDX-License-Identifier: MIT */
/*
 * The robot's assemblies, field by field: the one place where offsets,
 * bits and types are written down (spec/README.md, "Fields").
 *
 * Each list is an X-macro: X(A, T, member, kind, byte offset, first bit,
 * count, first index, indexed, path name, unit, help), with A the
 * assembly and T its typed struct. fields.c expands the lists into the
 * const field table that generic access walks; codec.c expands the same
 * lists into straight-line decode and encode functions per assembly, so
 * whole-assembly conversion runs at memcpy-like speed and still has no
 * offset of its own. Private to the library.
 */
#ifndef DRGATE_FIELDS_INTERNAL_H
#define DRGATE_FIELDS_INTERNAL_H

#include "drgate/codec.h"

/* io_state (dr1), 36 bytes, T->O */
#define DR_IO_STATE_FIELDS(X, A, T) \
    X(A, T, cb_di, BITS, 0, 0, 16, 1, 1, "cb_di", "", "ControlBox digital input 1-16") \
    X(A, T, cb_do, BITS, 0, 16, 16, 1, 1, "cb_do", "", "ControlBox digital output 1-16") \
    X(A, T, aio_type.ai0, BIT, 4, 0, 1, 0, 0, "aio_type.ai0", "", "analog input 0 type (0 current, 1 voltage)") \
    X(A, T, aio_type.ai1, BIT, 4, 1, 1, 0, 0, "aio_type.ai1", "", "analog input 1 type (0 current, 1 voltage)") \
    X(A, T, aio_type.ao0, BIT, 4, 2, 1, 0, 0, "aio_type.ao0", "", "analog output 0 type (0 current, 1 voltage)") \
    X(A, T, aio_type.ao1, BIT, 4, 3, 1, 0, 0, "aio_type.ao1", "", "analog output 1 type (0 current, 1 voltage)") \
    X(A, T, ai, REAL, 8, 0, 2, 0, 1, "ai", "", "analog input 0-1") \
    X(A, T, ao, REAL, 16, 0, 2, 0, 1, "ao", "", "analog output 0-1") \
    X(A, T, tool_di, BITS, 24, 0, 6, 1, 1, "tool_di", "", "tool flange digital input 1-6") \
    X(A, T, tool_do, BITS, 24, 16, 6, 1, 1, "tool_do", "", "tool flange digital output 1-6") \
    X(A, T, version.major, USINT, 28, 0, 1, 0, 0, "version.major", "", "controller major version") \
    X(A, T, version.minor, USINT, 29, 0, 1, 0, 0, "version.minor", "", "controller minor version") \
    X(A, T, version.patch, USINT, 30, 0, 1, 0, 0, "version.patch", "", "controller patch version") \
    X(A, T, robot_state, ENUM, 32, 0, 1, 0, 0, "robot_state", "", "robot state (INITIALIZING..SAFE_OFF2)") \
    X(A, T, servo_on, BIT, 32, 16, 1, 0, 0, "servo_on", "", "SO: servo on") \
    X(A, T, safety_stopped, BIT, 32, 17, 1, 0, 0, "safety_stopped", "", "SS: safety stopped") \
    X(A, T, emergency_stopped, BIT, 32, 18, 1, 0, 0, "emergency_stopped", "", "ES: emergency stopped") \
    X(A, T, direct_teach_pressed, BIT, 32, 19, 1, 0, 0, "direct_teach_pressed", "", "DTBP: direct teach button pressed") \
    X(A, T, power_button_pressed, BIT, 32, 20, 1, 0, 0, "power_button_pressed", "", "PBP: power button pressed")

/* joint_state (dr2), 144 bytes, T->O; joint j at base + 4*(j-1) */
#define DR_JOINT_STATE_FIELDS(X, A, T) \
    X(A, T, position, REAL, 0, 0, 6, 1, 1, "position", "degree", "joint position") \
    X(A, T, velocity, REAL, 24, 0, 6, 1, 1, "velocity", "degree/s", "joint velocity") \
    X(A, T, motor_current, REAL, 48, 0, 6, 1, 1, "motor_current", "A", "joint motor current") \
    X(A, T, motor_temperature, REAL, 72, 0, 6, 1, 1, "motor_temperature", "degC", "joint motor temperature") \
    X(A, T, torque, REAL, 96, 0, 6, 1, 1, "torque", "Nm", "joint torque") \
    X(A, T, external_torque, REAL, 120, 0, 6, 1, 1, "external_torque", "Nm", "joint external torque")

/* task_state (dr3), 96 bytes, T->O; base frame, A-B-C Euler Z-Y-Z */
#define DR_TASK_STATE_FIELDS(X, A, T) \
    X(A, T, position.x, REAL, 0, 0, 1, 0, 0, "position.x", "mm", "task position X (base frame)") \
    X(A, T, position.y, REAL, 4, 0, 1, 0, 0, "position.y", "mm", "task position Y (base frame)") \
    X(A, T, position.z, REAL, 8, 0, 1, 0, 0, "position.z", "mm", "task position Z (base frame)") \
    X(A, T, orientation.a, REAL, 12, 0, 1, 0, 0, "orientation.a", "degree", "task orientation A (base frame)") \
    X(A, T, orientation.b, REAL, 16, 0, 1, 0, 0, "orientation.b", "degree", "task orientation B (base frame)") \
    X(A, T, orientation.c, REAL, 20, 0, 1, 0, 0, "orientation.c", "degree", "task orientation C (base frame)") \
    X(A, T, velocity.x, REAL, 24, 0, 1, 0, 0, "velocity.x", "mm/s", "task velocity X (base frame)") \
    X(A, T, velocity.y, REAL, 28, 0, 1, 0, 0, "velocity.y", "mm/s", "task velocity Y (base frame)") \
    X(A, T, velocity.z, REAL, 32, 0, 1, 0, 0, "velocity.z", "mm/s", "task velocity Z (base frame)") \
    X(A, T, angular_velocity.rx, REAL, 36, 0, 1, 0, 0, "angular_velocity.rx", "degree/s", "task angular velocity RX (base frame)") \
    X(A, T, angular_velocity.ry, REAL, 40, 0, 1, 0, 0, "angular_velocity.ry", "degree/s", "task angular velocity RY (base frame)") \
    X(A, T, angular_velocity.rz, REAL, 44, 0, 1, 0, 0, "angular_velocity.rz", "degree/s", "task angular velocity RZ (base frame)") \
    X(A, T, tool_offset.x, REAL, 48, 0, 1, 0, 0, "tool_offset.x", "mm", "tool offset length X (tool frame)") \
    X(A, T, tool_offset.y, REAL, 52, 0, 1, 0, 0, "tool_offset.y", "mm", "tool offset length Y (tool frame)") \
    X(A, T, tool_offset.z, REAL, 56, 0, 1, 0, 0, "tool_offset.z", "mm", "tool offset length Z (tool frame)") \
    X(A, T, tool_offset.a, REAL, 60, 0, 1, 0, 0, "tool_offset.a", "degree", "tool offset angle A (tool frame)") \
    X(A, T, tool_offset.b, REAL, 64, 0, 1, 0, 0, "tool_offset.b", "degree", "tool offset angle B (tool frame)") \
    X(A, T, tool_offset.c, REAL, 68, 0, 1, 0, 0, "tool_offset.c", "degree", "tool offset angle C (tool frame)") \
    X(A, T, external_force.x, REAL, 72, 0, 1, 0, 0, "external_force.x", "N", "task external force X (base frame)") \
    X(A, T, external_force.y, REAL, 76, 0, 1, 0, 0, "external_force.y", "N", "task external force Y (base frame)") \
    X(A, T, external_force.z, REAL, 80, 0, 1, 0, 0, "external_force.z", "N", "task external force Z (base frame)") \
    X(A, T, external_moment.x, REAL, 84, 0, 1, 0, 0, "external_moment.x", "Nm", "task external moment X (base frame)") \
    X(A, T, external_moment.y, REAL, 88, 0, 1, 0, 0, "external_moment.y", "Nm", "task external moment Y (base frame)") \
    X(A, T, external_moment.z, REAL, 92, 0, 1, 0, 0, "external_moment.z", "Nm", "task external moment Z (base frame)")

/* bit_out (dr4), 8 bytes, T->O: register r is bit r%8 of byte r/8 */
#define DR_BIT_OUT_FIELDS(X, A, T) \
    X(A, T, bits, BITS, 0, 0, 64, 0, 1, "", "", "bit output register 0-63")

/* int_out (dr5), 96 bytes, T->O: DINT at 4*r */
#define DR_INT_OUT_FIELDS(X, A, T) \
    X(A, T, reg, DINT, 0, 0, 24, 0, 1, "", "", "int output register 00-23")

/* float_out (dr6), 96 bytes, T->O: REAL at 4*r */
#define DR_FLOAT_OUT_FIELDS(X, A, T) \
    X(A, T, reg, REAL, 0, 0, 24, 0, 1, "", "", "float output register 00-23")

/* io_control (dr7), 12 bytes, O->T */
#define DR_IO_CONTROL_FIELDS(X, A, T) \
    X(A, T, cb_do, BITS, 0, 0, 16, 1, 1, "cb_do", "", "ControlBox digital output 1-16") \
    X(A, T, tool_do, BITS, 0, 16, 6, 1, 1, "tool_do", "", "tool flange digital output 1-6") \
    X(A, T, ao_type.ao0, BIT, 0, 24, 1, 0, 0, "ao_type.ao0", "", "analog output 0 type (0 current, 1 voltage)") \
    X(A, T, ao_type.ao1, BIT, 0, 25, 1, 0, 0, "ao_type.ao1", "", "analog output 1 type (0 current, 1 voltage)") \
    X(A, T, ao, REAL, 4, 0, 2, 0, 1, "ao", "", "analog output 0-1")

/* bit_in (dr8), 8 bytes, O->T */
#define DR_BIT_IN_FIELDS(X, A, T) \
    X(A, T, bits, BITS, 0, 0, 64, 0, 1, "", "", "bit input register 0-63")

/* int_in (dr9), 96 bytes, O->T */
#define DR_INT_IN_FIELDS(X, A, T) \
    X(A, T, reg, DINT, 0, 0, 24, 0, 1, "", "", "int input register 00-23")

/* float_in (dr10), 96 bytes, O->T */
#define DR_FLOAT_IN_FIELDS(X, A, T) \
    X(A, T, reg, REAL, 0, 0, 24, 0, 1, "", "", "float input register 00-23")

/* Y(ID, name, typed struct, field list, 1 if O->T, wire size in bytes),
 * in dr_asm_t order. */
#define DR_ASSEMBLIES(Y) \
    Y(IO_STATE, io_state, dr_io_state_t, DR_IO_STATE_FIELDS, 0, 36) \
    Y(JOINT_STATE, joint_state, dr_joint_state_t, DR_JOINT_STATE_FIELDS, 0, 144) \
    Y(TASK_STATE, task_state, dr_task_state_t, DR_TASK_STATE_FIELDS, 0, 96) \
    Y(BIT_OUT, bit_out, dr_bit_gpr_t, DR_BIT_OUT_FIELDS, 0, 8) \
    Y(INT_OUT, int_out, dr_int_gpr_t, DR_INT_OUT_FIELDS, 0, 96) \
    Y(FLOAT_OUT, float_out, dr_float_gpr_t, DR_FLOAT_OUT_FIELDS, 0, 96) \
    Y(IO_CONTROL, io_control, dr_io_control_t, DR_IO_CONTROL_FIELDS, 1, 12) \
    Y(BIT_IN, bit_in, dr_bit_gpr_t, DR_BIT_IN_FIELDS, 1, 8) \
    Y(INT_IN, int_in, dr_int_gpr_t, DR_INT_IN_FIELDS, 1, 96) \
    Y(FLOAT_IN, float_in, dr_float_gpr_t, DR_FLOAT_IN_FIELDS, 1, 96)

/* Fields per assembly (DR_NF_*) and where each starts in the table. */
#define DR_FIELD_ONE(...) +1
#define DR_FIELD_N(ID, name, T, FIELDS, O2T, SIZE) DR_NF_##ID = 0 FIELDS(DR_FIELD_ONE, 0, T),
enum { DR_ASSEMBLIES(DR_FIELD_N) DR_NF_END_ };
#define DR_SIZE_ENUM(ID, name, T, FIELDS, O2T, SIZE) DR_SIZE_##ID = SIZE,
enum { DR_ASSEMBLIES(DR_SIZE_ENUM) DR_SIZE_END_ };
enum {
    DR_FF_IO_STATE = 0,
    DR_FF_JOINT_STATE = DR_FF_IO_STATE + DR_NF_IO_STATE,
    DR_FF_TASK_STATE = DR_FF_JOINT_STATE + DR_NF_JOINT_STATE,
    DR_FF_BIT_OUT = DR_FF_TASK_STATE + DR_NF_TASK_STATE,
    DR_FF_INT_OUT = DR_FF_BIT_OUT + DR_NF_BIT_OUT,
    DR_FF_FLOAT_OUT = DR_FF_INT_OUT + DR_NF_INT_OUT,
    DR_FF_IO_CONTROL = DR_FF_FLOAT_OUT + DR_NF_FLOAT_OUT,
    DR_FF_BIT_IN = DR_FF_IO_CONTROL + DR_NF_IO_CONTROL,
    DR_FF_INT_IN = DR_FF_BIT_IN + DR_NF_BIT_IN,
    DR_FF_FLOAT_IN = DR_FF_INT_IN + DR_NF_INT_IN,
    DR_FF_END = DR_FF_FLOAT_IN + DR_NF_FLOAT_IN
};

/* The field table (fields.c), DR_FF_END rows. Internal: applications see
 * it through dr_field_count(), dr_field_at() and dr_field_index(), so that
 * its size is no part of libdrgate.so's ABI (an exported data table is
 * copied into every program that uses it, with its size at link time). */
#pragma GCC visibility push(hidden)
extern const dr_field_t dr_field_tab[DR_FF_END];
#pragma GCC visibility pop

#endif /* DRGATE_FIELDS_INTERNAL_H */
