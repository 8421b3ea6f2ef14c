/* The gossamer reflector's pitch tracking as a MuJoCo engine plugin ("magsail.reflector_loads",
   passive force).

   Built and loaded by magsail_mj.compiled; the Python side is
   magsail_mj.concepts.reflector.compiled. Every time MuJoCo computes the passive forces (once per
   mj_forward: at the step's start and at each further stage of RK4) it adds to qfrc_passive of the
   plate's free joint the body-axes torque R_stage^T W of a world torque

     W = R_eval T_act + T_gg                                                     [N m, world axes]

   with the coil torque of the pitch controller (Robb et al. 2020, Eqs. 9-15, the laws of
   magsail_mj.control.reflector_pitch and magsail_mj.control.reflector_steering, the same operations
   in the same order):

     orbit     th = n (t - t_m), ph = w_e (t - t_m); a = r cos th - R_e cos ph, b = r sin th
     steering  eps = atan2(a, b), beta = eps + 2 pi round((beta_prev - eps) / 2 pi) (unwrapped against
               the previous step's beta; eps at the first), psi_c = pi/2 - beta,
               psi_dot = P/Q, psi_ddot = (P' Q - P Q')/Q^2 (Eq. 13),
               q_ref = [cos(beta/2), 0, sin(beta/2), 0]
     error     q_e = q_ref* (x) q (scalar part >= 0), omega_b = R^T omega_world
     law       T_ref = -P_q q_e,vec - P_w w_err [+ I alpha_ref], w_err = omega_b (absolute) or
               omega_b - (-psi_dot) y_b (error), y_b = row 1 of R(q_e), alpha_ref = -psi_ddot y_b
     field     B_w = B_r e_r + B_th e_th, B_r = -2 k sin th, B_th = -k cos th, k = B0 (R_e/r)^3
     actuator  T_act = sat_c((1 - b b^T) T_ref), b = B_b/|B_b|, B_b = R^T B_w; c = T_max ("norm") or
               T_max |B|/B_ref ("field_scaled"); "per_path": m = B_b x T_ref/|B_b|^2 clipped to
               +-m_max per path, T_act = m x B_b
     gravity   T_gg = 3 mu/|r|^3 u x (I_w u), u = r/|r|, r = r (cos th, 0, sin th), I_w = R diag(I) R^T
               (case B5; off unless params[P_GG])

   R = body -> world rotation of the plate quaternion divided by its norm (the rows of
   magsail_mj.quaternion.quat_to_matrix).

   Frames: world = the paper's xyz (Sun-fixed, +y the orbit normal); the free joint's angular dofs
   are in body axes, so the world torque W enters qfrc_passive[dof+3 .. dof+5] as xmat^T W (J^T of
   the world torque, as xfrc_applied does).

   Timing (params[P_TIMING]): 0 "start": the controller and the gravity gradient of the state at
   the step's start, t = k dt, k = round(d->time / dt); 1 "midpoint": the controller at the step's
   start (its zero-order hold), the rotation of its body torque and the gravity gradient at the
   state predicted at t + dt/2 (q advanced by dt/2 with v + (v - v_prev)/4 through
   mj_integratePos, the Python path's prediction); both held over the integrator's stages in world
   axes, as the Python path's xfrc_applied is; 2 "stage": the controller law and the gravity
   gradient evaluated at the state and time of every stage (a continuous-time law: RK4 integrates
   the closed loop to fourth order where it is smooth). The first evaluation of a step (plugin
   state S_STALE, set by `advance` at the end of the previous step and by `reset`) fixes k and
   stores beta for the next step's unwrapping; a stage's beta is unwrapped against the stored one.

   All data come from the model (the custom numeric named by the instance's "params" attribute) and
   from the instance's plugin state in mjData; nothing is kept in the process, so any number of
   models and datas may use the plugin at once. */

#include <math.h>
#include <stdio.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "plugin_common.h"

/* parameter block (the order of magsail_mj.concepts.reflector.compiled.PARAM_FIELDS) */
enum {
  P_VERSION = 0,
  P_BODY,
  P_QPOSADR,
  P_DOFADR,
  P_TIMING,
  P_ORBIT_R,
  P_R_E,
  P_N,
  P_OMEGA_E,
  P_T_MID,
  P_FIELD_K,
  P_PQ,
  P_PW = P_PQ + 3,
  P_INERTIA = P_PW + 3,
  P_RATE_ERROR = P_INERTIA + 3,
  P_FEEDFORWARD,
  P_SATURATION,
  P_CAP,
  P_B_REF,
  P_M_MAX,
  P_GG = P_M_MAX + 3,
  P_MU,
  P_SIZE
};

#define LAYOUT_VERSION 1

/* plugin state (the order of magsail_mj.concepts.reflector.compiled.STATE_FIELDS) */
enum {
  S_STALE = 0,        /* 1: the next evaluation is the first of a step */
  S_STEP,             /* k of the step being integrated */
  S_T_RAW,            /* d->time at the step's first evaluation (stage times are k dt + d->time - this) */
  S_PRIMED,           /* S_BETA holds a previous step's beta */
  S_BETA,             /* beta of the last step's start [rad] */
  S_T_ACT,            /* the step's coil torque [N m, body axes] */
  S_WORLD = S_T_ACT + 3, /* the held world torque W [N m] */
  S_MID_STEP = S_WORLD + 3, /* step whose start velocity S_V_CUR holds (-1: none) */
  S_V_PRIMED,         /* S_V_PREV holds a previous step's start velocity */
  S_FIXED             /* then S_V_PREV (nv), S_V_CUR (nv) */
};

enum { SAT_NORM = 0, SAT_FIELD_SCALED = 1, SAT_PER_PATH = 2 };

/* the probe's numbers (magsail_reflector_probe) */
enum {
  O_T_ACT = 0,
  O_T_REF = 3,
  O_SATURATED = 6,
  O_Q_E = 7,
  O_Q_REF = 11,
  O_PSI = 15,   /* psi_c, psi_dot, psi_ddot */
  O_B_WORLD = 18,
  O_GG_WORLD = 21,
  O_BETA = 24,
  O_SIZE = 25
};

static const char* kAttributes[] = {"params"};
static const StepMemory kMemory = {S_STALE, S_MID_STEP, S_V_PRIMED, S_FIXED};

static const mjtNum* params_of(const mjModel* m, const mjData* d, int instance) {
  return m->numeric_data + ((int)d->plugin_data[instance] - 1); /* address + 1: 0 means uninitialised */
}

/* rows of R(q) (magsail_mj.quaternion._matrix_rows) */
static void quat_rows(mjtNum R[9], const mjtNum q[4]) {
  mjtNum w = q[0], x = q[1], y = q[2], z = q[3];
  R[0] = 1 - 2 * (y * y + z * z);
  R[1] = 2 * (x * y - w * z);
  R[2] = 2 * (x * z + w * y);
  R[3] = 2 * (x * y + w * z);
  R[4] = 1 - 2 * (x * x + z * z);
  R[5] = 2 * (y * z - w * x);
  R[6] = 2 * (x * z - w * y);
  R[7] = 2 * (y * z + w * x);
  R[8] = 1 - 2 * (x * x + y * y);
}

static mjtNum dot3(const mjtNum a[3], const mjtNum b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* R a, R row-major */
static void mat_vec(mjtNum out[3], const mjtNum R[9], const mjtNum a[3]) {
  out[0] = R[0] * a[0] + R[1] * a[1] + R[2] * a[2];
  out[1] = R[3] * a[0] + R[4] * a[1] + R[5] * a[2];
  out[2] = R[6] * a[0] + R[7] * a[1] + R[8] * a[2];
}

/* the plate's unit quaternion q, its rows R and its world angular velocity from qpos/qvel
   (magsail_mj.sim.BodyKinematics) */
static void plate_pose(const mjtNum* p, const mjtNum* qpos, const mjtNum* qvel, mjtNum q[4], mjtNum R[9],
                       mjtNum omega_w[3]) {
  const mjtNum* qp = qpos + (int)p[P_QPOSADR] + 3;
  const mjtNum* a = qvel + (int)p[P_DOFADR] + 3;
  mjtNum n = sqrt(qp[0] * qp[0] + qp[1] * qp[1] + qp[2] * qp[2] + qp[3] * qp[3]);
  q[0] = qp[0] / n;
  q[1] = qp[1] / n;
  q[2] = qp[2] / n;
  q[3] = qp[3] / n;
  mjtNum Rm[9];
  mju_quat2Mat(Rm, q);
  omega_w[0] = Rm[0] * a[0] + Rm[1] * a[1] + Rm[2] * a[2];
  omega_w[1] = Rm[3] * a[0] + Rm[4] * a[1] + Rm[5] * a[2];
  omega_w[2] = Rm[6] * a[0] + Rm[7] * a[1] + Rm[8] * a[2];
  quat_rows(R, q);
}

/* the controller's command and diagnostics at time t (module comment) into out[0 .. O_GG_WORLD),
   out[O_BETA]: beta unwrapped against `beta_prev` when `primed` */
static void command(const mjtNum* p, mjtNum t, const mjtNum q[4], const mjtNum R[9], const mjtNum omega_w[3],
                    int primed, mjtNum beta_prev, mjtNum* out) {
  /* steering reference (ReflectorOrbit.rates, SteeringReference.at) */
  mjtNum n = p[P_N], r = p[P_ORBIT_R], Re = p[P_R_E], we = p[P_OMEGA_E];
  mjtNum th = n * (t - p[P_T_MID]), ph = we * (t - p[P_T_MID]);
  mjtNum st = sin(th), ct = cos(th), sp = sin(ph), cp = cos(ph);
  mjtNum a = r * ct - Re * cp, b = r * st;
  mjtNum P = -r * Re * we * sp * st + r * n * (r - Re * cp * ct);
  mjtNum Q = a * a + b * b;
  mjtNum Pd = r * Re * (n * n - we * we) * st * cp;
  mjtNum Qd = -Re * Re * we * sin(2 * ph) + 2 * r * Re * (n * st * cp + we * sp * ct);
  mjtNum eps = atan2(a, b), psi_dot = P / Q, psi_ddot = (Pd * Q - P * Qd) / (Q * Q);
  mjtNum beta = primed ? eps + 2 * mjPI * nearbyint((beta_prev - eps) / (2 * mjPI)) : eps;
  mjtNum h = 0.5 * beta, s = sin(h);
  mjtNum qr[4] = {cos(h), s * 0.0, s * 1.0, s * 0.0};

  /* error quaternion q_e = q_ref* (x) q, scalar part >= 0 (quat_conj, quat_mul, error_quaternion) */
  mjtNum w1 = qr[0] * 1.0, x1 = qr[1] * -1.0, y1 = qr[2] * -1.0, z1 = qr[3] * -1.0;
  mjtNum w2 = q[0], x2 = q[1], y2 = q[2], z2 = q[3];
  mjtNum qe[4] = {
      w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
      w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
      w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
      w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
  };
  if (qe[0] < 0.0) {
    for (int i = 0; i < 4; i++) {
      qe[i] = -qe[i];
    }
  }

  /* reference torque (ReflectorPitchController.reference_torque) */
  mjtNum wb[3], werr[3], yb[3] = {0.0, 0.0, 0.0}, T[3];
  mat_t_vec(wb, R, omega_w);
  mju_copy3(werr, wb);
  int rate_error = p[P_RATE_ERROR] != 0, ff = p[P_FEEDFORWARD] != 0;
  if (rate_error || ff) {
    mjtNum Re_[9];
    quat_rows(Re_, qe);
    yb[0] = Re_[3], yb[1] = Re_[4], yb[2] = Re_[5];
    if (rate_error) {
      for (int i = 0; i < 3; i++) {
        werr[i] = wb[i] - (-psi_dot) * yb[i];
      }
    }
  }
  for (int i = 0; i < 3; i++) {
    T[i] = (-p[P_PQ + i]) * qe[1 + i] - p[P_PW + i] * werr[i];
  }
  if (ff) {
    for (int i = 0; i < 3; i++) {
      T[i] = T[i] + p[P_INERTIA + i] * ((-psi_ddot) * yb[i]);
    }
  }

  /* field along the orbit (ReflectorOrbit._field_scalar) and the actuator (project_and_saturate) */
  mjtNum k = p[P_FIELD_K];
  mjtNum Br = -2.0 * k * st, Bt = -k * ct;
  mjtNum Bw[3] = {Br * ct - Bt * st, 0.0, Br * st + Bt * ct}, Bb[3], Tact[3];
  mat_t_vec(Bb, R, Bw);
  mjtNum B2 = dot3(Bb, Bb);
  int saturated = 0;
  if (!(B2 > 0)) {
    Tact[0] = Tact[1] = Tact[2] = 0.0;
    saturated = T[0] != 0 || T[1] != 0 || T[2] != 0;
  } else if ((int)p[P_SATURATION] == SAT_PER_PATH) {
    mjtNum mdip[3], mc[3];
    cross3(mdip, Bb, T);
    for (int i = 0; i < 3; i++) {
      mdip[i] = mdip[i] / B2;
      mjtNum lim = p[P_M_MAX + i];
      mc[i] = mdip[i] < -lim ? -lim : (mdip[i] > lim ? lim : mdip[i]);
      saturated |= fabs(mdip[i]) > lim;
    }
    cross3(Tact, mc, Bb);
  } else {
    mjtNum sB = sqrt(B2), bh[3] = {Bb[0] / sB, Bb[1] / sB, Bb[2] / sB};
    mjtNum bT = dot3(bh, T);
    for (int i = 0; i < 3; i++) {
      Tact[i] = T[i] - bh[i] * bT;
    }
    mjtNum cap = (int)p[P_SATURATION] == SAT_NORM ? p[P_CAP] : p[P_CAP] * sqrt(B2) / p[P_B_REF];
    mjtNum nrm = sqrt(dot3(Tact, Tact));
    if (nrm > cap) {
      mjtNum f = cap / nrm;
      for (int i = 0; i < 3; i++) {
        Tact[i] = Tact[i] * f;
      }
      saturated = 1;
    }
  }

  /* gravity gradient on the kinematic orbit (OrbitGravityGradientLoad, world axes) */
  mjtNum gg[3] = {0.0, 0.0, 0.0};
  if (p[P_GG] != 0) {
    mjtNum rv[3] = {r * ct, r * 0.0, r * st};
    mjtNum rn = sqrt(dot3(rv, rv)), u[3] = {rv[0] / rn, rv[1] / rn, rv[2] / rn};
    mjtNum RI[9], Iw[9], Iu[3];
    for (int i = 0; i < 3; i++) {
      for (int j = 0; j < 3; j++) {
        RI[3 * i + j] = R[3 * i + j] * p[P_INERTIA + j];
      }
    }
    for (int i = 0; i < 3; i++) {
      for (int j = 0; j < 3; j++) {
        Iw[3 * i + j] = RI[3 * i] * R[3 * j] + RI[3 * i + 1] * R[3 * j + 1] + RI[3 * i + 2] * R[3 * j + 2];
      }
    }
    mat_vec(Iu, Iw, u);
    cross3(gg, u, Iu);
    mjtNum kg = 3.0 * p[P_MU] / pow(rn, 3.0);
    for (int i = 0; i < 3; i++) {
      gg[i] = kg * gg[i];
    }
  }

  mju_copy3(out + O_T_ACT, Tact);
  mju_copy3(out + O_T_REF, T);
  out[O_SATURATED] = saturated;
  mju_copy4(out + O_Q_E, qe);
  mju_copy4(out + O_Q_REF, qr);
  out[O_PSI] = 0.5 * mjPI - beta;
  out[O_PSI + 1] = psi_dot;
  out[O_PSI + 2] = psi_ddot;
  mju_copy3(out + O_B_WORLD, Bw);
  mju_copy3(out + O_GG_WORLD, gg);
  out[O_BETA] = beta;
}

/* W = R T_act + T_gg at (qpos, qvel, t) with the given coil torque (T_act = NULL: the law's own) */
static void world_torque(const mjtNum* p, const mjtNum* s, mjtNum t, const mjtNum* qpos, const mjtNum* qvel,
                         const mjtNum* T_act, mjtNum W[3], mjtNum* out) {
  mjtNum q[4], R[9], omega_w[3], RT[3];
  plate_pose(p, qpos, qvel, q, R, omega_w);
  command(p, t, q, R, omega_w, s[S_PRIMED] != 0, s[S_BETA], out);
  mat_vec(RT, R, T_act ? T_act : out + O_T_ACT);
  for (int i = 0; i < 3; i++) {
    W[i] = (0.0 + RT[i]) + out[O_GG_WORLD + i];
  }
}

static int reflector_nstate(const mjModel* m, int instance) {
  return step_memory_nstate(m, &kMemory);
}

static void reflector_reset(const mjModel* m, mjtNum* state, void* plugin_data, int instance) {
  step_memory_reset(m, state, &kMemory);
}

static int reflector_init(const mjModel* m, mjData* d, int instance) {
  int ip = numeric_of(m, instance, "params");
  if (ip < 0) {
    mju_warning("magsail.reflector_loads: the instance's 'params' must name a custom numeric");
    return -1;
  }
  int adr = m->numeric_adr[ip];
  const mjtNum* p = m->numeric_data + adr;
  if (m->numeric_size[ip] != P_SIZE || (int)p[P_VERSION] != LAYOUT_VERSION) {
    mju_warning("magsail.reflector_loads: the parameter block is not of layout %d", LAYOUT_VERSION);
    return -1;
  }
  d->plugin_data[instance] = (uintptr_t)adr + 1;
  return 0;
}

static void reflector_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  const mjtNum* p = params_of(m, d, instance);
  mjtNum* s = d->plugin_state + m->plugin_stateadr[instance];
  int timing = (int)p[P_TIMING];
  mjtNum dt = m->opt.timestep, out[O_SIZE];
  if (s[S_STALE] != 0) {
    long k = lround(d->time / dt);
    mjtNum t = k * dt; /* the step's time as the runner counts it (d->time sums the steps) */
    s[S_STEP] = (mjtNum)k;
    s[S_T_RAW] = d->time;
    world_torque(p, s, t, d->qpos, d->qvel, NULL, s + S_WORLD, out);
    mju_copy3(s + S_T_ACT, out + O_T_ACT);
    if (timing == TIMING_MIDPOINT) {
      mjtNum *qpos, *vm, mid[O_SIZE];
      mj_markStack(d);
      midpoint_state(m, d, s, &kMemory, k, &qpos, &vm);
      world_torque(p, s, t + 0.5 * dt, qpos, vm, s + S_T_ACT, s + S_WORLD, mid);
      mj_freeStack(d);
    }
    s[S_BETA] = out[O_BETA];
    s[S_PRIMED] = 1;
    s[S_STALE] = 0;
  } else if (timing == TIMING_STAGE) {
    mjtNum t = s[S_STEP] * dt + (d->time - s[S_T_RAW]);
    world_torque(p, s, t, d->qpos, d->qvel, NULL, s + S_WORLD, out);
  }
  mjtNum T[3];
  mju_mulMatTVec3(T, d->xmat + 9 * (int)p[P_BODY], s + S_WORLD);
  int va = (int)p[P_DOFADR];
  d->qfrc_passive[va + 3] += T[0];
  d->qfrc_passive[va + 4] += T[1];
  d->qfrc_passive[va + 5] += T[2];
}

static void reflector_advance(const mjModel* m, mjData* d, int instance) {
  step_memory_advance(m, d, instance, &kMemory);
}

/* For the runner's records (called from Python through ctypes): into out (25) what the controller
   commands at d's state and the time k dt of its step k = round(d->time/dt), beta unwrapped against
   the plugin state's: T_act (3), T_ref (3), saturated (1), q_e (4), q_ref (4), psi_c, psi_dot,
   psi_ddot (3), B_world (3), the gravity gradient in world axes (3, zero when off) and beta (1).
   Nothing in d changes. Returns 0, or -1 when `instance` is not an initialised instance. */
int magsail_reflector_probe(const mjModel* m, const mjData* d, int instance, mjtNum* out) {
  if (!initialised_instance(m, d, instance)) {
    return -1;
  }
  const mjtNum* p = params_of(m, d, instance);
  const mjtNum* s = d->plugin_state + m->plugin_stateadr[instance];
  mjtNum dt = m->opt.timestep, q[4], R[9], omega_w[3];
  long k = lround(d->time / dt);
  plate_pose(p, d->qpos, d->qvel, q, R, omega_w);
  command(p, k * dt, q, R, omega_w, s[S_PRIMED] != 0, s[S_BETA], out);
  return 0;
}

mjPLUGIN_LIB_INIT(magsail_reflector_loads) {
  register_passive_plugin("magsail.reflector_loads", kAttributes, sizeof(kAttributes) / sizeof(kAttributes[0]),
                          reflector_nstate, reflector_init, reflector_reset, reflector_compute, reflector_advance);
}
