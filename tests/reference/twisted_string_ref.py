"""Independent reference of the TwistedString FMU.

The equations are written again from the model documentation (fmu-src/twisted-string/src/doc.rs,
i.e. documentation/index.html of the FMU) and the paper (Urukalo, Jovanovic, Rodic, "Modeling,
Development and Control of Linear Twisted-String Actuator", eq. 9-21, Tables 2-5); they are not a
transliteration of the Rust code. Integration: SciPy ``solve_ivp(method="Radau", rtol=1e-10)`` with
tight absolute tolerances, piecewise between the position-loop sample instants ``t0 + k*Ts`` and the
communication points; inputs are held constant over each communication step (FMI Co-Simulation
semantics, inputs evaluated at the communication point as FMPy does: linear interpolation,
right-hand value at a repeated time). The position loop samples the set point at its instants:
a sample at a communication point sees the inputs set there (it opens the step from that point;
the outputs recorded at the point are those before it, except at t0, where initialization takes
the sample with the initial inputs), a sample inside a step the inputs held over the step.

Usage:
    from twisted_string_ref import simulate, DEFAULTS
    out = simulate({"load_mass": 5.0}, {"theta_motor_ref": ([0, 1], [0, 500])}, t_end=1.0, dt=1e-3)
    python tests/reference/twisted_string_ref.py   # regenerates tests/reference/twisted_string_*.csv
"""

from __future__ import annotations

import math
import os
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp

from model_description import parameter_defaults

G = 9.81
RPM8000 = 8000.0 * 2.0 * math.pi / 60.0

# Parameter defaults: the start values of the FMU's interface (modelDescription/TwistedString.xml).
DEFAULTS = parameter_defaults("TwistedString")

INPUT_STARTS = {"theta_motor_ref": 0.0, "voltage": 0.0, "F_load": 0.0}

OUTPUTS = [
    "p", "theta_motor", "omega_motor", "theta_twist", "current", "tau_motor", "F_string",
    "F_tangential", "alpha", "transmission_ratio", "stiffness", "F_axial", "v_load",
    "voltage_motor", "omega_ref",
    "E_electrical", "W_external", "E_dissipated", "E_stored", "E_string_kinematic",
]

# regularisation widths stated in the documentation
W_TENSION = 0.01          # N
P_EFF = 0.1               # W
W_COULOMB = 1.0           # rad/s (motor)
W_HYST = 0.05             # rad/s (twist)
P_EPS = 1e-3              # m, p regularisation of the string_compliance load law

# gear_backlash contact (documentation section 7, "gear_backlash as a contact")
J_OUT = 1.5e-6                         # kg m^2, gearhead output carrier + shaft + string clamp
K_MESH = 1000.0                        # N m/rad, mesh stiffness at the output
D_MESH = 2.0 * math.sqrt(K_MESH * J_OUT)  # N m s/rad, critical for J_OUT on a held motor
W_PEN = 1e-6                           # rad, smoothing of the penetration
W_CLIP = 1e-5                          # N m, smoothing of "a flank can only push"


def pos(x, w):
    """Smooth positive part (x + sqrt(x^2 + w^2)) / 2."""
    return 0.5 * (x + math.sqrt(x * x + w * w))


def clamp_rate(e, u_raw, limit):
    """Integrator rate: e, faded to 0 over 1 % beyond the limit when e pushes u further out."""
    if e * u_raw <= 0:
        return e
    frac = (abs(u_raw) - limit) / (0.01 * limit)
    return e * (1.0 - min(1.0, max(0.0, frac)))


def pos_integral(x, w):
    """Int_0^x pos(z) dz (elastic energy of a spring with force pos(s/c) is c * this at s/c)."""
    return 0.25 * (x * x + x * math.sqrt(x * x + w * w) + w * w * math.asinh(x / w))


class Model:
    """The documented equations. State y = [i, theta_m, omega_m, p, v, z_i, z_w, E_el, E_loss,
    E_kin] (E_*: energy integrals of documentation section 9), with gear_backlash followed by
    [delta, omega_t] (position of the gearhead output in the gap, output speed)."""

    def __init__(self, prm: dict, extra_motor_friction=None):
        # extra_motor_friction: optional torque law omega_m -> tau [N.m] at the motor shaft, added
        # to the candidate's (a friction law the FMU does not have, for records of a mechanism
        # outside its candidate list: examples/gapgen.py, condition `mismatch`)
        self.extra_fric = extra_motor_friction
        self.q = dict(DEFAULTS)
        unknown = set(prm) - set(DEFAULTS)
        if unknown:
            raise KeyError(f"unknown parameters {unknown}")
        self.q.update(prm)
        q = self.q
        self.N = q["gear_ratio"]
        self.compl = bool(q["string_compliance.enabled"])
        self.c = q["string_compliance.a3"] if self.compl else 1.0 / q["string_stiffness"]
        self.backlash = bool(q["gear_backlash.enabled"])
        self.dim = 12 if self.backlash else 10

    # --- kinematics of the gearhead output ---------------------------------------------
    def twist(self, y):
        """(theta_t, omega_t): the gearhead output angle and speed. Rigid gearhead: theta_m / N and
        omega_m / N. gear_backlash: theta_t = theta_m / N - delta with the position delta of the
        output in the gap and the output speed omega_t as states y[10], y[11]."""
        if not self.backlash:
            return y[1] / self.N, y[2] / self.N
        return y[1] / self.N - y[10], y[11]

    def contact(self, delta, delta_rate):
        """Torque of the gear flanks on the output and its elastic part (doc. section 7): each
        flank pushes with pos(k pos(pen) + d pos'(pen) pen_rate) (a Kelvin-Voigt mesh that acts
        only in contact and cannot pull), pen = +-delta - b/2."""
        half = 0.5 * self.q["gear_backlash.angle"]
        tau = elastic = 0.0
        for sgn in (1.0, -1.0):
            pen, rate = sgn * delta - half, sgn * delta_rate
            root = math.sqrt(pen * pen + W_PEN ** 2)
            r, dr = 0.5 * (pen + root), 0.5 * (1.0 + pen / root)
            tau += sgn * pos(K_MESH * r + D_MESH * dr * rate, W_CLIP)
            elastic += sgn * K_MESH * r
        return tau, elastic

    def contact_energy(self, delta):
        """Elastic energy of the flanks, k (Phi(delta - b/2) + Phi(-delta - b/2))."""
        half = 0.5 * self.q["gear_backlash.angle"]
        return K_MESH * (pos_integral(delta - half, W_PEN) + pos_integral(-delta - half, W_PEN))

    def arc(self, th_t):
        """Twist arc a = theta_t r(theta_t) and a' with r = r0 (1 + g |theta_t| / 2pi)."""
        r0 = self.q["string_radius"]
        g = self.q["radius_growth.per_turn"] if self.q["radius_growth.enabled"] else 0.0
        r = r0 * (1.0 + g * abs(th_t) / (2 * math.pi))
        return th_t * r, r + abs(th_t) * r0 * g / (2 * math.pi)

    def lfree(self, th_t):
        """Unloaded strand length and its derivative w.r.t. the twist angle (eq. 10)."""
        L0 = self.q["string_length"]
        if not self.compl:
            return L0, 0.0
        thM = self.N * th_t
        a1, a2 = self.q["string_compliance.a1"], self.q["string_compliance.a2"]
        sgn = -1.0 if thM < 0 else 1.0  # forward derivative at zero twist
        return L0 + a1 * abs(thM) + a2 * thM ** 2, (a1 * sgn + 2 * a2 * thM) * self.N

    def strings(self, y):
        """Tension and forces of the helix for state y."""
        th_t, w_t = self.twist(y)
        a, ad = self.arc(th_t)
        p, v = y[3], y[4]
        L = math.hypot(p, a)
        Lf, dLf = self.lfree(th_t)
        stretch = L - Lf
        stretch_rate = (p * v + a * ad * w_t) / L - dLf * w_t
        x = pos(stretch / self.c + self.q["string_damping"] * stretch_rate, W_TENSION)
        # power into the strings from shaft and load, split (doc. section 9) into the rate of the
        # elastic energy c Phi(s/c), the damping part and (string_compliance) the kinematic part
        elastic = pos(stretch / self.c, W_TENSION)
        if self.compl:
            # eq. 10: elongation a3 * F_L (the load), p regularised with P_EPS near zero
            qp = math.sqrt(p * p + P_EPS ** 2)
            FL, T = x * p / qp, x * L / qp
            L_rate = (p * v + a * ad * w_t) / L
            P_kin = x * (L / qp) * L_rate - x * stretch_rate
        else:
            T = x                      # strand tension from strand stretch
            FL = T * p / L             # eq. 12/19: F_L = T cos(alpha)
            P_kin = 0.0
        return dict(th_t=th_t, w_t=w_t, a=a, ad=ad, L=L, dLf=dLf, T=T, stretch=stretch,
                    FL=FL, Ftau=T * a / L, tauL=T * a * ad / L,
                    P_damp=(x - elastic) * stretch_rate, P_kin=P_kin)

    def controller(self, y, w_ref, volt):
        """Continuous ESCON speed and current PI, conditional-integration anti-windup."""
        q = self.q
        if not q["internal_controller"]:
            return volt, 0.0, 0.0
        Kw, Tw = q["controller_speed_P"], q["controller_speed_Ti"]
        Ki, Ti = q["controller_current_P"], q["controller_current_Ti"]
        ew = w_ref - y[2]
        iref_raw = Kw * (ew + y[6] / Tw)
        iref = min(max(iref_raw, -q["current_limit"]), q["current_limit"])
        ei = iref - y[0]
        u_raw = Ki * (ei + y[5] / Ti)
        u = min(max(u_raw, -q["supply_voltage"]), q["supply_voltage"])
        return u, clamp_rate(ei, u_raw, q["supply_voltage"]), clamp_rate(ew, iref_raw, q["current_limit"])

    def deriv(self, y, w_ref, volt, fload):
        q = self.q
        s = self.strings(y)
        tau_out = s["tauL"]
        tau_h = 0.0
        if q["twist_hysteresis.enabled"]:
            tau_h = (q["twist_hysteresis.friction_coefficient"] * s["T"] * s["ad"]
                     * math.tanh(s["w_t"] / W_HYST))
            tau_out += tau_h
        # torque and speed of the gear output as the gear sees them: the strings' torque and the
        # twist rate (rigid gearhead), or the flank torque and the motor side's speed (backlash)
        P_contact = 0.0
        if self.backlash:
            delta_rate = y[2] / self.N - y[11]
            tau_gear, tau_el = self.contact(y[10], delta_rate)
            P_contact = (tau_gear - tau_el) * delta_rate
            w_gear = y[2] / self.N
        else:
            tau_gear, w_gear = tau_out, s["w_t"]
        eta = q["gear_efficiency"]
        P = tau_gear * w_gear
        f = 0.5 * (1 / eta + eta) + 0.5 * (1 / eta - eta) * math.tanh(P / P_EFF)
        tau_in = f * tau_gear / self.N
        fric = 0.0
        if q["motor_friction.enabled"]:
            fric = (q["motor_friction.coulomb"] * math.tanh(y[2] / W_COULOMB)
                    + q["motor_friction.viscous"] * y[2])
        if self.extra_fric is not None:
            fric += self.extra_fric(y[2])
        u, dzi, dzw = self.controller(y, w_ref, volt)
        di = (u - q["motor_resistance"] * y[0] - q["back_emf_constant"] * y[2]) / q["motor_inductance"]
        dw = (q["torque_constant"] * y[0] - tau_in - fric) / q["rotor_inertia"]
        Fs = q["spring_preload"] + q["spring_stiffness"] * (q["string_length"] - y[3])
        m = q["load_mass"]
        dv = (m * G + fload + Fs - s["FL"] - q["guide_damping"] * y[4]) / m
        # dissipated power (doc. section 9): copper, k_e/k_t mismatch, gearhead, motor friction,
        # strand friction, guides, string damping, gear-flank damping
        P_loss = (q["motor_resistance"] * y[0] ** 2
                  + (q["back_emf_constant"] - q["torque_constant"]) * y[0] * y[2]
                  + (f - 1.0) * P + fric * y[2] + tau_h * s["w_t"]
                  + q["guide_damping"] * y[4] ** 2 + s["P_damp"] + P_contact)
        dy = [di, y[2], dw, y[4], dv, dzi, dzw, u * y[0], P_loss, s["P_kin"]]
        if self.backlash:
            dy += [delta_rate, (tau_gear - tau_out) / J_OUT]
        return dy

    def stored(self, y):
        """E_stored: L i^2/2 + J w^2/2 + m v^2/2 + (m g + F0)(L0 - p) + k (L0 - p)^2/2 + c Phi(s/c)."""
        q = self.q
        d = q["string_length"] - y[3]
        s = self.strings(y)
        return (0.5 * q["motor_inductance"] * y[0] ** 2 + 0.5 * q["rotor_inertia"] * y[2] ** 2
                + 0.5 * q["load_mass"] * y[4] ** 2
                + (q["load_mass"] * G + q["spring_preload"]) * d + 0.5 * q["spring_stiffness"] * d * d
                + self.c * pos_integral(s["stretch"] / self.c, W_TENSION)
                + (0.5 * J_OUT * y[11] ** 2 + self.contact_energy(y[10]) if self.backlash else 0.0))

    def outputs(self, y, w_ref, volt):
        q = self.q
        s = self.strings(y)
        u, _, _ = self.controller(y, w_ref, volt)
        p, a, L = y[3], s["a"], s["L"]
        cos = p / L
        if self.compl:
            a3, qp = self.c, math.sqrt(p * p + P_EPS ** 2)
            # d/dp of F_L = (stretch / a3) p / qp at fixed twist
            stiff = cos * (p / qp) / a3 + s["stretch"] / a3 * P_EPS ** 2 / qp ** 3
        else:
            # d/dp of F_L = (stretch / c) p / L
            stiff = cos * cos / self.c + s["T"] * a * a / L ** 3
        return {
            "p": p, "theta_motor": y[1], "omega_motor": y[2], "theta_twist": s["th_t"],
            "current": y[0], "tau_motor": q["torque_constant"] * y[0],
            "F_string": s["T"] / q["string_count"], "F_tangential": s["Ftau"],
            "alpha": math.atan2(a, p),
            "transmission_ratio": (L * s["dLf"] - a * s["ad"]) / max(p, 1e-4),
            "stiffness": stiff,
            "F_axial": s["FL"], "v_load": y[4], "voltage_motor": u, "omega_ref": w_ref,
            "E_electrical": y[7], "E_dissipated": y[8] + y[9], "E_stored": self.stored(y),
            "E_string_kinematic": y[9],
        }

    def rest_state(self, fload):
        """Untwisted equilibrium of the load: F_L(p0) = m g + F_load + F_s(p0), p0 = L0 + c x."""
        q = self.q
        b = q["load_mass"] * G + fload + q["spring_preload"]
        def residual(x):
            p0 = q["string_length"] + self.c * x
            y = np.zeros(self.dim)
            y[3] = p0
            Fs = q["spring_preload"] + q["spring_stiffness"] * (q["string_length"] - p0)
            return self.strings(y)["FL"] - (q["load_mass"] * G + fload + Fs)
        # bisection (monotone), independent of the Rust Newton iteration
        lo, hi = min(-1.0, 2.0 * b - 1.0), max(b, 1.0) * 2 + 1.0
        for _ in range(300):
            mid = 0.5 * (lo + hi)
            if residual(mid) > 0:
                hi = mid
            else:
                lo = mid
        x = 0.5 * (lo + hi)
        # at rest untwisted the strings exert no torque: the output rests in the middle of the
        # gap (delta = 0, omega_t = 0 with gear_backlash)
        y = np.zeros(self.dim)
        y[3] = q["string_length"] + self.c * x
        return y


def input_at(tv, t):
    """Input value at communication point t as FMPy applies it (after_event=True)."""
    times, vals = np.asarray(tv[0], float), np.asarray(tv[1], float)
    if times.size == 1:
        return float(vals[0])
    if t <= times[0] and not math.isclose(t, times[0]):
        return float(vals[0])
    if t >= times[-1] or math.isclose(t, times[-1]):
        return float(vals[-1])
    idx = np.flatnonzero(np.isclose(times, t, rtol=1e-9, atol=0.0))
    if idx.size:
        return float(vals[idx[-1]])
    return float(np.interp(t, times, vals))


# gear_backlash states: delta 1e-2 rad, omega_t 1 rad/s
NOMINAL = np.array([1.0, 1.0, 10.0, 0.01, 0.01, 1e-3, 1.0, 1.0, 1.0, 1.0, 1e-2, 1.0])


def simulate(params: dict | None = None, inputs: dict | None = None, t_end: float = 1.0,
             dt: float = 1e-3, rtol: float = 1e-10, atol_scale: float = 1e-9,
             extra_motor_friction=None):
    """Simulate the reference; returns dict of arrays at the communication points 0, dt, ...
    extra_motor_friction: see Model (None: the documented model)."""
    params = dict(params or {})
    inputs = dict(inputs or {})
    model = Model(params, extra_motor_friction)
    q = model.q
    n = int(round(t_end / dt))
    tgrid = np.arange(n + 1) * dt
    def u_at(name, t):
        return input_at(inputs[name], t) if name in inputs else INPUT_STARTS[name]
    y = model.rest_state(u_at("F_load", 0.0))
    out = {k: np.empty(n + 1) for k in OUTPUTS}
    out["time"] = tgrid
    Ts = q["controller_position_period"]
    eps = 1e-6 * Ts
    k_next = 0
    w_ref = 0.0
    internal = bool(q["internal_controller"])
    quantum = 2 * math.pi / (4 * q["encoder_cpt"])
    atol = atol_scale * NOMINAL[:model.dim]

    w_ext = 0.0  # work of F_load: held over each step, so F_load * (change of p) exactly

    def record(j, th_ref, volt):
        for key, val in model.outputs(y, w_ref if internal else 0.0, volt).items():
            out[key][j] = val
        out["W_external"][j] = w_ext

    band, Kp, wmax = q["controller_position_band"], q["controller_position_P"], q["speed_limit"]

    def position_loop(th_ref):
        """Eq. 20-21 on the encoder angle: the speed set point of one sample."""
        meas = math.floor(y[1] / quantum) * quantum
        err = th_ref - meas
        return 0.0 if -band < err < band else min(max(Kp * err, -wmax), wmax)

    if internal:
        # the sample at t0 is in the outputs at t0 (initialization takes it with the initial
        # inputs); the first step takes it again with the inputs set for it (k_next stays 0)
        w_ref = position_loop(u_at("theta_motor_ref", 0.0))
    record(0, u_at("theta_motor_ref", 0.0), u_at("voltage", 0.0))
    for j in range(n):
        t = tgrid[j]
        t_stop = tgrid[j + 1]
        th_ref, volt, fload = (u_at("theta_motor_ref", t), u_at("voltage", t), u_at("F_load", t))
        tc = t
        p_start = y[3]
        while tc < t_stop:
            if internal:
                # the samples at tc: at the step's start those at the communication point t,
                # with the inputs set at t; a sample at t_stop is left to the next step
                while k_next * Ts <= tc + eps:
                    w_ref = position_loop(th_ref)
                    k_next += 1
            tn = t_stop
            if internal and k_next * Ts < t_stop - eps:
                tn = k_next * Ts
            wr = w_ref if internal else 0.0
            sol = solve_ivp(lambda _t, yy: model.deriv(yy, wr, volt, fload), (tc, tn), y,
                            method="Radau", rtol=rtol, atol=atol)
            if not sol.success:
                raise RuntimeError(f"reference failed at t={tc}: {sol.message}")
            y = sol.y[:, -1].copy()
            tc = tn
        w_ext += fload * (y[3] - p_start)
        record(j + 1, th_ref, volt)
    return out


# ---- reference traces ---------------------------------------------------------------------
def step(t0, v0, v1):
    """A step from v0 to v1 at time t0 (repeated time point: FMPy takes the right value)."""
    return ([0.0, t0, t0], [v0, v0, v1])


def cases():
    """The reference traces: name -> (params, inputs, t_end, dt)."""
    c = {}
    c["voltage_steps"] = ({"internal_controller": False},
                          {"voltage": ([0, 0.05, 0.05, 0.4, 0.4, 0.8], [0, 0, 12, 12, -6, -6])},
                          0.8, 1e-3)
    for F in (23, 39, 54, 97, 124):
        c[f"position_step_{F}N"] = ({"load_mass": F / G, "string_compliance.enabled": True},
                                    {"theta_motor_ref": step(0.01, 0.0, 335.1)}, 1.0, 1e-3)
    # communication step 2.5 ms: position-loop samples fall inside steps (split at k*Ts)
    c["position_step_54N_dt2p5ms"] = ({"load_mass": 54 / G, "string_compliance.enabled": True},
                                      {"theta_motor_ref": step(0.01, 0.0, 335.1)}, 1.0, 2.5e-3)
    # external force input under closed-loop hold at 300 rad: +60 N pull, then -20 N relief
    tf = [0, 0.6, 0.6, 1.0, 1.0, 1.4]
    c["force_steps"] = ({"string_compliance.enabled": True, "load_mass": 39 / G},
                        {"theta_motor_ref": (tf, [300.0] * 6),
                         "F_load": (tf, [0, 0, 60, 60, -20, -20])}, 1.4, 1e-3)
    c["twist_untwist"] = ({"string_compliance.enabled": True, "load_mass": 54 / G},
                          {"theta_motor_ref": ([0, 0.05, 1.05, 1.55, 2.55], [0, 0, 600, 600, 0])},
                          2.8, 1e-3)
    eff = {
        "string_compliance": {"string_compliance.enabled": True},
        "twist_hysteresis": {"twist_hysteresis.enabled": True},
        "motor_friction": {"motor_friction.enabled": True},
        "gear_backlash": {"gear_backlash.enabled": True},
        "radius_growth": {"radius_growth.enabled": True},
    }
    for name, prm in eff.items():
        c[f"effect_{name}"] = (dict(prm, load_mass=39 / G),
                               {"theta_motor_ref": ([0, 0.02, 0.62, 0.82, 1.42], [0, 0, 500, 500, 100])},
                               1.6, 1e-3)
    # gear_backlash load reversals (documentation section 7): with strand friction the torque
    # through the gear reverses while the strings untwist near zero twist (100 -> 10 rad), and
    # again when they are twisted (10 -> 80 rad): each time the motor crosses the gap
    c["backlash_load_reversal"] = (
        {"load_mass": 39 / G, "twist_hysteresis.enabled": True, "gear_backlash.enabled": True},
        {"theta_motor_ref": ([0, 0.02, 0.02, 0.5, 0.5, 1.0, 1.0], [0, 0, 100, 100, 10, 10, 80])},
        1.5, 1e-3)
    # steps through zero twist under 54 N: the strings' torque changes sign with the twist
    c["backlash_through_zero"] = (
        {"load_mass": 54 / G, "gear_backlash.enabled": True},
        {"theta_motor_ref": ([0, 0.02, 0.02, 0.4, 0.4, 0.8, 0.8, 1.2, 1.2],
                             [0, 0, 30, 30, -30, -30, 30, 30, 0])},
        1.6, 1e-3)
    return c


HEADER = ("# Reference trace of the TwistedString FMU, case {name}.\n"
          "# Source: tests/reference/twisted_string_ref.py, an independent Python implementation of the\n"
          "# equations in the FMU documentation (paper: Urukalo, Jovanovic, Rodic, eq. 9-21, Tables 2-5),\n"
          "# integrated with scipy.integrate.solve_ivp(method='Radau', rtol=1e-10, atol=1e-9*nominal),\n"
          "# position loop sampled every controller_position_period (a sample at a communication point\n"
          "# with the inputs set there, outputs before it but at t0), inputs held over each step.\n"
          "# parameters: {params}\n# inputs: {inputs}\n# t_end={t_end} dt={dt}\n")


def write_csv(path, name, prm, inp, t_end, dt, out):
    cols = ["time"] + OUTPUTS
    with open(path, "w") as fh:
        fh.write(HEADER.format(name=name, params=repr(prm), inputs=repr(inp), t_end=t_end, dt=dt))
        fh.write(",".join(cols) + "\n")
        data = np.column_stack([out[c] for c in cols])
        np.savetxt(fh, data, delimiter=",", fmt="%.12g")


def main(argv):
    here = os.path.dirname(os.path.abspath(__file__))
    only = set(argv[1:])
    for name, (prm, inp, t_end, dt) in cases().items():
        if only and name not in only:
            continue
        t0 = time.time()
        out = simulate(prm, inp, t_end, dt)
        write_csv(os.path.join(here, f"twisted_string_{name}.csv"), name, prm, inp, t_end, dt, out)
        print(f"{name}: {time.time() - t0:.1f} s", flush=True)


if __name__ == "__main__":
    main(sys.argv)
