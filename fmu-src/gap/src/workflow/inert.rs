//! Candidates whose best scanned setting is inert: where a level or a threshold lies beyond
//! what the signal reaches (a saturation above its peak, a dead zone of zero width), the sum of
//! squares is flat in the effect's parameters and a local refit started there stays there or
//! ends on a bound. Such a candidate's range is searched, one parameter at a time, on a finer
//! grid spaced as the parameter acts (geometrically for a positive level or width, evenly in
//! the fitting coordinate otherwise), so its refit starts where the effect acts.

use super::Ctx;
use crate::lm::{Bounded, Coord};
use crate::policy::{RANGE_SEARCH_FLOOR, RANGE_SEARCH_POINTS};
use crate::sim::GridModel;

/// The values a parameter of range `b` takes in the range search: [`RANGE_SEARCH_POINTS`]
/// of them, evenly spaced in the log coordinate of a positive wide range, geometrically from
/// [`RANGE_SEARCH_FLOOR`] of the upper end (or the lower end if larger) for a range that begins
/// at or above 0, evenly otherwise. Empty for an unbounded range.
pub(super) fn search_values(b: &Bounded) -> Vec<f64> {
    let m = RANGE_SEARCH_POINTS.max(2);
    let (lo, hi) = (b.lo, b.hi);
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return Vec::new();
    }
    let even = |a: f64, c: f64| -> Vec<f64> {
        (0..m)
            .map(|i| a + (c - a) * i as f64 / (m - 1) as f64)
            .collect()
    };
    match b.coord {
        Coord::Log => even(libm::log(lo), libm::log(hi))
            .into_iter()
            .map(libm::exp)
            .collect(),
        Coord::Linear(_) if lo >= 0.0 && hi > 0.0 => {
            let from = lo.max(RANGE_SEARCH_FLOOR * hi);
            even(libm::log(from), libm::log(hi))
                .into_iter()
                .map(|z| libm::exp(z).clamp(lo, hi))
                .collect()
        }
        Coord::Linear(_) => even(lo, hi),
    }
}

/// The settings of effect `e` searched from its inert setting `at`: each parameter in turn
/// over [`search_values`], the others held at `at`.
pub(super) fn search_points<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    e: usize,
    at: &[(usize, f64)],
) -> Vec<Vec<(usize, f64)>> {
    let mut pts = Vec::new();
    for &i in &ctx.effects[e].params {
        let q = &ctx.params[i];
        for v in search_values(&Bounded::new(q.start, q.min, q.max)) {
            let mut pt: Vec<(usize, f64)> = ctx.effects[e]
                .params
                .iter()
                .map(|&j| {
                    let given = ctx.params[j].start;
                    (j, at.iter().find(|x| x.0 == j).map_or(given, |x| x.1))
                })
                .collect();
            if let Some(x) = pt.iter_mut().find(|x| x.0 == i) {
                x.1 = v;
            }
            if !pts.contains(&pt) && pt.as_slice() != at {
                pts.push(pt);
            }
        }
    }
    pts
}

#[cfg(test)]
mod tests {
    use super::search_values;
    use crate::lm::Bounded;
    use crate::policy::{RANGE_SEARCH_FLOOR, RANGE_SEARCH_POINTS};

    fn ratios(v: &[f64]) -> Vec<f64> {
        v.windows(2).map(|w| w[1] / w[0]).collect()
    }

    #[test]
    fn a_level_from_zero_is_searched_geometrically_from_a_thousandth_of_its_range() {
        // A current limit in [0, 100] A starting at 100 A: its linear scan (0, 25, ..., 100)
        // has nothing between 0 and 25 A; the search goes 0.1 A, ..., 100 A by equal factors.
        let v = search_values(&Bounded::new(100.0, Some(0.0), Some(100.0)));
        assert_eq!(v.len(), RANGE_SEARCH_POINTS);
        assert!((v[0] - RANGE_SEARCH_FLOOR * 100.0).abs() < 1e-12);
        assert!((v[v.len() - 1] - 100.0).abs() < 1e-9);
        let r = ratios(&v);
        let f = libm::pow(1.0 / RANGE_SEARCH_FLOOR, 1.0 / (v.len() - 1) as f64);
        assert!(r.iter().all(|x| (x - f).abs() < 1e-9), "{r:?}");
        // every value between 2 A and 3 A is within a factor f of a searched one
        assert!(v.iter().any(|x| (2.0..2.0 * f).contains(x)));
    }

    #[test]
    fn a_wide_positive_range_is_searched_evenly_in_its_log_and_one_through_zero_evenly() {
        let v = search_values(&Bounded::new(2e-5, Some(1e-6), Some(5e-4)));
        let r = ratios(&v);
        assert!((v[0] - 1e-6).abs() < 1e-18 && (v[v.len() - 1] - 5e-4).abs() < 1e-15);
        assert!(r.iter().all(|x| (x - r[0]).abs() < 1e-9));
        let v = search_values(&Bounded::new(0.1, Some(-0.5), Some(0.5)));
        assert!((v[0] + 0.5).abs() < 1e-12 && (v[v.len() - 1] - 0.5).abs() < 1e-12);
        let d: Vec<f64> = v.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(d
            .iter()
            .all(|x| (x - 1.0 / (v.len() - 1) as f64).abs() < 1e-12));
        assert!(search_values(&Bounded::new(1.0, None, Some(2.0))).is_empty());
    }
}
