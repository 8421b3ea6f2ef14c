/* The lattice's strut springs and dashpots as a MuJoCo engine plugin ("magsail.lattice_springs",
   passive force), in place of one spatial tendon per strut.

   Built and loaded by magsail_mj.compiled (one shared library per digest of the source and the
   folder's headers, MuJoCo version and compiler); the Python side is magsail_mj.lattice.compiled_springs. Every time MuJoCo
   computes the passive forces (mj_passive, once per mj_forward: at the step's start and at each
   further stage of RK4) it adds, for every strut s from node i to node j with r = x_j - x_i,
   l = |r|, e = r / l (x: the node bodies' xpos, world axes [m]; v: their slide-joint velocities,
   world axes [m/s]),

     F_s = k_s (l - l0_s) + gamma_s ((v_j - v_i) . e)                      [N, tension positive]
     qfrc_passive[dofs of i] += F_s e,   qfrc_passive[dofs of j] -= F_s e

   the generalized force J^T f of a two-site spatial tendon with stiffness k_s, damping gamma_s and
   spring length l0_s (MuJoCo's passive tendon force -k (L - l0) - gamma dL/dt along J = dL/dq):
   the same two-sided spring-dashpot law (Robb et al. 2022a, Sec. 2.1). A node's three dofs are
   world-aligned slide joints (x, y, z) at consecutive addresses; a clamped node has none
   (dof address -1: no velocity, no force).

   All data come from one custom numeric named by the instance's "struts" attribute:

     [version, n_nodes, n_struts,
      body of node 0 .. n-1, dof address of node 0 .. n-1 (-1: clamped),
      (i, j, k [N/m], l0 [m], gamma [N s/m]) per strut]

   nothing is kept in the process, so any number of models and datas may use the plugin at once.

   magsail_clock_us is the calling thread's CPU time [us] for MuJoCo's profiler (mjcb_time, set
   from Python through ctypes so that MuJoCo calls it with no interpreter in between); CPU time,
   not wall time, so that other jobs on a shared machine do not count. */

#define _POSIX_C_SOURCE 199309L  /* clock_gettime under -std=c11 */

#include <math.h>
#include <time.h>

#include <mujoco/mujoco.h>

#include "plugin_common.h"

#define LAYOUT_VERSION 1
enum { P_VERSION = 0, P_NNODE, P_NSTRUT, P_HEAD };

static const char* kAttributes[] = {"struts"};

/* the calling thread's CPU time [us] (the profiler's time callback) */
mjtNum magsail_clock_us(void) {
  struct timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return (mjtNum)ts.tv_sec * 1e6 + (mjtNum)ts.tv_nsec * 1e-3;
}

static int springs_nstate(const mjModel* m, int instance) {
  return 0;
}

static void springs_reset(const mjModel* m, mjtNum* state, void* plugin_data, int instance) {
}

static int springs_init(const mjModel* m, mjData* d, int instance) {
  const char* name = mj_getPluginConfig(m, instance, "struts");
  int id = (name && name[0]) ? mj_name2id(m, mjOBJ_NUMERIC, name) : -1;
  if (id < 0) {
    mju_warning("magsail.lattice_springs: the instance's 'struts' must name a custom numeric");
    return -1;
  }
  const mjtNum* p = m->numeric_data + m->numeric_adr[id];
  int size = m->numeric_size[id];
  if (size < P_HEAD || (int)p[P_VERSION] != LAYOUT_VERSION) {
    mju_warning("magsail.lattice_springs: the strut table is not of layout %d", LAYOUT_VERSION);
    return -1;
  }
  int n = (int)p[P_NNODE], S = (int)p[P_NSTRUT];
  if (n < 1 || S < 0 || size != P_HEAD + 2 * n + 5 * S) {
    mju_warning("magsail.lattice_springs: the strut table's size disagrees with its node and strut counts");
    return -1;
  }
  for (int a = 0; a < n; a++) {
    int body = (int)p[P_HEAD + a], dof = (int)p[P_HEAD + n + a];
    if (body < 1 || body >= m->nbody || dof < -1 || dof + 3 > m->nv) {
      mju_warning("magsail.lattice_springs: node %d has body %d or dof address %d outside the model", a, body, dof);
      return -1;
    }
  }
  for (int s = 0; s < S; s++) {
    const mjtNum* r = p + P_HEAD + 2 * n + 5 * s;
    if (r[0] < 0 || r[0] >= n || r[1] < 0 || r[1] >= n) {
      mju_warning("magsail.lattice_springs: strut %d has an end outside the %d nodes", s, n);
      return -1;
    }
  }
  d->plugin_data[instance] = (uintptr_t)m->numeric_adr[id];
  return 0;
}

static void springs_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  const mjtNum* p = m->numeric_data + (int)d->plugin_data[instance];
  int n = (int)p[P_NNODE], S = (int)p[P_NSTRUT];
  const mjtNum* body = p + P_HEAD;
  const mjtNum* dof = body + n;
  const mjtNum* table = dof + n;
  static const mjtNum still[3] = {0, 0, 0};
  for (int s = 0; s < S; s++) {
    const mjtNum* row = table + 5 * s;
    int i = (int)row[0], j = (int)row[1];
    int di = (int)dof[i], dj = (int)dof[j];
    const mjtNum* xi = d->xpos + 3 * (int)body[i];
    const mjtNum* xj = d->xpos + 3 * (int)body[j];
    mjtNum r0 = xj[0] - xi[0], r1 = xj[1] - xi[1], r2 = xj[2] - xi[2];
    mjtNum l = sqrt(r0 * r0 + r1 * r1 + r2 * r2);
    mjtNum e0 = r0 / l, e1 = r1 / l, e2 = r2 / l;
    mjtNum f = row[2] * (l - row[3]);
    if (row[4] != 0) {
      const mjtNum* vi = di >= 0 ? d->qvel + di : still;
      const mjtNum* vj = dj >= 0 ? d->qvel + dj : still;
      f += row[4] * ((vj[0] - vi[0]) * e0 + (vj[1] - vi[1]) * e1 + (vj[2] - vi[2]) * e2);
    }
    mjtNum F0 = e0 * f, F1 = e1 * f, F2 = e2 * f;
    if (di >= 0) {
      d->qfrc_passive[di] += F0;
      d->qfrc_passive[di + 1] += F1;
      d->qfrc_passive[di + 2] += F2;
    }
    if (dj >= 0) {
      d->qfrc_passive[dj] -= F0;
      d->qfrc_passive[dj + 1] -= F1;
      d->qfrc_passive[dj + 2] -= F2;
    }
  }
}

mjPLUGIN_LIB_INIT(magsail_lattice_springs) {
  register_passive_plugin("magsail.lattice_springs", kAttributes, sizeof(kAttributes) / sizeof(kAttributes[0]),
                          springs_nstate, springs_init, springs_reset, springs_compute, NULL);
}
