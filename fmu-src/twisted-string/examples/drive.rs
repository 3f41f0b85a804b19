//! Drive the model directly (no FMI): `cargo run --release -p twisted-string --example drive -- [ref] [T] [set=val...]`.
use fmu_core::Model;
use twisted_string::{TwistedString, V, VARIABLES};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let theta_ref: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(2011.0);
    let t_end: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10.0);
    let mut vars: Vec<f64> = VARIABLES.iter().map(|v| v.start).collect();
    for a in args.iter().skip(3) {
        let (k, v) = a.split_once('=').expect("name=value");
        let idx = VARIABLES
            .iter()
            .position(|x| x.name == k)
            .expect("unknown variable");
        vars[idx] = match v {
            "true" => 1.0,
            "false" => 0.0,
            _ => v.parse().unwrap(),
        };
    }
    let mut m = TwistedString::new();
    m.initialize(&mut vars, 0.0).unwrap();
    vars[V::THETA_MOTOR_REF as usize] = theta_ref;
    let h = 1e-3;
    let n = (t_end / h).round() as usize;
    let t0 = std::time::Instant::now();
    for k in 0..n {
        let t = k as f64 * h;
        if let Err(e) = m.do_step(&mut vars, t, h) {
            println!("error at {t}: {e}");
            break;
        }
        if (k + 1) % (n / 20).max(1) == 0 {
            println!(
                "t={:.3} th={:.3} w={:.2} i={:.3} p={:.5} T={:.2} u={:.2} wref={:.1}",
                t + h,
                vars[V::THETA_MOTOR as usize],
                vars[V::OMEGA_MOTOR as usize],
                vars[V::CURRENT as usize],
                vars[V::P as usize],
                vars[V::F_STRING as usize] * 4.0,
                vars[V::VOLTAGE_MOTOR as usize],
                vars[V::OMEGA_REF as usize]
            );
        }
    }
    println!("cpu {:?} {:?}", t0.elapsed(), m.solver_stats());
}
