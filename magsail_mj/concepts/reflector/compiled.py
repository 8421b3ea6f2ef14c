r"""The reflector's pitch tracking compiled into its model (``sim.loads = "compiled"``).

The pitch controller of Scenario B (:class:`~magsail_mj.control.reflector_pitch.ReflectorPitchController`:
steering reference, quaternion feedback, projection ⟂ B and saturation, Robb et al. 2020, Eqs. 9–15)
runs every integration step, and its coil torque (:class:`~magsail_mj.loads.body_torque.HeldBodyTorqueLoad`)
and the optional gravity gradient (:class:`~magsail_mj.loads.body_torque.OrbitGravityGradientLoad`,
case B5) are the run's loads. With compiled loads all three are computed by the MuJoCo plugin
``magsail.reflector_loads`` (``magsail_mj/compiled/reflector_loads.c``, its equations and frames in
its header comment) inside ``mj_step``, so Python acts only at the records and checkpoints. This
module builds the plugin's data (a copy of the plate's MjSpec with one custom numeric, the
parameter block :data:`PARAM_FIELDS` read from the run's own controller and orbit, so both paths
use the very same numbers, and the plugin instance naming it) and reads, for the records, what the
controller commands at a state (:meth:`CompiledReflector.probe`: the C function the plugin uses).

Timing (``sim.load_timing``): ``"start"`` and ``"midpoint"`` are the Python path's (the controller
at the step's start, zero-order hold; its torque rotated to world axes and the gravity gradient
evaluated at the step's start or its predicted middle, held over the step in world axes), equal to
it to round-off; ``"stage"`` evaluates the control law and the gravity gradient at every RK4 stage
(the law as a continuous-time feedback: fourth order where the torque is smooth).
"""

from __future__ import annotations

from types import SimpleNamespace

import mujoco
import numpy as np

from magsail_mj.compiled import load_plugin
from magsail_mj.compiled.plugin import PARAM_HEAD, TIMINGS, CompiledPlant, field_offsets, param_block
from magsail_mj.compiled.plugin import plugin_model, probe_function
from magsail_mj.control.reflector_pitch import ReflectorPitchController

__all__ = [
    "PARAM_FIELDS",
    "STATE_FIELDS",
    "PROBE_FIELDS",
    "LAYOUT_VERSION",
    "TIMINGS",
    "SATURATIONS",
    "CompiledReflector",
    "reflector_params",
]

PLUGIN = "magsail.reflector_loads"
LIBRARY = "reflector_loads"
LAYOUT_VERSION = 1
SATURATIONS = {"norm": 0, "field_scaled": 1, "per_path": 2}

PARAM_FIELDS: tuple[tuple[str, int], ...] = (
    *PARAM_HEAD,
    ("ORBIT_R", 1),
    ("R_E", 1),
    ("N", 1),
    ("OMEGA_E", 1),
    ("T_MID", 1),
    ("FIELD_K", 1),
    ("PQ", 3),
    ("PW", 3),
    ("INERTIA", 3),
    ("RATE_ERROR", 1),
    ("FEEDFORWARD", 1),
    ("SATURATION", 1),
    ("CAP", 1),
    ("B_REF", 1),
    ("M_MAX", 3),
    ("GG", 1),
    ("MU", 1),
)
"""The parameter block, in the order of the C source's ``P_*`` enum (name, length): the common
head (:data:`~magsail_mj.compiled.plugin.PARAM_HEAD`), then, in SI units, flags 0/1: orbit radius
``r`` [m], Earth radius [m], mean motion ``n`` [rad/s], ground-point rate [rad/s], overhead time
``t_m`` [s], field factor ``k = B₀ (R_e/r)³`` [T]; gains ``P_q`` [N m], ``P_ω`` [N m s] and
principal inertia [kg m²] per body axis; the torque cap [N m], the cap's reference field [T], the
per-path dipole limits [A m²]; μ [m³/s²] of the gravity gradient."""

STATE_FIELDS: tuple[tuple[str, int], ...] = (
    ("STALE", 1),
    ("STEP", 1),
    ("T_RAW", 1),
    ("PRIMED", 1),
    ("BETA", 1),
    ("T_ACT", 3),
    ("WORLD", 3),
    ("MID_STEP", 1),
    ("V_PRIMED", 1),
)
"""The plugin state, in the order of the C source's ``S_*`` enum; then ``2 nv`` velocities (the
previous and the current step's start ``qvel``, for the midpoint prediction)."""

PROBE_FIELDS: tuple[tuple[str, int], ...] = (
    ("T_ACT", 3),
    ("T_REF", 3),
    ("SATURATED", 1),
    ("Q_E", 4),
    ("Q_REF", 4),
    ("PSI", 3),
    ("B_WORLD", 3),
    ("GG_WORLD", 3),
    ("BETA", 1),
)
"""What :meth:`CompiledReflector.probe` returns, in the order of the C source's ``O_*`` enum."""


_S = field_offsets(STATE_FIELDS)
_O = field_offsets(PROBE_FIELDS)


def reflector_params(
    *,
    controller: ReflectorPitchController,
    gravity_gradient_mu: float | None,
    qpos_adr: int,
    dof_adr: int,
    timing: str,
) -> np.ndarray:
    """The plugin's parameter block (:data:`PARAM_FIELDS`) from the run's controller (its orbit,
    gains, inertia, law options and actuator limits) and ``gravity_gradient_mu`` [m³/s²] (``None``:
    no gravity gradient).

    Raises:
      ValueError: an unknown ``timing`` or saturation mode.
    """
    p, put = param_block(
        PARAM_FIELDS,
        version=LAYOUT_VERSION,
        body=controller.body_id,
        qpos_adr=qpos_adr,
        dof_adr=dof_adr,
        timing=timing,
    )
    if controller.saturation not in SATURATIONS:
        raise ValueError(f"control.saturation: must be one of {sorted(SATURATIONS)}, got {controller.saturation!r}")
    o = controller.orbit
    put("ORBIT_R", o.r_m)
    put("R_E", o.R_e_m)
    put("N", o.n_rad_s)
    put("OMEGA_E", o.omega_e_rad_s)
    put("T_MID", o.t_mid_s)
    put("FIELD_K", o.B0_T * (o.R_e_m / o.r_m) ** 3)  # as ReflectorOrbit._field_scalar computes it
    put("PQ", controller.Pq)
    put("PW", controller.Pw)
    put("INERTIA", controller.inertia)
    put("RATE_ERROR", controller.rate_term == "error")
    put("FEEDFORWARD", controller.feedforward)
    put("SATURATION", SATURATIONS[controller.saturation])
    put("CAP", controller.cap)
    put("B_REF", controller.B_ref)
    put("M_MAX", controller.m_max)
    put("GG", gravity_gradient_mu is not None)
    put("MU", gravity_gradient_mu if gravity_gradient_mu is not None else 0.0)
    return p


class CompiledReflector(CompiledPlant):
    """The plate's model with the compiled pitch tracking (module docstring).

    Args:
      spec: the plate's MjSpec (copied; the copy gets the plugin and its numeric).
      bare_model: the plate's model without the plugin (the bare ``mj_step`` a benchmark compares with).
      controller: the run's pitch controller (its numbers go to the plugin; it is not stepped).
      gravity_gradient_mu: μ [m³/s²] of the gravity gradient (``gravity.gg_torque``), or ``None``.
      plate_qpos, plate_dof: the plate free joint's first ``qpos`` and ``qvel`` addresses.
      timing: ``"start"``, ``"midpoint"`` or ``"stage"`` (``sim.load_timing``).

    Attributes:
      model: the model with the plugin; ``bare_model``; ``timing``; ``state_adr``: the instance's
        first plugin state address.

    Raises:
      CompiledLoadsError: the plugin library cannot be built or loaded (no compiler).
    """

    state_fields = STATE_FIELDS

    def __init__(
        self,
        spec: mujoco.MjSpec,
        *,
        bare_model: mujoco.MjModel,
        controller: ReflectorPitchController,
        gravity_gradient_mu: float | None,
        plate_qpos: int,
        plate_dof: int,
        timing: str,
    ) -> None:
        probe = probe_function(load_plugin(LIBRARY), "magsail_reflector_probe")
        # a C function, its output buffer (with a view per field) and the key of the state the
        # buffer holds: not part of the walked state
        out = np.empty(_O["END"])
        self._probe = SimpleNamespace(
            fn=probe,
            key=None,
            out=out,
            ptr=out.ctypes.data,
            fields={name: out[_O[name] : _O[name] + n] for name, n in PROBE_FIELDS},
        )
        params = reflector_params(
            controller=controller,
            gravity_gradient_mu=gravity_gradient_mu,
            qpos_adr=plate_qpos,
            dof_adr=plate_dof,
            timing=timing,
        )
        model = plugin_model(
            spec,
            plugin=PLUGIN,
            instance="magsail_reflector_loads",
            numerics={"params": ("magsail_reflector_params", params)},
        )
        super().__init__(model, bare_model=bare_model, timing=timing)

    def probe(self, data: mujoco.MjData) -> np.ndarray:
        """(25,) what the controller commands at ``data``'s state and step (``magsail_reflector_probe``
        of the C source; :data:`PROBE_FIELDS`): the coil torque ``T_act`` and ``T_ref`` [N m, body
        axes], saturated (0/1), ``q_e``, ``q_ref``, ``ψ_c`` [rad], ``ψ̇`` [rad/s], ``ψ̈`` [rad/s²], the
        world field [T], the gravity-gradient torque [N m, world axes; zero when off] and β [rad].

        A live buffer, like ``data.qpos``: the call for another state overwrites it (copy what is
        kept). The C function runs once per state (the same data, time, ``qpos``, ``qvel`` and
        unwrapping memory as the last call reuse the buffer), so the probes of one record call it
        once."""
        ns = self._probe
        a = self.state_adr + _S["PRIMED"]
        key = (
            data._address,
            data.time,
            data.qpos.tobytes(),
            data.qvel.tobytes(),
            data.plugin_state[a : a + 2].tobytes(),
        )
        if key != ns.key:
            ns.key = None
            if ns.fn(self.model._address, data._address, 0, ns.ptr) != 0:
                raise ValueError("data: its model has no initialised reflector-loads plugin")
            ns.key = key
        return ns.out

    def field(self, data: mujoco.MjData, name: str) -> np.ndarray:
        """The field ``name`` of :data:`PROBE_FIELDS` at ``data``'s state: a view of :meth:`probe`'s
        live buffer."""
        self.probe(data)
        return self._probe.fields[name]
