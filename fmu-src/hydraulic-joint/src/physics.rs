//! Pure physics of the hydraulic joint: each function is one documented equation, SI units.
//!
//! Paper: "Description, Characterization and Assessment of a Bio-Inspired Shoulder Joint-First
//! Link Robot for Neuro-Robotic Applications" (NEUROexos), equations (1)-(18). Textbooks:
//! H. E. Merritt, *Hydraulic Control Systems* (1967), and N. D. Manring, *Hydraulic Control
//! Systems* (2005). Pressures are gauge pressures [Pa] unless stated otherwise.

/// C1-smooth positive part with a quadratic blend of width `w` > 0:
/// `0` for `d <= 0`, `d^2/(2w)` for `0 < d < w`, `d - w/2` for `d >= w`.
/// Used for cable slack, end-stop penetration and the valve dead band so that the
/// error-controlled solver sees a continuous derivative (no step-size collapse at the kink).
pub fn smooth_pos(d: f64, w: f64) -> f64 {
    if d <= 0.0 {
        0.0
    } else if d < w {
        d * d / (2.0 * w)
    } else {
        d - 0.5 * w
    }
}

/// Derivative of [`smooth_pos`] with respect to `d`: `0`, `d/w`, `1`.
pub fn smooth_pos_slope(d: f64, w: f64) -> f64 {
    if d <= 0.0 {
        0.0
    } else if d < w {
        d / w
    } else {
        1.0
    }
}

/// Signed square root with a laminar regularisation below `p_tr` [Pa]:
/// `sign(dp) sqrt(|dp|)` for `|dp| >= p_tr` (turbulent orifice, Merritt eq. 2-8), and the odd
/// cubic `sqrt(p_tr) (5/4 r - 1/4 r^3)`, `r = dp/p_tr`, inside, which matches value and slope at
/// `|dp| = p_tr` and has the finite slope `5/(4 sqrt(p_tr))` at zero (laminar flow near zero
/// pressure drop; avoids the infinite Jacobian of `sqrt` at 0).
pub fn signed_sqrt_reg(dp: f64, p_tr: f64) -> f64 {
    let a = dp.abs();
    if a >= p_tr {
        dp.signum() * a.sqrt()
    } else {
        let r = dp / p_tr;
        p_tr.sqrt() * (1.25 * r - 0.25 * r * r * r)
    }
}

/// Derivative of [`signed_sqrt_reg`] with respect to `dp`: `1/(2 sqrt|dp|)` outside,
/// `(5/4 - 3/4 r^2)/sqrt(p_tr)` inside.
pub fn signed_sqrt_reg_slope(dp: f64, p_tr: f64) -> f64 {
    let a = dp.abs();
    if a >= p_tr {
        0.5 / a.sqrt()
    } else {
        let r = dp / p_tr;
        (1.25 - 0.75 * r * r) / p_tr.sqrt()
    }
}

/// Central difference `(f(x + h) - f(x - h)) / 2h` with `h = 1e-6 max(|x|, scale)`: the slope of
/// a smooth scalar law for the analytic Jacobian's chain rule.
pub fn central_slope(f: impl Fn(f64) -> f64, x: f64, scale: f64) -> f64 {
    let h = 1e-6 * x.abs().max(scale);
    (f(x + h) - f(x - h)) / (2.0 * h)
}

/// Orifice flow, paper eq. (13)-(16) with the opening as a magnitude:
/// `Q = c * a * ssqrt(dp)` [m3/s], `c` [m3 s^-1 V^-1 Pa^-1/2] (Table I), `a >= 0` [V] the
/// effective spool opening, `dp` [Pa] the pressure drop in the flow direction.
pub fn orifice_flow(c: f64, a: f64, dp: f64, p_tr: f64) -> f64 {
    c * a * signed_sqrt_reg(dp, p_tr)
}

/// Flows of the three-land four-way valve, paper eq. (7)-(16) read with physically consistent
/// signs: for `u >= 0` orifice 1 (P->A) feeds chamber 1 and orifice 3 (B->T) drains chamber 2;
/// for `u < 0` orifice 2 (P->B) feeds chamber 2 and orifice 4 (A->T) drains chamber 1
/// (the paper's eq. 15-16 carry `-c u` with `u < 0`, which would reverse the drains; we use `|u|`).
/// Returns `(q1, q2, q_supply)`: net flow into chamber 1, into chamber 2 [m3/s] and the flow
/// drawn from the supply port.
pub fn valve_flows(
    u_eff: f64,
    p1: f64,
    p2: f64,
    ps: f64,
    pr: f64,
    c: &[f64; 4],
    p_tr: f64,
) -> (f64, f64, f64) {
    if u_eff >= 0.0 {
        let q_in = orifice_flow(c[0], u_eff, ps - p1, p_tr);
        let q_out = orifice_flow(c[2], u_eff, p2 - pr, p_tr);
        (q_in, -q_out, q_in)
    } else {
        let a = -u_eff;
        let q_in = orifice_flow(c[1], a, ps - p2, p_tr);
        let q_out = orifice_flow(c[3], a, p1 - pr, p_tr);
        (-q_out, q_in, q_in)
    }
}

/// Chamber volumes, paper eq. (11)-(12): `V1 = V1^0 + x A1`, `V2 = V2^0 + (s - x) A2` [m3].
pub fn chamber_volumes(x: f64, s: f64, a1: f64, a2: f64, v10: f64, v20: f64) -> (f64, f64) {
    (v10 + x * a1, v20 + (s - x) * a2)
}

/// Continuity equation of a chamber, paper eq. (7)-(10): `dP/dt = beta/V (Q - dV/dt)` [Pa/s].
pub fn pressure_rate(beta: f64, v: f64, v_dot: f64, q: f64) -> f64 {
    beta / v * (q - v_dot)
}

/// Piston force, paper eq. (2)-(3) and (6): `F = P1 A1 - P2 A2` [N], positive extending.
pub fn piston_force(p1: f64, p2: f64, a1: f64, a2: f64) -> f64 {
    p1 * a1 - p2 * a2
}

/// Seal friction `g(v)` of paper eq. (6) as a Stribeck curve with frictional memory
/// (Armstrong-Helouvry, Dupont, Canudas de Wit 1994, the "seven-parameter" model; Hess & Soom
/// 1990): `g = (Fc + Fex exp(-(v_m/vs)^2)) tanh(v/v_eps) + sigma v` [N] with Coulomb force `Fc`,
/// breakaway excess `Fex = Fs - Fc`, Stribeck speed `vs`, viscous coefficient `sigma`; `v_m` is
/// the velocity as the contact "remembers" it (see [`friction_memory_rate`]; `v_m = v` in steady
/// sliding gives the static Stribeck curve); `tanh(v/v_eps)` is the smooth sign (stiction
/// regularisation: below the breakaway force the seal creeps at `v_eps atanh(F/Fs)`).
/// Returns `(g, dg/dv, dg/dv_m)`.
pub fn seal_friction(
    v: f64,
    v_m: f64,
    fc: f64,
    fex: f64,
    vs: f64,
    sigma: f64,
    v_eps: f64,
) -> (f64, f64, f64) {
    let r = v_m / vs;
    let e = ode::math::exp(-r * r);
    let level = fc + fex * e;
    let th = ode::math::tanh(v / v_eps);
    (
        level * th + sigma * v,
        level * (1.0 - th * th) / v_eps + sigma,
        -2.0 * fex * e * r / vs * th,
    )
}

/// Frictional memory: the Stribeck part of the friction follows the sliding velocity with a
/// lag `tau` [s] (Hess & Soom 1990 measured lags of milliseconds in lubricated contacts; the
/// seven-parameter model of Armstrong-Helouvry et al. 1994 uses `v(t - tau_L)`; a first-order
/// lag is its smooth stand-in): `dv_m/dt = (v - v_m)/tau` [m/s2].
pub fn friction_memory_rate(v: f64, v_m: f64, tau: f64) -> f64 {
    (v - v_m) / tau
}

/// Cable tension through the series spring with slack, the cable cannot push:
/// `T = k smooth_pos(e, w)` [N], `e` the spring elongation [m], `w` a tiny blend width.
pub fn cable_tension(e: f64, k: f64, w: f64) -> f64 {
    k * smooth_pos(e, w)
}

/// End-stop contact force on a piston with stops at `x = 0` and `x = s` [N], positive pushing
/// toward +x: a stiff penalty spring `k smooth_pos(d, w)` on the penetration `d` plus a damper
/// `c v_pen min(d/w, 1)` that fades in over the blend width; the total never pulls (clamped at 0).
pub fn end_stop_force(x: f64, v: f64, s: f64, k: f64, c: f64, w: f64) -> f64 {
    let d_lo = -x;
    let d_hi = x - s;
    let mut f = 0.0;
    if d_lo > 0.0 {
        let push = k * smooth_pos(d_lo, w) - c * v * (d_lo / w).min(1.0);
        f += push.max(0.0);
    }
    if d_hi > 0.0 {
        let push = k * smooth_pos(d_hi, w) + c * v * (d_hi / w).min(1.0);
        f -= push.max(0.0);
    }
    f
}

/// Valve command dead band around null (measured, paper Fig. 6: no motion for `lo < u < hi`):
/// effective spool opening `u_eff = smooth_pos(u - hi, w)` above the band,
/// `-smooth_pos(lo - u, w)` below, exactly 0 inside [V].
pub fn dead_band(u: f64, lo: f64, hi: f64, w: f64) -> f64 {
    if u > hi {
        smooth_pos(u - hi, w)
    } else if u < lo {
        -smooth_pos(lo - u, w)
    } else {
        0.0
    }
}

/// Derivative of [`dead_band`] with respect to `u`.
pub fn dead_band_slope(u: f64, lo: f64, hi: f64, w: f64) -> f64 {
    if u > hi {
        smooth_pos_slope(u - hi, w)
    } else if u < lo {
        smooth_pos_slope(lo - u, w)
    } else {
        0.0
    }
}

/// Inverse of [`dead_band`] for a desired effective opening `y` [V] (the dead-band
/// compensation of the paper's `f`, eq. 25-26): `0` for `y = 0`, else the command on the
/// matching side: `hi + w/2 + y` (or `hi + sqrt(2 w y)` inside the blend), mirrored below.
pub fn dead_band_inverse(y: f64, lo: f64, hi: f64, w: f64) -> f64 {
    let inv = |y: f64| {
        if y >= 0.5 * w {
            y + 0.5 * w
        } else {
            (2.0 * w * y).sqrt()
        }
    };
    if y > 0.0 {
        hi + inv(y)
    } else if y < 0.0 {
        lo - inv(-y)
    } else {
        0.0
    }
}

/// Spool dynamics, paper eq. (18): `xv'' + 2 zeta omega xv' + omega^2 xv = omega^2 u`;
/// returns `xv''` [V/s2] (spool position expressed in volts of command).
pub fn spool_accel(xv: f64, vv: f64, u: f64, omega: f64, zeta: f64) -> f64 {
    omega * omega * (u - xv) - 2.0 * zeta * omega * vv
}

/// Capstan (Euler-Eytelwein) friction of the Bowden cable: tension at the joint end
/// `T_j = T_p exp(-mu phi tanh(v_slide/v_eps))` [N] from the tension `T_p` at the piston end,
/// `v_slide` the core speed toward the piston [m/s] (piston pulling: the joint end sees less;
/// joint pulling: the piston end sees less). `mu phi` is friction coefficient (`cable_friction.mu`) times total wrap
/// angle (`bowden_wrap_angle`; only the product is identifiable from data) (Kaneko et al.,
/// IEEE TRA 1991; Agrawal et al. 2010).
pub fn capstan_joint_tension(t_piston: f64, mu_phi: f64, v_slide: f64, v_eps: f64) -> f64 {
    t_piston * ode::math::exp(-mu_phi * ode::math::tanh(v_slide / v_eps))
}

/// Compressibility of the oil in a chamber at gauge pressure `p` [Pa]: effective bulk modulus
/// `beta_e` [Pa], its slope `d beta_e / dp` [1] and the density ratio `r = rho(p)/rho(0)` [1]
/// (oil mass per chamber volume relative to 0 gauge), with `d r / dp = r / beta_e`, i.e.
/// `beta_e = rho dp/drho` (definition of the bulk modulus, Merritt eq. 2-3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OilState {
    pub beta: f64,
    pub dbeta: f64,
    pub r: f64,
}

/// Pure oil of constant bulk modulus `beta`: `beta_e = beta`, `r = exp(p/beta)` (the exact
/// solution of `dr/r = dp/beta`).
pub fn oil_state(p: f64, beta: f64) -> OilState {
    OilState {
        beta,
        dbeta: 0.0,
        r: ode::math::exp(p / beta),
    }
}

/// Specific volume of oil with entrained air and its first two derivatives with respect to the
/// gauge pressure `p` [Pa], per unit volume of gas-free oil at 0 gauge:
/// `v(p) = exp(-p/beta) + x0 (p_atm/p_a)^(1/kappa)`: the oil compressed with bulk modulus `beta`
/// plus the air, a polytropic gas (index `kappa`) whose volume is `x0` times the oil's at
/// atmospheric pressure (Merritt sec. 2.6; Manring sec. 1.4). `p_a` is the absolute pressure
/// kept positive by the smooth max `p_a = 0.5 (q + sqrt(q^2 + eps^2))`, `q = p + p_atm`,
/// `eps = 0.1 p_atm` (the gas cannot expand without bound under vacuum).
pub fn mixture_volume(p: f64, beta: f64, x0: f64, p_atm: f64, kappa: f64) -> [f64; 3] {
    let eps = 0.1 * p_atm;
    let q = p + p_atm;
    let s = (q * q + eps * eps).sqrt();
    let pa = 0.5 * (q + s);
    let pa1 = 0.5 * (1.0 + q / s);
    let pa2 = 0.5 * eps * eps / (s * s * s);
    let e = ode::math::exp(-p / beta);
    let n = 1.0 / kappa;
    let x = x0 * ode::math::pow(p_atm / pa, n);
    // d/dp of x(pa(p)) = -n x / pa * pa1
    let x1 = -n * x / pa * pa1;
    let x2 = n * (n + 1.0) * x / (pa * pa) * pa1 * pa1 - n * x / pa * pa2;
    [e + x, -e / beta + x1, e / (beta * beta) + x2]
}

/// Oil with entrained air: from [`mixture_volume`] `v`, `beta_e = -v/v'`,
/// `d beta_e/dp = -1 + v v''/v'^2`, `r = v(0)/v(p)` (mass conservation of the mixture).
/// For `x0 = 0` this is [`oil_state`]. Merritt's and Manring's
/// `beta_e = beta (1 + X)/(1 + X beta/(kappa p_a))`, `X = x0 (p_atm/p_a)^(1/kappa)`, is the same law
/// with the oil's own compression neglected in `X` (they differ by `p/beta` < 2 % relative in
/// `X`); the exact form is used because it has the closed-form density ratio the oil balance needs.
pub fn air_oil_state(p: f64, beta: f64, x0: f64, p_atm: f64, kappa: f64, v_ref: f64) -> OilState {
    let [v, v1, v2] = mixture_volume(p, beta, x0, p_atm, kappa);
    OilState {
        beta: -v / v1,
        dbeta: -1.0 + v * v2 / (v1 * v1),
        r: v_ref / v,
    }
}

/// Effective bulk modulus of oil with entrained air [Pa] (see [`air_oil_state`]).
pub fn effective_bulk_modulus(beta: f64, p_gauge: f64, x0: f64, p_atm: f64, kappa: f64) -> f64 {
    let [v, v1, _] = mixture_volume(p_gauge, beta, x0, p_atm, kappa);
    -v / v1
}

/// Internal leakage across the piston from chamber 1 to chamber 2 (Merritt eq. 5-32, laminar):
/// `Q_leak = C_ip (P1 - P2)` [m3/s].
pub fn leakage_flow(c_ip: f64, p1: f64, p2: f64) -> f64 {
    c_ip * (p1 - p2)
}

/// Free-piston speed per volt of effective opening in steady state (no load, no friction),
/// from eq. (6), (13)-(16) with `Q_in = A_in v`, `Q_out = A_out v` and the force balance:
/// extending `k = sqrt((Ps - alpha Pr) / (A1^2/c1^2 + alpha A2^2/c3^2))`, `alpha = A2/A1`;
/// retracting `k = sqrt((Ps - Pr/alpha) / (A2^2/c2^2 + A1^3/(A2 c4^2)))` [m s^-1 V^-1].
/// These are the slopes of the Fig. 6 curve outside the dead band.
pub fn free_piston_slopes(a1: f64, a2: f64, ps: f64, pr: f64, c: &[f64; 4]) -> (f64, f64) {
    let alpha = a2 / a1;
    let ext =
        ((ps - alpha * pr) / (a1 * a1 / (c[0] * c[0]) + alpha * a2 * a2 / (c[2] * c[2]))).sqrt();
    let ret =
        ((ps - pr / alpha) / (a2 * a2 / (c[1] * c[1]) + a1 * a1 * a1 / (a2 * c[3] * c[3]))).sqrt();
    (ext, ret)
}

#[cfg(test)]
mod tests {
    use super::{
        air_oil_state, cable_tension, capstan_joint_tension, chamber_volumes, dead_band,
        dead_band_inverse, dead_band_slope, effective_bulk_modulus, end_stop_force,
        free_piston_slopes, friction_memory_rate, leakage_flow, mixture_volume, oil_state,
        orifice_flow, piston_force, pressure_rate, seal_friction, signed_sqrt_reg,
        signed_sqrt_reg_slope, smooth_pos, smooth_pos_slope, spool_accel, valve_flows,
    };

    const C: [f64; 4] = [0.3667e-8, 0.3404e-8, 0.3282e-8, 0.3276e-8];

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * (1.0 + b.abs())
    }

    #[test]
    fn smooth_pos_is_c1_and_exact_outside_blend() {
        let w = 1e-3;
        assert_eq!(smooth_pos(-1.0, w), 0.0);
        assert_eq!(smooth_pos(0.0, w), 0.0);
        assert!(close(smooth_pos(2.0, w), 2.0 - 0.5e-3, 1e-15));
        // value and slope continuous at d = w
        assert!(close(smooth_pos(w * (1.0 - 1e-9), w), 0.5 * w, 1e-8));
        assert!(close(smooth_pos_slope(w * (1.0 - 1e-9), w), 1.0, 1e-8));
        let h = 1e-9;
        let fd = (smooth_pos(0.4 * w + h, w) - smooth_pos(0.4 * w - h, w)) / (2.0 * h);
        assert!(close(fd, smooth_pos_slope(0.4 * w, w), 1e-6));
    }

    #[test]
    fn signed_sqrt_matches_sqrt_outside_and_is_smooth_inside() {
        let p = 1e4;
        assert_eq!(signed_sqrt_reg(4e6, p), 2000.0);
        assert_eq!(signed_sqrt_reg(-4e6, p), -2000.0);
        assert_eq!(signed_sqrt_reg(0.0, p), 0.0);
        // continuity and slope match at p_tr
        let inside = signed_sqrt_reg(p * (1.0 - 1e-10), p);
        assert!(close(inside, p.sqrt(), 1e-9));
        let h = 1e-3;
        let slope_in = (signed_sqrt_reg(p - h, p) - signed_sqrt_reg(p - 2.0 * h, p)) / h;
        assert!(close(slope_in, 0.5 / p.sqrt(), 1e-5));
        // finite slope at zero = 5/(4 sqrt p)
        let s0 = signed_sqrt_reg(1e-6, p) / 1e-6;
        assert!(close(s0, 1.25 / p.sqrt(), 1e-9));
        // odd function
        assert_eq!(signed_sqrt_reg(-3e3, p), -signed_sqrt_reg(3e3, p));
    }

    #[test]
    fn signed_sqrt_slope_matches_difference() {
        for dp in [-5e6f64, -2e4, -5e3, -10.0, 0.0, 3e3, 9.99e3, 1e4, 4e6] {
            let h = 1e-3 * (1.0 + dp.abs() * 1e-6);
            let fd = (signed_sqrt_reg(dp + h, 1e4) - signed_sqrt_reg(dp - h, 1e4)) / (2.0 * h);
            assert!(close(signed_sqrt_reg_slope(dp, 1e4), fd, 1e-5), "{dp}");
        }
    }

    #[test]
    fn valve_paths_switch_with_sign_of_u() {
        let (ps, pr, p1, p2) = (1e7, 0.0, 4e6, 5e6);
        let (q1, q2, qs) = valve_flows(2.0, p1, p2, ps, pr, &C, 1e4);
        assert!(close(q1, C[0] * 2.0 * (ps - p1).sqrt(), 1e-14));
        assert!(close(q2, -C[2] * 2.0 * (p2 - pr).sqrt(), 1e-14));
        assert_eq!(qs, q1);
        let (q1, q2, qs) = valve_flows(-2.0, p1, p2, ps, pr, &C, 1e4);
        assert!(close(q1, -C[3] * 2.0 * (p1 - pr).sqrt(), 1e-14));
        assert!(close(q2, C[1] * 2.0 * (ps - p2).sqrt(), 1e-14));
        assert_eq!(qs, q2);
        assert_eq!(valve_flows(0.0, p1, p2, ps, pr, &C, 1e4), (0.0, -0.0, 0.0));
    }

    #[test]
    fn table_one_gives_plausible_d1fp_flow() {
        // 10 V, 35 bar across one metering edge: a few L/min, the range of small D1FP spools.
        let q = orifice_flow(C[0], 10.0, 35e5, 1e4) * 6e4;
        assert!(q > 2.0 && q < 10.0, "{q} L/min");
    }

    #[test]
    fn volumes_and_pressure_rate() {
        let (v1, v2) = chamber_volumes(0.02, 0.1, 2e-4, 1e-4, 1e-6, 2e-6);
        assert!(close(v1, 1e-6 + 4e-6, 1e-14));
        assert!(close(v2, 2e-6 + 8e-6, 1e-14));
        // compressing a sealed chamber raises its pressure: dP/dt = -beta/V dV/dt
        assert!(close(pressure_rate(1e9, 1e-5, -1e-6, 0.0), 1e8, 1e-14));
        assert_eq!(pressure_rate(1e9, 1e-5, 1e-6, 1e-6), 0.0);
        assert_eq!(piston_force(2e6, 1e6, 2e-4, 1e-4), 300.0);
    }

    #[test]
    fn seal_friction_stribeck_shape() {
        let (fc, fex, vs, sig, eps) = (50.0, 30.0, 0.01, 200.0, 1e-4);
        // steady sliding: v_m = v
        let g = |v: f64| seal_friction(v, v, fc, fex, vs, sig, eps).0;
        assert_eq!(g(0.0), 0.0);
        // just above the regularisation the breakaway force Fc + Fex is reached
        let f_break = g(5e-4);
        assert!(f_break > 0.99 * (fc + fex) - 1.0 && f_break < fc + fex + 1.0);
        // far above vs: Coulomb + viscous
        assert!(close(g(0.2), fc + sig * 0.2, 1e-9));
        assert_eq!(g(-0.05), -g(0.05));
        // just after breakaway the remembered speed is still 0: the full breakaway level
        let (f, _, _) = seal_friction(0.05, 0.0, fc, fex, vs, sig, eps);
        assert!(close(f, fc + fex + sig * 0.05, 1e-9));
        // partial derivatives
        for (v, vm) in [(3e-5, 0.0), (2e-3, 5e-3), (-0.02, -0.01), (0.1, 0.12)] {
            let (_, dv, dvm) = seal_friction(v, vm, fc, fex, vs, sig, eps);
            let h = 1e-9;
            let fd_v = (seal_friction(v + h, vm, fc, fex, vs, sig, eps).0
                - seal_friction(v - h, vm, fc, fex, vs, sig, eps).0)
                / (2.0 * h);
            let fd_m = (seal_friction(v, vm + h, fc, fex, vs, sig, eps).0
                - seal_friction(v, vm - h, fc, fex, vs, sig, eps).0)
                / (2.0 * h);
            assert!(close(dv, fd_v, 1e-5), "{v} {vm}: {dv} {fd_v}");
            assert!((dvm - fd_m).abs() < 1e-5 * (1.0 + fd_m.abs()), "{v} {vm}");
        }
        assert_eq!(friction_memory_rate(0.01, 0.0, 5e-3), 2.0);
    }

    #[test]
    fn cable_cannot_push() {
        assert_eq!(cable_tension(-1e-3, 5e4, 1e-5), 0.0);
        assert!(close(
            cable_tension(3e-3, 5e4, 1e-5),
            5e4 * (3e-3 - 0.5e-5),
            1e-14
        ));
    }

    #[test]
    fn end_stops_push_back_and_never_pull() {
        let (s, k, c, w) = (0.1, 1e7, 2e3, 1e-4);
        assert_eq!(end_stop_force(0.05, 1.0, s, k, c, w), 0.0);
        assert!(end_stop_force(-1e-3, 0.0, s, k, c, w) > 9e3);
        assert!(end_stop_force(s + 1e-3, 0.0, s, k, c, w) < -9e3);
        // leaving the lower stop fast: damping would pull, clamped to zero
        assert_eq!(end_stop_force(-1e-5, 10.0, s, k, c, w), 0.0);
    }

    #[test]
    fn dead_band_and_its_inverse() {
        let (lo, hi, w) = (-1.8, 1.5, 0.02);
        for u in [-1.79, -1.0, 0.0, 1.0, 1.49] {
            assert_eq!(dead_band(u, lo, hi, w), 0.0);
        }
        assert!(close(dead_band(5.0, lo, hi, w), 3.5 - 0.01, 1e-14));
        assert!(close(dead_band(-5.0, lo, hi, w), -(3.2 - 0.01), 1e-14));
        for y in [-3.0, -0.5, -0.005, 1e-4, 0.003, 0.02, 2.0] {
            let u = dead_band_inverse(y, lo, hi, w);
            assert!(close(dead_band(u, lo, hi, w), y, 1e-12), "{y}");
        }
        assert_eq!(dead_band_inverse(0.0, lo, hi, w), 0.0);
        let h = 1e-7;
        let fd = (dead_band(1.51 + h, lo, hi, w) - dead_band(1.51 - h, lo, hi, w)) / (2.0 * h);
        assert!(close(fd, dead_band_slope(1.51, lo, hi, w), 1e-6));
    }

    #[test]
    fn spool_second_order_settles_in_about_3_5_ms() {
        // explicit small-step integration of eq. (18), omega = 1300 rad/s, zeta = 0.7
        let (om, ze) = (1300.0, 0.7);
        let (mut x, mut v, dt) = (0.0, 0.0, 1e-7);
        let mut t95 = None;
        for i in 0..100_000 {
            let a = spool_accel(x, v, 1.0, om, ze);
            v += a * dt;
            x += v * dt;
            if t95.is_none() && x >= 0.95 {
                t95 = Some(i as f64 * dt);
            }
        }
        let t95 = t95.unwrap();
        assert!(t95 > 2e-3 && t95 < 4e-3, "{t95}");
        assert!(close(x, 1.0, 1e-3));
    }

    #[test]
    fn capstan_direction() {
        let mp = 0.3;
        assert_eq!(capstan_joint_tension(100.0, mp, 0.0, 1e-3), 100.0);
        assert!(close(
            capstan_joint_tension(100.0, mp, 1.0, 1e-3),
            100.0 * (-mp).exp(),
            1e-12
        ));
        assert!(close(
            capstan_joint_tension(100.0, mp, -1.0, 1e-3),
            100.0 * mp.exp(),
            1e-12
        ));
    }

    #[test]
    fn entrained_air_lowers_modulus_at_low_pressure() {
        let b = 1e9;
        let hi = effective_bulk_modulus(b, 8e6, 0.01, 101325.0, 1.4);
        let lo = effective_bulk_modulus(b, 2e5, 0.01, 101325.0, 1.4);
        assert!(lo < hi && hi < b);
        assert!(lo < 0.3 * b);
        assert!(close(
            effective_bulk_modulus(b, 5e6, 0.0, 101325.0, 1.4),
            b,
            1e-15
        ));
        // stays finite and positive under vacuum
        let v = effective_bulk_modulus(b, -2e5, 0.01, 101325.0, 1.4);
        assert!(v.is_finite() && v > 0.0);
    }

    #[test]
    fn oil_state_density_ratio_integrates_inverse_modulus() {
        // d ln r / dp = 1/beta_e and d beta_e/dp, by differences, with and without air
        let (b, pa) = (1e9, 101325.0);
        let v_ref = mixture_volume(0.0, b, 0.02, pa, 1.2)[0];
        for p in [-5e4, 0.0, 3e5, 2e6, 9e6] {
            let st = air_oil_state(p, b, 0.02, pa, 1.2, v_ref);
            let h = 1.0 + 1e-6 * p.abs();
            let sp = air_oil_state(p + h, b, 0.02, pa, 1.2, v_ref);
            let sm = air_oil_state(p - h, b, 0.02, pa, 1.2, v_ref);
            let dlnr = (sp.r.ln() - sm.r.ln()) / (2.0 * h);
            assert!(
                close(dlnr, 1.0 / st.beta, 1e-6),
                "{p}: {dlnr} {}",
                1.0 / st.beta
            );
            let db = (sp.beta - sm.beta) / (2.0 * h);
            assert!(
                (db - st.dbeta).abs() < 1e-5 * (1.0 + db.abs()),
                "{p}: {db} {}",
                st.dbeta
            );
            assert!(close(
                st.beta,
                effective_bulk_modulus(b, p, 0.02, pa, 1.2),
                1e-14
            ));
        }
        assert_eq!(air_oil_state(0.0, b, 0.02, pa, 1.2, v_ref).r, 1.0);
        let o = oil_state(5e6, b);
        assert!(close(o.r, (5e-3f64).exp(), 1e-15));
        assert_eq!((o.beta, o.dbeta), (b, 0.0));
        // Merritt's approximate form agrees to within the neglected oil compression p/beta
        for p in [2e5, 3e6, 1e7] {
            let q = p + pa;
            let pabs = 0.5 * (q + (q * q + (0.1 * pa) * (0.1 * pa)).sqrt());
            let x = 0.02 * (pa / pabs).powf(1.0 / 1.2);
            let merritt = b * (1.0 + x) / (1.0 + x * b / (1.2 * pabs));
            let exact = effective_bulk_modulus(b, p, 0.02, pa, 1.2);
            assert!(
                (exact / merritt - 1.0).abs() < 0.03,
                "{p}: {exact} {merritt}"
            );
        }
    }

    #[test]
    fn leakage_linear() {
        assert_eq!(leakage_flow(1e-12, 3e6, 1e6), 2e-6);
    }

    #[test]
    fn free_piston_extends_faster_than_it_retracts() {
        let a1 = std::f64::consts::PI / 4.0 * 0.016f64.powi(2);
        let a2 = a1 - std::f64::consts::PI / 4.0 * 0.010f64.powi(2);
        let (ke, kr) = free_piston_slopes(a1, a2, 1e7, 0.0, &C);
        assert!(ke > kr);
        // matched orifices: ratio exactly 1/sqrt(alpha)
        let cm = [3.4e-9; 4];
        let (ke, kr) = free_piston_slopes(a1, a2, 1e7, 0.0, &cm);
        assert!(close(ke / kr, (a1 / a2).sqrt(), 1e-12));
        // check the closed form against the flow equations: extending at speed v
        let (ke, _) = free_piston_slopes(a1, a2, 1e7, 0.0, &C);
        let u = 5.0;
        let v = ke * u;
        let p1 = 1e7 - (a1 * v / (C[0] * u)).powi(2);
        let p2 = (a2 * v / (C[2] * u)).powi(2);
        assert!(close(p1 * a1, p2 * a2, 1e-10));
    }
}
