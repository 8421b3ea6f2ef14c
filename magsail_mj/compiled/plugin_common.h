/* Pieces shared by the package's plugins: for the loads plugins (cubesat_loads.c,
   reflector_loads.c) the lookup of a custom numeric an instance attribute names, 3-vector helpers,
   the timing codes and the step memory of the plugin state with the midpoint prediction it serves;
   for every plugin of the folder (also dipole_in_field.c, lattice_springs.c) the registration of a
   passive-force plugin.

   Included as "plugin_common.h" from a source in this folder; magsail_mj.compiled.build hashes the
   folder's headers into every library's cache key, so an edited header rebuilds its libraries.

   Step memory: a loads plugin's state holds, at offsets the plugin names in a StepMemory,

     stale     1: the next evaluation is the first of a step (set by reset and advance)
     mid_step  step k whose start velocity the current-velocity slot holds (-1: none)
     primed    1: the previous-velocity slot holds a previous step's start velocity
     fixed     the number of fixed fields; then v_prev (nv) and v_cur (nv), the previous and the
               current step's start qvel

   Midpoint prediction (magsail_mj.sim, the Python path's): at the first evaluation of step
   k the state at t + dt/2 is predicted from the step's start (q, v) and the previous step's start
   velocity v_prev,

     dv = v - v_prev (0 before a previous step is known),
     q_mid = q advanced by dt/2 with v + dv/4 (mj_integratePos),  v_mid = v + dv/2. */

#ifndef MAGSAIL_PLUGIN_COMMON_H
#define MAGSAIL_PLUGIN_COMMON_H

#include <mujoco/mujoco.h>

/* the timing codes of a parameter block's P_TIMING (magsail_mj.compiled.plugin.TIMINGS) */
enum { TIMING_START = 0, TIMING_MIDPOINT = 1, TIMING_STAGE = 2 };

/* offsets of the step memory in a plugin's state (module comment) */
typedef struct {
  int stale, mid_step, primed, fixed;
} StepMemory;

/* the custom numeric named by attribute `key` of plugin instance `instance` (-1 when absent) */
static inline int numeric_of(const mjModel* m, int instance, const char* key) {
  const char* name = mj_getPluginConfig(m, instance, key);
  if (!name || !name[0]) {
    return -1;
  }
  return mj_name2id(m, mjOBJ_NUMERIC, name);
}

/* 1 when `instance` is an initialised plugin instance of d (its init stored a nonzero
   plugin_data), else 0 */
static inline int initialised_instance(const mjModel* m, const mjData* d, int instance) {
  return instance >= 0 && instance < m->nplugin && d->plugin_data[instance] != 0;
}

/* out = a x b (out may alias a or b) */
static inline void cross3(mjtNum out[3], const mjtNum a[3], const mjtNum b[3]) {
  mjtNum o0 = a[1] * b[2] - a[2] * b[1], o1 = a[2] * b[0] - a[0] * b[2], o2 = a[0] * b[1] - a[1] * b[0];
  out[0] = o0;
  out[1] = o1;
  out[2] = o2;
}

/* out = R^T a, R row-major (the body components of a world vector when R is body -> world) */
static inline void mat_t_vec(mjtNum out[3], const mjtNum R[9], const mjtNum a[3]) {
  out[0] = R[0] * a[0] + R[3] * a[1] + R[6] * a[2];
  out[1] = R[1] * a[0] + R[4] * a[1] + R[7] * a[2];
  out[2] = R[2] * a[0] + R[5] * a[1] + R[8] * a[2];
}

/* the state size of a plugin with step memory `mem`: its fixed fields and 2 nv velocities */
static inline int step_memory_nstate(const mjModel* m, const StepMemory* mem) {
  return mem->fixed + 2 * m->nv;
}

/* a fresh state: zeros, the next evaluation the first of a step, no start velocity held */
static inline void step_memory_reset(const mjModel* m, mjtNum* state, const StepMemory* mem) {
  mju_zero(state, mem->fixed + 2 * m->nv);
  state[mem->stale] = 1;
  state[mem->mid_step] = -1;
}

/* the plugin's advance: the next evaluation is the first of the next step */
static inline void step_memory_advance(const mjModel* m, mjData* d, int instance, const StepMemory* mem) {
  d->plugin_state[m->plugin_stateadr[instance] + mem->stale] = 1;
}

/* The midpoint state (q_mid, v_mid) of step k (module comment) into arrays allocated on d's stack
   (*qpos_mid: nq, *qvel_mid: nv); call between mj_markStack(d) and mj_freeStack(d). At a new step
   (k differs from the memory's) the step's start velocity d->qvel becomes the memory, the one it
   replaces the previous velocity. */
static inline void midpoint_state(const mjModel* m, mjData* d, mjtNum* s, const StepMemory* mem, long k,
                                  mjtNum** qpos_mid, mjtNum** qvel_mid) {
  int nv = m->nv;
  mjtNum* v_prev = s + mem->fixed;
  mjtNum* v_cur = v_prev + nv;
  if ((long)s[mem->mid_step] != k) { /* a new step: its start velocity becomes the memory */
    if (s[mem->mid_step] >= 0) {
      mju_copy(v_prev, v_cur, nv);
      s[mem->primed] = 1;
    }
    mju_copy(v_cur, d->qvel, nv);
    s[mem->mid_step] = (mjtNum)k;
  }
  mjtNum* qpos = mj_stackAllocNum(d, m->nq);
  mjtNum* vq = mj_stackAllocNum(d, nv);
  mjtNum* vm = mj_stackAllocNum(d, nv);
  mju_copy(qpos, d->qpos, m->nq);
  for (int i = 0; i < nv; i++) {
    mjtNum v = d->qvel[i], dv = s[mem->primed] != 0 ? v - v_prev[i] : 0.0;
    vq[i] = v + 0.25 * dv;
    vm[i] = v + 0.5 * dv;
  }
  mj_integratePos(m, qpos, vq, 0.5 * m->opt.timestep);
  *qpos_mid = qpos;
  *qvel_mid = vm;
}

/* register the passive-force plugin `name` with its attributes and callbacks (advance may be NULL) */
static inline void register_passive_plugin(const char* name, const char* const* attributes, int nattribute,
                                           int (*nstate)(const mjModel*, int),
                                           int (*init)(const mjModel*, mjData*, int),
                                           void (*reset)(const mjModel*, mjtNum*, void*, int),
                                           void (*compute)(const mjModel*, mjData*, int, int),
                                           void (*advance)(const mjModel*, mjData*, int)) {
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = name;
  plugin.capabilityflags = mjPLUGIN_PASSIVE;
  plugin.nattribute = nattribute;
  plugin.attributes = attributes;
  plugin.nstate = nstate;
  plugin.init = init;
  plugin.reset = reset;
  plugin.compute = compute;
  plugin.advance = advance;
  mjp_registerPlugin(&plugin);
}

#endif
