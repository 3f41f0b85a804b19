//! A small synthetic model with hidden effects to test the statistics without an FMU:
//! a mass–spring–damper `m ẍ + c ẋ + k x = u_eff − F_f(ẋ) − k3 x³` driven by a force input `u`
//! through an optional first-order lag `τ u̇_eff = u − u_eff`, with optional Coulomb friction
//! `F_f = F_c tanh(ẋ / 0.01)` (smoothed sign) and cubic stiffening `k3`. Integrated with classical
//! RK4 at four substeps per sample (the input held over the sample, as a co-simulation step).

use crate::sim::{GridModel, SimError};
use crate::spec::ParamSpec;
use crate::workflow::{self, CandidateVerdict, Config, Data, Verdict};

pub struct Msd {
    pub params: Vec<ParamSpec>,
    pub outputs: Vec<String>,
    pub time: Vec<f64>,
    pub u: Vec<f64>,
}

pub const M: usize = 0;
pub const C: usize = 1;
pub const FRICTION_ON: usize = 3;
pub const FRICTION_FC: usize = 4;
pub const STIFF_ON: usize = 5;
pub const STIFF_K3: usize = 6;
pub const LAG_ON: usize = 7;
pub const LAG_TAU: usize = 8;

impl Msd {
    pub fn new(time: Vec<f64>, u: Vec<f64>) -> Self {
        let params = vec![
            ParamSpec::real(
                "mass",
                1.0,
                Some(0.2),
                Some(5.0),
                "kg",
                "[calibrate] moving mass",
            ),
            ParamSpec::real(
                "damping",
                2.0,
                Some(0.1),
                Some(20.0),
                "N.s/m",
                "[calibrate] viscous damping",
            ),
            ParamSpec::real("stiffness", 40.0, Some(1.0), Some(1000.0), "N/m", "spring"),
            ParamSpec::flag("friction.enabled", false, "Coulomb friction"),
            ParamSpec::real(
                "friction.coulomb",
                0.5,
                Some(0.05),
                Some(5.0),
                "N",
                "Coulomb force",
            ),
            ParamSpec::flag("stiffening.enabled", false, "cubic spring"),
            ParamSpec::real(
                "stiffening.k3",
                200.0,
                Some(10.0),
                Some(5000.0),
                "N/m3",
                "cubic coefficient",
            ),
            ParamSpec::flag("lag.enabled", false, "input lag"),
            ParamSpec::real(
                "lag.tau",
                0.02,
                Some(0.002),
                Some(0.2),
                "s",
                "time constant",
            ),
        ];
        Msd {
            params,
            outputs: vec![
                "x".into(),
                "v".into(),
                "u_eff".into(),
                "spring_force".into(),
            ],
            time,
            u,
        }
    }
}

fn rhs(p: &[f64], u: f64, s: [f64; 3]) -> [f64; 3] {
    let [x, v, ue] = s;
    let uin = if p[LAG_ON] > 0.5 { ue } else { u };
    let ff = if p[FRICTION_ON] > 0.5 {
        p[FRICTION_FC] * libm::tanh(v / 0.01)
    } else {
        0.0
    };
    let k3 = if p[STIFF_ON] > 0.5 {
        p[STIFF_K3] * x * x * x
    } else {
        0.0
    };
    let a = (uin - p[C] * v - p[2] * x - k3 - ff) / p[M];
    let due = if p[LAG_ON] > 0.5 {
        (u - ue) / p[LAG_TAU]
    } else {
        0.0
    };
    [v, a, due]
}

impl GridModel for Msd {
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
    fn output_names(&self) -> &[String] {
        &self.outputs
    }
    fn simulate(&self, set: &[(usize, f64)], n: usize) -> Result<Vec<Vec<f64>>, SimError> {
        let mut p: Vec<f64> = self.params.iter().map(|q| q.start).collect();
        for &(i, v) in set {
            p[i] = v;
        }
        let mut s = [0.0, 0.0, self.u[0]];
        let mut out: Vec<Vec<f64>> = (0..4).map(|_| Vec::with_capacity(n)).collect();
        for i in 0..n {
            let ue = if p[LAG_ON] > 0.5 { s[2] } else { self.u[i] };
            out[0].push(s[0]);
            out[1].push(s[1]);
            out[2].push(ue);
            out[3].push(p[2] * s[0]);
            if i + 1 == n {
                break;
            }
            let h = (self.time[i + 1] - self.time[i]) / 4.0;
            let u = self.u[i];
            for _ in 0..4 {
                let k1 = rhs(&p, u, s);
                let k2 = rhs(&p, u, std::array::from_fn(|j| s[j] + 0.5 * h * k1[j]));
                let k3 = rhs(&p, u, std::array::from_fn(|j| s[j] + 0.5 * h * k2[j]));
                let k4 = rhs(&p, u, std::array::from_fn(|j| s[j] + h * k3[j]));
                for j in 0..3 {
                    s[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
                }
            }
        }
        Ok(out)
    }
}

/// Deterministic pseudo-random numbers (xorshift64*).
pub struct Rng(u64);
impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    pub fn normal(&mut self) -> f64 {
        let (a, b) = (self.uniform(), self.uniform());
        (-2.0 * libm::log(a)).sqrt() * libm::cos(2.0 * std::f64::consts::PI * b)
    }
}

/// A random multisine-plus-steps force input over `n` samples at `dt`.
pub fn input(rng: &mut Rng, n: usize, dt: f64) -> Vec<f64> {
    let comps: Vec<(f64, f64, f64)> = (0..4)
        .map(|_| {
            (
                0.5 + 2.0 * rng.uniform(),
                0.2 + 3.0 * rng.uniform(),
                6.3 * rng.uniform(),
            )
        })
        .collect();
    let mut level = 0.0;
    (0..n)
        .map(|i| {
            if i % (n / 8).max(1) == 0 {
                level = 4.0 * (rng.uniform() - 0.5);
            }
            let t = i as f64 * dt;
            level
                + comps
                    .iter()
                    .map(|(a, f, ph)| a * libm::sin(f * t + ph))
                    .sum::<f64>()
        })
        .collect()
}

/// Measured data: simulate with `truth`, add noise of `frac` of each output's range, optionally
/// AR(1)-correlated with coefficient `ar` (same marginal standard deviation).
pub fn measure(
    m: &Msd,
    truth: &[(usize, f64)],
    rng: &mut Rng,
    frac: f64,
    ar: f64,
    outs: &[usize],
) -> Data {
    let n = m.time.len();
    let y = m.simulate(truth, n).expect("truth simulation");
    let outputs = outs
        .iter()
        .map(|&k| {
            let s = frac * crate::stats::range(&y[k]);
            let mut e = 0.0;
            let v = (0..n)
                .map(|i| {
                    let w = rng.normal();
                    e = if i == 0 {
                        w
                    } else {
                        ar * e + (1.0 - ar * ar).sqrt() * w
                    };
                    y[k][i] + s * e
                })
                .collect();
            (m.outputs[k].clone(), v)
        })
        .collect();
    Data {
        time: m.time.clone(),
        inputs: vec![("u".into(), m.u.clone())],
        outputs,
    }
}

fn case(seed: u64, truth: &[(usize, f64)], ar: f64) -> (Msd, Data) {
    let mut rng = Rng::new(seed);
    let n = 5000;
    let dt = 1e-3;
    let time: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    let u = input(&mut rng, n, dt);
    let m = Msd::new(time, u);
    let d = measure(&m, truth, &mut rng, 0.01, ar, &[0, 1]);
    (m, d)
}

fn run(seed: u64, truth: &[(usize, f64)], ar: f64) -> workflow::GapResult {
    let (m, d) = case(seed, truth, ar);
    workflow::run(&m, &d, &Config::default()).expect("workflow")
}

#[test]
fn hidden_friction_is_named() {
    for seed in [1, 2] {
        let r = run(
            seed,
            &[(M, 1.2), (FRICTION_ON, 1.0), (FRICTION_FC, 1.5)],
            0.0,
        );
        assert_eq!(
            r.named,
            vec!["friction".to_string()],
            "seed {seed}: {:?}",
            r.verdict
        );
        let named: Vec<&str> = r
            .candidates
            .iter()
            .flatten()
            .filter(|c| matches!(c.verdict, CandidateVerdict::Named { .. }))
            .map(|c| c.effect.as_str())
            .collect();
        assert_eq!(named, ["friction"], "seed {seed}: {:?}", r.verdict);
        assert_eq!(
            r.verdict,
            Verdict::Named {
                effects: vec!["friction".to_string()]
            }
        );
        let fc = &r.parameters["friction.coulomb"];
        assert!(
            fc.ci_low < 1.5 && 1.5 < fc.ci_high && (fc.value - 1.5).abs() < 0.1,
            "{fc:?}"
        );
        for o in r.outputs.values() {
            assert!(
                o.rmse_after < 1.2 * o.noise_sigma || o.rmse_after * 5.0 < o.rmse_base_fit,
                "{o:?}"
            );
        }
    }
}

#[test]
fn hidden_stiffening_and_lag_are_named() {
    let r = run(3, &[(STIFF_ON, 1.0), (STIFF_K3, 800.0)], 0.0);
    assert_eq!(r.named, vec!["stiffening".to_string()], "{:?}", r.verdict);
    let r = run(4, &[(LAG_ON, 1.0), (LAG_TAU, 0.05)], 0.0);
    assert_eq!(r.named, vec!["lag".to_string()], "{:?}", r.verdict);
}

#[test]
fn clean_data_names_nothing_white_or_correlated_noise() {
    for seed in [5, 6] {
        let r = run(seed, &[], 0.0);
        assert!(r.named.is_empty(), "white, seed {seed}: {:?}", r.verdict);
        let r = run(seed, &[], 0.9);
        assert!(r.named.is_empty(), "AR(1), seed {seed}: {:?}", r.verdict);
    }
}

#[test]
fn wrong_mass_is_calibrated_not_named() {
    let r = run(7, &[(M, 1.3)], 0.0);
    assert!(r.named.is_empty(), "{:?}", r.verdict);
    let m = &r.parameters["mass"];
    assert!(
        m.ci_low < 1.3 && 1.3 < m.ci_high && (m.value - 1.3).abs() < 0.02,
        "{m:?}"
    );
    let x = &r.outputs["x"];
    assert!(x.rmse_before > 3.0 * x.rmse_after, "{x:?}");
}

#[test]
fn two_hidden_effects_are_both_named() {
    let r = run(
        8,
        &[
            (FRICTION_ON, 1.0),
            (FRICTION_FC, 1.0),
            (STIFF_ON, 1.0),
            (STIFF_K3, 1000.0),
        ],
        0.0,
    );
    let mut named = r.named.clone();
    named.sort();
    assert_eq!(
        named,
        vec!["friction".to_string(), "stiffening".to_string()],
        "{:?}",
        r.verdict
    );
}

#[test]
fn report_and_plots_are_written() {
    let (m, d) = case(9, &[(FRICTION_ON, 1.0), (FRICTION_FC, 1.0)], 0.0);
    let r = workflow::run(&m, &d, &Config::default()).unwrap();
    let dir = std::env::temp_dir().join(format!("gap-test-{}", std::process::id()));
    let plots = crate::plots::write(&r, &{
        std::fs::create_dir_all(&dir).unwrap();
        dir.clone()
    });
    crate::report::write(
        &r,
        &dir,
        "synthetic",
        "synthetic",
        &plots,
        &Default::default(),
    )
    .unwrap();
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    assert_eq!(j["named"][0], "friction");
    assert!(j["parameters"]["mass"]["ci_low"].is_number());
    assert!(j["outputs"]["x"]["rmse_after"].as_f64().unwrap() > 0.0);
    assert!(j["timing"]["total_s"].as_f64().unwrap() > 0.0);
    assert_eq!(j["candidates"][0][0]["effect"], "friction");
    assert!(plots.len() >= 2, "{plots:?}");
    for p in &plots {
        assert!(std::fs::metadata(dir.join(p)).unwrap().len() > 1000);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A lightly damped free oscillation over about ten periods (mass 4 kg against a start of 1 kg,
/// damping 0.2 against 2 N·s/m): the direct fit from the start values locks onto a wrong
/// period; the growing-horizon calibration (`workflow::calibrate_base`) finds the true values.
#[test]
fn an_oscillation_over_many_periods_is_calibrated_over_growing_horizons() {
    let dt = 4e-3;
    let n = 5000;
    let time: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    let u: Vec<f64> = time
        .iter()
        .map(|&t| if t < 0.5 { 5.0 } else { 0.0 })
        .collect();
    let m = Msd::new(time, u);
    let mut rng = Rng::new(11);
    let d = measure(&m, &[(M, 4.0), (C, 0.2)], &mut rng, 0.01, 0.0, &[0, 1]);
    let r = workflow::run(&m, &d, &Config::default()).expect("workflow");
    let cal = &r.calibration;
    let growing = cal.horizons.last().expect("horizons").1;
    // Two outputs over the training part: chi-square ~ 2 * 3500 at the truth.
    let at_noise = 2.0 * r.train_samples as f64;
    assert!(growing < 1.2 * at_noise, "{cal:?}");
    assert!(cal.direct_chi2 > 10.0 * at_noise, "{cal:?}");
    assert_eq!(cal.chosen, workflow::CalibrationFit::GrowingHorizons);
    assert_eq!(cal.horizons.len(), 3, "{cal:?}");
    for (name, truth) in [("mass", 4.0), ("damping", 0.2)] {
        let e = &r.parameters[name];
        assert!(e.ci_low < truth && truth < e.ci_high, "{name}: {e:?}");
    }
    assert!(r.named.is_empty(), "{:?}", r.verdict);
}

/// Strong Coulomb friction hidden from the start: the base model misses even the first quarter
/// of the trace by far, so the growing-horizon calibration has no anchor and is not continued;
/// the direct fit is kept and the friction is named from it.
#[test]
fn a_model_that_misses_the_start_gets_no_growing_horizon_fit() {
    let r = run(1, &[(M, 1.2), (FRICTION_ON, 1.0), (FRICTION_FC, 3.0)], 0.0);
    let cal = &r.calibration;
    let (n_first, chi2_first) = match cal.horizons[..] {
        [first] => first,
        _ => panic!("continued: {cal:?}"),
    };
    assert!(chi2_first > 2.0 * (2 * n_first) as f64, "{cal:?}");
    assert_eq!(cal.chosen, workflow::CalibrationFit::Direct);
    assert_eq!(r.named, vec!["friction".to_string()], "{:?}", r.verdict);
    let text = cal.text(&r.traces.time, r.train_samples, 2);
    assert!(text.contains("was not continued"), "{text}");
}
