/* The CNUSAIL cubesat's loads as a MuJoCo engine plugin ("magsail.cubesat_loads", passive force).

   Built and loaded by magsail_mj.compiled (one shared library per digest of the source and the
   folder's headers, MuJoCo version and compiler); the Python side is magsail_mj.concepts.cnusail.compiled. Every time MuJoCo
   computes the passive forces (mj_passive, once per mj_forward: once at the step's start and at
   each further stage of RK4) it adds to qfrc_passive of the bus's free joint the body-axes torque

     T = T_gg + T_drag + T_srp + T_D + T_mtq                                    [N m, body axes]

   (Yoo et al. 2016, Eqs. 5 and 12-23, with the misprints corrected as in the Python loads):

     T_gg   = 3 mu / |r_b|^3  u x (J u),   r_b = R^T (r_ref + p),  u = r_b / |r_b|   (Eq. 12)
     T_drag = rho (sum_i -1/2 C_d A_i proj_i c_i) x V,   V = R^T (v_rel + v),
              proj_i = |n_i . V| (two-sided) or max(n_i . V, 0) (one-sided)      (Eqs. 13-15)
     T_srp  = r_cp x F,  F = -P A cos(a) [(1 - r s) s_hat + (2 r s cos(a) + B_l r (1 - s)
              + (1 - r) kappa) n_l]  on the sail (one two-sided plate, normal +z_B) (Eqs. 16-22)
     T_D    = D x R^T B                                                           (Eq. 23)
     T_mtq  = m x R^T B,  m the held dipole, zero in the blanking window          (Eq. 5)

   R = body -> world rotation of the bus quaternion divided by its norm; r_ref, v_ref, B, the Sun
   position and ln(rho) (MSIS) come from the environment's piecewise cubic table (uniform grid
   t_k = t0 + k h, coefficients of tau^0..tau^3 per interval and channel), sampled at t with
   tau = t - (t0 + i h), i = floor((t - t0)/h) clipped to [0, K-1]; the Sun direction, the
   cylindrical shadow, the distance-scaled pressure, the exponential density and the co-rotating
   flow velocity are the formulas of magsail_mj.environment.environment.Environment.sample.

   Frames: world = ECI axes; the free joint's angular dofs are in body axes (MuJoCo), so a
   body-axes torque goes to qfrc_passive[dof+3 .. dof+5] as it is (J^T of the world torque R T).

   Timing (params[P_TIMING]): 0 "start": the loads of the state at the step's start; 1
   "midpoint": of the state predicted at t + dt/2 (q advanced by dt/2 with v + (v - v_prev)/4
   through mj_integratePos, v + (v - v_prev)/2, the environment at t + dt/2); both held over the
   integrator's stages in world axes, W = R_eval T, as the Python path's xfrc_applied is, so each
   stage adds R_stage^T W with R_stage the bus's xmat of that stage; 2 "stage": the loads of the
   state and time of every stage, added in body axes. The first evaluation of a
   step (plugin state S_STALE set by `advance` at the end of the previous step, by `reset`, or by
   Python when it writes a command) also fixes the step index k = round(t/dt), the magnetorquer
   blanking (on while k mod n_cycle < n_on) and the wheel motor torques of the quasi-static DC
   driver (Yoo et al. 2016, Eqs. 8-11), written to ctrl and held over the step:

     V = clip(R_M i_c + K_b w, +-V_max),  i = (V - K_b w)/R_M,  T_M = K_M i
     (ideal wheels: T_M = the held command); where |w| >= W_max and (T_M - K_B w) w > 0: T_M = K_B w.

   All data come from the model (two custom numerics named by the instance's "params" and
   "table" attributes) and from the instance's plugin state in mjData (held dipole and wheel
   command written by Python at the controller's samples, the step's memory); nothing is kept
   in the process, so any number of models and datas may use the plugin at once. */

#include <math.h>
#include <stdio.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "plugin_common.h"

/* parameter block (the order of magsail_mj.concepts.cnusail.compiled.PARAM_FIELDS) */
enum {
  P_VERSION = 0,
  P_BODY,
  P_QPOSADR,
  P_DOFADR,
  P_TIMING,
  P_T0,
  P_H,
  P_K,
  P_NCH,
  P_R_E,
  P_HAS_SUN,
  P_SHADOW,
  P_P0,
  P_SCALE_DISTANCE,
  P_ATMOSPHERE,
  P_COROTATING,
  P_OMEGA_EARTH,
  P_AU,
  P_GG,
  P_MU,
  P_J,
  P_HAS_DIPOLE = P_J + 9,
  P_D,
  P_NFACET = P_D + 3,
  P_HAS_SAIL,
  P_SAIL_CENTRE,
  P_SAIL_AREA = P_SAIL_CENTRE + 3,
  P_OPT_R,
  P_OPT_S,
  P_B_F,
  P_B_B,
  P_E_F,
  P_E_B,
  P_SWAP_BACK,
  P_N_CYCLE,
  P_N_ON,
  P_WHEEL_MODEL,
  P_R_M,
  P_K_BEMF,
  P_K_M,
  P_K_FRICTION,
  P_V_MAX,
  P_W_MAX,
  P_WHEEL_DOF,
  P_WHEEL_ACT = P_WHEEL_DOF + 3,
  P_NEXP = P_WHEEL_ACT + 3,
  P_FACETS,                          /* MAX_FACETS rows of (n, k = -1/2 C_d A c, two-sided) */
  P_EXP = P_FACETS + 7 * 8,          /* P_NEXP rows of (h0 [km], h0 [m], rho0, H [m]) */
  P_SIZE_FIXED = P_EXP
};

#define LAYOUT_VERSION 1
#define MAX_FACETS 8

/* plugin state (the order of magsail_mj.concepts.cnusail.compiled.STATE_FIELDS) */
enum {
  S_STALE = 0,                  /* 1: the next evaluation is the first of a step */
  S_STEP,                       /* k of the step being integrated */
  S_DIPOLE,                     /* held dipole [A m^2, body axes] (Python) */
  S_WHEEL_CMD = S_DIPOLE + 3,   /* held wheel command: current [A] or torque [N m] (Python) */
  S_T_M = S_WHEEL_CMD + 3,      /* motor torques of the step [N m] */
  S_TORQUE = S_T_M + 3,         /* the last evaluated total torque [N m, body axes] */
  S_WORLD = S_TORQUE + 3,       /* the held torque in world axes R_eval T [N m] */
  S_SOURCES = S_WORLD + 3,      /* gravity gradient, drag, SRP, residual dipole, mtq (5 x 3) */
  S_MID_STEP = S_SOURCES + 15,  /* step whose start velocity S_V_CUR holds (-1: none) */
  S_PRIMED,                     /* S_V_PREV holds a previous step's start velocity */
  S_FIXED                       /* then S_V_PREV (nv), S_V_CUR (nv) */
};

enum { ATMO_NONE = 0, ATMO_EXPONENTIAL = 1, ATMO_MSIS = 2 };
enum { WHEELS_NONE = 0, WHEELS_DC_MOTOR = 1, WHEELS_IDEAL = 2 };

static const char* kAttributes[] = {"params", "table"};
static const StepMemory kMemory = {S_STALE, S_MID_STEP, S_PRIMED, S_FIXED};

typedef struct {
  mjtNum r[3], v[3], B[3], sun[3], P, rho, vrel[3];
} EnvSample;

static const mjtNum* params_of(const mjModel* m, const mjData* d, int instance) {
  return m->numeric_data + (int)(d->plugin_data[instance] & 0xffffffffu);
}

static const mjtNum* table_of(const mjModel* m, const mjData* d, int instance) {
  return m->numeric_data + (int)(d->plugin_data[instance] >> 32);
}

/* the environment at time t (module comment) */
static void environment(const mjtNum* p, const mjtNum* table, mjtNum t, EnvSample* e) {
  mjtNum t0 = p[P_T0], h = p[P_H];
  int K = (int)p[P_K], nch = (int)p[P_NCH];
  mjtNum s = (t - t0) / h;
  int i = (int)s;
  if (i >= K) {
    i = K - 1;
  } else if (i < 0) {
    i = 0;
  }
  mjtNum tau = t - (t0 + i * h), t2 = tau * tau, t3 = t2 * tau;
  const mjtNum* c = table + (size_t)i * 4 * nch;
  mjtNum val[13];
  int n = nch < 13 ? nch : 13;
  for (int j = 0; j < n; j++) {
    val[j] = c[j] + tau * c[nch + j] + t2 * c[2 * nch + j] + t3 * c[3 * nch + j];
  }
  mjtNum rx = val[0], ry = val[1], rz = val[2];
  for (int j = 0; j < 3; j++) {
    e->r[j] = val[j];
    e->v[j] = val[3 + j];
    e->B[j] = val[6 + j];
  }
  mjtNum rn = sqrt(rx * rx + ry * ry + rz * rz);
  if (p[P_HAS_SUN] != 0) {
    mjtNum Sx = val[9], Sy = val[10], Sz = val[11];
    mjtNum dx = Sx - rx, dy = Sy - ry, dz = Sz - rz;
    mjtNum dist = sqrt(dx * dx + dy * dy + dz * dz);
    e->sun[0] = dx / dist;
    e->sun[1] = dy / dist;
    e->sun[2] = dz / dist;
    int shadow = 0;
    if (p[P_SHADOW] != 0) {
      mjtNum sn = sqrt(Sx * Sx + Sy * Sy + Sz * Sz);
      mjtNum proj = (rx * Sx + ry * Sy + rz * Sz) / sn;
      shadow = proj < 0.0 && (rn * rn - proj * proj) < p[P_R_E] * p[P_R_E];
    }
    if (shadow) {
      e->P = 0.0;
    } else if (p[P_SCALE_DISTANCE] != 0) {
      mjtNum a = p[P_AU] / dist;
      e->P = p[P_P0] * (a * a);
    } else {
      e->P = p[P_P0];
    }
  } else {
    e->sun[0] = e->sun[1] = e->sun[2] = 0.0;
    e->P = 0.0;
  }
  mjtNum alt = rn - p[P_R_E];
  int atmo = (int)p[P_ATMOSPHERE];
  if (atmo == ATMO_EXPONENTIAL) {
    e->rho = 0.0;
    if (rn > 0) {
      int nexp = (int)p[P_NEXP], k = -1;
      mjtNum alt_km = alt * 1e-3;
      for (int j = 0; j < nexp; j++) {
        if (p[P_EXP + 4 * j] <= alt_km) {
          k = j;
        }
      }
      if (k < 0) {
        k = 0;
      }
      const mjtNum* row = p + P_EXP + 4 * k;
      e->rho = row[2] * exp(-(alt - row[1]) / row[3]);
    }
  } else if (atmo == ATMO_MSIS) {
    e->rho = exp(val[12]);
  } else {
    e->rho = 0.0;
  }
  if (p[P_COROTATING] != 0) {
    mjtNum w = p[P_OMEGA_EARTH];
    e->vrel[0] = val[3] + w * ry;
    e->vrel[1] = val[4] - w * rx;
    e->vrel[2] = val[5];
  } else {
    e->vrel[0] = val[3];
    e->vrel[1] = val[4];
    e->vrel[2] = val[5];
  }
}

/* the five body-axes torques at the bus state (qpos of the free joint: position, quaternion;
   qvel: linear velocity in world axes) and time t, with the effective dipole m */
static void torques(const mjtNum* p, const mjtNum* table, mjtNum t, const mjtNum* q, const mjtNum* v,
                    const mjtNum dipole[3], mjtNum out[15]) {
  EnvSample e;
  environment(p, table, t, &e);
  mjtNum w = q[3], x = q[4], y = q[5], z = q[6];
  mjtNum n = sqrt(w * w + x * x + y * y + z * z);
  mjtNum quat[4] = {w / n, x / n, y / n, z / n};
  mjtNum R[9];
  mju_quat2Mat(R, quat);
  mju_zero(out, 15);

  /* gravity gradient */
  if (p[P_GG] != 0) {
    mjtNum rw[3] = {e.r[0] + q[0], e.r[1] + q[1], e.r[2] + q[2]}, rb[3], Ju[3], c[3];
    mat_t_vec(rb, R, rw);
    mjtNum rn = sqrt(rb[0] * rb[0] + rb[1] * rb[1] + rb[2] * rb[2]);
    mjtNum u[3] = {rb[0] / rn, rb[1] / rn, rb[2] / rn};
    const mjtNum* J = p + P_J;
    for (int i = 0; i < 3; i++) {
      Ju[i] = J[3 * i] * u[0] + J[3 * i + 1] * u[1] + J[3 * i + 2] * u[2];
    }
    mjtNum k = 3.0 * p[P_MU] / pow(rn, 3.0);
    cross3(c, u, Ju);
    for (int i = 0; i < 3; i++) {
      out[i] = k * c[i];
    }
  }

  /* drag over the facets */
  int nfacet = (int)p[P_NFACET];
  if (nfacet > 0 && e.rho > 0.0) {
    mjtNum vw[3] = {e.vrel[0] + v[0], e.vrel[1] + v[1], e.vrel[2] + v[2]}, V[3];
    mat_t_vec(V, R, vw);
    mjtNum l[3] = {0.0, 0.0, 0.0};
    for (int f = 0; f < nfacet; f++) {
      const mjtNum* row = p + P_FACETS + 7 * f;
      mjtNum pr = row[0] * V[0] + row[1] * V[1] + row[2] * V[2];
      if (row[6] != 0) {
        pr = fabs(pr);
      } else if (pr < 0.0) {
        continue;
      }
      l[0] += pr * row[3];
      l[1] += pr * row[4];
      l[2] += pr * row[5];
    }
    mjtNum rl[3] = {e.rho * l[0], e.rho * l[1], e.rho * l[2]};
    cross3(out + 3, rl, V);
  }

  /* solar radiation pressure on the sail */
  if (p[P_HAS_SAIL] != 0 && e.P > 0.0) {
    mjtNum s[3];
    mat_t_vec(s, R, e.sun);
    mjtNum c = s[2];
    int front = c >= 0.0;
    mjtNum cos_a = fabs(c);
    mjtNum B_l, B_d, e_l, e_d;
    if (front || p[P_SWAP_BACK] == 0) {
      B_l = p[P_B_F], B_d = p[P_B_B], e_l = p[P_E_F], e_d = p[P_E_B];
    } else {
      B_l = p[P_B_B], B_d = p[P_B_F], e_l = p[P_E_B], e_d = p[P_E_F];
    }
    mjtNum esum = e_l + e_d;
    mjtNum kappa = esum > 0 ? (e_l * B_l - e_d * B_d) / esum : 0.0;
    mjtNum r = p[P_OPT_R], so = p[P_OPT_S], rs = r * so;
    mjtNum k_n = (2.0 * rs * cos_a + B_l * r * (1.0 - so) + (1.0 - r) * kappa) * (front ? 1.0 : -1.0);
    mjtNum scale = -e.P * p[P_SAIL_AREA] * cos_a;
    mjtNum a = scale * (1.0 - rs);
    mjtNum F[3] = {a * s[0], a * s[1], a * s[2] + scale * k_n};
    cross3(out + 6, p + P_SAIL_CENTRE, F);
  }

  /* residual dipole and magnetorquers */
  mjtNum Bb[3];
  mat_t_vec(Bb, R, e.B);
  if (p[P_HAS_DIPOLE] != 0) {
    cross3(out + 9, p + P_D, Bb);
  }
  if (dipole[0] != 0.0 || dipole[1] != 0.0 || dipole[2] != 0.0) {
    cross3(out + 12, dipole, Bb);
  }
}

/* the wheel motor torques for the held command at the wheel speeds of qvel (module comment) */
static void wheel_torques(const mjtNum* p, const mjtNum* s, const mjtNum* qvel, mjtNum T_M[3]) {
  int model = (int)p[P_WHEEL_MODEL];
  mjtNum R = p[P_R_M], Kb = p[P_K_BEMF], KM = p[P_K_M], KB = p[P_K_FRICTION];
  mjtNum Vm = p[P_V_MAX], wmax = p[P_W_MAX];
  for (int j = 0; j < 3; j++) {
    mjtNum w = qvel[(int)p[P_WHEEL_DOF + j]], c = s[S_WHEEL_CMD + j], T;
    if (model == WHEELS_DC_MOTOR) {
      mjtNum V = R * c + Kb * w;
      V = V > Vm ? Vm : (V < -Vm ? -Vm : V);
      mjtNum i = (V - Kb * w) / R;
      T = KM * i;
    } else {
      T = c;
    }
    if ((w >= wmax || w <= -wmax) && (T - KB * w) * w > 0.0) {
      T = KB * w;
    }
    T_M[j] = model == WHEELS_NONE ? 0.0 : T;
  }
}

/* the dipole of step k: the held one while the coils are on, else zero */
static const mjtNum* effective_dipole(const mjtNum* p, const mjtNum* s, long k) {
  static const mjtNum zero[3] = {0.0, 0.0, 0.0};
  int n_cycle = (int)p[P_N_CYCLE], n_on = (int)p[P_N_ON];
  return n_cycle > 0 && (k % n_cycle) < n_on ? s + S_DIPOLE : zero;
}

/* the evaluation of the step's start state, its midpoint prediction or a stage (module comment) */
static void evaluate(const mjtNum* p, const mjtNum* table, mjtNum* s, mjtNum t, const mjtNum* qpos,
                     const mjtNum* qvel) {
  int qa = (int)p[P_QPOSADR], va = (int)p[P_DOFADR];
  mjtNum* src = s + S_SOURCES;
  torques(p, table, t, qpos + qa, qvel + va, effective_dipole(p, s, (long)s[S_STEP]), src);
  for (int i = 0; i < 3; i++) {
    s[S_TORQUE + i] = (((src[i] + src[3 + i]) + src[6 + i]) + src[9 + i]) + src[12 + i];
  }
  const mjtNum* q = qpos + qa;
  mjtNum n = sqrt(q[3] * q[3] + q[4] * q[4] + q[5] * q[5] + q[6] * q[6]);
  mjtNum quat[4] = {q[3] / n, q[4] / n, q[5] / n, q[6] / n}, R[9];
  mju_quat2Mat(R, quat);
  mju_mulMatVec3(s + S_WORLD, R, s + S_TORQUE);
}

static int cubesat_nstate(const mjModel* m, int instance) {
  return step_memory_nstate(m, &kMemory);
}

static void cubesat_reset(const mjModel* m, mjtNum* state, void* plugin_data, int instance) {
  step_memory_reset(m, state, &kMemory);
}

static int cubesat_init(const mjModel* m, mjData* d, int instance) {
  int ip = numeric_of(m, instance, "params"), it = numeric_of(m, instance, "table");
  if (ip < 0 || it < 0) {
    mju_warning("magsail.cubesat_loads: the instance's 'params' and 'table' must name custom numerics");
    return -1;
  }
  int adr_p = m->numeric_adr[ip], adr_t = m->numeric_adr[it];
  const mjtNum* p = m->numeric_data + adr_p;
  if (m->numeric_size[ip] < P_SIZE_FIXED || (int)p[P_VERSION] != LAYOUT_VERSION) {
    mju_warning("magsail.cubesat_loads: the parameter block is not of layout %d", LAYOUT_VERSION);
    return -1;
  }
  int nch = (int)p[P_NCH], K = (int)p[P_K];
  if (nch < 12 || K < 1 || m->numeric_size[it] != 4 * K * nch || (int)p[P_NFACET] > MAX_FACETS ||
      m->numeric_size[ip] != P_EXP + 4 * (int)p[P_NEXP] || (p[P_ATMOSPHERE] == ATMO_MSIS && nch < 13)) {
    mju_warning("magsail.cubesat_loads: the table or parameter sizes disagree");
    return -1;
  }
  d->plugin_data[instance] = (uintptr_t)adr_p | ((uintptr_t)adr_t << 32);
  return 0;
}

static void cubesat_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  const mjtNum* p = params_of(m, d, instance);
  const mjtNum* table = table_of(m, d, instance);
  mjtNum* s = d->plugin_state + m->plugin_stateadr[instance];
  int timing = (int)p[P_TIMING];
  mjtNum dt = m->opt.timestep;
  if (s[S_STALE] != 0) {
    long k = lround(d->time / dt);
    mjtNum t = k * dt;  /* the step's time as the runner counts it (d->time sums the steps) */
    s[S_STEP] = (mjtNum)k;
    if ((int)p[P_WHEEL_MODEL] != WHEELS_NONE) {
      wheel_torques(p, s, d->qvel, s + S_T_M);
      for (int j = 0; j < 3; j++) {
        d->ctrl[(int)p[P_WHEEL_ACT + j]] = s[S_T_M + j];
      }
    }
    if (timing == TIMING_START) {
      evaluate(p, table, s, t, d->qpos, d->qvel);
    } else if (timing == TIMING_MIDPOINT) {
      mjtNum *qpos, *vm;
      mj_markStack(d);
      midpoint_state(m, d, s, &kMemory, k, &qpos, &vm);
      evaluate(p, table, s, t + 0.5 * dt, qpos, vm);
      mj_freeStack(d);
    }
    s[S_STALE] = 0;
  }
  if (timing == TIMING_STAGE) {
    evaluate(p, table, s, d->time, d->qpos, d->qvel);
  }
  int va = (int)p[P_DOFADR];
  mjtNum T[3];
  if (timing == TIMING_STAGE) {
    mju_copy3(T, s + S_TORQUE);
  } else {
    mju_mulMatTVec3(T, d->xmat + 9 * (int)p[P_BODY], s + S_WORLD);
  }
  d->qfrc_passive[va + 3] += T[0];
  d->qfrc_passive[va + 4] += T[1];
  d->qfrc_passive[va + 5] += T[2];
}

/* the probe's 18 numbers (see magsail_cubesat_probe) from a parameter block, table, plugin state and
   the state (time, qpos, qvel) of one simulation */
static void probe_values(const mjtNum* p, const mjtNum* table, const mjtNum* s, mjtNum dt, mjtNum time,
                         const mjtNum* qpos, const mjtNum* qvel, mjtNum* out) {
  long k = lround(time / dt);
  int qa = (int)p[P_QPOSADR], va = (int)p[P_DOFADR];
  torques(p, table, k * dt, qpos + qa, qvel + va, effective_dipole(p, s, k), out);
  wheel_torques(p, s, qvel, out + 15);
}

/* For the runner's records (called from Python through ctypes): into out (18) the five body-axes
   torques of the bus (gravity gradient, drag, SRP, residual dipole, magnetorquer; module comment)
   at d's state and the time k dt of its step k = round(d->time/dt), with that step's effective
   dipole, and the wheel motor torques the step applies (3). Nothing in d changes. Returns 0, or -1
   when `instance` is not an instance of this plugin's data. */
int magsail_cubesat_probe(const mjModel* m, const mjData* d, int instance, mjtNum* out) {
  if (!initialised_instance(m, d, instance)) {
    return -1;
  }
  probe_values(params_of(m, d, instance), table_of(m, d, instance), d->plugin_state + m->plugin_stateadr[instance],
               m->opt.timestep, d->time, d->qpos, d->qvel, out);
  return 0;
}

/* The same for n simulations of a batch (called from Python through ctypes): simulation i runs on
   models[i] (the numerics of its parameter block and table at the addresses adr_params, adr_table
   of its numeric_data) and its state is read from rows of the batch's state: time[i * stride],
   qpos[i * stride ...], qvel[i * stride ...] and plugin_state[i * stride + state_adr ...], stride
   the row length in numbers; out[18 i ...] gets its 18 numbers. Simulations with skip[i] != 0 are
   left out (their out rows untouched). Returns 0, or -1 - i for the first model i whose numerics
   are not a parameter block of this layout. */
int magsail_cubesat_probe_rows(int n, const mjModel* const* models, int adr_params, int adr_table, int state_adr,
                               const mjtNum* time, const mjtNum* qpos, const mjtNum* qvel,
                               const mjtNum* plugin_state, long stride, const unsigned char* skip, mjtNum* out) {
  for (int i = 0; i < n; i++) {
    if (skip && skip[i]) {
      continue;
    }
    const mjModel* m = models[i];
    if (adr_params < 0 || adr_params + P_SIZE_FIXED > m->nnumericdata ||
        (int)m->numeric_data[adr_params + P_VERSION] != LAYOUT_VERSION) {
      return -1 - i;
    }
    long r = (long)i * stride;
    probe_values(m->numeric_data + adr_params, m->numeric_data + adr_table, plugin_state + r + state_adr,
                 m->opt.timestep, time[r], qpos + r, qvel + r, out + 18 * (long)i);
  }
  return 0;
}

static void cubesat_advance(const mjModel* m, mjData* d, int instance) {
  step_memory_advance(m, d, instance, &kMemory);
}

mjPLUGIN_LIB_INIT(magsail_cubesat_loads) {
  register_passive_plugin("magsail.cubesat_loads", kAttributes, sizeof(kAttributes) / sizeof(kAttributes[0]),
                          cubesat_nstate, cubesat_init, cubesat_reset, cubesat_compute, cubesat_advance);
}
