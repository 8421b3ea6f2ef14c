/* A body-fixed magnetic dipole in a uniform field as a MuJoCo engine plugin
   ("magsail.dipole_in_field", passive force): the magnetic pendulum's torque, evaluated by MuJoCo
   each time it computes the passive forces (mj_passive, once per mj_forward: at the step's start
   and at each further stage of RK4), so the load takes part in every stage of the integration.

   Built and loaded by magsail_mj.compiled (one shared library per digest of the source and the
   folder's headers, MuJoCo version and compiler); the Python side is magsail_mj.compiled.dipole. With R the body -> world rotation
   of the body's frame (d->xmat), m the dipole [A m^2, body axes] and B the field [T, world axes],
   the world torque

     tau = (R m) x B                                                       [N m]

   acts on the body (no force), and its generalized force J_r^T tau goes to qfrc_passive
   (mj_applyFT at the body's centre of mass: the same map MuJoCo applies to xfrc_applied, so any
   joint tree works; for a free joint it is the body-axes torque m x R^T B). The potential energy
   of the load is U = -(R m) . B [J].

   Attributes (strings, read once per MjData at reset):
     body    the name of the body carrying the dipole (not the world body);
     dipole  three numbers, the dipole in the body's frame [A m^2];
     field   three numbers, the uniform field in world axes [T].

   Plugin state (6 numbers per instance): the dipole (body axes) and the field (world axes),
   set from the attributes at reset. Python may overwrite them between steps (a commanded dipole,
   a field that changes from step to step); being plugin state, they are part of MuJoCo's
   integration state (mj_getState with mjSTATE_PLUGIN). plugin_data holds the body's id. */

#include <stdlib.h>

#include <mujoco/mujoco.h>

#include "plugin_common.h"

enum { S_DIPOLE = 0, S_FIELD = 3, S_COUNT = 6 };

static const char* kAttributes[] = {"body", "dipole", "field"};

/* parse exactly three numbers from text into out; 0 on success, -1 otherwise */
static int parse_vec3(const char* text, mjtNum out[3]) {
  if (!text) {
    return -1;
  }
  const char* p = text;
  for (int i = 0; i < 3; i++) {
    char* end;
    out[i] = strtod(p, &end);
    if (end == p) {
      return -1;
    }
    p = end;
  }
  while (*p == ' ' || *p == '\t' || *p == '\n') {
    p++;
  }
  return *p == '\0' ? 0 : -1;
}

static int dipole_nstate(const mjModel* m, int instance) {
  return S_COUNT;
}

static void dipole_reset(const mjModel* m, mjtNum* state, void* plugin_data, int instance) {
  if (parse_vec3(mj_getPluginConfig(m, instance, "dipole"), state + S_DIPOLE) != 0) {
    mju_zero3(state + S_DIPOLE);
  }
  if (parse_vec3(mj_getPluginConfig(m, instance, "field"), state + S_FIELD) != 0) {
    mju_zero3(state + S_FIELD);
  }
}

static int dipole_init(const mjModel* m, mjData* d, int instance) {
  const char* name = mj_getPluginConfig(m, instance, "body");
  int body = (name && name[0]) ? mj_name2id(m, mjOBJ_BODY, name) : -1;
  if (body < 1) {
    mju_warning("magsail.dipole_in_field: the instance's 'body' must name a body other than the world");
    return -1;
  }
  mjtNum v[3];
  const char* keys[] = {"dipole", "field"};
  for (int k = 0; k < 2; k++) {
    if (parse_vec3(mj_getPluginConfig(m, instance, keys[k]), v) != 0) {
      mju_warning("magsail.dipole_in_field: the instance's '%s' must be three numbers", keys[k]);
      return -1;
    }
  }
  d->plugin_data[instance] = (uintptr_t)body;
  return 0;
}

static void dipole_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  int body = (int)d->plugin_data[instance];
  const mjtNum* s = d->plugin_state + m->plugin_stateadr[instance];
  mjtNum mw[3], torque[3];
  static const mjtNum no_force[3] = {0, 0, 0};
  mju_mulMatVec3(mw, d->xmat + 9 * body, s + S_DIPOLE);
  mju_cross(torque, mw, s + S_FIELD);
  mj_applyFT(m, d, no_force, torque, d->xipos + 3 * body, body, d->qfrc_passive);
}

mjPLUGIN_LIB_INIT(magsail_dipole_in_field) {
  register_passive_plugin("magsail.dipole_in_field", kAttributes, sizeof(kAttributes) / sizeof(kAttributes[0]),
                          dipole_nstate, dipole_init, dipole_reset, dipole_compute, NULL);
}
