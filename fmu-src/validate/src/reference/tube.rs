//! A result against a reference trace in a tolerance tube, the method of the Modelica
//! community's csv-compare (modelica-tools/csv-compare, "Rectangle" algorithm): around every
//! point of the reference curve stands a rectangle of half width `dx` in time and half height
//! `dy` in value; the tube is the union of the rectangles, and the result passes where each of
//! its points lies inside. A step of the reference thus tolerates a result whose step is up to
//! `dx` early or late, while a smooth stretch is held to about `dy`.
//!
//! Sizes as csv-compare's relative tube: `dx = time_tolerance * (t_max - t_min)` of the
//! reference and `dy = rel_tolerance * base + abs_tolerance`, `base` the reference signal's
//! range `max - min` (its largest magnitude when it is constant). The rectangles are centred on
//! the piecewise-linear reference curve, so at time `t` the tube spans the smallest and largest
//! reference value over `[t - dx, t + dx]`, widened by `dy`.

/// The tube's size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerances {
    /// Half height relative to the reference signal's range.
    pub rel: f64,
    /// Half height added in the signal's unit.
    pub abs: f64,
    /// Half width relative to the reference's time span.
    pub time: f64,
}

impl Default for Tolerances {
    /// csv-compare's default tube, 0.002 relative in time and value.
    fn default() -> Self {
        Tolerances {
            rel: 2e-3,
            abs: 0.0,
            time: 2e-3,
        }
    }
}

/// Where a result first leaves the tube.
#[derive(Clone, Debug, PartialEq)]
pub struct Exit {
    /// Time of the result's first point outside the tube [s].
    pub time: f64,
    /// The result's value there.
    pub value: f64,
    /// The tube's lower and upper bound there.
    pub lower: f64,
    /// The tube's upper bound there.
    pub upper: f64,
}

impl Exit {
    /// How far the value lies outside the tube (positive).
    pub fn distance(&self) -> f64 {
        (self.lower - self.value).max(self.value - self.upper)
    }
}

/// The tube around the reference `(t, y)` (`t` increasing, at least one point).
#[derive(Clone, Debug)]
pub struct Tube<'a> {
    t: &'a [f64],
    y: &'a [f64],
    /// Half width in time [s].
    pub dx: f64,
    /// Half height in value.
    pub dy: f64,
}

impl<'a> Tube<'a> {
    /// The tube of size `tol` around the reference `(t, y)`.
    pub fn new(t: &'a [f64], y: &'a [f64], tol: Tolerances) -> Tube<'a> {
        let span = t.last().copied().unwrap_or(0.0) - t.first().copied().unwrap_or(0.0);
        let (lo, hi) = min_max(y);
        let range = hi - lo;
        let base = if range > 0.0 {
            range
        } else {
            lo.abs().max(hi.abs())
        };
        Tube {
            t,
            y,
            dx: tol.time * span,
            dy: tol.rel * base + tol.abs,
        }
    }

    /// The tube's bounds at `time`: the extreme reference values over `[time - dx, time + dx]`
    /// (the curve interpolated linearly, its end values held beyond its ends), widened by `dy`.
    pub fn bounds(&self, time: f64) -> (f64, f64) {
        let (a, b) = (time - self.dx, time + self.dx);
        let (ya, yb) = (self.at(a), self.at(b));
        let (mut lo, mut hi) = (ya.min(yb), ya.max(yb));
        let first = self.t.partition_point(|&x| x <= a);
        let last = self.t.partition_point(|&x| x < b);
        for &v in &self.y[first..last.max(first)] {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        (lo - self.dy, hi + self.dy)
    }

    /// The reference at `time`, interpolated linearly; the end values beyond the ends.
    fn at(&self, time: f64) -> f64 {
        let k = self.t.partition_point(|&x| x <= time);
        if k == 0 {
            return self.y[0];
        }
        if k == self.t.len() {
            return self.y[k - 1];
        }
        let (t0, t1, y0, y1) = (self.t[k - 1], self.t[k], self.y[k - 1], self.y[k]);
        if t1 > t0 {
            y0 + (y1 - y0) * (time - t0) / (t1 - t0)
        } else {
            y1
        }
    }

    /// The first point of the result `(time, value)` outside the tube, among those within the
    /// reference's time span (beyond it the reference says nothing); a NaN is outside.
    pub fn first_exit(&self, time: &[f64], value: &[f64]) -> Option<Exit> {
        let (t0, t1) = (self.t[0], self.t[self.t.len() - 1]);
        let slack = 1e-9 * (t1 - t0).abs().max(1.0);
        time.iter()
            .zip(value)
            .filter(|(&t, _)| t >= t0 - slack && t <= t1 + slack)
            .find_map(|(&t, &v)| {
                let (lower, upper) = self.bounds(t);
                (v.is_nan() || v < lower || v > upper).then_some(Exit {
                    time: t,
                    value: v,
                    lower,
                    upper,
                })
            })
    }
}

fn min_max(y: &[f64]) -> (f64, f64) {
    y.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 0, 0.01, ..., 1 s.
    fn grid() -> Vec<f64> {
        (0..=100).map(|k| k as f64 * 0.01).collect()
    }

    fn step_at(t: &[f64], at: f64) -> Vec<f64> {
        t.iter().map(|&x| if x >= at { 1.0 } else { 0.0 }).collect()
    }

    #[test]
    fn a_trace_inside_the_tube_passes() {
        let t = grid();
        // smooth step 3 x^2 - 2 x^3 from 0 to 1: range 1, dy = 0.002
        let reference: Vec<f64> = t.iter().map(|x| x * x * (3.0 - 2.0 * x)).collect();
        let result: Vec<f64> = reference.iter().map(|y| y + 0.0015).collect();
        let tube = Tube::new(&t, &reference, Tolerances::default());
        assert_eq!(tube.first_exit(&t, &result), None);
    }

    /// Where a unit step at `late` leaves the tube of a unit step at 0.5 with a time tolerance
    /// of 0.015 (dx = 15 ms over the 1 s span).
    fn late_step_exit(late: f64) -> Option<Exit> {
        let t = grid();
        let tol = Tolerances {
            time: 0.015,
            ..Tolerances::default()
        };
        Tube::new(&t, &step_at(&t, 0.5), tol).first_exit(&t, &step_at(&t, late))
    }

    #[test]
    fn a_step_within_the_time_tolerance_passes() {
        assert_eq!(late_step_exit(0.51), None);
    }

    #[test]
    fn a_step_shifted_beyond_the_time_tolerance_fails_at_the_step() {
        let exit = late_step_exit(0.55).expect("leaves the tube");
        // at 0.50 the reference's window [0.485, 0.515] reaches down to 0: inside; at 0.51 the
        // window [0.495, 0.525] starts halfway up the reference's ramp from 0.49 to 0.50, so the
        // tube's floor is 0.5 - dy while the late result is still 0
        assert!((exit.time - 0.51).abs() < 1e-12, "{exit:?}");
        assert_eq!(exit.value, 0.0);
        assert!((exit.distance() - (0.5 - 0.002)).abs() < 1e-9, "{exit:?}");
    }

    #[test]
    fn a_value_beyond_the_value_tolerance_fails() {
        let t = grid();
        let reference: Vec<f64> = t.iter().map(|x| 2.0 * x).collect();
        let mut result = reference.clone();
        result[70] += 0.01; // dy = 0.004, the slope adds 2 * dx = 0.004 at most
        let exit = Tube::new(&t, &reference, Tolerances::default())
            .first_exit(&t, &result)
            .expect("leaves the tube");
        assert!((exit.time - 0.7).abs() < 1e-12);
        assert!(exit.distance() > 0.0 && exit.distance() < 0.01);
    }

    #[test]
    fn a_constant_reference_takes_its_magnitude_as_base_and_nan_fails() {
        let t = grid();
        let reference = vec![5.0; t.len()];
        let tube = Tube::new(&t, &reference, Tolerances::default());
        assert!((tube.dy - 0.01).abs() < 1e-15);
        let mut result = vec![5.005; t.len()];
        assert_eq!(tube.first_exit(&t, &result), None);
        result[3] = f64::NAN;
        assert_eq!(tube.first_exit(&t, &result).map(|e| e.time), Some(0.03));
    }

    #[test]
    fn points_beyond_the_reference_span_are_not_judged() {
        let t = grid();
        let reference = vec![0.0; t.len()];
        let tube = Tube::new(&t, &reference, Tolerances::default());
        assert_eq!(tube.first_exit(&[1.5], &[100.0]), None);
    }
}
