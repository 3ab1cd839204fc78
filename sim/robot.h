/* SPDX-License-Identifier: MIT */
/*
 * drsim robot model: what a Doosan controller would publish.
 *
 * Pure computation over the assembly images: no sockets, no clock (the
 * caller passes monotonic nanoseconds), so unit tests can drive it.
 * T->O images are written only through the codec's typed structs.
 */
#ifndef DRSIM_ROBOT_H
#define DRSIM_ROBOT_H

#include <stdbool.h>
#include <stdint.h>

#include "drgate/codec.h"

/* All ten assembly images, indexed by dr_asm_t; each uses the first
 * dr_asm_info(a)->size bytes of its row. */
typedef struct {
    uint8_t buf[DR_ASM_COUNT][DR_ASM_MAX_SIZE];
} drsim_images_t;

/* Seconds from start at which robot_state moves on. */
#define DRSIM_T_STANDBY_S 1.5
#define DRSIM_T_OPERATING_S 3.0

typedef struct {
    uint64_t start_ns;  /* model time zero */
    uint64_t last_ns;   /* time of the last update */
    bool updated;       /* an update has happened (last_ns valid) */
    bool echo;          /* GPR inputs echo to GPR outputs */
    bool still;         /* stands still once booted: no motion, no noise */
    uint64_t seed;
    uint64_t step;      /* update counter, varies the noise */
    /* Safety stops raised from outside (drsim_robot_safety): an emergency
     * stop, a protective stop; while either holds the arm stands where it
     * stopped, and the motion goes on from there when both are clear. */
    bool estop, pstop;
    uint64_t stop_since_ns; /* when the current stop began */
    uint64_t stopped_ns;    /* motion time lost to stops that ended */
    float temperature[6];
    double rot[3][3];   /* last TCP orientation, for angular velocity */
    double tcp[3];      /* last TCP position, for linear velocity */
    dr_io_state_t io;
    dr_joint_state_t joints;
    dr_task_state_t task;
} drsim_robot_t;

/* Start the model at `now_ns` and write every T->O image once. */
void drsim_robot_init(drsim_robot_t *r, uint64_t now_ns, uint64_t seed,
                      bool echo, drsim_images_t *img);

/* Advance the model to `now_ns` and rewrite the T->O images. */
void drsim_robot_update(drsim_robot_t *r, uint64_t now_ns, drsim_images_t *img);

/* Raise or clear the emergency stop and the protective stop at `now_ns`
 * and rewrite the T->O images at once. An emergency stop shows as
 * robot_state EMERGENCY_STOP, emergency_stopped set and the servos off; a
 * protective stop (with no emergency stop) as robot_state SAFE_STOP and
 * safety_stopped set, the servos on and holding. */
void drsim_robot_safety(drsim_robot_t *r, bool estop, bool pstop, uint64_t now_ns,
                        drsim_images_t *img);

/* O->T image `a` changed (Set_Attribute_Single or a Class 1 packet): make
 * it show at once in the T->O images (io_control in io_state, GPR echo),
 * so a read right after a write sees the round trip. */
void drsim_robot_input(drsim_robot_t *r, dr_asm_t a, drsim_images_t *img);

#endif /* DRSIM_ROBOT_H */
