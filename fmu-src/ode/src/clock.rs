//! Exact sample instants for controllers sampled at a fixed rate.
//!
//! Sample `k` is at `t_k = start + k * period`, computed from the integer counter every time
//! (never by accumulating floats), so the instants are the same whatever the communication step.

use serde::{Deserialize, Serialize};

/// A fixed-rate sample clock: instants `start + k * period`, `k = 0, 1, 2, ...`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleClock {
    /// Time of sample 0 (s).
    pub start: f64,
    /// Sample period Ts (s), finite and > 0.
    pub period: f64,
}

impl SampleClock {
    /// A clock with sample 0 at `start` and period `period`; `None` unless `period` is finite and
    /// > 0 and `start` is finite.
    pub fn new(start: f64, period: f64) -> Option<Self> {
        (start.is_finite() && period.is_finite() && period > 0.0)
            .then_some(SampleClock { start, period })
    }

    /// Instant of sample `k`: `t_k = start + k * period`.
    pub fn time(&self, k: u64) -> f64 {
        self.start + k as f64 * self.period
    }

    /// Tolerance (in seconds) under which a time counts as reaching a sample instant:
    /// `1e-9` periods. A communication point computed by an importer as `t + h` carries rounding
    /// of order 1e-16 `t`, so a sample instant it meant to hit may lie just after it; far below
    /// any meaningful sub-interval, the tolerance treats such a point as the instant itself.
    pub fn tolerance(&self) -> f64 {
        1e-9 * self.period
    }

    /// True when sample `k` is due at `t`: `time(k) <= t` within [`Self::tolerance`].
    pub fn is_due(&self, k: u64, t: f64) -> bool {
        self.time(k) <= t + self.tolerance()
    }

    /// The index following every sample due at `t`, and at least `k + 1`: after one controller
    /// update at `t`, the samples a long communication step jumped over are not replayed.
    pub fn after_due(&self, k: u64, t: f64) -> u64 {
        let due = ((t + self.tolerance() - self.start) / self.period)
            .floor()
            .max(0.0) as u64;
        due.max(k) + 1
    }

    /// Where an integration from a point whose next sample is `k` must stop on its way to
    /// `t_end`: `(time(k), true)` when sample `k` comes first (earlier than `t_end` by more than
    /// the tolerance), else `(t_end, false)`.
    pub fn stop_before(&self, k: u64, t_end: f64) -> (f64, bool) {
        let tk = self.time(k);
        if tk < t_end - self.tolerance() {
            (tk, true)
        } else {
            (t_end, false)
        }
    }

    /// Smallest `k` with `time(k) >= t` (0 for `t <= start`; saturates for huge or NaN `t`).
    pub fn index_at_or_after(&self, t: f64) -> u64 {
        if t.is_nan() || t <= self.start {
            return 0;
        }
        let guess = ((t - self.start) / self.period).floor();
        if guess >= u64::MAX as f64 / 2.0 {
            return u64::MAX / 2;
        }
        // The floating division may be off by one either way: correct against `time(k)`.
        let mut k = guess.max(0.0) as u64;
        while k > 0 && self.time(k - 1) >= t {
            k -= 1;
        }
        while self.time(k) < t {
            k += 1;
        }
        k
    }

    /// Smallest `k` with `time(k) > t` (the next sample strictly after `t`).
    pub fn next_sample_after(&self, t: f64) -> u64 {
        let mut k = self.index_at_or_after(t);
        if self.time(k) <= t {
            k += 1;
        }
        k
    }

    /// Split `[t0, t1]` at the sample instants strictly inside it and return the sub-interval
    /// ends in order, each with the sample index it ends on (if any). The last end is exactly
    /// `t1`; an end that is a sample instant is exactly `time(k)`. Allocation-free iterator.
    pub fn segments(&self, t0: f64, t1: f64) -> Segments {
        Segments {
            clock: *self,
            t: t0,
            t1,
            k: self.next_sample_after(t0),
            done: t0.is_nan() || t1.is_nan() || t1 <= t0,
        }
    }
}

/// Iterator returned by [`SampleClock::segments`]: items `(t_end, Some(k))` when the segment ends
/// on sample `k` (so `t_end == clock.time(k)`), `(t1, None)` for a final segment ending between
/// samples.
#[derive(Clone, Debug)]
pub struct Segments {
    clock: SampleClock,
    t: f64,
    t1: f64,
    k: u64,
    done: bool,
}

impl Iterator for Segments {
    type Item = (f64, Option<u64>);
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let ts = self.clock.time(self.k);
        if ts < self.t1 {
            let k = self.k;
            self.t = ts;
            self.k += 1;
            Some((ts, Some(k)))
        } else if ts == self.t1 {
            self.done = true;
            let k = self.k;
            self.k += 1;
            Some((ts, Some(k)))
        } else {
            self.done = true;
            self.t = self.t1;
            Some((self.t1, None))
        }
    }
}

#[cfg(test)]
mod sampled_loop_tests {
    use super::SampleClock;

    #[test]
    fn a_communication_point_rounded_just_before_a_sample_counts_as_the_sample() {
        let c = SampleClock::new(0.0, 0.025).unwrap();
        // 25 steps of 1 ms accumulate to 0.025000000000000012: sample 1 is due there
        let t: f64 = (0..25).map(|_| 1e-3).sum();
        assert!(c.is_due(1, t) && c.is_due(1, 0.025 - 1e-13) && !c.is_due(1, 0.0249));
        // a step ending 1e-13 s after sample 1 does not integrate a 1e-13 s sliver
        assert_eq!(c.stop_before(1, 0.025 + 1e-13), (0.025 + 1e-13, false));
        assert_eq!(c.stop_before(1, 0.03), (0.025, true));
        assert_eq!(c.stop_before(2, 0.03), (0.03, false));
    }

    #[test]
    fn samples_jumped_over_by_a_long_step_are_not_replayed() {
        let c = SampleClock::new(1.0, 0.5).unwrap();
        assert_eq!(c.after_due(0, 1.0), 1);
        assert_eq!(c.after_due(0, 3.2), 5); // samples 0..=4 (1.0 .. 3.0) were due at 3.2
        assert_eq!(c.after_due(7, 3.2), 8);
    }
}
