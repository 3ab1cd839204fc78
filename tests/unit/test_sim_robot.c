/* SPDX-License-Identifier: MIT */
/* drsim robot model: plausible, self-consistent T->O images. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "robot.h"

#define S 1000000000ull

static drsim_images_t img;
static drsim_robot_t robot;

static dr_io_state_t io_at(uint64_t t)
{
    drsim_robot_update(&robot, t, &img);
    dr_io_state_t io;
    assert_int_equal(dr_io_state_decode(img.buf[DR_ASM_IO_STATE], 36, &io), DR_OK);
    return io;
}

static void test_boot_sequence(void **state)
{
    (void)state;
    drsim_robot_init(&robot, S, 1, true, &img);
    dr_io_state_t io = io_at(S);
    assert_int_equal(io.robot_state, DR_ROBOT_INITIALIZING);
    assert_false(io.servo_on);
    assert_int_equal(io.version.major, 2);
    io = io_at(S + 2 * S);
    assert_int_equal(io.robot_state, DR_ROBOT_STANDBY);
    assert_true(io.servo_on);
    io = io_at(S + 4 * S);
    assert_int_equal(io.robot_state, DR_ROBOT_OPERATING);
    assert_false(io.emergency_stopped);
}

/* The safety stops raised from outside: the flags and robot_state as the
 * controller shows them, the arm held where it stopped, and the motion
 * going on from there (no jump) when they are cleared. */
static void test_safety_stops(void **state)
{
    (void)state;
    drsim_robot_init(&robot, 0, 3, true, &img);
    dr_joint_state_t before, held, after;
    drsim_robot_update(&robot, 10 * S, &img);
    assert_int_equal(dr_joint_state_decode(img.buf[DR_ASM_JOINT_STATE], 144, &before), DR_OK);
    drsim_robot_safety(&robot, true, false, 10 * S, &img);
    dr_io_state_t io = io_at(11 * S);
    assert_int_equal(io.robot_state, DR_ROBOT_EMERGENCY_STOP);
    assert_true(io.emergency_stopped);
    assert_false(io.safety_stopped);
    assert_false(io.servo_on);
    assert_int_equal(dr_joint_state_decode(img.buf[DR_ASM_JOINT_STATE], 144, &held), DR_OK);
    for (int j = 0; j < 6; j++) {
        assert_true(held.position[j] == before.position[j]);
        assert_true(held.velocity[j] == 0.0f);
    }
    /* both: the emergency stop shows; then the protective stop alone */
    drsim_robot_safety(&robot, true, true, 12 * S, &img);
    assert_int_equal(io_at(12 * S).robot_state, DR_ROBOT_EMERGENCY_STOP);
    drsim_robot_safety(&robot, false, true, 13 * S, &img);
    io = io_at(14 * S);
    assert_int_equal(io.robot_state, DR_ROBOT_SAFE_STOP);
    assert_true(io.safety_stopped);
    assert_false(io.emergency_stopped);
    assert_true(io.servo_on);
    drsim_robot_safety(&robot, false, false, 15 * S, &img);
    io = io_at(15 * S);
    assert_int_equal(io.robot_state, DR_ROBOT_OPERATING);
    assert_false(io.safety_stopped || io.emergency_stopped);
    /* where it stood, moving on */
    assert_int_equal(dr_joint_state_decode(img.buf[DR_ASM_JOINT_STATE], 144, &after), DR_OK);
    for (int j = 0; j < 6; j++)
        assert_true(fabsf(after.position[j] - before.position[j]) < 0.01f);
    drsim_robot_update(&robot, 16 * S, &img);
    assert_int_equal(dr_joint_state_decode(img.buf[DR_ASM_JOINT_STATE], 144, &after), DR_OK);
    assert_true(after.position[0] != before.position[0]);
}

/* Velocities agree with the change of position; everything is finite and
 * in a plausible range. */
static void test_joint_motion(void **state)
{
    (void)state;
    drsim_robot_init(&robot, 0, 7, true, &img);
    dr_joint_state_t a, b;
    const uint64_t dt = 1000000; /* 1 ms */
    for (uint64_t t = 5 * S; t < 30 * S; t += S / 3) {
        drsim_robot_update(&robot, t, &img);
        assert_int_equal(dr_joint_state_decode(img.buf[DR_ASM_JOINT_STATE], 144, &a), DR_OK);
        drsim_robot_update(&robot, t + dt, &img);
        assert_int_equal(dr_joint_state_decode(img.buf[DR_ASM_JOINT_STATE], 144, &b), DR_OK);
        for (int j = 0; j < 6; j++) {
            double v = (b.position[j] - a.position[j]) / 1e-3;
            assert_true(fabs(v - a.velocity[j]) < 2.0 + 0.02 * fabs(v));
            assert_true(fabsf(a.position[j]) <= 360.0f);
            assert_true(a.motor_temperature[j] > 20.0f && a.motor_temperature[j] < 80.0f);
            assert_true(fabsf(a.motor_current[j]) < 20.0f);
            assert_true(isfinite(a.torque[j]));
        }
    }
    /* Joints have different periods: they do not move in lockstep. */
    assert_true(fabsf(a.velocity[0] - a.velocity[3]) > 1e-3f);
}

/* task_state follows the joints: the TCP moves when they move, its
 * speed matches its displacement, and it stays within the arm's reach. */
static void test_task_state(void **state)
{
    (void)state;
    drsim_robot_init(&robot, 0, 3, true, &img);
    dr_task_state_t a, b;
    drsim_robot_update(&robot, 10 * S, &img);
    assert_int_equal(dr_task_state_decode(img.buf[DR_ASM_TASK_STATE], 96, &a), DR_OK);
    drsim_robot_update(&robot, 10 * S + 10000000, &img);
    assert_int_equal(dr_task_state_decode(img.buf[DR_ASM_TASK_STATE], 96, &b), DR_OK);
    double reach = sqrt((double)a.position.x * a.position.x +
                        (double)a.position.y * a.position.y +
                        (double)a.position.z * a.position.z);
    assert_true(reach > 100.0 && reach < 1700.0);
    double vx = (b.position.x - a.position.x) / 0.01;
    assert_true(fabs(vx - b.velocity.x) < 1.0 + 0.01 * fabs(vx));
    assert_true(b.tool_offset.z == 100.0f);
    assert_true(fabsf(b.orientation.b) <= 180.0f);
}

static void test_inputs(void **state)
{
    (void)state;
    drsim_robot_init(&robot, 0, 3, true, &img);
    dr_io_control_t ctl = {.cb_do = 0x8001, .tool_do = 0x03, .ao_type = {false, true},
                           .ao = {4.0f, 12.0f}};
    assert_int_equal(dr_io_control_encode(&ctl, img.buf[DR_ASM_IO_CONTROL], 12), DR_OK);
    drsim_robot_input(&robot, DR_ASM_IO_CONTROL, &img);
    dr_io_state_t io = io_at(5 * S);
    assert_int_equal(io.cb_do, 0x8001);
    assert_int_equal(io.tool_do, 0x03);
    assert_false(io.aio_type.ao0);
    assert_true(io.aio_type.ao1);
    assert_true(io.ao[1] == 12.0f);
    assert_true(fabsf(io.ai[0] - 4.0f) < 0.01f); /* AO0 wired to AI0 */

    dr_float_gpr_t in = {{0}}, out;
    in.reg[23] = -2.5f;
    in.reg[0] = NAN;
    assert_int_equal(dr_asm_encode(DR_ASM_FLOAT_IN, &in, img.buf[DR_ASM_FLOAT_IN], 96),
                     DR_ENONFINITE); /* a PLC cannot send NaN through the codec */
    /* A float object, not the literal: with FLT_EVAL_METHOD 1 (s390x,
     * -std=c99) 1e30f itself is evaluated in double precision. */
    const float big = 1e30f;
    in.reg[0] = big;
    assert_int_equal(dr_asm_encode(DR_ASM_FLOAT_IN, &in, img.buf[DR_ASM_FLOAT_IN], 96), DR_OK);
    drsim_robot_input(&robot, DR_ASM_FLOAT_IN, &img);
    assert_int_equal(dr_asm_decode(DR_ASM_FLOAT_OUT, img.buf[DR_ASM_FLOAT_OUT], 96, &out), DR_OK);
    assert_true(out.reg[23] == -2.5f);
    assert_true(out.reg[0] == big);
    /* Raw bytes echo exactly, even a NaN written by Set_Attribute_Single. */
    memset(img.buf[DR_ASM_FLOAT_IN], 0xFF, 96);
    drsim_robot_input(&robot, DR_ASM_FLOAT_IN, &img);
    assert_memory_equal(img.buf[DR_ASM_FLOAT_OUT], img.buf[DR_ASM_FLOAT_IN], 96);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_boot_sequence),
        cmocka_unit_test(test_joint_motion),
        cmocka_unit_test(test_safety_stops),
        cmocka_unit_test(test_task_state),
        cmocka_unit_test(test_inputs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
