/* SPDX-License-Identifier: MIT */
/*
 * drsim robot model. A six-axis arm (link lengths of a Doosan M1013) that
 * boots (INITIALIZING -> STANDBY -> OPERATING), then moves every joint on
 * its own sine, with velocities that are the exact derivative of the
 * positions, torques from gravity and inertia, currents from torque and
 * temperatures that follow the currents. The TCP comes from forward
 * kinematics, so task_state agrees with joint_state.
 */
#include <math.h>
#include <string.h>

#include "log.h"
#include "robot.h"

#define PI 3.14159265358979323846
#define DEG (PI / 180.0)

/* Joint motion: centre, amplitude (degree) and period (s); different
 * periods so the arm never repeats a short pattern. */
static const double j_centre[6] = {0.0, 0.0, 90.0, 0.0, 90.0, 0.0};
static const double j_amp[6] = {60.0, 25.0, 35.0, 90.0, 40.0, 120.0};
static const double j_period[6] = {8.0, 11.0, 13.0, 7.0, 9.0, 5.0};
/* Rotor-side inertia seen at the joint (kg m^2) and torque constant incl.
 * gear ratio (Nm/A): enough for plausible magnitudes. */
static const double j_inertia[6] = {2.5, 3.0, 1.2, 0.15, 0.1, 0.05};
static const double j_kt[6] = {25.0, 25.0, 18.0, 8.0, 8.0, 8.0};
/* Motion ramps in over this long so nothing jumps at OPERATING. */
#define RAMP_S 2.0
/* Ambient temperature and thermal time constant of a motor. */
#define T_AMBIENT 27.0
#define T_TAU_S 300.0
#define TOOL_Z_MM 100.0

/* splitmix64: small, deterministic noise from (seed, step, channel). */
static uint64_t mix64(uint64_t x)
{
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

/* Uniform noise in [-amp, amp]. */
static double noise(const drsim_robot_t *r, unsigned channel, double amp)
{
    if (r->still)
        return 0.0;
    uint64_t x = mix64(r->seed ^ mix64(r->step * 64u + channel));
    double u = (double)(x >> 11) / 9007199254740992.0; /* [0, 1) */
    return amp * (2.0 * u - 1.0);
}

static double seconds_since(uint64_t now_ns, uint64_t t0_ns)
{
    return now_ns > t0_ns ? (double)(now_ns - t0_ns) / 1e9 : 0.0;
}

static uint8_t robot_state_at(double t)
{
    if (t < DRSIM_T_STANDBY_S)
        return DR_ROBOT_INITIALIZING;
    if (t < DRSIM_T_OPERATING_S)
        return DR_ROBOT_STANDBY;
    return DR_ROBOT_OPERATING;
}

/* Joint j at time tau after OPERATING: position (degree), velocity
 * (degree/s) and acceleration (degree/s^2), exact derivatives of
 * centre + amp * ramp(tau) * sin(w tau). */
static void joint_motion(unsigned j, double tau, double *pos, double *vel,
                         double *acc)
{
    double w = 2.0 * PI / j_period[j];
    double ramp = 1.0, dramp = 0.0, ddramp = 0.0;
    if (tau < RAMP_S) {
        double k = PI / RAMP_S;
        ramp = 0.5 * (1.0 - cos(k * tau));
        dramp = 0.5 * k * sin(k * tau);
        ddramp = 0.5 * k * k * cos(k * tau);
    }
    double s = sin(w * tau), c = cos(w * tau);
    *pos = j_centre[j] + j_amp[j] * ramp * s;
    *vel = j_amp[j] * (dramp * s + ramp * w * c);
    *acc = j_amp[j] * (ddramp * s + 2.0 * dramp * w * c - ramp * w * w * s);
}

/* ---- kinematics ------------------------------------------------------- */

typedef double mat4_t[4][4];

static void mat4_mul(mat4_t out, mat4_t a, mat4_t b)
{
    mat4_t t;
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 4; k++) {
            t[i][k] = 0.0;
            for (int m = 0; m < 4; m++)
                t[i][k] += a[i][m] * b[m][k];
        }
    memcpy(out, t, sizeof t);
}

/* Standard Denavit-Hartenberg transform. */
static void dh(mat4_t out, double theta, double d, double a, double alpha)
{
    double ct = cos(theta), st = sin(theta), ca = cos(alpha), sa = sin(alpha);
    mat4_t m = {{ct, -st * ca, st * sa, a * ct},
                {st, ct * ca, -ct * sa, a * st},
                {0.0, sa, ca, d},
                {0.0, 0.0, 0.0, 1.0}};
    memcpy(out, m, sizeof m);
}

/* TCP pose (mm, rotation matrix) of joint angles q (degree), tool offset
 * TOOL_Z_MM along the flange z. Link lengths of an M1013. */
static void forward_kinematics(const double q[6], double pos[3], double rot[3][3])
{
    static const double d[6] = {152.5, 0.0, 0.0, 559.0, 0.0, 121.5};
    static const double a[6] = {0.0, 620.0, 0.0, 0.0, 0.0, 0.0};
    static const double alpha[6] = {-90.0, 0.0, 90.0, -90.0, 90.0, 0.0};
    static const double offset[6] = {0.0, -90.0, 90.0, 0.0, 0.0, 0.0};
    mat4_t t = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    for (int j = 0; j < 6; j++) {
        mat4_t m;
        dh(m, (q[j] + offset[j]) * DEG, d[j], a[j], alpha[j] * DEG);
        mat4_mul(t, t, m);
    }
    mat4_t tool;
    dh(tool, 0.0, TOOL_Z_MM, 0.0, 0.0);
    mat4_mul(t, t, tool);
    for (int i = 0; i < 3; i++) {
        pos[i] = t[i][3];
        for (int k = 0; k < 3; k++)
            rot[i][k] = t[i][k];
    }
}

/* Euler Z-Y-Z angles (degree) of a rotation matrix, as Doosan reports. */
static void euler_zyz(double rot[3][3], double *a, double *b, double *c)
{
    double sb = sqrt(rot[0][2] * rot[0][2] + rot[1][2] * rot[1][2]);
    *b = atan2(sb, rot[2][2]) / DEG;
    if (sb > 1e-9) {
        *a = atan2(rot[1][2], rot[0][2]) / DEG;
        *c = atan2(rot[2][1], -rot[2][0]) / DEG;
    } else { /* gimbal lock: put it all in a */
        *a = atan2(rot[1][0], rot[0][0]) / DEG;
        *c = 0.0;
    }
}

/* ---- state update ------------------------------------------------------ */

static void update_io(drsim_robot_t *r, double t)
{
    uint8_t state = robot_state_at(t);
    r->io.servo_on = state != DR_ROBOT_INITIALIZING && !r->estop;
    if (r->estop)
        state = DR_ROBOT_EMERGENCY_STOP;
    else if (r->pstop)
        state = DR_ROBOT_SAFE_STOP;
    r->io.robot_state = state;
    r->io.safety_stopped = r->pstop && !r->estop;
    r->io.emergency_stopped = r->estop;
    r->io.direct_teach_pressed = false;
    r->io.power_button_pressed = false;
    /* DI1: "cell ready" once booted; DI2: a part sensor toggling every 2 s. */
    uint16_t di = 0;
    if (state != DR_ROBOT_INITIALIZING)
        di |= 0x0001u;
    if (!r->still && ((uint64_t)(t / 2.0)) % 2u)
        di |= 0x0002u;
    r->io.cb_di = di;
    /* AI0 is wired back from AO0; AI1 reads a slowly varying sensor. */
    r->io.ai[0] = r->io.ao[0] + (float)noise(r, 40, 0.002);
    r->io.ai[1] = r->still ? 2.5f : (float)(2.5 + 0.5 * sin(2.0 * PI * t / 20.0));
    /* The gripper on tool DO1/DO2 reports back on tool DI1/DI2. */
    r->io.tool_di = (uint8_t)(r->io.tool_do & 0x03u);
}

/* t: the motion's time (stops left out); stopped: a safety stop holds. */
static void update_joints(drsim_robot_t *r, double t, bool stopped, double dt, double q[6])
{
    bool moving = !r->still && t >= DRSIM_T_OPERATING_S;
    double tau = moving ? t - DRSIM_T_OPERATING_S : 0.0;
    double qd[6], qdd[6];
    for (unsigned j = 0; j < 6; j++) {
        joint_motion(j, tau, &q[j], &qd[j], &qdd[j]);
        if (!moving || stopped) /* stopped: held where the stop found it */
            qd[j] = qdd[j] = 0.0;
    }
    /* Gravity on the shoulder and elbow (arm masses ~25 kg and ~10 kg). */
    double s2 = sin(q[1] * DEG), s23 = sin((q[1] + q[2] - 90.0) * DEG);
    const double gravity[6] = {0.0, 9.81 * (25.0 * 0.31 * s2 + 10.0 * 0.62 * s2) +
                                  9.81 * 10.0 * 0.28 * s23,
                         9.81 * 10.0 * 0.28 * s23, 0.0,
                         9.81 * 2.0 * 0.06 * sin(q[4] * DEG), 0.0};
    bool servo = r->io.servo_on;
    for (unsigned j = 0; j < 6; j++) {
        double friction = qd[j] > 0.0 ? 1.5 : (qd[j] < 0.0 ? -1.5 : 0.0);
        double torque = servo ? gravity[j] + j_inertia[j] * qdd[j] * DEG + friction +
                                    noise(r, j, 0.2)
                              : 0.0;
        double current = servo ? torque / j_kt[j] + 0.3 + noise(r, 10 + j, 0.02) : 0.0;
        /* First-order thermal model: heats with I^2, cools to ambient. */
        double target = T_AMBIENT + 4.0 + 6.0 * current * current;
        if (!r->still) /* still: the motors hold their temperature */
            r->temperature[j] += (float)((target - r->temperature[j]) * (dt / T_TAU_S));
        r->joints.position[j] = (float)q[j];
        r->joints.velocity[j] = (float)qd[j];
        r->joints.torque[j] = (float)torque;
        r->joints.external_torque[j] = servo ? (float)noise(r, 20 + j, 0.3) : 0.0f;
        r->joints.motor_current[j] = (float)current;
        r->joints.motor_temperature[j] = r->temperature[j];
    }
}

static void update_task(drsim_robot_t *r, const double q[6], double dt)
{
    double pos[3], rot[3][3], a, b, c;
    forward_kinematics(q, pos, rot);
    euler_zyz(rot, &a, &b, &c);
    double v[3] = {0.0, 0.0, 0.0}, w[3] = {0.0, 0.0, 0.0};
    if (r->updated && dt > 0.0) {
        for (int i = 0; i < 3; i++)
            v[i] = (pos[i] - r->tcp[i]) / dt;
        /* Angular velocity from dR = R_new R_old^T ~ I + [w]x dt. */
        double dr[3][3];
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++) {
                dr[i][k] = 0.0;
                for (int m = 0; m < 3; m++)
                    dr[i][k] += rot[i][m] * r->rot[k][m];
            }
        w[0] = (dr[2][1] - dr[1][2]) / (2.0 * dt) / DEG;
        w[1] = (dr[0][2] - dr[2][0]) / (2.0 * dt) / DEG;
        w[2] = (dr[1][0] - dr[0][1]) / (2.0 * dt) / DEG;
    }
    memcpy(r->tcp, pos, sizeof pos);
    memcpy(r->rot, rot, sizeof rot);
    dr_task_state_t *ts = &r->task;
    ts->position.x = (float)pos[0];
    ts->position.y = (float)pos[1];
    ts->position.z = (float)pos[2];
    ts->orientation.a = (float)a;
    ts->orientation.b = (float)b;
    ts->orientation.c = (float)c;
    ts->velocity.x = (float)v[0];
    ts->velocity.y = (float)v[1];
    ts->velocity.z = (float)v[2];
    ts->angular_velocity.rx = (float)w[0];
    ts->angular_velocity.ry = (float)w[1];
    ts->angular_velocity.rz = (float)w[2];
    memset(&ts->tool_offset, 0, sizeof ts->tool_offset);
    ts->tool_offset.z = (float)TOOL_Z_MM;
    bool servo = r->io.servo_on;
    ts->external_force.x = servo ? (float)noise(r, 30, 1.0) : 0.0f;
    ts->external_force.y = servo ? (float)noise(r, 31, 1.0) : 0.0f;
    ts->external_force.z = servo ? (float)noise(r, 32, 1.0) : 0.0f;
    ts->external_moment.x = servo ? (float)noise(r, 33, 0.1) : 0.0f;
    ts->external_moment.y = servo ? (float)noise(r, 34, 0.1) : 0.0f;
    ts->external_moment.z = servo ? (float)noise(r, 35, 0.1) : 0.0f;
}

/* Encode one T->O image from its typed struct. The model only produces
 * in-range values, so an error here is a bug worth shouting about. */
static void put(dr_asm_t a, const void *in, drsim_images_t *img)
{
    dr_status_t st = dr_asm_encode(a, in, img->buf[a], dr_asm_info(a)->size);
    if (st != DR_OK)
        drsim_log(0, "robot: encoding %s failed: %s", dr_asm_info(a)->name,
                  dr_strerror(st));
}

static void write_images(drsim_robot_t *r, drsim_images_t *img)
{
    put(DR_ASM_IO_STATE, &r->io, img);
    put(DR_ASM_JOINT_STATE, &r->joints, img);
    put(DR_ASM_TASK_STATE, &r->task, img);
}

void drsim_robot_init(drsim_robot_t *r, uint64_t now_ns, uint64_t seed,
                      bool echo, drsim_images_t *img)
{
    memset(r, 0, sizeof *r);
    r->start_ns = now_ns;
    r->seed = seed;
    r->echo = echo;
    r->io.version.major = 2;
    r->io.version.minor = 12;
    r->io.version.patch = 3;
    for (unsigned j = 0; j < 6; j++)
        r->temperature[j] = (float)(T_AMBIENT + 1.0 + 0.5 * j);
    drsim_robot_update(r, now_ns, img);
    drsim_robot_input(r, DR_ASM_BIT_IN, img);
    drsim_robot_input(r, DR_ASM_INT_IN, img);
    drsim_robot_input(r, DR_ASM_FLOAT_IN, img);
}

void drsim_robot_update(drsim_robot_t *r, uint64_t now_ns, drsim_images_t *img)
{
    double t = seconds_since(now_ns, r->start_ns);
    double dt = r->updated ? seconds_since(now_ns, r->last_ns) : 0.0;
    uint8_t before = r->io.robot_state;
    bool stopped = r->estop || r->pstop;
    /* the motion's clock stands while a stop holds */
    uint64_t lost = r->stopped_ns + (stopped && now_ns > r->stop_since_ns
                                         ? now_ns - r->stop_since_ns : 0u);
    double q[6];
    update_io(r, t);
    update_joints(r, seconds_since(now_ns, r->start_ns + lost), stopped, dt, q);
    update_task(r, q, dt);
    if (r->updated && before != r->io.robot_state)
        drsim_log(1, "robot: state %s -> %s", dr_robot_state_name(before),
                  dr_robot_state_name(r->io.robot_state));
    r->updated = true;
    r->last_ns = now_ns;
    r->step++;
    write_images(r, img);
}

void drsim_robot_safety(drsim_robot_t *r, bool estop, bool pstop, uint64_t now_ns,
                        drsim_images_t *img)
{
    bool was = r->estop || r->pstop, is = estop || pstop;
    if (!was && is)
        r->stop_since_ns = now_ns;
    if (was && !is && now_ns > r->stop_since_ns)
        r->stopped_ns += now_ns - r->stop_since_ns;
    r->estop = estop;
    r->pstop = pstop;
    drsim_robot_update(r, now_ns, img);
}

/* Copy a GPR input image to its output image through the typed structs. */
static void echo_gpr(dr_asm_t in, dr_asm_t out, void *scratch, bool echo,
                     drsim_images_t *img)
{
    if (!echo)
        return;
    if (dr_asm_decode(in, img->buf[in], dr_asm_info(in)->size, scratch) == DR_OK)
        put(out, scratch, img);
}

void drsim_robot_input(drsim_robot_t *r, dr_asm_t a, drsim_images_t *img)
{
    switch (a) {
    case DR_ASM_IO_CONTROL: {
        dr_io_control_t ctl;
        if (dr_io_control_decode(img->buf[a], dr_asm_info(a)->size, &ctl) != DR_OK)
            return;
        r->io.cb_do = ctl.cb_do;
        r->io.tool_do = ctl.tool_do;
        r->io.aio_type.ao0 = ctl.ao_type.ao0;
        r->io.aio_type.ao1 = ctl.ao_type.ao1;
        r->io.ao[0] = ctl.ao[0];
        r->io.ao[1] = ctl.ao[1];
        r->io.tool_di = (uint8_t)(r->io.tool_do & 0x03u);
        put(DR_ASM_IO_STATE, &r->io, img);
        break;
    }
    case DR_ASM_BIT_IN: {
        dr_bit_gpr_t g;
        echo_gpr(a, DR_ASM_BIT_OUT, &g, r->echo, img);
        break;
    }
    case DR_ASM_INT_IN: {
        dr_int_gpr_t g;
        echo_gpr(a, DR_ASM_INT_OUT, &g, r->echo, img);
        break;
    }
    case DR_ASM_FLOAT_IN: {
        dr_float_gpr_t g;
        echo_gpr(a, DR_ASM_FLOAT_OUT, &g, r->echo, img);
        break;
    }
    default:
        break;
    }
}
