//! Measured records with missing samples (an empty or `NaN` cell, as loggers write a dropped
//! sample): the rows holding one are left out and the inputs bridged over them by the
//! interpolation every record's inputs get, up to [`MAX_LEFT_OUT_SHARE`] of the rows.

use crate::policy::MAX_LEFT_OUT_SHARE;
use crate::workflow::{Data, InputError};

/// The rows of a record left out for a missing sample.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LeftOut {
    /// Rows left out.
    pub rows: usize,
    /// Rows of the record.
    pub of: usize,
    /// Missing samples per column that misses any, in the record's column order.
    pub by_column: Vec<(String, usize)>,
    /// Time of the first row left out (s).
    pub first_time: f64,
}

/// `data` without its rows that miss a sample in an input or an output; `None` when no row
/// does. Err when more than [`MAX_LEFT_OUT_SHARE`] of the rows miss one.
pub fn leave_out_missing(data: Data) -> Result<(Data, Option<LeftOut>), InputError> {
    let n = data.time.len();
    let columns = || data.inputs.iter().chain(&data.outputs);
    let keep: Vec<bool> = (0..n)
        .map(|i| columns().all(|(_, v)| !v.get(i).is_some_and(|x| x.is_nan())))
        .collect();
    let rows = keep.iter().filter(|k| !**k).count();
    if rows == 0 {
        return Ok((data, None));
    }
    let by_column: Vec<(String, usize)> = columns()
        .map(|(name, v)| (name.clone(), v.iter().filter(|x| x.is_nan()).count()))
        .filter(|(_, count)| *count > 0)
        .collect();
    if rows as f64 > MAX_LEFT_OUT_SHARE * n as f64 {
        let (column, in_column) = by_column
            .iter()
            .max_by_key(|(_, count)| *count)
            .cloned()
            .unwrap_or_default();
        return Err(InputError::TooManyMissing {
            rows,
            of: n,
            column,
            in_column,
        });
    }
    let first_time = data.time[keep.iter().position(|k| !k).unwrap_or(0)];
    let kept = |v: &[f64]| -> Vec<f64> {
        v.iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(x, _)| *x)
            .collect()
    };
    let kept_columns = |cols: &[(String, Vec<f64>)]| -> Vec<(String, Vec<f64>)> {
        cols.iter()
            .map(|(name, v)| (name.clone(), kept(v)))
            .collect()
    };
    let left_out = LeftOut {
        rows,
        of: n,
        by_column,
        first_time,
    };
    let data = Data {
        time: kept(&data.time),
        inputs: kept_columns(&data.inputs),
        outputs: kept_columns(&data.outputs),
    };
    Ok((data, Some(left_out)))
}

#[cfg(test)]
mod tests {
    use super::{leave_out_missing, LeftOut};
    use crate::workflow::{Data, InputError};

    fn record(y: Vec<f64>) -> Data {
        let n = y.len();
        Data {
            time: (0..n).map(|i| i as f64 * 0.5).collect(),
            inputs: vec![("u".into(), (0..n).map(|i| i as f64).collect())],
            outputs: vec![("y".into(), y)],
        }
    }

    #[test]
    fn rows_missing_a_sample_are_left_out_and_counted() {
        let mut y: Vec<f64> = (0..20).map(|i| 10.0 + i as f64).collect();
        y[3] = f64::NAN;
        y[7] = f64::NAN;
        let (data, left) = leave_out_missing(record(y)).unwrap();
        assert_eq!(data.time.len(), 18);
        assert_eq!(data.time[3], 2.0, "the row at t = 1.5 s is gone");
        assert_eq!(data.inputs[0].1[3], 4.0, "inputs lose the same rows");
        assert!(data.outputs[0].1.iter().all(|x| x.is_finite()));
        let expected = LeftOut {
            rows: 2,
            of: 20,
            by_column: vec![("y".into(), 2)],
            first_time: 1.5,
        };
        assert_eq!(left, Some(expected));
    }

    #[test]
    fn a_complete_record_is_unchanged() {
        let y: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let (data, left) = leave_out_missing(record(y.clone())).unwrap();
        assert_eq!((data.outputs[0].1.clone(), left), (y, None));
    }

    #[test]
    fn more_than_a_tenth_of_the_rows_missing_is_refused_naming_the_column() {
        let y: Vec<f64> = (0..20)
            .map(|i| if i % 4 == 0 { f64::NAN } else { 1.0 })
            .collect();
        match leave_out_missing(record(y)) {
            Err(InputError::TooManyMissing {
                rows: 5,
                of: 20,
                column,
                in_column: 5,
            }) => assert_eq!(column, "y"),
            other => panic!("{other:?}"),
        }
    }
}
