//! Quick exploration: runs scenarios through the Model trait and prints key numbers.
// A development tool run on this machine, not FMU code (workspace clippy.toml).
#![allow(clippy::disallowed_methods)]
use fmu_core::Model;
use hydraulic_joint::vars::{V, VARIABLES};
use hydraulic_joint::HydraulicJoint;

fn vars0() -> Vec<f64> {
    VARIABLES.iter().map(|v| v.start).collect()
}

/// Start values with `NAME=VALUE` overrides.
fn vars_with(sets: &[String]) -> Vec<f64> {
    let mut v = vars0();
    for a in sets {
        let (n, x) = a.split_once('=').unwrap();
        let i = VARIABLES.iter().position(|q| q.name == n).unwrap();
        v[i] = x.parse().unwrap();
    }
    v
}

fn minjerk(t: f64) -> f64 {
    let s = (t / 1.0).clamp(0.0, 1.0);
    45f64.to_radians() * (10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5))
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let args = &args;
    let what = args.get(1).map(|s| s.as_str()).unwrap_or("bench");
    match what {
        "bench" => {
            for u in [
                -10.0, -6.0, -3.0, -2.0, -1.7, 0.0, 1.4, 1.7, 2.0, 3.0, 6.0, 10.0,
            ] {
                let mut v = vars0();
                v[V::INTERNAL_CONTROLLER as usize] = 0.0;
                v[V::CABLES_ATTACHED as usize] = 0.0;
                let mut m = HydraulicJoint::new();
                m.initialize(&mut v, 0.0).unwrap();
                v[V::U_LEFT as usize] = u;
                let mut speeds = vec![];
                for k in 0..60 {
                    m.do_step(&mut v, k as f64 * 1e-3, 1e-3).unwrap();
                    if k + 1 >= 20 {
                        speeds.push(v[V::V_LEFT as usize]);
                    }
                }
                let mean = speeds.iter().sum::<f64>() / speeds.len() as f64;
                println!(
                    "U={u:6.2} v(20-60ms) mean={mean:.5} min={:.5} max={:.5} p1={:.3e} p2={:.3e}",
                    speeds.iter().cloned().fold(f64::INFINITY, f64::min),
                    speeds.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
                    v[V::P1_LEFT as usize],
                    v[V::P2_LEFT as usize]
                );
            }
        }
        "catch" => {
            let mut v = vars_with(&args[2..]);
            let mut m = HydraulicJoint::new();
            m.initialize(&mut v, 0.0).unwrap();
            let dt = 1e-3;
            let n = 2000;
            let mut th = vec![0.0];
            let mut rf = vec![0.0];
            let t0 = std::time::Instant::now();
            for k in 0..n {
                let t = k as f64 * dt;
                v[V::THETA_REF as usize] = minjerk(t);
                m.do_step(&mut v, t, dt).unwrap();
                th.push(v[V::THETA as usize]);
                rf.push(minjerk(t + dt));
            }
            let el = t0.elapsed();
            let mut maxe: f64 = 0.0;
            for (a, b) in th.iter().zip(&rf) {
                maxe = maxe.max((a - b).abs());
            }
            // lag by best shift
            let mut best = (0usize, f64::INFINITY);
            for s in 0..400 {
                let mut e = 0.0;
                for k in 0..1500 {
                    let d = th[k + s] - rf[k];
                    e += d * d;
                }
                if e < best.1 {
                    best = (s, e);
                }
            }
            // 50% crossing
            let half = 22.5f64.to_radians();
            let tc = |x: &[f64]| x.iter().position(|&q| q >= half).unwrap_or(0) as f64 * dt;
            println!("peak err {:.2} deg, lag(best shift) {:.3} s, lag(50%) {:.3} s, final {:.3} deg, time {:?}",
                maxe.to_degrees(), best.0 as f64 * dt, tc(&th) - tc(&rf), th[n].to_degrees(), el);
            for k in (0..=n).step_by(100) {
                println!(
                    "t={:.2} ref={:6.2} th={:6.2}",
                    k as f64 * dt,
                    rf[k].to_degrees(),
                    th[k].to_degrees()
                );
            }
        }
        "perf" => {
            // 10 s at 1 ms communication steps: closed-loop reach out and back (and open-loop
            // voltage steps); CPU time is the minimum over 5 runs (the machine is shared)
            let cases: Vec<(&str, Vec<(V, f64)>)> = vec![
                ("catch", vec![]),
                ("catch+seal", vec![(V::SEAL_FRICTION_ENABLED, 1.0)]),
                ("catch+overlap", vec![(V::VALVE_OVERLAP_ENABLED, 1.0)]),
                ("catch+leakage", vec![(V::INTERNAL_LEAKAGE_ENABLED, 1.0)]),
                ("catch+cable", vec![(V::CABLE_FRICTION_ENABLED, 1.0)]),
                ("catch+air", vec![(V::ENTRAINED_AIR_ENABLED, 1.0)]),
                ("catch+spool", vec![(V::VALVE_DYNAMICS_ENABLED, 1.0)]),
                ("open", vec![(V::INTERNAL_CONTROLLER, 0.0)]),
            ];
            for (label, extra) in cases {
                if let Some(only) = args.get(2) {
                    if only != label {
                        continue;
                    }
                }
                let mut best = f64::INFINITY;
                let mut stats = None;
                for _ in 0..5 {
                    let mut v = vars0();
                    for (k, x) in &extra {
                        v[*k as usize] = *x;
                    }
                    let open = v[V::INTERNAL_CONTROLLER as usize] == 0.0;
                    let mut m = HydraulicJoint::new();
                    m.initialize(&mut v, 0.0).unwrap();
                    let t0 = std::time::Instant::now();
                    for k in 0..10_000 {
                        let t = k as f64 * 1e-3;
                        if open {
                            let ph = (t * 2.0) as i64 % 4;
                            v[V::U_LEFT as usize] = [0.0, 3.0, 0.0, -4.0][ph as usize];
                            v[V::U_RIGHT as usize] = [0.0, -3.0, 0.0, 4.0][ph as usize];
                        } else {
                            v[V::THETA_REF as usize] =
                                minjerk(t % 5.0) * if t >= 5.0 { -1.0 } else { 1.0 };
                        }
                        m.do_step(&mut v, t, 1e-3).unwrap();
                    }
                    best = best.min(t0.elapsed().as_secs_f64());
                    stats = m.solver_stats().cloned();
                    if args.get(3).map(|s| s.as_str()) == Some("once") {
                        break;
                    }
                }
                let s = stats.unwrap();
                println!(
                    "{label:14} {:7.1} ms  steps {:6} rejected {:5} rhs {:7}",
                    best * 1e3,
                    s.steps,
                    s.rejected,
                    s.rhs_evals
                );
            }
        }
        "steps" => {
            // where the solver spends its steps: per 1 ms step, accepted steps and v_left
            let mut v = vars_with(&args[2..]);
            let mut m = HydraulicJoint::new();
            m.initialize(&mut v, 0.0).unwrap();
            let mut last = 0;
            for k in 0..3000 {
                let t = k as f64 * 1e-3;
                v[V::THETA_REF as usize] = minjerk(t);
                m.do_step(&mut v, t, 1e-3).unwrap();
                let s = m.solver_stats().unwrap().steps;
                println!(
                    "{:.3} {} {:.6e} {:.6e} {:.4e} {:.4e} {:.3}",
                    t + 1e-3,
                    s - last,
                    v[V::V_LEFT as usize],
                    v[V::V_RIGHT as usize],
                    v[V::P1_LEFT as usize],
                    v[V::P2_LEFT as usize],
                    v[V::U_VALVE_LEFT as usize]
                );
                last = s;
            }
        }
        "oil" => {
            // oil balance over 10 s of pseudo-random closed/open-loop input
            let mut v = vars_with(&args[2..]);
            let open = v[V::INTERNAL_CONTROLLER as usize] == 0.0;
            let mut m = HydraulicJoint::new();
            m.initialize(&mut v, 0.0).unwrap();
            let s0 = v[V::V_STORED as usize];
            let mut seed = 12345u64;
            let mut rnd = || {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (seed >> 11) as f64 / (1u64 << 53) as f64
            };
            let t0 = std::time::Instant::now();
            let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
            for k in 0..10_000 {
                let t = k as f64 * 1e-3;
                if k % 200 == 0 {
                    a = rnd() * 2.0 - 1.0;
                    b = rnd() * 20.0 - 10.0;
                    c = rnd() * 20.0 - 10.0;
                }
                v[V::THETA_REF as usize] = a;
                v[V::U_LEFT as usize] = b;
                v[V::U_RIGHT as usize] = c;
                v[V::TAU_EXT as usize] = if open { 0.0 } else { 2.0 * a };
                m.do_step(&mut v, t, 1e-3).unwrap();
            }
            let (vs, vr, st) = (
                v[V::V_SUPPLIED as usize],
                v[V::V_RETURNED as usize],
                v[V::V_STORED as usize],
            );
            let res = vs - vr - (st - s0);
            println!(
                "{:?}: Vs {vs:.6e} Vr {vr:.6e} dS {:.6e} residual {res:.3e} rel {:.3e} steps {:?}",
                t0.elapsed(),
                st - s0,
                res / (vs + vr),
                m.solver_stats().map(|s| s.steps)
            );
        }
        "rhs" => {
            use hydraulic_joint::plant::Plant;
            let v = vars0();
            let p = hydraulic_joint::plant::Params::read(&v);
            let d = p.derive().unwrap();
            let mut y = p.rest_state(&d, [0.0; 2]);
            let plant = Plant {
                p: &p,
                d: &d,
                u: [2.0, -2.5],
                tau_ext: 0.0,
            };
            let mut dy = vec![0.0; d.dim];
            let t0 = std::time::Instant::now();
            for k in 0..1_000_000 {
                y[0] = k as f64 * 1e-9;
                plant.eval(&y, &mut dy);
            }
            println!("rhs: {:?} per eval, {}", t0.elapsed() / 1_000_000, dy[1]);
        }
        _ => {}
    }
}
