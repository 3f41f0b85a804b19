//! Unit tests of the plant.
use super::{
    ix, rest_position, stored_energy, with_every_effect, GearBacklash, Inputs, MotorFriction,
    Params, Plant, RadiusGrowth, StringCompliance, TwistHysteresis, DIM, DIM_BASE,
    EFFICIENCY_POWER_WIDTH, GEAR_OUTPUT_INERTIA, MESH, NOMINAL,
};
use crate::physics::{bundle_radius, free_length, helix_position, twist_arc, GRAVITY};

pub fn defaults() -> Params {
    Params {
        internal_controller: false,
        load_mass: 23.0 / GRAVITY,
        string_length: 0.0897,
        string_radius: bundle_radius(1e-3),
        string_count: 4.0,
        string_stiffness: 1e6,
        string_damping: 2000.0,
        spring_stiffness: 100.0,
        spring_preload: 5.0,
        guide_damping: 20.0,
        motor_resistance: 2.32,
        motor_inductance: 0.238e-3,
        torque_constant: 0.0234,
        back_emf_constant: 0.0234,
        rotor_inertia: 1.09e-6,
        gear_ratio: 19.2,
        gear_efficiency: 0.81,
        encoder_cpt: 1000.0,
        supply_voltage: 24.0,
        current_limit: 3.0,
        speed_limit: 837.758,
        controller_current_p: 0.165,
        controller_current_ti: 69e-6,
        controller_speed_p: 9.196e-3,
        controller_speed_ti: 0.042,
        controller_position_p: 8.75,
        controller_position_band: 2f64.to_radians(),
        controller_position_period: 1e-3,
        rtol: 1e-6,
        atol: 1e-6,
        ..Default::default()
    }
}

#[test]
fn mesh_damping_is_critical_for_the_output() {
    let crit = 2.0 * (MESH.k * GEAR_OUTPUT_INERTIA).sqrt();
    assert!((MESH.d - crit).abs() < 1e-15 * crit);
}

#[test]
fn rest_is_equilibrium() {
    for compl in [
        None,
        Some(StringCompliance {
            a1: 8.1153e-06,
            a2: 8.4427e-09,
            a3: 1.6914e-5,
        }),
    ] {
        let mut q = defaults();
        q.string_compliance = compl;
        let p0 = rest_position(&q, 0.0).unwrap();
        let plant = Plant {
            par: &q,
            inp: Inputs::default(),
        };
        let y = [0.0, 0.0, 0.0, p0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let aux = plant.eval(&y);
        for (k, d) in aux.dy.iter().enumerate() {
            assert!(d.abs() < 1e-9, "state {k}: {d}");
        }
        assert!((aux.f_axial - (23.0 + 5.0 + 100.0 * (0.0897 - p0))).abs() < 1e-9);
    }
}

#[test]
fn stall_torque_finite_beyond_full_twist() {
    // theta_t r > L0: strands stretched, tension large but finite
    let q = defaults();
    let plant = Plant {
        par: &q,
        inp: Inputs::default(),
    };
    let th_m = 1.05 * q.string_length / q.string_radius * q.gear_ratio;
    let y = [0.0, th_m, 0.0, 1e-3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let aux = plant.eval(&y);
    assert!(aux.tension > 1e3 && aux.tension.is_finite());
    assert!(aux.dy.iter().all(|d| d.is_finite()));
}

/// Every effect alone and all together, in both controller modes.
fn effect_cases() -> Vec<Params> {
    let base = defaults();
    let mut cases = vec![];
    for internal in [true, false] {
        for effect in 0..7 {
            let mut q = base.clone();
            q.internal_controller = internal;
            match effect {
                1 => {
                    q.string_compliance = Some(StringCompliance {
                        a1: 8.1153e-06,
                        a2: 8.4427e-09,
                        a3: 1.6914e-5,
                    })
                }
                2 => {
                    q.twist_hysteresis = Some(TwistHysteresis {
                        friction_coefficient: 0.1,
                    })
                }
                3 => {
                    q.motor_friction = Some(MotorFriction {
                        coulomb: 1e-3,
                        viscous: 1e-6,
                    })
                }
                4 => {
                    q.gear_backlash = Some(GearBacklash {
                        angle: 1f64.to_radians(),
                    })
                }
                5 => q.radius_growth = Some(RadiusGrowth { per_turn: 0.005 }),
                6 => q = with_every_effect(&q, 2f64.to_radians()),
                _ => {}
            }
            cases.push(q);
        }
    }
    cases
}

/// Where the gearhead output is in the `gear_backlash` test states.
#[derive(Clone, Copy, Debug)]
enum Output {
    /// On the positive flank, 1e-4 rad deep, turning 10 % slower than the motor side.
    Pressed,
    /// Inside the gap, a third of the way from the centre, turning at half the motor side's
    /// speed.
    InGap,
}

const OUTPUTS: [Output; 2] = [Output::Pressed, Output::InGap];

/// The 10 base states `y0` with the strings carrying about 100 N (taut, as in operation), and
/// with `gear_backlash` the output placed as `out` says.
fn taut(q: &Params, y0: &[f64; DIM_BASE], out: Output) -> [f64; DIM] {
    let mut y = [0.0; DIM];
    y[..DIM_BASE].copy_from_slice(y0);
    if let Some(GearBacklash { angle: b }) = q.gear_backlash {
        let w = y[ix::OMEGA] / q.gear_ratio;
        (y[ix::DELTA], y[ix::OMEGA_T]) = match out {
            Output::Pressed => (0.5 * b + 1e-4, 0.9 * w),
            Output::InGap => (b / 6.0, 0.5 * w),
        };
    }
    let th_t = y[1] / q.gear_ratio - y[ix::DELTA];
    let (a, _) = twist_arc(
        th_t,
        q.string_radius,
        q.radius_growth.map_or(0.0, |g| g.per_turn),
    );
    let lf = match q.string_compliance {
        Some(StringCompliance { a1, a2, .. }) => {
            free_length(q.gear_ratio * th_t, q.string_length, a1, a2).0
        }
        None => q.string_length,
    };
    y[3] = helix_position(lf + 100.0 * q.compliance_c(), a);
    y
}

/// The plant of `q` with set point 0, no angle offset and the given voltage, load force and
/// speed set point.
fn test_plant(q: &Params, voltage: f64, f_load: f64, omega_ref: f64) -> Plant<'_> {
    Plant {
        par: q,
        inp: Inputs {
            theta_ref: 0.0,
            voltage,
            f_load,
            omega_ref,
            theta_offset: 0.0,
        },
    }
}

#[test]
fn power_balance_holds_pointwise() {
    // d/dt E_stored (central difference along the flow) = u i + F_load v - P_loss - P_kin
    let states = [
        [0.4, 600.0, 300.0, 0.08, -0.004, 2e-4, 3.0, 0.0, 0.0, 0.0],
        [1.2, 1200.0, -50.0, 0.05, 0.01, -1e-3, 40.0, 0.0, 0.0, 0.0],
        [-0.7, 80.0, 20.0, 0.0898, 0.002, 1e-5, -0.1, 0.0, 0.0, 0.0],
    ];
    for q in &effect_cases() {
        let plant = test_plant(q, 5.0, 10.0, 200.0);
        for (y0, out) in states.iter().flat_map(|y| OUTPUTS.map(|o| (y, o))) {
            for stretch in [true, false] {
                let mut y = taut(q, y0, out);
                if !stretch {
                    y[3] += 0.3 * 100.0 * q.compliance_c(); // less tension, damping active
                }
                let aux = plant.eval(&y);
                let h = 1e-7; // s, along the flow
                let mut yp = y;
                let mut ym = y;
                for k in 0..DIM {
                    yp[k] += h * aux.dy[k];
                    ym[k] -= h * aux.dy[k];
                }
                let de = (stored_energy(q, &yp) - stored_energy(q, &ym)) / (2.0 * h);
                let rhs = aux.p_el + plant.inp.f_load * y[ix::V] - aux.p_loss - aux.p_kin;
                let scale = aux.p_el.abs() + aux.p_loss.abs() + aux.p_kin.abs() + 1.0;
                assert!(
                    (de - rhs).abs() < 1e-6 * scale,
                    "dE/dt {de} vs {rhs} (scale {scale}, {q:?}, y {y:?})"
                );
                if q.string_compliance.is_none() {
                    assert_eq!(aux.p_kin, 0.0);
                }
            }
        }
    }
}

#[test]
fn losses_are_dissipative_without_compliance() {
    // every loss term >= 0 up to the smoothed gearhead switch, bounded by its blend width
    for q in effect_cases()
        .iter()
        .filter(|q| q.string_compliance.is_none())
    {
        let plant = test_plant(q, -3.0, 0.0, -100.0);
        for om in [-500.0, -1.0, 0.0, 0.5, 300.0] {
            let y0 = [0.3, 700.0, om, 0.0, 0.001, 0.0, 0.0, 0.0, 0.0, 0.0];
            let y = taut(q, &y0, Output::Pressed);
            let aux = plant.eval(&y);
            assert!(
                aux.p_loss > -0.01 * EFFICIENCY_POWER_WIDTH,
                "{}",
                aux.p_loss
            );
        }
    }
}

#[test]
fn analytic_jacobian_matches_differences() {
    let cases = effect_cases();
    let states = [
        [0.4, 600.0, 300.0, 0.08, -0.004, 2e-4, 3.0, 1.0, 0.5, 0.1],
        [1.2, 1200.0, -50.0, 0.05, 0.01, -1e-3, 40.0, 2.0, 1.0, 0.0],
        [0.05, 0.01, 0.3, 0.0898, 0.0, 1e-5, 0.1, 0.0, 0.0, 0.0],
    ];
    for q in &cases {
        let plant = test_plant(q, 5.0, 10.0, 200.0);
        for (y0, out) in states.iter().flat_map(|y| OUTPUTS.map(|o| (y, o))) {
            // place the load so that the strings carry about 100 N (taut), as in operation
            let y = &taut(q, y0, out);
            let jr = plant.jacobian_rows(y);
            for c in 0..DIM {
                let h = 1e-6 * NOMINAL[c].max(y[c].abs() * 1e-2);
                let mut yp = *y;
                let mut ym = *y;
                yp[c] += h;
                ym[c] -= h;
                let fp = plant.eval(&yp).dy;
                let fm = plant.eval(&ym).dy;
                let f0 = plant.eval(y).dy;
                for r in 0..DIM {
                    let fd = (fp[r] - fm[r]) / (2.0 * h);
                    let an = jr[r][c];
                    // relative agreement, above the roundoff floor of the differences
                    let noise = 1e3 * f64::EPSILON * f0[r].abs().max(fp[r].abs()) / h;
                    assert!(
                        (fd - an).abs() <= 1e-4 * fd.abs().max(an.abs()) + noise,
                        "d f{r}/d y{c}: analytic {an} vs differences {fd} (effects {q:?}, y {y:?})"
                    );
                }
            }
        }
    }
}
