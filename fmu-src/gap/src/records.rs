//! Several records of one model fitted with one parameter set (`gap --data A.csv --data B.csv`).
//!
//! The records are joined into one record that the workflow fits as it fits a single one
//! ([`Joined`], a [`GridModel`] over one simulator per record):
//! - **Order.** The training parts of all records first, then their held-out ends:
//!   `[A_train, B_train, …, A_held, B_held, …]`, so that the workflow's training part (a prefix
//!   of the joined trace) is every record's training part, and its held-out end every record's
//!   held-out end (each record's last `holdout` fraction). A simulation of the first `n` joined
//!   samples runs each record from its own start over the samples it needs.
//! - **Initial state.** Each record begins in its own state: the model's `[initial]` parameters
//!   apply to the first record, and for every further record `r` a copy named `<name>@r` (same
//!   tag, range and start) holds its own, estimated by the workflow when it estimates the first
//!   record's (the start test reads the first record's start).
//! - **Noise.** Each record keeps its own noise level per output (second differences,
//!   `noise::difference_level`): record `r`'s outputs, measured and simulated, are scaled by
//!   `w_rk = σ_1k / σ_rk`, so the weighted residual `(y − ŷ) w_rk / σ_1k = (y − ŷ)/σ_rk` is in
//!   record `r`'s own noise levels, and the likelihood terms of the records add. BIC counts the
//!   samples of all records. [`Joined::unscale`] takes the scale off the traces and errors
//!   reported.
//! - **Time.** The joined time axis lays the segments end to end (each shifted so that it
//!   begins one sample interval after the previous ends); [`RecordSpan`] maps it back.

use crate::policy::MIN_TRAIN_SAMPLES;
use crate::sim::{GridModel, SimError};
use crate::spec::{self, ParamSpec};
use crate::workflow::noise::difference_level;
use crate::workflow::{Data, GapError, GapResult, InputError};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// One contiguous part of a record in the joined trace: samples `from..to` of record `record`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Segment {
    record: usize,
    from: usize,
    to: usize,
}

impl Segment {
    fn len(&self) -> usize {
        self.to - self.from
    }
}

/// Where a record lies in the joined trace, for the report.
#[derive(Clone, Debug, Serialize)]
pub struct RecordSpan {
    /// The record's file (as given on the command line).
    pub data: String,
    pub samples: usize,
    pub train_samples: usize,
    /// Joined time of its training part and of its held-out end [s].
    pub train_joined_s: (f64, f64),
    pub held_out_joined_s: (f64, f64),
    /// The record's own time at its first and last sample [s].
    pub record_s: (f64, f64),
    /// Per measured output: the record's noise level (second differences).
    pub noise_white: BTreeMap<String, f64>,
    /// The record's own initial-state parameters (`<name>@r`; empty for the first record).
    pub initial_parameters: Vec<String>,
}

/// The records joined for the workflow: the simulator, the joined data and its training part.
pub struct Joined<'a, S: GridModel + ?Sized> {
    records: Vec<&'a S>,
    /// The model's parameters, then the copies of the initial-state ones for records 2, 3, …
    params: Vec<ParamSpec>,
    n_model: usize,
    /// Per copy (index `n_model + c`): its record and the model parameter it stands for.
    copies: Vec<(usize, usize)>,
    /// The model's initial-state parameters (copied for every further record).
    initial: Vec<usize>,
    segments: Vec<Segment>,
    /// Per record, per model output: the scale `w_rk` of its values.
    weights: Vec<Vec<f64>>,
    /// Joined index of each segment's first sample.
    starts: Vec<usize>,
    lens: Vec<usize>,
    spans: Vec<RecordSpan>,
}

/// The training samples of a record of `n` samples with `holdout` held out at its end, as the
/// workflow splits a single record.
fn train_samples(n: usize, holdout: f64) -> usize {
    ((n as f64) * (1.0 - holdout))
        .round()
        .clamp(MIN_TRAIN_SAMPLES, n as f64) as usize
}

impl<'a, S: GridModel + ?Sized> Joined<'a, S> {
    /// Joins `records` (a simulator per record, all of one model) with their `data` (same
    /// measured output columns in the same order) and `names` (their files). Returns the joined
    /// simulator and data, and the samples of the joined training part.
    pub fn new(
        records: Vec<&'a S>,
        data: &[Data],
        names: &[String],
        holdout: f64,
    ) -> Result<(Self, Data, usize), GapError> {
        let first = records.first().ok_or(InputError::NoOutputColumn)?;
        let model_params = first.params().to_vec();
        let outputs = first.output_names().to_vec();
        let columns: Vec<&String> = data[0].outputs.iter().map(|(s, _)| s).collect();
        for d in &data[1..] {
            let other: Vec<&String> = d.outputs.iter().map(|(s, _)| s).collect();
            if other != columns {
                return Err(InputError::RecordOutputs {
                    first: columns.iter().map(|s| s.to_string()).collect(),
                    other: other.iter().map(|s| s.to_string()).collect(),
                }
                .into());
            }
        }
        let initial = spec::initial_state(&model_params);
        let (params, copies) = with_copies(&model_params, &initial, records.len());
        let sigma: Vec<Vec<f64>> = data
            .iter()
            .map(|d| d.outputs.iter().map(|(_, y)| difference_level(y)).collect())
            .collect();
        let weights = weights(&sigma, &outputs, &columns);
        let lens: Vec<usize> = data.iter().map(|d| d.time.len()).collect();
        let train: Vec<usize> = lens.iter().map(|&n| train_samples(n, holdout)).collect();
        let segments: Vec<Segment> = (0..lens.len())
            .map(|r| Segment {
                record: r,
                from: 0,
                to: train[r],
            })
            .chain((0..lens.len()).map(|r| Segment {
                record: r,
                from: train[r],
                to: lens[r],
            }))
            .filter(|s| s.len() > 0)
            .collect();
        let mut starts = Vec::with_capacity(segments.len());
        let mut at = 0;
        for s in &segments {
            starts.push(at);
            at += s.len();
        }
        let joined = join_data(data, &segments, &weights, &outputs, &params)?;
        let n_model = model_params.len();
        let spans = spans(
            data,
            names,
            &segments,
            &joined.time,
            &starts,
            &sigma,
            &params,
            &copies,
            n_model,
        );
        let j = Joined {
            records,
            params,
            n_model,
            copies,
            initial,
            segments,
            weights,
            starts,
            lens,
            spans,
        };
        Ok((j, joined, train.iter().sum()))
    }

    /// Where each record lies in the joined trace.
    pub fn spans(&self) -> &[RecordSpan] {
        &self.spans
    }

    /// Record and the record's own sample of each joined sample.
    pub fn sample_origin(&self) -> Vec<(usize, usize)> {
        self.segments
            .iter()
            .flat_map(|s| (s.from..s.to).map(move |i| (s.record, i)))
            .collect()
    }

    /// The settings of one record from the joined settings: a model parameter applies to every
    /// record except an initial-state one, which applies to the first record; a copy applies
    /// to its record as the parameter it stands for.
    fn record_settings(&self, set: &[(usize, f64)], r: usize) -> Vec<(usize, f64)> {
        set.iter()
            .filter_map(|&(i, v)| {
                if i < self.n_model {
                    (r == 0 || !self.initial.contains(&i)).then_some((i, v))
                } else {
                    let (rec, p) = self.copies[i - self.n_model];
                    (rec == r).then_some((p, v))
                }
            })
            .collect()
    }

    /// Samples of each record the first `n` joined samples need.
    fn needed(&self, n: usize) -> Vec<usize> {
        let mut need = vec![0; self.lens.len()];
        for (s, &at) in self.segments.iter().zip(&self.starts) {
            if at < n {
                let end = s.from + (n - at).min(s.len());
                need[s.record] = need[s.record].max(end);
            }
        }
        need
    }

    /// Takes the record scale off the result's traces and recomputes its errors per output from
    /// them (the workflow saw record `r`'s values × `w_rk`).
    pub fn unscale(&self, res: &mut GapResult) {
        let origin = self.sample_origin();
        let model_names = self.records[0].output_names();
        for o in &mut res.traces.outputs {
            let Some(k) = model_names.iter().position(|s| s == &o.name) else {
                continue;
            };
            for v in [
                &mut o.measured,
                &mut o.nominal,
                &mut o.base_fit,
                &mut o.final_fit,
            ] {
                for (x, &(r, _)) in v.iter_mut().zip(&origin) {
                    *x /= self.weights[r][k];
                }
            }
            if let Some(e) = res.outputs.get_mut(&o.name) {
                let err = |m: &[f64]| errors(&o.measured, m);
                (e.rmse_before, e.max_before) = err(&o.nominal);
                (e.rmse_base_fit, e.max_base_fit) = err(&o.base_fit);
                (e.rmse_after, e.max_after) = err(&o.final_fit);
                e.mean_after = o
                    .final_fit
                    .iter()
                    .zip(&o.measured)
                    .map(|(m, d)| m - d)
                    .sum::<f64>()
                    / o.measured.len().max(1) as f64;
                e.unexplained_rms = (crate::stats::sq(e.rmse_after)
                    - crate::stats::sq(e.noise_white))
                .max(0.0)
                .sqrt();
            }
        }
    }
}

/// RMS and largest absolute difference of `model` from `measured`.
pub(crate) fn errors(measured: &[f64], model: &[f64]) -> (f64, f64) {
    let d: Vec<f64> = model.iter().zip(measured).map(|(a, b)| a - b).collect();
    let max = d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    (crate::stats::rms(&d), max)
}

/// The model's parameters followed by a copy of each initial-state parameter for every record
/// after the first (`<name>@r`, r counting from 1), and per copy its record and original.
fn with_copies(
    params: &[ParamSpec],
    initial: &[usize],
    records: usize,
) -> (Vec<ParamSpec>, Vec<(usize, usize)>) {
    let mut all = params.to_vec();
    let mut copies = Vec::new();
    for r in 1..records {
        for &i in initial {
            let mut p = params[i].clone();
            p.name = format!("{}@{}", p.name, r + 1);
            all.push(p);
            copies.push((r, i));
        }
    }
    (all, copies)
}

/// Per record, per model output: `σ_1k / σ_rk` for a measured output `k`, 1 for the others.
fn weights(sigma: &[Vec<f64>], outputs: &[String], columns: &[&String]) -> Vec<Vec<f64>> {
    sigma
        .iter()
        .map(|s| {
            outputs
                .iter()
                .map(|name| {
                    columns
                        .iter()
                        .position(|c| *c == name)
                        .map_or(1.0, |j| sigma[0][j] / s[j])
                })
                .collect()
        })
        .collect()
}

/// The joined data: segments end to end on one time axis, measured outputs scaled by their
/// record's weights, inputs (union of the records' columns; a record without a column has the
/// input's start value there).
fn join_data(
    data: &[Data],
    segments: &[Segment],
    weights: &[Vec<f64>],
    outputs: &[String],
    params: &[ParamSpec],
) -> Result<Data, GapError> {
    let mut time = Vec::new();
    for s in segments {
        let t = &data[s.record].time;
        let dt = host::csv::sample_interval(t).ok_or(InputError::NoSampleInterval)?;
        let shift = time
            .last()
            .map_or(-t[s.from], |&last: &f64| last + dt - t[s.from]);
        time.extend(t[s.from..s.to].iter().map(|x| x + shift));
    }
    let out_cols = data[0]
        .outputs
        .iter()
        .enumerate()
        .map(|(j, (name, _))| {
            let k = outputs.iter().position(|s| s == name);
            let v = segments
                .iter()
                .flat_map(|s| {
                    let w = k.map_or(1.0, |k| weights[s.record][k]);
                    data[s.record].outputs[j].1[s.from..s.to]
                        .iter()
                        .map(move |y| y * w)
                })
                .collect();
            (name.clone(), v)
        })
        .collect();
    let mut in_names: Vec<&String> = Vec::new();
    for d in data {
        for (name, _) in &d.inputs {
            if !in_names.contains(&name) {
                in_names.push(name);
            }
        }
    }
    let inputs = in_names
        .iter()
        .map(|name| {
            let start = params
                .iter()
                .find(|p| &&p.name == name)
                .map_or(0.0, |p| p.start);
            let v = segments
                .iter()
                .flat_map(|s| {
                    let col = data[s.record].inputs.iter().find(|(c, _)| c == *name);
                    (s.from..s.to).map(move |i| col.map_or(start, |(_, v)| v[i]))
                })
                .collect();
            ((*name).clone(), v)
        })
        .collect();
    Ok(Data {
        time,
        inputs,
        outputs: out_cols,
    })
}

/// The report's map of the joined trace back to the records.
#[allow(clippy::too_many_arguments)]
fn spans(
    data: &[Data],
    names: &[String],
    segments: &[Segment],
    joined_time: &[f64],
    starts: &[usize],
    sigma: &[Vec<f64>],
    params: &[ParamSpec],
    copies: &[(usize, usize)],
    n_model: usize,
) -> Vec<RecordSpan> {
    let range = |r: usize, held: bool| {
        segments
            .iter()
            .zip(starts)
            .find(|(s, _)| s.record == r && (s.from > 0) == held)
            .map_or((f64::NAN, f64::NAN), |(s, &at)| {
                (joined_time[at], joined_time[at + s.len() - 1])
            })
    };
    data.iter()
        .enumerate()
        .map(|(r, d)| RecordSpan {
            data: names.get(r).cloned().unwrap_or_default(),
            samples: d.time.len(),
            train_samples: segments
                .iter()
                .find(|s| s.record == r && s.from == 0)
                .map_or(0, |s| s.len()),
            train_joined_s: range(r, false),
            held_out_joined_s: range(r, true),
            record_s: (d.time[0], *d.time.last().unwrap_or(&d.time[0])),
            noise_white: d
                .outputs
                .iter()
                .zip(&sigma[r])
                .map(|((n, _), s)| (n.clone(), *s))
                .collect(),
            initial_parameters: copies
                .iter()
                .enumerate()
                .filter(|(_, (rec, _))| *rec == r)
                .map(|(c, _)| params[n_model + c].name.clone())
                .collect(),
        })
        .collect()
}

impl<S: GridModel + ?Sized> GridModel for Joined<'_, S> {
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }

    fn output_names(&self) -> &[String] {
        self.records[0].output_names()
    }

    /// Each record simulated from its own start over the samples the first `n` joined samples
    /// need (in parallel), its values scaled by its weights, laid out in the joined order.
    fn simulate(&self, set: &[(usize, f64)], n: usize) -> Result<Vec<Vec<f64>>, SimError> {
        let need = self.needed(n);
        let runs: Vec<Option<Vec<Vec<f64>>>> = (0..self.records.len())
            .into_par_iter()
            .map(|r| {
                if need[r] == 0 {
                    return Ok(None);
                }
                let m = need[r].max(2).min(self.lens[r]);
                self.records[r]
                    .simulate(&self.record_settings(set, r), m)
                    .map(Some)
            })
            .collect::<Result<_, SimError>>()?;
        let k = self.output_names().len();
        let mut out = vec![Vec::with_capacity(n); k];
        for (s, &at) in self.segments.iter().zip(&self.starts) {
            if at >= n {
                break;
            }
            let end = s.from + (n - at).min(s.len());
            let run = runs[s.record].as_ref().ok_or(SimError::Short {
                what: "records",
                got: 0,
                want: s.record + 1,
            })?;
            for (o, col) in out.iter_mut().enumerate() {
                let v = run.get(o).ok_or(SimError::Short {
                    what: "outputs",
                    got: run.len(),
                    want: o + 1,
                })?;
                let w = self.weights[s.record][o];
                let part = v.get(s.from..end).ok_or(SimError::Short {
                    what: "samples",
                    got: v.len(),
                    want: end,
                })?;
                col.extend(part.iter().map(|y| y * w));
            }
        }
        Ok(out)
    }
}
