"""The batch's arithmetic over a world axis equals, bit for bit, what one world's run computes.

Each function of :mod:`magsail_mj.batch.worldmath` and the CNUSAIL telemetry over the world axis
(:mod:`magsail_mj.concepts.cnusail.batch_control`) is compared with the function a single run calls
— MuJoCo's ``mju_quat2Mat``, ``mju_quatIntegrate``, ``mj_integratePos``, the runner's
``BodyKinematics``, the plain-float helpers of :mod:`magsail_mj.vec3` and of the controller, NumPy's
BLAS products — on random inputs (and the edge cases each has: the unit quaternion, a zero rate, a
rate below mjMINVAL), with ``np.array_equal``: a MuJoCo or NumPy that rounds otherwise fails here
first.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from magsail_mj.batch import worldmath as wm
from magsail_mj.concepts.cnusail.batch_control import eigen_angle, error_quaternion, nadir_frame, rate_error
from magsail_mj.concepts.cnusail.eigenaxis import eigen_angle_f, error_quaternion_f, rate_error_f
from magsail_mj.concepts.cnusail.modes import Mode, command_frame
from magsail_mj.sim import BodyKinematics
from magsail_mj.vec3 import cross_f, mat_t_vec_f, mat_vec_f

N = 4000
RNG = np.random.default_rng(20160101)
FREE_BODY = "<mujoco><worldbody><body><freejoint/><geom size='.1'/></body></worldbody></mujoco>"


def _quats(n: int = N) -> np.ndarray:
    q = RNG.normal(size=(n, 4))
    q[:4] = (1.0, 0.0, 0.0, 0.0)  # MuJoCo's identity shortcut
    q[4:8] *= 1e-3  # far from unit length
    q[8:12] /= np.linalg.norm(q[8:12], axis=1)[:, None]  # unit length: mju_normalize4 leaves it
    return q


def test_quat_to_mat_is_mujocos():
    q = _quats()
    ref = np.empty((N, 9))
    for i in range(N):
        mujoco.mju_quat2Mat(ref[i], q[i])
    assert np.array_equal(wm.quat_to_mat(q), ref)


def test_quat_integrate_and_free_joint_integration_are_mujocos():
    q = _quats()
    w = RNG.normal(size=(N, 3)) * RNG.uniform(0.0, 3.0, size=(N, 1))
    w[:6] = 0.0
    w[6:12] *= 1e-17  # below mjMINVAL: MuJoCo's unit x axis
    ref = q.copy()
    for i in range(N):
        mujoco.mju_quatIntegrate(ref[i], w[i], 0.1)
    assert np.array_equal(wm.quat_integrate(q, w, 0.1), ref)
    m = mujoco.MjModel.from_xml_string(FREE_BODY)
    pos, v = RNG.normal(size=(N, 3)), RNG.normal(size=(N, 3))
    for i in range(200):  # mj_integratePos: p + h v, then the quaternion as above
        qpos = np.concatenate([pos[i], q[i]])
        mujoco.mj_integratePos(m, qpos, np.concatenate([v[i], w[i]]), 0.1)
        assert np.array_equal(qpos[:3], pos[i] + 0.1 * v[i])
        assert np.array_equal(qpos[3:], wm.quat_integrate(q[i : i + 1], w[i : i + 1], 0.1)[0])


def test_normalise_quat_is_the_runners_kinematics():
    m = mujoco.MjModel.from_xml_string(FREE_BODY)
    d = mujoco.MjData(m)
    kin = BodyKinematics(m)
    q = _quats(300)
    out = wm.normalise_quat(q)
    for i in range(300):
        d.qpos[3:7] = q[i]
        kin.update(d)
        assert np.array_equal(out[i], kin.xquat[1])


def test_plain_float_helpers_and_blas_products():
    R = wm.quat_to_mat(wm.normalise_quat(_quats()))
    a, b = RNG.normal(size=(N, 3)) * 7e6, RNG.normal(size=(N, 3)) * 3e-5
    rows = [(R[i].tolist(), a[i].tolist(), b[i].tolist()) for i in range(N)]
    assert np.array_equal(wm.mat_vec(R, a), np.array([mat_vec_f(r, x) for r, x, _ in rows]))
    assert np.array_equal(wm.mat_t_vec(R, a), np.array([mat_t_vec_f(r, x) for r, x, _ in rows]))
    assert np.array_equal(wm.cross(a, b), np.array([cross_f(x, y) for _, x, y in rows]))
    assert np.array_equal(wm.cross(a, b), np.cross(a, b))
    R33 = R.reshape(N, 3, 3)
    assert np.array_equal(wm.vec_mat_blas(a, R), np.array([a[i] @ R33[i] for i in range(N)]))
    assert np.array_equal(wm.mat_t_vec_blas(R, b), np.array([R33[i].T @ b[i] for i in range(N)]))
    assert np.array_equal(wm.dot_blas(a, a), np.array([float(a[i] @ a[i]) for i in range(N)]))


def test_per_world_functions_are_pythons_and_survive_bad_values():
    x = np.concatenate([RNG.normal(size=500) * 1e3, [0.0, -0.0, np.inf, np.nan, 1e300]])
    s = wm.per_world(math.sin, x)
    assert np.array_equal(s[:-3], np.array([math.sin(v) for v in x[:-3]]))
    assert np.isnan(s[-3]) and np.isnan(s[-2])  # math.sin(inf) raises: NaN, the others go on
    assert np.isnan(wm.per_world(math.exp, np.array([1e3]))[0])
    p = wm.pow_per_world(np.abs(x[:-3]) * 7e3, 3)
    assert np.array_equal(p, np.array([v**3 for v in (np.abs(x[:-3]) * 7e3).tolist()]))
    assert wm.pow_per_world(np.array([1e300, -1e300]), 3).tolist() == [math.inf, -math.inf]


def test_cnusail_telemetry_over_worlds_is_the_controllers():
    n = 500
    r = RNG.normal(size=(n, 3)) * 7e6
    v = np.cross(RNG.normal(size=(n, 3)), r)
    v *= 7.5e3 / np.linalg.norm(v, axis=1)[:, None]
    q = wm.normalise_quat(_quats(n))
    om = RNG.normal(size=(n, 3)) * 0.1
    shortest = RNG.uniform(size=n) < 0.7
    p_c, w_o = nadir_frame(r, v)
    p_e = error_quaternion(p_c, q, shortest)
    theta, omega_e = eigen_angle(p_e), rate_error(om, p_e, w_o)
    for i in range(n):
        qc, wo = command_frame(Mode.NADIR, r[i], v[i])
        assert np.array_equal(p_c[i], qc) and w_o[i] == wo
        pe = error_quaternion_f(qc.tolist(), q[i].tolist(), shortest=bool(shortest[i]))
        assert np.array_equal(p_e[i], pe)
        assert theta[i] == eigen_angle_f(pe)
        assert np.array_equal(omega_e[i], rate_error_f(om[i].tolist(), pe, wo))
