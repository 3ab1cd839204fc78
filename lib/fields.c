/* SPDX-License-Identifier: MIT */
/*
 * The field table, expanded from the field lists in fields_internal.h, and
 * the assemblies' names and sizes (spec/README.md).
 */
#include <stddef.h>

#include "drgate/codec.h"
#include "fields_internal.h"

#define MEMBER_SIZE(T, m) sizeof(((T *)0)->m)

/* One table entry from one X-macro line of fields_internal.h. */
#define DR_FIELD_ENTRY(A, T, M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)  \
    {(uint8_t)(A), (uint8_t)DR_KIND_##K, (BIT), (N), (FIRST), (IDX), (OFF),  \
     (uint16_t)offsetof(T, M), (uint16_t)MEMBER_SIZE(T, M), NAME, UNIT, HELP},
#define DR_ASM_ENTRIES(ID, name, T, FIELDS, O2T, SIZE) FIELDS(DR_FIELD_ENTRY, DR_ASM_##ID, T)

const dr_field_t dr_field_tab[DR_FF_END] = {DR_ASSEMBLIES(DR_ASM_ENTRIES)};

uint16_t dr_field_count(void)
{
    return DR_FF_END;
}

const dr_field_t *dr_field_at(uint16_t i)
{
    return i < DR_FF_END ? &dr_field_tab[i] : NULL;
}

/* By equality, not by subtraction: a pointer from outside the table may
 * not be compared or subtracted with it (C99 6.5.6, 6.5.8). */
uint16_t dr_field_index(const dr_field_t *f)
{
    for (unsigned i = 0; i < DR_FF_END; i++)
        if (f == &dr_field_tab[i])
            return (uint16_t)i;
    return DR_FIELD_NONE;
}

/* Names and titles; sizes and field ranges come from fields_internal.h. */
static const dr_asm_info_t asm_info[DR_ASM_COUNT] = {
    {"io_state", "dr1", "IO & Robot State", DR_DIR_T2O, DR_SIZE_IO_STATE, DR_FF_IO_STATE, DR_NF_IO_STATE, sizeof(dr_io_state_t)},
    {"joint_state", "dr2", "Joint State", DR_DIR_T2O, DR_SIZE_JOINT_STATE, DR_FF_JOINT_STATE, DR_NF_JOINT_STATE, sizeof(dr_joint_state_t)},
    {"task_state", "dr3", "Task State", DR_DIR_T2O, DR_SIZE_TASK_STATE, DR_FF_TASK_STATE, DR_NF_TASK_STATE, sizeof(dr_task_state_t)},
    {"bit_out", "dr4", "Bit General Purpose Register (robot output)", DR_DIR_T2O, DR_SIZE_BIT_OUT, DR_FF_BIT_OUT, DR_NF_BIT_OUT, sizeof(dr_bit_gpr_t)},
    {"int_out", "dr5", "Int General Purpose Register (robot output)", DR_DIR_T2O, DR_SIZE_INT_OUT, DR_FF_INT_OUT, DR_NF_INT_OUT, sizeof(dr_int_gpr_t)},
    {"float_out", "dr6", "Float General Purpose Register (robot output)", DR_DIR_T2O, DR_SIZE_FLOAT_OUT, DR_FF_FLOAT_OUT, DR_NF_FLOAT_OUT, sizeof(dr_float_gpr_t)},
    {"io_control", "dr7", "IO Control", DR_DIR_O2T, DR_SIZE_IO_CONTROL, DR_FF_IO_CONTROL, DR_NF_IO_CONTROL, sizeof(dr_io_control_t)},
    {"bit_in", "dr8", "Bit General Purpose Register (robot input)", DR_DIR_O2T, DR_SIZE_BIT_IN, DR_FF_BIT_IN, DR_NF_BIT_IN, sizeof(dr_bit_gpr_t)},
    {"int_in", "dr9", "Int General Purpose Register (robot input)", DR_DIR_O2T, DR_SIZE_INT_IN, DR_FF_INT_IN, DR_NF_INT_IN, sizeof(dr_int_gpr_t)},
    {"float_in", "dr10", "Float General Purpose Register (robot input)", DR_DIR_O2T, DR_SIZE_FLOAT_IN, DR_FF_FLOAT_IN, DR_NF_FLOAT_IN, sizeof(dr_float_gpr_t)},
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
