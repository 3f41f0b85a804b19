"""Independent reference of the EMPS FMU (ball-screw positioning axis of the Nonlinear System
Identification Benchmarks, Janot, Gautier, Brunot, "Data Set and Reference Models of EMPS", 2019).

The equations are written again from the benchmark description (eqs. 1, 6, 7, 12 and sec. 2.2) and
the FMU's documentation; they are not a transliteration of the Rust code.

    plant      M q'' = F - Fv q' - Fc sign(q') - offset                      (description eq. 1, 3)
               asymmetric friction: Fv, Fc of the direction of q'           (eq. 12)
    controller qfm(k) = (qm(k) + qm(k-1)) / 2, v(k) = (qfm(k) - qfm(k-1)) / Ts
               nu(k) = kv (kp (qg(k) - qm(k)) - v(k))                        (eq. 6, sec. 2.2)
               u(k) = sat(nu(k) + F_pulse(k) / gtau, +-10 V), F = gtau u     (eq. 7)
               held over [t_k + d, t_k+1 + d) (d: controller delay, 0 as logged)

Coulomb friction, two ways (`friction=`):
  "exact"   event-exact sign with sticking: over each interval where the force is constant the
            rigid plant is linear between velocity reversals and is solved in closed form
            (v = v_inf + (v0 - v_inf) exp(-Fv t / M)); at v = 0 the axis sticks while
            |F - offset| <= Fc of the direction it would move in. No integrator involved.
  "smooth"  sign(v) replaced by tanh(v / v_s), as the FMU does (v_s its parameter
            friction_smoothing_velocity), integrated with SciPy's odeint (LSODA, rtol 1e-11,
            atol 1e-14) between the force changes; also the effects the closed form does not cover (friction along the
            screw, the two-mass flexibility and backlash).
The FMU's smoothing is checked against "smooth" at solver accuracy and "smooth" against "exact"
for the effect of the smoothing itself (tests/test_emps.py).

Outputs per sample k, in the FMU's Co-Simulation stamping (scripts/emps_csv.py --stamp held):
qm(t_k), and the force and velocity held over [t_k-1, t_k) (sample 0's at row 0).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.io
from scipy.integrate import odeint

TS = 1e-3
V_SAT = 10.0
GTAU = 35.15065188248547   # N/V, DATA_EMPS.mat `gtau`
KP = 160.18                # 1/s
KV = 243.45                # V/(m/s)

# IDIM-LS on DATA_EMPS (description sec. 3.4 and 4.2).
PUBLISHED_SYMMETRIC = {"mass": 95.1089, "viscous_friction": 203.5034, "coulomb": 20.3935,
                       "offset": -3.1648}
PUBLISHED_ASYMMETRIC = {"mass": 95.1540, "viscous_friction": 166.7061, "coulomb": 20.1440,
                        "viscous_negative": 240.4236, "coulomb_negative": 20.6277, "offset": 0.0}


@dataclass
class Params:
    """Plant and controller parameters (SI). Effects are off when their field is None."""
    mass: float = 95.1089
    viscous_friction: float = 203.5034
    offset: float = 0.0
    coulomb: float | None = None            # Fc (q' > 0 with asymmetric friction)
    viscous_negative: float | None = None   # asymmetric friction: Fv for q' < 0
    coulomb_negative: float | None = None   # asymmetric friction: Fc for q' < 0
    delay: float = 0.0                      # controller delay d [s], 0 <= d <= 2 Ts
    friction_gradient: float | None = None  # friction along the screw: factor 1 + g (q - q_mid)
    travel_mid: float = 0.125
    load_mass: float = 5.0                  # two-mass: load side; motor side M - load_mass
    stiffness: float | None = None          # flexibility: screw/nut/bearing stiffness [N/m]
    damping_ratio: float = 0.05
    backlash: float | None = None           # total gap [m]
    contact_stiffness: float = 1e8          # backlash without flexibility
    contact_damping_ratio: float = 0.1
    smoothing: float = 1e-4                 # v_s of tanh(v / v_s) [m/s] ("smooth" only)
    kp: float = KP
    kv: float = KV
    gtau: float = GTAU
    v_sat: float = V_SAT
    extra: dict = field(default_factory=dict)

    def friction_coefficients(self, direction: float) -> tuple[float, float]:
        """(Fv, Fc) of motion in `direction` (+1 or -1)."""
        fc = self.coulomb or 0.0
        fv = self.viscous_friction
        if direction < 0 and self.viscous_negative is not None:
            fv = self.viscous_negative
        if direction < 0 and self.coulomb_negative is not None:
            fc = self.coulomb_negative
        return fv, fc


def load_record(path) -> dict:
    """t, qg, qm, vir (float arrays), pulses_N (float, zeros when absent) of one .mat file."""
    mat = scipy.io.loadmat(path)
    rec = {k: np.asarray(mat[k], dtype=float).ravel() for k in ("t", "qg", "qm", "vir")}
    rec["pulses_N"] = np.asarray(mat.get("pulses_N", np.zeros_like(rec["t"])), float).ravel()
    return rec


def logged_controller(qg, qm, pulses=None, pulse_gain=0.0, kp=KP, kv=KV, v_sat=V_SAT):
    """vir(k) the logged law gives from the logged qg, qm (samples 0 and 1: NaN, no history)."""
    qm = np.asarray(qm, float)
    v = np.full_like(qm, np.nan)
    v[2:] = (qm[2:] - qm[:-2]) / (2.0 * TS)
    nu = kv * (kp * (np.asarray(qg, float) - qm) - v)
    if pulses is not None:
        nu = nu + pulse_gain * np.asarray(pulses, float)
    return np.clip(nu, -v_sat, v_sat)


# ---- plant: exact Coulomb friction, closed form ---------------------------------------------

def _moving(q, v, f_net, fv, fc, s, m, dt):
    """Advance q, v by dt moving in direction s (Fc acts as -s Fc) with constant net force f_net.
    Returns (q, v, t_used); stops early (t_used < dt) where v reaches 0."""
    tau = m / fv
    v_inf = (f_net - s * fc) / fv
    if s * v_inf < 0.0:  # decelerating towards 0: time of the reversal
        t_zero = tau * math.log((v - v_inf) / (0.0 - v_inf))
        if t_zero < dt:
            q += v_inf * t_zero + (v - v_inf) * tau * (1.0 - math.exp(-t_zero / tau))
            return q, 0.0, t_zero
    e = math.exp(-dt / tau)
    return q + v_inf * dt + (v - v_inf) * tau * (1.0 - e), v_inf + (v - v_inf) * e, dt


def advance_exact(q, v, force, p: Params, dt):
    """Rigid plant over dt under a constant force, event-exact Coulomb friction with sticking."""
    f_net = force - p.offset
    left = dt
    for _ in range(8):  # at most a few reversals in one interval
        if left <= 0.0:
            break
        if v == 0.0:
            s = 1.0 if f_net > 0 else -1.0
            fv, fc = p.friction_coefficients(s)
            if abs(f_net) <= fc:
                return q, 0.0  # sticks for the rest of the interval
        else:
            s = 1.0 if v > 0 else -1.0
            fv, fc = p.friction_coefficients(s)
        q, v, used = _moving(q, v, f_net, fv, fc, s, p.mass, left)
        left -= used
    return q, v


# ---- plant: smooth sign, LSODA --------------------------------------------------------------

def _friction(q, v, p: Params):
    s = 1.0 if v >= 0 else -1.0
    fv, fc = p.friction_coefficients(s)
    f = fv * v + fc * math.tanh(v / p.smoothing)
    if p.friction_gradient is not None:
        f *= 1.0 + p.friction_gradient * (q - p.travel_mid)
    return f


def _two_mass(p: Params) -> bool:
    return p.stiffness is not None or p.backlash is not None


def _coupling(dq, dv, p: Params):
    """Force of the screw on the load: k dz(dq) + c dv in contact (dz: dead zone of the gap)."""
    k = p.stiffness if p.stiffness is not None else p.contact_stiffness
    zeta = p.damping_ratio if p.stiffness is not None else p.contact_damping_ratio
    mm = p.mass - p.load_mass
    c = 2.0 * zeta * math.sqrt(k * mm * p.load_mass / p.mass)
    half = 0.5 * (p.backlash or 0.0)
    if abs(dq) <= half:
        return 0.0
    return k * (dq - math.copysign(half, dq)) + c * dv


def rhs_smooth(y, force, p: Params):
    q, v = y[0], y[1]
    base = force - p.offset - _friction(q, v, p)
    if not _two_mass(p):
        return [v, base / p.mass]
    ql, vl = y[2], y[3]
    fc = _coupling(q - ql, v - vl, p)
    return [v, (base - fc) / (p.mass - p.load_mass), vl, fc / p.load_mass]


def advance_smooth(y, force, p: Params, dt):
    """Integrate over dt under a constant force (LSODA switches to BDF where tanh is stiff)."""
    sol, info = odeint(lambda x, t: rhs_smooth(x, force, p), y, [0.0, dt], rtol=1e-11,
                       atol=1e-14, mxstep=100000, full_output=True)
    if info["message"] != "Integration successful.":
        raise RuntimeError(info["message"])
    return sol[-1]


# ---- closed loop ----------------------------------------------------------------------------

def simulate(qg, params: Params, force_pulse=None, q0=0.0, v0=0.0, friction="exact",
             open_loop_force=None):
    """Closed loop over len(qg) samples (1 kHz) from q = q0, q' = v0 (the controller's position
    history q0 - v0 Ts, q0 - 2 v0 Ts, the load at rest relative to the motor). Returns a dict of
    per-row arrays qm, force, velocity (held stamping), and force_sample, velocity_sample (the
    values of sample k), q_load."""
    p = params
    n = len(qg)
    pulse = np.zeros(n) if force_pulse is None else np.asarray(force_pulse, float)
    y = np.array([q0, v0, q0, v0] if _two_mass(p) else [q0, v0], float)
    hist = [q0 - 2 * v0 * TS, q0 - v0 * TS]
    out = {k: np.empty(n) for k in ("qm", "force_sample", "velocity_sample", "q_load")}
    pending = []  # (time it takes effect, force)
    applied = None
    d = p.delay
    for k in range(n):
        t = k * TS
        qm = y[0]
        v_est = (qm - hist[0]) / (2.0 * TS)
        hist = [hist[1], qm]
        nu = p.kv * (p.kp * (qg[k] - qm) - v_est)
        u = min(max(nu + pulse[k] / p.gtau, -p.v_sat), p.v_sat)
        f = p.gtau * u if open_loop_force is None else open_loop_force[k]
        if applied is None:
            applied = f  # before the first delayed output: as if the loop had held it
        out["qm"][k], out["force_sample"][k], out["velocity_sample"][k] = qm, f, v_est
        out["q_load"][k] = y[2] if len(y) > 2 else qm
        pending.append((t + d, f))
        y, applied, pending = _interval(y, t, applied, pending, p, friction)
    out["force"] = _held(out["force_sample"]) if d == 0 else _applied_at_rows(out, d)
    out["velocity"] = _held(out["velocity_sample"])
    return out


def _interval(y, t, applied, pending, p, friction):
    """Integrate [t, t + Ts], switching the applied force at the pending instants inside it."""
    t_end = t + TS
    tc = t
    while True:
        while pending and pending[0][0] <= tc + 1e-12:
            applied = pending.pop(0)[1]
        t_next = min(t_end, pending[0][0]) if pending else t_end
        if t_next > tc:
            if friction == "exact":
                q, v = advance_exact(y[0], y[1], applied, p, t_next - tc)
                y = np.array([q, v])
            else:
                y = advance_smooth(y, applied, p, t_next - tc)
        tc = t_next
        if tc >= t_end - 1e-12:
            return y, applied, pending


def _held(x):
    return np.concatenate([x[:1], x[:-1]])


def _applied_at_rows(out, d):
    """The force acting just before each row time with the outputs delayed by d."""
    f = out["force_sample"]
    n = f.size
    rows = np.empty(n)
    for k in range(n):
        j = math.floor((k * TS - d) / TS - 1e-9)  # last sample whose output acts before t_k
        rows[k] = f[min(max(j, 0), n - 1)]
    rows[0] = f[0]
    return rows


def relative_error(measured, simulated):
    """100 ||y - y_hat|| / ||y|| (description eq. 11)."""
    measured = np.asarray(measured, float)
    return 100.0 * np.linalg.norm(measured - simulated) / np.linalg.norm(measured)


if __name__ == "__main__":
    import sys
    import time
    path = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/emps/DATA_EMPS.mat"
    rec = load_record(path)
    vir = logged_controller(rec["qg"], rec["qm"])
    print("controller RMS", np.sqrt(np.nanmean((vir - rec["vir"]) ** 2)))
    v0 = KP * (rec["qg"][0] - rec["qm"][0]) - rec["vir"][0] / KV
    p = Params(coulomb=20.3935, offset=-3.1648)
    for fr in ("exact", "smooth"):
        t0 = time.time()
        out = simulate(rec["qg"], p, q0=rec["qm"][0], v0=v0, friction=fr)
        meas = GTAU * rec["vir"]
        print(fr, f"{time.time() - t0:.1f} s", "force rel err (sample stamping)",
              relative_error(meas, out["force_sample"]),
              "position rel err", relative_error(rec["qm"], out["qm"]))
