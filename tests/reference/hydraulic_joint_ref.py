"""Independent reference of the HydraulicJoint FMU (SciPy Radau), written from the model
documentation (documentation/index.html of the FMU: equations of the NEUROexos paper, eq. 1-18,
23-26, the textbook effect models and the numerical regularisations stated there).

Semantics reproduced (FMI 2.0 Co-Simulation):
  * inputs are held constant over each communication step [t_k, t_k + dt) at the value they
    have at t_k;
  * the 40 Hz controller samples at t0 + j/f (j integer); a sample falling on the start of a
    communication step uses that step's inputs, one strictly inside a step interrupts the
    integration there; the valve voltages are held between samples;
  * the system starts at rest: theta = 0, pistons mid-stroke, cables at their pretension.

Integration: scipy.integrate.solve_ivp(method="Radau", rtol=1e-10, atol=1e-10 * nominal) on
every piece between communication points and controller samples.

    simulate(params, inputs, t_end, dt) -> dict of output arrays on the communication grid
    python tests/reference/hydraulic_joint_ref.py    # regenerates the reference CSV traces
"""

from __future__ import annotations

import datetime
import math
import os
import sys

import numpy as np
from scipy.integrate import solve_ivp

from model_description import parameter_defaults

HERE = os.path.dirname(os.path.abspath(__file__))

# Parameter defaults: the start values of the FMU's interface (modelDescription/HydraulicJoint.xml).
DEFAULTS = parameter_defaults("HydraulicJoint")

# Numerical constants of the documentation ("Regularisations").
DP_LAMINAR = 1e4  # Pa
W_SLACK = 1e-5  # m
W_DEADBAND = 0.02  # V
K_STOP, C_STOP, W_STOP = 1e8, 5e3, 1e-5
V_STICTION = 1e-4  # m/s
V_CAPSTAN = 1e-3  # m/s
P_ATM = 101325.0
U_SAT = 10.0

OUTPUTS = [
    "theta", "omega", "x_left", "x_right", "v_left", "v_right",
    "p1_left", "p2_left", "p1_right", "p2_right", "F_left", "F_right",
    "T_left", "T_right", "u_valve_left", "u_valve_right", "Q_left", "Q_right",
]
INPUTS = ["theta_ref", "u_left", "u_right", "tau_ext"]


def ramp_c1(d, w):
    """Quadratic-blended ramp max(d, 0): d^2/(2w) on (0, w), d - w/2 beyond."""
    if d <= 0.0:
        return 0.0
    return d * d / (2 * w) if d < w else d - w / 2


def ramp_c1_inv(y, w):
    """Inverse of ramp_c1 for y > 0."""
    return y + w / 2 if y >= w / 2 else math.sqrt(2 * w * y)


def sqrt_flow(dp):
    """sign(dp) sqrt|dp| with the laminar cubic below DP_LAMINAR."""
    if abs(dp) >= DP_LAMINAR:
        return math.copysign(math.sqrt(abs(dp)), dp)
    r = dp / DP_LAMINAR
    return math.sqrt(DP_LAMINAR) * (1.25 * r - 0.25 * r**3)


class Joint:
    """The documented equations, one object per parameter set."""

    def __init__(self, params: dict, extra_joint_friction=None):
        # extra_joint_friction: optional torque law omega -> tau [N.m] opposing the link's
        # rotation (a friction the FMU does not have, for records of a mechanism outside its
        # candidate list: examples/gapgen.py, condition `mismatch`)
        self.extra_fric = extra_joint_friction
        p = dict(DEFAULTS)
        unknown = set(params) - set(p)
        if unknown:
            raise KeyError(f"unknown parameters {sorted(unknown)}")
        p.update(params)
        self.p = p
        c = np.array([p["c1"], p["c2"], p["c3"], p["c4"]]) * p["valve_flow_scale"]
        if p["valve_use_mean"]:
            c[:] = c.mean()
        self.c = c
        self.I = p["link_inertia"] + p["load_mass"] * p["load_radius"] ** 2
        self.x_mid = p["stroke"] / 2
        T0, ks = p["spring_pretension"], p["spring_stiffness"]
        # pre-elongation e0 with ks * ramp_c1(e0) = T0
        self.e0 = ramp_c1_inv(T0 / ks, W_SLACK) if T0 > 0 else 0.0
        extra = p["valve_overlap.width"] if p["valve_overlap.enabled"] else 0.0
        self.band = (p["valve_deadband_low"] - extra, p["valve_deadband_high"] + extra)
        self.spool = bool(p["valve_dynamics.enabled"])
        self.memory = bool(p["seal_friction.enabled"])
        # state: theta, omega, (x, v, P1, P2) left and right, spools (xv, vv) left and right when
        # valve_dynamics, remembered speeds left and right when seal_friction
        nominal = [1, 1, .01, .1, 1e6, 1e6, .01, .1, 1e6, 1e6]
        if self.spool:
            nominal += [1, 1e3, 1, 1e3]
        self.i_mem = len(nominal)
        if self.memory:
            nominal += [.1, .1]
        self.n = len(nominal)
        self.nominal = np.array(nominal, dtype=float)

    # --- pieces of the documentation -----------------------------------------------------
    def opening(self, u):
        lo, hi = self.band
        if u > hi:
            return ramp_c1(u - hi, W_DEADBAND)
        if u < lo:
            return -ramp_c1(lo - u, W_DEADBAND)
        return 0.0

    def mixture(self, pg):
        """Documentation, entrained_air: specific volume v(P) = exp(-P/beta) + x0 (p_atm/p_a)^(1/n)
        of the oil-air mixture and dv/dP (p_a the smoothly positive absolute pressure)."""
        p = self.p
        B = p["bulk_modulus"]
        q = pg + P_ATM
        root = math.sqrt(q * q + (0.1 * P_ATM) ** 2)
        pabs = 0.5 * (q + root)
        dpabs = 0.5 * (1 + q / root)
        n = p["entrained_air.polytropic_index"]
        air = p["entrained_air.fraction"] * (P_ATM / pabs) ** (1 / n)
        oil = math.exp(-pg / B)
        return oil + air, -oil / B - air / (n * pabs) * dpabs

    def beta(self, pg):
        """Effective bulk modulus: beta, or -v/(dv/dP) with entrained air."""
        p = self.p
        if not p["entrained_air.enabled"]:
            return p["bulk_modulus"]
        v, dv = self.mixture(pg)
        return -v / dv

    def density_ratio(self, pg):
        """r(P) = rho(P)/rho(0): exp(P/beta), or v(0)/v(P) with entrained air."""
        p = self.p
        if not p["entrained_air.enabled"]:
            return math.exp(pg / p["bulk_modulus"])
        return self.mixture(0.0)[0] / self.mixture(pg)[0]

    def chamber_flows(self, a, p1, p2):
        """Net flows into cap and rod chambers and the supply flow."""
        Ps, Pr, c = self.p["supply_pressure"], self.p["return_pressure"], self.c
        if a >= 0:
            qa = c[0] * a * sqrt_flow(Ps - p1)  # P -> A
            qb = -c[2] * a * sqrt_flow(p2 - Pr)  # B -> T
            qs = qa
        else:
            qb = c[1] * (-a) * sqrt_flow(Ps - p2)  # P -> B
            qa = -c[3] * (-a) * sqrt_flow(p1 - Pr)  # A -> T
            qs = qb
        if self.p["internal_leakage.enabled"]:
            # out of the cap chamber as ql, into the rod chamber as the same mass: ql r(P1)/r(P2)
            ql = self.p["internal_leakage.coefficient"] * (p1 - p2)
            qa, qb = qa - ql, qb + ql * self.density_ratio(p1) / self.density_ratio(p2)
        return qa, qb, qs

    def seal(self, v, vm):
        """Stribeck seal friction with frictional memory: the Stribeck term sees the remembered
        speed vm (first-order lag of v, documentation 'seal_friction')."""
        p = self.p
        if not p["seal_friction.enabled"]:
            return 0.0
        Fc, Fx = p["seal_friction.coulomb"], p["seal_friction.breakaway_excess"]
        vs, sv = p["seal_friction.stribeck_velocity"], p["seal_friction.viscous"]
        return (Fc + Fx * math.exp(-((vm / vs) ** 2))) * math.tanh(v / V_STICTION) + sv * v

    def stop(self, x, v):
        s = self.p["stroke"]
        f = 0.0
        if x < 0:
            d = -x
            f += max(0.0, K_STOP * ramp_c1(d, W_STOP) - C_STOP * v * min(d / W_STOP, 1.0))
        if x > s:
            d = x - s
            f -= max(0.0, K_STOP * ramp_c1(d, W_STOP) + C_STOP * v * min(d / W_STOP, 1.0))
        return f

    def side(self, y, side, u):
        """Everything about one cylinder. side = +1 left (its pull raises theta), -1 right."""
        p = self.p
        j = 2 if side > 0 else 6
        x, v, p1, p2 = y[j : j + 4]
        th, om = y[0], y[1]
        A1, A2 = p["piston_area"], p["annulus_area"]
        if self.spool:
            xs = y[10] if side > 0 else y[12]
        else:
            xs = u
        a = self.opening(xs)
        qa, qb, qs = self.chamber_flows(a, p1, p2)
        V1 = p["dead_volume_cap"] + A1 * x
        V2 = p["dead_volume_rod"] + A2 * (p["stroke"] - x)
        dp1 = self.beta(p1) / V1 * (qa - A1 * v)
        dp2 = self.beta(p2) / V2 * (qb + A2 * v)
        R = p["pulley_radius"]
        if p["cables_attached"]:
            elong = self.e0 + (x - self.x_mid) - side * R * th
            Tp = p["spring_stiffness"] * ramp_c1(elong, W_SLACK)
            if p["cable_friction.enabled"]:
                mphi = p["cable_friction.mu"] * p["bowden_wrap_angle"]
                Tj = Tp * math.exp(-mphi * math.tanh(side * R * om / V_CAPSTAN))
            else:
                Tj = Tp
        else:
            Tp = Tj = 0.0
        F = p1 * A1 - p2 * A2
        vm = y[self.i_mem + (0 if side > 0 else 1)] if self.memory else v
        acc = (F - Tp - p["piston_damping"] * v - self.seal(v, vm) + self.stop(x, v)) / p["piston_mass"]
        return dict(F=F, Tj=Tj, qs=qs, dx=v, dv=acc, dp1=dp1, dp2=dp2)

    def f(self, t, y, uL, uR, tau):
        p = self.p
        L = self.side(y, +1, uL)
        Rr = self.side(y, -1, uR)
        dy = np.zeros(self.n)
        dy[0] = y[1]
        dy[1] = ((L["Tj"] - Rr["Tj"]) * p["pulley_radius"] - p["link_damping"] * y[1] + tau) / self.I
        if self.extra_fric is not None:
            dy[1] -= self.extra_fric(y[1]) / self.I
        dy[2:6] = L["dx"], L["dv"], L["dp1"], L["dp2"]
        dy[6:10] = Rr["dx"], Rr["dv"], Rr["dp1"], Rr["dp2"]
        if self.memory:
            tau = p["seal_friction.memory_time"]
            dy[self.i_mem] = (y[3] - y[self.i_mem]) / tau
            dy[self.i_mem + 1] = (y[7] - y[self.i_mem + 1]) / tau
        if self.spool:
            wn = p["valve_dynamics.natural_frequency"]
            z = p["valve_dynamics.damping_ratio"]
            for k, u in ((10, uL), (12, uR)):
                dy[k] = y[k + 1]
                dy[k + 1] = wn * wn * (u - y[k]) - 2 * z * wn * y[k + 1]
        return dy

    # --- controller (paper sec. IV) ----------------------------------------------------------
    def voltage(self, speed):
        p = self.p
        s = p["controller_gain"] * speed
        if s > 0:
            y = s / p["controller_slope_extend"]
            u = p["controller_deadband_high"] + ramp_c1_inv(y, W_DEADBAND)
        elif s < 0:
            y = -s / p["controller_slope_retract"]
            u = p["controller_deadband_low"] - ramp_c1_inv(y, W_DEADBAND)
        else:
            u = 0.0
        return min(U_SAT, max(-U_SAT, u))

    def control(self, theta_ref, y):
        """Eq. (23)-(24) plus the co-contraction loop: both pistons also get the common speed
        -K_c f m, m = (x_L + x_R)/2 - x_mid (see the model documentation)."""
        p = self.p
        f = p["controller_rate"]
        xd = (theta_ref - y[0]) * f * p["pulley_radius"]
        m = 0.5 * (y[2] + y[6]) - self.x_mid
        xc = -p["controller_cocontraction"] * f * m
        return self.voltage(xd + xc), self.voltage(-xd + xc)

    # --- rest state -----------------------------------------------------------------------------
    def rest(self, uL, uR):
        p = self.p
        T0 = p["spring_pretension"] if p["cables_attached"] else 0.0
        A1, A2 = p["piston_area"], p["annulus_area"]
        if p["internal_leakage.enabled"]:
            p1 = p2 = T0 / (A1 - A2)
        else:
            p2 = 0.5 * (p["supply_pressure"] + p["return_pressure"])
            p1 = (T0 + p2 * A2) / A1
        y = np.zeros(self.n)
        y[2], y[4], y[5] = self.x_mid, p1, p2
        y[6], y[8], y[9] = self.x_mid, p1, p2
        if self.spool:
            y[10], y[12] = uL, uR
        return y

    def outputs(self, y, uL, uR):
        L = self.side(y, +1, uL)
        Rr = self.side(y, -1, uR)
        return {
            "theta": y[0], "omega": y[1], "x_left": y[2], "x_right": y[6],
            "v_left": y[3], "v_right": y[7], "p1_left": y[4], "p2_left": y[5],
            "p1_right": y[8], "p2_right": y[9], "F_left": L["F"], "F_right": Rr["F"],
            "T_left": L["Tj"], "T_right": Rr["Tj"], "u_valve_left": uL, "u_valve_right": uR,
            "Q_left": L["qs"], "Q_right": Rr["qs"],
        }


def _input_at(inputs, name, t):
    if name not in inputs:
        return 0.0
    times, values = inputs[name]
    return float(np.interp(t, times, values))


def simulate(params: dict, inputs: dict, t_end: float, dt: float, rtol=1e-10, atol=1e-10,
             extra_joint_friction=None):
    """Outputs (dict name -> array) at t = 0, dt, ..., t_end. `inputs`: name -> (times, values),
    linearly interpolated and sampled at the start of each communication step.
    extra_joint_friction: see Joint (None: the documented model)."""
    m = Joint(params, extra_joint_friction)
    p = m.p
    n_steps = int(round(t_end / dt))
    internal = bool(p["internal_controller"])
    Ts = 1.0 / p["controller_rate"]
    tol = 1e-9 * Ts
    t0 = 0.0

    def sat(u):
        return min(U_SAT, max(-U_SAT, u))

    if internal:
        # at rest: theta = 0 and the pistons mid-stroke (no co-contraction correction)
        y = m.rest(0.0, 0.0)
        uL, uR = m.control(_input_at(inputs, "theta_ref", t0), y)
    else:
        uL, uR = sat(_input_at(inputs, "u_left", t0)), sat(_input_at(inputs, "u_right", t0))
    y = m.rest(uL, uR)
    rows = [m.outputs(y, uL, uR)]
    at = atol * m.nominal
    j = 0  # next controller sample index

    def advance(ta, tb, y, uL, uR, tau):
        if tb <= ta:
            return y
        sol = solve_ivp(m.f, (ta, tb), y, method="Radau", rtol=rtol, atol=at, args=(uL, uR, tau))
        if not sol.success:
            raise RuntimeError(sol.message)
        return sol.y[:, -1]

    for k in range(n_steps):
        t = k * dt
        te = (k + 1) * dt
        tau = _input_at(inputs, "tau_ext", t)
        if internal:
            ref = _input_at(inputs, "theta_ref", t)
            while t0 + j * Ts <= t + tol:
                uL, uR = m.control(ref, y)
                j += 1
            tc = t
            while t0 + j * Ts < te - tol:
                ts = t0 + j * Ts
                y = advance(tc, ts, y, uL, uR, tau)
                uL, uR = m.control(ref, y)
                j += 1
                tc = ts
            y = advance(tc, te, y, uL, uR, tau)
        else:
            uL, uR = sat(_input_at(inputs, "u_left", t)), sat(_input_at(inputs, "u_right", t))
            y = advance(t, te, y, uL, uR, tau)
        rows.append(m.outputs(y, uL, uR))
    out = {"time": np.arange(n_steps + 1) * dt}
    for name in OUTPUTS:
        out[name] = np.array([r[name] for r in rows])
    return out


# ---- reference scenarios ----------------------------------------------------------------------


def min_jerk(t, amplitude=math.radians(45.0), duration=1.0):
    """Minimum-jerk move 0 -> amplitude in `duration`, then hold (Flash & Hogan 1985)."""
    s = np.clip(np.asarray(t) / duration, 0.0, 1.0)
    return amplitude * (10 * s**3 - 15 * s**4 + 6 * s**5)


def scenarios():
    """name -> (params, inputs on the communication grid, t_end, dt)."""
    sc = {}
    # open loop, cables attached: voltage steps on both valves
    dt, T = 1e-3, 1.0
    t = np.arange(0, T + dt / 2, dt)
    uL = np.select([t < 0.1, t < 0.4, t < 0.7], [0.0, 3.0, -4.0], 1.0)
    uR = np.select([t < 0.1, t < 0.4, t < 0.7], [0.0, -3.0, 4.0], 0.0)
    sc["open_loop_steps"] = (
        {"internal_controller": False},
        {"u_left": (t, uL), "u_right": (t, uR)},
        T, dt,
    )
    # Fig. 6 bench: one free piston, steps of +-6 V
    t = np.arange(0, 0.6 + dt / 2, dt)
    u = np.select([t < 0.05, t < 0.25, t < 0.3, t < 0.5], [0.0, 6.0, 0.0, -6.0], 0.0)
    sc["bench_steps"] = (
        {"internal_controller": False, "cables_attached": False},
        {"u_left": (t, u)},
        0.6, dt,
    )
    # closed loop catching reach
    dt, T = 5e-3, 1.5
    t = np.arange(0, T + dt / 2, dt)
    sc["catching"] = ({}, {"theta_ref": (t, min_jerk(t))}, T, dt)
    # sustained sinusoidal tracking: the co-contraction loop holds the pretension
    t = np.arange(0, 3.0 + dt / 2, dt)
    sc["sustained_tracking"] = ({}, {"theta_ref": (t, 0.5 * np.sin(2 * np.pi * 0.7 * t))}, 3.0, dt)
    # external torque disturbance at rest, controller holding 0
    t = np.arange(0, 1.0 + dt / 2, dt)
    tau = np.where((t >= 0.2) & (t < 0.6), 3.0, 0.0)
    sc["torque_disturbance"] = ({}, {"tau_ext": (t, tau)}, 1.0, dt)
    # one per effect, on the catching reach
    t = np.arange(0, 1.2 + dt / 2, dt)
    for eff in ["seal_friction", "valve_overlap", "internal_leakage", "cable_friction",
                "entrained_air", "valve_dynamics"]:
        sc[f"effect_{eff}"] = ({f"{eff}.enabled": True}, {"theta_ref": (t, min_jerk(t))}, 1.2, dt)
    return sc


def write_csv(path, out, inputs, params, source_note):
    names = ["time"] + list(inputs) + OUTPUTS
    cols = [out["time"]] + [np.interp(out["time"], *inputs[k]) for k in inputs] + [out[k] for k in OUTPUTS]
    with open(path, "w") as fh:
        fh.write(f"# {source_note}\n")
        fh.write(f"# parameters: {params}\n")
        fh.write(",".join(names) + "\n")
        for row in zip(*cols):
            fh.write(",".join(repr(float(v)) for v in row) + "\n")


def main(argv):
    only = set(argv[1:])
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
    for name, (params, inputs, T, dt) in scenarios().items():
        if only and name not in only:
            continue
        out = simulate(params, inputs, T, dt)
        note = (f"HydraulicJoint reference '{name}': tests/reference/hydraulic_joint_ref.py, SciPy "
                f"solve_ivp Radau rtol=1e-10 atol=1e-10*nominal, dt={dt}, generated {date}")
        path = os.path.join(HERE, f"hydraulic_joint_{name}.csv")
        write_csv(path, out, inputs, params, note)
        print("wrote", path, flush=True)


if __name__ == "__main__":
    main(sys.argv)
