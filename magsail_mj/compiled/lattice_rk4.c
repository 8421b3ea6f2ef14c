/* The spring-dashpot lattice's classical RK4 in C: the compiled reference of
   magsail_mj.reference.compiled_rk4 (called through ctypes; no MuJoCo plugin).

   The equations are those of the NumPy reference magsail_mj.reference.numpy_rk4 (Robb et al.
   2022a, Sec. 2.1). State: node positions x (n, 3) [m] and velocities v (n, 3) [m/s], row-major.
   Strut s from node i to node j, r = x_j - x_i, l = |r|, e = r / l:

     F_s = k_s (l - l0_s) + gamma_s ((v_j - v_i) . e)         [N, tension positive]
     node i gets +F_s e, node j gets -F_s e

   and the distributed strut torque (magsail_mj.loads.strut_torque, "local" torque axis) on the
   actuated struts m with ends i, j and the columns (i_bot, i_top), (j_bot, j_top) through them:

     n = (x_itop - x_ibot) + (x_jtop - x_jbot),  n_perp = n - (n . e) e,  n_hat = n_perp / |n_perp|
     a_m = w1_m tau_1 + w2_m tau_2,  c_m = w3_m tau_3
     F_j = (a_m n_hat + c_m (n_hat x e)) / l,   F_i = -F_j               [N]

   with the body torque command tau(t) [N m] given per step at t, t + dt/2 and t + dt (a command
   of time alone). Acceleration a = (F_springs + F_load) / m, zero on clamped nodes (inv_m = 0).
   One step:

     a1 = a(t, x, v);                x2 = x + dt/2 v,  v2 = v + dt/2 a1
     a2 = a(t + dt/2, x2, v2);       x3 = x + dt/2 v2, v3 = v + dt/2 a2
     a3 = a(t + dt/2, x3, v3);       x4 = x + dt v3,   v4 = v + dt a3
     a4 = a(t + dt, x4, v4)
     x' = x + dt/6 (v + 2 v2 + 2 v3 + v4),   v' = v + dt/6 (a1 + 2 a2 + 2 a3 + a4)

   The sums follow the NumPy reference's order (the strut forces gathered into the +e ends, then
   into the -e ends and subtracted; the load's forces likewise, then added), so the two differ
   only by the rounding of the square roots and dot products. */

#include <math.h>
#include <string.h>

typedef struct {
  int n, S, M;
  const int* ends;       /* (S, 2) strut end nodes */
  const double* k;       /* (S,) spring constants [N/m] */
  const double* l0;      /* (S,) rest lengths [m] */
  const double* gamma;   /* (S,) dashpots [N s/m] */
  const double* inv_m;   /* (n, 3) 1/m, 0 on clamped nodes [1/kg] */
  const int* act;        /* (M, 6) i, j, i_bot, i_top, j_bot, j_top of the actuated struts */
  const double* w;       /* (M, 3) shares of tau_1, tau_2, tau_3 */
  int damped;
  double* plus;          /* (n, 3) scratch: sums into the first ends */
  double* minus;         /* (n, 3) scratch: sums into the second ends */
} Lattice;

/* a = (F_springs(x, v) + F_load(x, tau)) * inv_m (module comment) */
static void acceleration(const Lattice* L, const double* x, const double* v, const double tau[3], double* a) {
  int n3 = 3 * L->n;
  memset(L->plus, 0, sizeof(double) * n3);
  memset(L->minus, 0, sizeof(double) * n3);
  for (int s = 0; s < L->S; s++) {
    int i = 3 * L->ends[2 * s], j = 3 * L->ends[2 * s + 1];
    double r0 = x[j] - x[i], r1 = x[j + 1] - x[i + 1], r2 = x[j + 2] - x[i + 2];
    double l = sqrt(r0 * r0 + r1 * r1 + r2 * r2);
    double e0 = r0 / l, e1 = r1 / l, e2 = r2 / l;
    double f = L->k[s] * (l - L->l0[s]);
    if (L->damped) {
      double d0 = v[j] - v[i], d1 = v[j + 1] - v[i + 1], d2 = v[j + 2] - v[i + 2];
      f += L->gamma[s] * (d0 * e0 + d1 * e1 + d2 * e2);
    }
    double F0 = e0 * f, F1 = e1 * f, F2 = e2 * f;
    L->plus[i] += F0;
    L->plus[i + 1] += F1;
    L->plus[i + 2] += F2;
    L->minus[j] += F0;
    L->minus[j + 1] += F1;
    L->minus[j + 2] += F2;
  }
  for (int q = 0; q < n3; q++) {
    a[q] = L->plus[q] - L->minus[q];
  }
  if (L->M == 0 || (tau[0] == 0.0 && tau[1] == 0.0 && tau[2] == 0.0)) {
    for (int q = 0; q < n3; q++) {
      a[q] *= L->inv_m[q];
    }
    return;
  }
  memset(L->plus, 0, sizeof(double) * n3);
  memset(L->minus, 0, sizeof(double) * n3);
  for (int m = 0; m < L->M; m++) {
    const int* c = L->act + 6 * m;
    int i = 3 * c[0], j = 3 * c[1], ib = 3 * c[2], it = 3 * c[3], jb = 3 * c[4], jt = 3 * c[5];
    double nv[3], e[3], r[3];
    for (int q = 0; q < 3; q++) {
      nv[q] = (x[it + q] - x[ib + q]) + (x[jt + q] - x[jb + q]);
      r[q] = x[j + q] - x[i + q];
    }
    double l = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    for (int q = 0; q < 3; q++) {
      e[q] = r[q] / l;
    }
    double ne = nv[0] * e[0] + nv[1] * e[1] + nv[2] * e[2];
    double np_[3];
    for (int q = 0; q < 3; q++) {
      np_[q] = nv[q] - ne * e[q];
    }
    double nn = sqrt(np_[0] * np_[0] + np_[1] * np_[1] + np_[2] * np_[2]);
    double h[3] = {np_[0] / nn, np_[1] / nn, np_[2] / nn};
    double wv[3] = {h[1] * e[2] - h[2] * e[1], h[2] * e[0] - h[0] * e[2], h[0] * e[1] - h[1] * e[0]};
    double am = L->w[3 * m] * tau[0] + L->w[3 * m + 1] * tau[1], cm = L->w[3 * m + 2] * tau[2];
    for (int q = 0; q < 3; q++) {
      double Fj = (am * h[q] + cm * wv[q]) / l;
      L->plus[j + q] += Fj;
      L->minus[i + q] += Fj;
    }
  }
  for (int q = 0; q < n3; q++) {
    a[q] = (a[q] + (L->plus[q] - L->minus[q])) * L->inv_m[q];
  }
}

/* n_steps RK4 steps of dt [s] from (x, v), overwritten with the final state. tau: (n_steps, 3, 3)
   commands [N m] at t, t + dt/2 and t + dt of each step (ignored when M = 0). work: 16 n numbers
   of scratch. When rec_every > 0, positions are copied into rec (row r = x after r rec_every
   steps, the initial state first; 1 + n_steps / rec_every rows). Returns 0, or -1 on bad sizes. */
int magsail_lattice_rk4(int n, int S, const int* ends, const double* k, const double* l0, const double* gamma,
                        const double* inv_m, int M, const int* act, const double* w, const double* tau,
                        double dt, long n_steps, double* x, double* v, double* work, long rec_every, double* rec) {
  if (n <= 0 || S < 0 || M < 0 || n_steps < 0) {
    return -1;
  }
  int n3 = 3 * n;
  Lattice L = {n, S, M, ends, k, l0, gamma, inv_m, act, w, 0, work, work + n3};
  for (int s = 0; s < S; s++) {
    if (gamma[s] != 0.0) {
      L.damped = 1;
    }
  }
  double *a1 = work + 2 * n3, *a2 = a1 + n3, *a3 = a2 + n3, *a4 = a3 + n3;
  double *x2 = a4 + n3, *v2 = x2 + n3, *x3 = v2 + n3, *v3 = x3 + n3, *x4 = v3 + n3, *v4 = x4 + n3;
  static const double zero[9] = {0};
  double h2 = 0.5 * dt, h6 = dt / 6.0;
  long row = 0;
  for (long step = 0; step < n_steps; step++) {
    if (rec_every > 0 && step % rec_every == 0) {
      memcpy(rec + (row++) * n3, x, sizeof(double) * n3);
    }
    const double* t3 = M > 0 ? tau + 9 * step : zero;
    acceleration(&L, x, v, t3, a1);
    for (int q = 0; q < n3; q++) {
      x2[q] = x[q] + h2 * v[q];
      v2[q] = v[q] + h2 * a1[q];
    }
    acceleration(&L, x2, v2, t3 + 3, a2);
    for (int q = 0; q < n3; q++) {
      x3[q] = x[q] + h2 * v2[q];
      v3[q] = v[q] + h2 * a2[q];
    }
    acceleration(&L, x3, v3, t3 + 3, a3);
    for (int q = 0; q < n3; q++) {
      x4[q] = x[q] + dt * v3[q];
      v4[q] = v[q] + dt * a3[q];
    }
    acceleration(&L, x4, v4, t3 + 6, a4);
    for (int q = 0; q < n3; q++) {
      x[q] = x[q] + h6 * (((v[q] + 2.0 * v2[q]) + 2.0 * v3[q]) + v4[q]);
      v[q] = v[q] + h6 * (((a1[q] + 2.0 * a2[q]) + 2.0 * a3[q]) + a4[q]);
    }
  }
  if (rec_every > 0) {
    memcpy(rec + row * n3, x, sizeof(double) * n3);
  }
  return 0;
}
