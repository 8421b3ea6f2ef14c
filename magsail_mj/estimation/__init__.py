"""Attitude estimation of flexible bodies: best-fit rotation, body rates, Euler angles."""

from magsail_mj.estimation.attitude import (
    BestFitRotation,
    ParticleInertia,
    best_fit_rotation,
    body_rate_step,
    body_rates,
    euler_zyx,
    hat,
    matrix_from_quat,
    particle_inertia,
    quat_from_matrix,
    rotation_angle,
    rotation_from_euler_zyx,
    so3_exp,
    so3_log,
    vee,
)

__all__ = [
    "BestFitRotation",
    "ParticleInertia",
    "best_fit_rotation",
    "body_rate_step",
    "body_rates",
    "euler_zyx",
    "hat",
    "matrix_from_quat",
    "particle_inertia",
    "quat_from_matrix",
    "rotation_angle",
    "rotation_from_euler_zyx",
    "so3_exp",
    "so3_log",
    "vee",
]
