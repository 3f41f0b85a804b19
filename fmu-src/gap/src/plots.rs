//! PNG plots (plotters): measured vs model before/after, residuals over time, residual against
//! the variable that reveals the effect.

use crate::validation::Validation;
use crate::workflow::GapResult;
use plotters::prelude::*;
use plotters::style::register_font;
use std::path::Path;
use std::sync::OnceLock;

type DynErr = Box<dyn std::error::Error>;

/// The font of every plot's text, DejaVu Sans compiled into the binary: a plot looks the same on
/// every machine, and the CLI needs no system font library (fontconfig, FreeType), so it runs on
/// a bare system and ships in a portable wheel.
fn embedded_font() -> Result<(), DynErr> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = REGISTERED.get_or_init(|| {
        register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular()).is_ok()
    });
    if *ok {
        Ok(())
    } else {
        Err("the embedded DejaVu Sans font could not be read".into())
    }
}

fn stride(n: usize) -> usize {
    (n / 2000).max(1)
}

fn bounds(series: &[&[f64]]) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for s in series {
        for &v in s.iter() {
            if v.is_finite() {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        let c = if lo.is_finite() { lo } else { 0.0 };
        return (c - 1.0, c + 1.0);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

fn line(t: &[f64], y: &[f64]) -> Vec<(f64, f64)> {
    let s = stride(t.len());
    t.iter().zip(y).step_by(s).map(|(a, b)| (*a, *b)).collect()
}

type Chart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Draw `y` over `t` in `color` with a legend entry `label`.
fn labelled_line(
    ch: &mut Chart,
    t: &[f64],
    y: &[f64],
    color: RGBColor,
    label: &str,
) -> Result<(), DynErr> {
    ch.draw_series(LineSeries::new(line(t, y), color))?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], color));
    Ok(())
}

/// Measured vs model (as given, base fit, final) per output.
fn outputs_png(res: &GapResult, path: &Path) -> Result<(), DynErr> {
    let tr = &res.traces;
    let k = tr.outputs.len().max(1);
    let root = BitMapBackend::new(path, (1100, 260 * k as u32)).into_drawing_area();
    root.fill(&WHITE)?;
    let areas = root.split_evenly((k, 1));
    let (t0, t1) = (tr.time[0], *tr.time.last().unwrap_or(&1.0));
    for (area, o) in areas.iter().zip(&tr.outputs) {
        let (name, meas, nom, base, fin) =
            (&o.name, &o.measured, &o.nominal, &o.base_fit, &o.final_fit);
        let (lo, hi) = bounds(&[meas, nom, base, fin]);
        let mut ch = ChartBuilder::on(area)
            .caption(format!("{name}: measured vs model"), ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(70)
            .build_cartesian_2d(t0..t1, lo..hi)?;
        ch.configure_mesh()
            .x_desc("time [s]")
            .max_light_lines(2)
            .draw()?;
        labelled_line(&mut ch, &tr.time, meas, RGBColor(150, 150, 150), "measured")?;
        labelled_line(&mut ch, &tr.time, nom, BLUE, "model as given")?;
        labelled_line(&mut ch, &tr.time, base, RGBColor(230, 140, 0), "base fit")?;
        labelled_line(&mut ch, &tr.time, fin, RED, "after")?;
        ch.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    Ok(())
}

/// Residuals over time: base fit and final.
fn residuals_png(res: &GapResult, path: &Path) -> Result<(), DynErr> {
    let tr = &res.traces;
    let k = tr.outputs.len().max(1);
    let root = BitMapBackend::new(path, (1100, 220 * k as u32)).into_drawing_area();
    root.fill(&WHITE)?;
    let areas = root.split_evenly((k, 1));
    let (t0, t1) = (tr.time[0], *tr.time.last().unwrap_or(&1.0));
    for (area, o) in areas.iter().zip(&tr.outputs) {
        let (name, meas, base, fin) = (&o.name, &o.measured, &o.base_fit, &o.final_fit);
        let rb: Vec<f64> = base.iter().zip(meas).map(|(a, b)| a - b).collect();
        let rf: Vec<f64> = fin.iter().zip(meas).map(|(a, b)| a - b).collect();
        let (lo, hi) = bounds(&[&rb, &rf]);
        let mut ch = ChartBuilder::on(area)
            .caption(
                format!("{name}: residual (model − measured)"),
                ("sans-serif", 16),
            )
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(70)
            .build_cartesian_2d(t0..t1, lo..hi)?;
        ch.configure_mesh()
            .x_desc("time [s]")
            .max_light_lines(2)
            .draw()?;
        labelled_line(&mut ch, &tr.time, &rb, RGBColor(230, 140, 0), "base fit")?;
        labelled_line(&mut ch, &tr.time, &rf, RED, "after")?;
        ch.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    Ok(())
}

/// Residual of the worst output against the variable that organises it best.
fn revealing_png(res: &GapResult, path: &Path) -> Result<bool, DynErr> {
    let tr = &res.traces;
    let Some((k, var, v)) = &tr.revealing else {
        return Ok(false);
    };
    let Some(o) = tr.outputs.get(*k) else {
        return Ok(false);
    };
    let (name, meas, base, fin) = (&o.name, &o.measured, &o.base_fit, &o.final_fit);
    let rb: Vec<f64> = base.iter().zip(meas).map(|(a, b)| a - b).collect();
    let rf: Vec<f64> = fin.iter().zip(meas).map(|(a, b)| a - b).collect();
    let (lo, hi) = bounds(&[&rb, &rf]);
    let (vlo, vhi) = bounds(&[v]);
    let root = BitMapBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut ch = ChartBuilder::on(&root)
        .caption(format!("{name} residual against {var}"), ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(70)
        .build_cartesian_2d(vlo..vhi, lo..hi)?;
    ch.configure_mesh()
        .x_desc(var.as_str())
        .y_desc("model − measured")
        .draw()?;
    let s = stride(v.len());
    ch.draw_series(
        v.iter()
            .zip(&rb)
            .step_by(s)
            .map(|(a, b)| Circle::new((*a, *b), 2, RGBColor(230, 140, 0).filled())),
    )?
    .label("base fit")
    .legend(|(x, y)| Circle::new((x + 7, y), 3, RGBColor(230, 140, 0).filled()));
    ch.draw_series(
        v.iter()
            .zip(&rf)
            .step_by(s)
            .map(|(a, b)| Circle::new((*a, *b), 2, RED.filled())),
    )?
    .label("after")
    .legend(|(x, y)| Circle::new((x + 7, y), 3, RED.filled()));
    ch.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(true)
}

fn file_safe(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Draw every plot into `dir`; returns the file names written. A plot that fails is skipped with
/// a message on stderr (plots never fail the workflow).
pub fn write(res: &GapResult, dir: &Path) -> Vec<String> {
    let mut names = Vec::new();
    if res.traces.time.len() < 2 {
        return names;
    }
    if let Err(e) = embedded_font() {
        eprintln!("warning: no plots written: {e}");
        return names;
    }
    let mut go = |name: String, f: &dyn Fn(&Path) -> Result<bool, DynErr>| match f(&dir.join(&name))
    {
        Ok(true) => names.push(name),
        Ok(false) => {}
        Err(e) => eprintln!("warning: plot {name} not written: {e}"),
    };
    go("outputs.png".into(), &|p| outputs_png(res, p).map(|_| true));
    go("residuals.png".into(), &|p| {
        residuals_png(res, p).map(|_| true)
    });
    if let Some((_, var, _)) = &res.traces.revealing {
        go(format!("residual_vs_{}.png", file_safe(var)), &|p| {
            revealing_png(res, p)
        });
    }
    names
}

/// Measured vs the base fit and the final model per output on a record not fitted.
fn validation_png(v: &Validation, path: &Path) -> Result<(), DynErr> {
    let k = v.traces.len().max(1);
    let root = BitMapBackend::new(path, (1100, 260 * k as u32)).into_drawing_area();
    root.fill(&WHITE)?;
    let areas = root.split_evenly((k, 1));
    let (t0, t1) = (v.time[0], *v.time.last().unwrap_or(&1.0));
    for (area, o) in areas.iter().zip(&v.traces) {
        let (lo, hi) = bounds(&[&o.measured, &o.base, &o.final_model]);
        let mut ch = ChartBuilder::on(area)
            .caption(
                format!("{}: record not fitted, {}", o.name, v.data),
                ("sans-serif", 16),
            )
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(70)
            .build_cartesian_2d(t0..t1, lo..hi)?;
        ch.configure_mesh()
            .x_desc("time [s]")
            .max_light_lines(2)
            .draw()?;
        labelled_line(
            &mut ch,
            &v.time,
            &o.measured,
            RGBColor(150, 150, 150),
            "measured",
        )?;
        labelled_line(&mut ch, &v.time, &o.base, RGBColor(230, 140, 0), "base fit")?;
        labelled_line(&mut ch, &v.time, &o.final_model, RED, "final")?;
        ch.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    Ok(())
}

/// Draw `validation-<i>.png` (i from 1) for each record not fitted; returns the names written.
pub fn write_validation(validation: &[Validation], dir: &Path) -> Vec<String> {
    let mut names = Vec::new();
    if embedded_font().is_err() {
        return names;
    }
    for (i, v) in validation.iter().enumerate() {
        if v.time.len() < 2 {
            continue;
        }
        let name = format!("validation-{}.png", i + 1);
        match validation_png(v, &dir.join(&name)) {
            Ok(()) => names.push(name),
            Err(e) => eprintln!("warning: plot {name} not written: {e}"),
        }
    }
    names
}
