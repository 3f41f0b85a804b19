//! The library of input signals an experiment design chooses from: for one input with range
//! `[lo, hi]` on a time grid, square waves, staircases, triangles and raised cosines between the
//! ends of several windows of the range (all of it, its lower and upper fifths, half the way from the start value to each end, and windows
//! around zero when the range spans it: small reversals are what a backlash or a friction
//! reversal needs), at two periods. Every signal starts at the input's start value and leaves it
//! along a minimum-jerk move, so the model starts at rest and no step excites what the effect
//! should explain. [`gentlest_first`] orders them for the search. Deterministic: the same grid
//! and range give the same signals.

use crate::policy::{PERIODS, REST};
use std::f64::consts::PI;

/// One candidate signal of one input.
#[derive(Clone, Debug)]
pub struct Signal {
    /// What it is, for the report: e.g. "square 0 .. 402 rad, period 1.25 s".
    pub label: String,
    pub values: Vec<f64>,
}

/// Minimum-jerk blend from 0 to 1 over `s` in [0, 1] (10 s^3 − 15 s^4 + 6 s^5).
fn min_jerk(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
}

/// The windows `(a, b)` of `[lo, hi]` the library excites: the whole range, its lower and upper
/// fifths, half the way from the start value towards each end, and, when the range spans zero,
/// windows around zero of 2, 10 and 25 % of the range each side. The intermediate ones let the
/// design stop short of the range's ends when less already shows the effect (see
/// [`super::ENOUGH`]).
fn windows(lo: f64, hi: f64, start: f64) -> Vec<(&'static str, f64, f64)> {
    let w = hi - lo;
    let mut v = vec![
        ("whole range", lo, hi),
        ("lower fifth", lo, lo + 0.2 * w),
        ("upper fifth", hi - 0.2 * w, hi),
    ];
    if hi > start {
        v.push((
            "half way up from the start",
            start,
            start + 0.5 * (hi - start),
        ));
    }
    if lo < start {
        v.push((
            "half way down from the start",
            start - 0.5 * (start - lo),
            start,
        ));
    }
    if lo < 0.0 && hi > 0.0 {
        for f in [0.25, 0.1, 0.02] {
            v.push(("around zero", (-f * w).max(lo), (f * w).min(hi)));
        }
    }
    v
}

/// A periodic waveform `g(phase) ∈ [0, 1]` over one period.
type Wave = fn(f64) -> f64;

/// Square wave with minimum-jerk edges taking 15 % of each half period.
fn square(ph: f64) -> f64 {
    let up = min_jerk(ph / 0.15);
    let down = min_jerk((ph - 0.5) / 0.15);
    up - down
}

/// Five levels up and back down (dwell a fifth of a half period each), minimum-jerk edges.
fn staircase(ph: f64) -> f64 {
    let k = (ph * 10.0).floor();
    let within = ph * 10.0 - k;
    let level = |k: f64| {
        {
            let k = k.rem_euclid(10.0);
            if k < 5.0 {
                k / 4.0
            } else {
                (9.0 - k) / 4.0
            }
        }
        .min(1.0)
    };
    let prev = level(k - 1.0);
    let cur = level(k);
    prev + (cur - prev) * min_jerk(within / 0.3)
}

fn triangle(ph: f64) -> f64 {
    1.0 - (2.0 * ph - 1.0).abs()
}

fn raised_cosine(ph: f64) -> f64 {
    0.5 * (1.0 - libm::cos(2.0 * PI * ph))
}

const WAVES: [(&str, Wave); 4] = [
    ("square", square),
    ("staircase", staircase),
    ("triangle", triangle),
    ("raised cosine", raised_cosine),
];

/// `a + (b − a) g(phase)` after a rest at `start` and a minimum-jerk move onto the waveform.
fn shaped(t: &[f64], start: f64, a: f64, b: f64, period: f64, g: Wave) -> Vec<f64> {
    let (t0, dur) = (t[0], t[t.len() - 1] - t[0]);
    let begin = t0 + REST * dur;
    let settle = (0.15 * period).max(f64::EPSILON);
    t.iter()
        .map(|&ti| {
            if ti < begin {
                return start;
            }
            let ph = ((ti - begin) / period).fract();
            let target = a + (b - a) * g(ph);
            start + (target - start) * min_jerk((ti - begin) / settle)
        })
        .collect()
}

/// Every signal of the library for an input with range `[lo, hi]` and start value `start`.
pub fn library(t: &[f64], lo: f64, hi: f64, start: f64, unit: &str) -> Vec<Signal> {
    let dur = t[t.len() - 1] - t[0];
    let start = start.clamp(lo, hi);
    let mut out = Vec::new();
    for (wname, a, b) in windows(lo, hi, start) {
        for (gname, g) in WAVES {
            for f in PERIODS {
                let period = f * dur;
                out.push(Signal {
                    label: format!(
                        "{gname} {a:.4} .. {b:.4} {unit} ({wname}), period {period:.3} s"
                    ),
                    values: shaped(t, start, a, b, period, g),
                });
            }
        }
    }
    out
}

/// Largest distance of a signal from the start value.
pub fn excursion(values: &[f64], start: f64) -> f64 {
    values.iter().fold(0.0_f64, |m, v| m.max((v - start).abs()))
}

/// Signals in the order the design's search tries them, which takes the first that is good
/// enough: within `envelope` (the excursion of the data at hand) the widest first, since they
/// excite the base parameters at least as the data did; beyond it the least excursion first, to
/// leave the operating range the base parameters were calibrated in no further than needed.
/// Stable within equal keys.
pub fn gentlest_first(mut signals: Vec<Signal>, start: f64, envelope: f64) -> Vec<Signal> {
    let key = |s: &Signal| {
        let e = excursion(&s.values, start);
        if e <= envelope {
            (0, -e)
        } else {
            (1, e)
        }
    };
    signals.sort_by(|a, b| {
        let (ka, kb) = (key(a), key(b));
        ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
    signals
}

/// Levels for an input that accompanies another one's signal: its start value, the ends and the
/// middle of its range. Like every signal, each rests at the start value first and moves to its
/// level along a minimum-jerk move (over 15 % of the shorter period): an FMU initialises at its
/// inputs' start values, and a level out of its rest state from time 0 could leave it no
/// initial equilibrium (a TwistedString load pushing the strings slack).
pub fn constants(t: &[f64], lo: f64, hi: f64, start: f64, unit: &str) -> Vec<Signal> {
    let start = start.clamp(lo, hi);
    let mut levels = vec![start, lo, 0.5 * (lo + hi), hi];
    levels.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * (hi - lo).abs());
    let mut seen: Vec<f64> = Vec::new();
    let period = PERIODS[0] * (t[t.len() - 1] - t[0]);
    levels
        .into_iter()
        .filter(|x| {
            let new = !seen.contains(x);
            seen.push(*x);
            new
        })
        .map(|x| Signal {
            label: format!("level {x:.4} {unit}"),
            values: shaped(t, start, x, x, period, |_| 0.0),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{constants, excursion, gentlest_first, library, shaped, square};

    fn grid() -> Vec<f64> {
        (0..=1000).map(|i| i as f64 * 0.01).collect()
    }

    #[test]
    fn every_signal_starts_at_rest_and_stays_in_range() {
        let t = grid();
        let lib = library(&t, -2.0, 6.0, 0.0, "rad");
        // 8 windows (two from the start, three around zero) x 4 waves x 2 periods.
        assert_eq!(lib.len(), 64);
        for s in &lib {
            assert_eq!(s.values[0], 0.0, "{}", s.label);
            assert!(
                s.values.iter().all(|v| (-2.0..=6.0).contains(v)),
                "{}",
                s.label
            );
            // It moves: the experiment excites something.
            let (mn, mx) = s
                .values
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
            assert!(mx - mn > 0.01, "{}", s.label);
        }
    }

    #[test]
    fn within_the_envelope_the_widest_first_beyond_it_the_least_excursion() {
        let t = grid();
        let lib = gentlest_first(library(&t, -2.0, 6.0, 0.0, "rad"), 0.0, 1.0);
        let reaches: Vec<f64> = lib.iter().map(|s| excursion(&s.values, 0.0)).collect();
        let inside = reaches.iter().take_while(|&&e| e <= 1.0).count();
        // Inside: around zero at 10 % (0.8) then 2 % (0.16) of the range, and half way down (1).
        assert_eq!(inside, 24, "{reaches:?}");
        assert!(
            reaches[..inside].windows(2).all(|w| w[0] >= w[1]),
            "{reaches:?}"
        );
        assert!(
            reaches[inside..].windows(2).all(|w| w[0] <= w[1]),
            "{reaches:?}"
        );
        // The nearest window beyond reaches 2 (a fifth, or 25 % around zero).
        assert!(
            reaches[inside] > 1.9 && reaches[inside] <= 2.0,
            "{}",
            reaches[inside]
        );
        assert!((reaches[reaches.len() - 1] - 6.0).abs() < 1e-9);
    }

    #[test]
    fn a_square_wave_reaches_both_ends_of_its_window() {
        let t = grid();
        let s = shaped(&t, 0.0, 1.0, 3.0, 2.0, square);
        let (mn, mx) = s[100..]
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        assert!(
            (mn - 1.0).abs() < 1e-9 && (mx - 3.0).abs() < 1e-9,
            "{mn} {mx}"
        );
    }

    #[test]
    fn moves_are_smooth() {
        let t = grid();
        for s in library(&t, 0.0, 10.0, 0.0, "m") {
            let jump = s
                .values
                .windows(2)
                .map(|w| (w[1] - w[0]).abs())
                .fold(0.0, f64::max);
            // Edges are spread over several samples: no sample-to-sample jump of more than
            // 15 % of the range (a step would jump by all of its window).
            assert!(jump < 1.5, "{}: {jump}", s.label);
        }
    }

    #[test]
    fn levels_are_distinct_and_start_at_rest() {
        let t = grid();
        let c = constants(&t, -10.0, 40.0, 0.0, "N");
        let ends: Vec<f64> = c.iter().map(|s| *s.values.last().unwrap()).collect();
        assert_eq!(ends, vec![0.0, -10.0, 15.0, 40.0]);
        for s in &c {
            assert_eq!(s.values[0], 0.0, "{}", s.label);
            let jump = s
                .values
                .windows(2)
                .map(|w| (w[1] - w[0]).abs())
                .fold(0.0, f64::max);
            assert!(jump < 7.5, "{}: {jump}", s.label);
        }
    }
}
