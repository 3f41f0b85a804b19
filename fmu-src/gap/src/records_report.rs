//! The report's parts for several records: where each fitted record lies in the joined trace
//! ([`crate::records`]) and the errors on records not fitted ([`crate::validation`]). Empty for a
//! single record without `--validate`, which leaves the report as it was.

use crate::records::RecordSpan;
use crate::report::g;
use crate::validation::Validation;
use serde_json::{json, Value};
use std::fmt::Write;
use std::path::Path;

/// What the report adds for several records and records not fitted.
#[derive(Clone, Debug, Default)]
pub struct Extras {
    /// The records fitted together (empty for one record).
    pub records: Vec<RecordSpan>,
    /// The records not fitted (`--validate`).
    pub validation: Vec<Validation>,
    /// Per joined sample of `traces.csv`: its record (1, 2, …) and the record's own time
    /// (empty for one record).
    pub trace_origin: Vec<(usize, f64)>,
}

impl Extras {
    /// `records` and `validation` keys of `report.json`, where there are any.
    pub fn add_json(&self, doc: &mut Value) {
        let Some(obj) = doc.as_object_mut() else {
            return;
        };
        let mut add = |key: &str, v: Value| {
            obj.insert(key.to_string(), v);
        };
        if !self.records.is_empty() {
            add("records", json!(self.records));
        }
        if !self.validation.is_empty() {
            add("validation", json!(self.validation));
        }
    }

    /// The Markdown sections (empty when there is nothing to add).
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        if !self.records.is_empty() {
            records_md(&mut s, &self.records);
        }
        if !self.validation.is_empty() {
            validation_md(&mut s, &self.validation);
        }
        s
    }

    /// `validation-<i>.csv` per record not fitted: time, then per output `.measured`, `.base_fit`,
    /// `.final`; returns the file names.
    pub fn write_traces(&self, dir: &Path) -> std::io::Result<Vec<String>> {
        let mut names = Vec::new();
        for (i, v) in self.validation.iter().enumerate() {
            let name = format!("validation-{}.csv", i + 1);
            let mut cols = Vec::new();
            let mut heads = Vec::new();
            for t in &v.traces {
                for (kind, c) in [
                    ("measured", &t.measured),
                    ("base_fit", &t.base),
                    ("final", &t.final_model),
                ] {
                    heads.push(format!("{}.{kind}", t.name));
                    cols.push(c.clone());
                }
            }
            host::csv::write_atomically(&dir.join(&name), |f| {
                host::csv::write_csv_to(std::io::BufWriter::new(f), &v.time, &heads, &cols)
            })?;
            names.push(name);
        }
        Ok(names)
    }
}

fn records_md(s: &mut String, records: &[RecordSpan]) {
    let _ = writeln!(
        s,
        "## Records fitted together\n\nOne parameter set for all records; each begins in its \
         own state (its own initial-state parameters `<name>@r`, estimated with the first \
         record's) and is weighted by its own noise levels. The joined time axis of the plots, \
         the diagnosis and `traces.csv` lays the training parts end to end, then the held-out \
         ends; `traces.csv` gives each row's record and record time.\n\n| record | file | \
         samples (training) | training, joined time [s] | held out, joined time [s] | record \
         time [s] | white noise per output |\n|---|---|---|---|---|---|---|"
    );
    for (r, d) in records.iter().enumerate() {
        let noise = d
            .noise_white
            .iter()
            .map(|(k, v)| format!("{k} {}", g(*v)))
            .collect::<Vec<_>>()
            .join(", ");
        let _ = writeln!(
            s,
            "| {} | `{}` | {} ({}) | {}–{} | {}–{} | {}–{} | {} |",
            r + 1,
            d.data,
            d.samples,
            d.train_samples,
            g(d.train_joined_s.0),
            g(d.train_joined_s.1),
            g(d.held_out_joined_s.0),
            g(d.held_out_joined_s.1),
            g(d.record_s.0),
            g(d.record_s.1),
            noise
        );
    }
    let _ = writeln!(s);
}

fn validation_md(s: &mut String, validation: &[Validation]) {
    let _ = writeln!(
        s,
        "## Records not fitted (`--validate`)\n\nThe calibrated base model and the final model \
         with every parameter as fitted; only the state each record begins in is estimated on \
         it. Times are the record's own.\n"
    );
    for (i, v) in validation.iter().enumerate() {
        let _ = writeln!(
            s,
            "### `{}` ({} samples; traces in `validation-{}.csv`)\n\n| output | white noise | \
             RMSE base fit | RMSE final | max base fit (at t) | max final (at t) | worst tenth \
             for the final model: time, RMSE |\n|---|---|---|---|---|---|---|",
            v.data,
            v.samples,
            i + 1
        );
        for (k, e) in &v.outputs {
            let (a, b, w) = e.worst_window_final;
            let _ = writeln!(
                s,
                "| {k} | {} | {} | {} | {} ({} s) | {} ({} s) | {}–{} s: {} |",
                g(e.noise_white),
                g(e.rmse_base),
                g(e.rmse_final),
                g(e.max_base),
                g(e.max_base_at_s),
                g(e.max_final),
                g(e.max_final_at_s),
                g(a),
                g(b),
                g(w)
            );
        }
        let state = |m: &std::collections::BTreeMap<String, f64>| {
            m.iter()
                .map(|(k, v)| format!("`{k}` = {}", g(*v)))
                .collect::<Vec<_>>()
                .join(", ")
        };
        if !v.initial_state_final.is_empty() {
            let _ = writeln!(
                s,
                "\nInitial state estimated on the record: base fit {}; final {}.",
                state(&v.initial_state_base),
                state(&v.initial_state_final)
            );
        }
        let _ = writeln!(s);
    }
}
