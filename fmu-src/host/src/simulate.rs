//! High-level simulation: start values by name, input series, fixed communication step.

use crate::error::{HostError, Result};
use crate::fmu::Fmu;
use crate::instance::Instance;
use crate::md::{Causality, ModelDescription, ScalarVariable, VarKind};

/// A value for a variable before initialization (`--set NAME=VALUE`).
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// For Real variables (Integer variables accept integral values).
    Real(f64),
    /// For Boolean variables.
    Boolean(bool),
}

impl Value {
    /// Parses `text` for the variable `v`: `true`/`false` (or 1/0) for Booleans, a finite
    /// number within the variable's min/max otherwise.
    pub fn parse_for(v: &ScalarVariable, text: &str) -> Result<Value> {
        let t = text.trim();
        match v.kind {
            VarKind::Boolean => match t {
                "true" | "1" => Ok(Value::Boolean(true)),
                "false" | "0" => Ok(Value::Boolean(false)),
                _ => Err(HostError::Request(format!(
                    "'{}' is Boolean: expected true or false, got '{text}'",
                    v.name
                ))),
            },
            VarKind::Real | VarKind::Integer | VarKind::Enumeration => {
                let x: f64 = t.parse().map_err(|_| {
                    HostError::Request(format!("'{}': '{text}' is not a number", v.name))
                })?;
                if !x.is_finite() {
                    return Err(HostError::Request(format!(
                        "'{}': value must be finite, got '{text}'",
                        v.name
                    )));
                }
                if matches!(v.min, Some(lo) if x < lo) || matches!(v.max, Some(hi) if x > hi) {
                    return Err(HostError::Request(format!(
                        "'{}' = {x} is outside its range [{}, {}]",
                        v.name,
                        v.min.unwrap_or(f64::NEG_INFINITY),
                        v.max.unwrap_or(f64::INFINITY)
                    )));
                }
                Ok(Value::Real(x))
            }
            VarKind::String => Err(HostError::Request(format!(
                "'{}' is a String variable: not supported",
                v.name
            ))),
        }
    }
}

/// Input time series: `time` strictly increasing, each column as long as `time`.
/// Values are interpolated linearly at each communication point and held at the ends.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InputSeries {
    /// Sample times.
    pub time: Vec<f64>,
    /// (input name, samples).
    pub columns: Vec<(String, Vec<f64>)>,
}

/// What to simulate.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulationRequest {
    /// Start time (fmi2SetupExperiment).
    pub start_time: f64,
    /// Stop time; the last communication point is exactly this.
    pub stop_time: f64,
    /// Communication step; the last step is shortened if it does not divide the interval.
    pub step: f64,
    /// Values set after instantiation, before initialization (parameters and inputs).
    pub start_values: Vec<(String, Value)>,
    /// Inputs driven over time (override the start values of those inputs).
    pub inputs: InputSeries,
    /// Variables to record; empty means every output.
    pub outputs: Vec<String>,
    /// Tolerance passed to fmi2SetupExperiment (None: not defined).
    pub tolerance: Option<f64>,
}

impl SimulationRequest {
    /// A request from `start` to `stop` with step `step`, no inputs, every output.
    pub fn new(start_time: f64, stop_time: f64, step: f64) -> Self {
        SimulationRequest {
            start_time,
            stop_time,
            step,
            start_values: Vec::new(),
            inputs: InputSeries::default(),
            outputs: Vec::new(),
            tolerance: None,
        }
    }
}

/// Recorded trajectories: `columns[j][k]` is variable `names[j]` at `time[k]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SimulationResult {
    /// Communication points, the start included.
    pub time: Vec<f64>,
    /// Recorded variable names.
    pub names: Vec<String>,
    /// One trajectory per name (Booleans as 0/1).
    pub columns: Vec<Vec<f64>>,
}

impl SimulationResult {
    /// Trajectory of `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.columns[i].as_slice())
    }
}

/// Communication points from `start` to `stop`: `t_k = start + k*h` computed from the integer
/// k (no accumulated rounding), the last one exactly `stop`.
pub fn communication_points(start: f64, stop: f64, h: f64) -> Result<Vec<f64>> {
    if !(start.is_finite() && stop.is_finite() && h.is_finite()) {
        return Err(HostError::Request(
            "start, stop and step must be finite".into(),
        ));
    }
    if h <= 0.0 {
        return Err(HostError::Request(format!("step must be > 0, got {h}")));
    }
    if stop < start {
        return Err(HostError::Request(format!(
            "stop time {stop} is before start time {start}"
        )));
    }
    let ratio = (stop - start) / h;
    if ratio > 1e8 {
        return Err(HostError::Request(format!(
            "{ratio:.0} steps: step too small for the interval"
        )));
    }
    let n_round = ratio.round();
    let n = if (ratio - n_round).abs() <= 1e-9 * n_round.max(1.0) {
        n_round as usize
    } else {
        ratio.ceil() as usize
    };
    let mut t: Vec<f64> = (0..=n).map(|k| start + k as f64 * h).collect();
    if let Some(last) = t.last_mut() {
        *last = stop;
    }
    Ok(t)
}

/// Linear interpolation of `(xs, ys)` at `x`, holding the end values; `cursor` speeds up
/// monotone queries (start it at 0).
///
/// For `xs[i] < x <= xs[i+1]`: `w0 = (xs[i+1] - x) / (xs[i+1] - xs[i])`,
/// `y = w0 ys[i] + (1 - w0) ys[i+1]`: the formula of FMPy's `Input.interpolate`, so inputs
/// reach the FMU bit-identical to an FMPy run on the same table.
pub fn interpolate(xs: &[f64], ys: &[f64], x: f64, cursor: &mut usize) -> f64 {
    let n = xs.len();
    if n == 0 {
        return f64::NAN;
    }
    if x <= xs[0] {
        return ys[0];
    }
    if x > xs[n - 1] {
        return ys[n - 1];
    }
    // Find i with xs[i] < x <= xs[i + 1].
    if *cursor >= n - 1 || xs[*cursor] >= x {
        *cursor = 0;
    }
    while xs[*cursor + 1] < x {
        *cursor += 1;
    }
    let (i, j) = (*cursor, *cursor + 1);
    let w0 = (xs[j] - x) / (xs[j] - xs[i]);
    let w1 = 1.0 - w0;
    w0 * ys[i] + w1 * ys[j]
}

/// Variable lookup split by type for one get/set call per type.
#[derive(Clone, Debug, Default)]
struct ByType {
    real: Vec<(usize, u32)>,
    integer: Vec<(usize, u32)>,
    boolean: Vec<(usize, u32)>,
}

fn lookup<'m>(md: &'m ModelDescription, name: &str) -> Result<&'m ScalarVariable> {
    md.variable(name)
        .ok_or_else(|| HostError::UnknownVariable(name.to_string()))
}

/// Reusable simulation driver: one instance, reset between runs (fmi2Reset), so repeated
/// simulations (calibration) do not pay for instantiation. If a reset fails, the instance is
/// freed and a new one made.
pub struct Simulator<'a> {
    fmu: &'a Fmu,
    instance: Option<Instance<'a>>,
    used: bool,
}

impl<'a> Simulator<'a> {
    /// Instantiates the FMU once.
    pub fn new(fmu: &'a Fmu) -> Result<Self> {
        Ok(Simulator {
            fmu,
            instance: Some(fmu.instantiate("host")?),
            used: false,
        })
    }

    /// The instance (for direct calls between runs); None only after a failed re-instantiation.
    pub fn instance(&mut self) -> Option<&mut Instance<'a>> {
        self.instance.as_mut()
    }

    /// Runs one simulation. After any run the instance is reset before the next.
    pub fn run(&mut self, req: &SimulationRequest) -> Result<SimulationResult> {
        if self.used {
            let reset = match self.instance.as_mut() {
                Some(inst) => inst.reset().map(|_| ()),
                None => Err(HostError::Request("no instance".into())),
            };
            if let Err(e) = reset {
                // A failed reset leaves the instance unusable: free it, then make a new one.
                self.instance = None;
                self.instance = Some(self.fmu.instantiate("host").map_err(|_| e)?);
            }
        }
        self.used = true;
        let inst = match self.instance.as_mut() {
            Some(i) => i,
            None => return Err(HostError::Request("no instance".into())),
        };
        let _ = inst.take_log();
        run_on(inst, req)
    }
}

/// Simulates `req` on a fresh instance of `fmu`.
pub fn simulate(fmu: &Fmu, req: &SimulationRequest) -> Result<SimulationResult> {
    let mut inst = fmu.instantiate("host")?;
    run_on(&mut inst, req)
}

fn run_on(inst: &mut Instance<'_>, req: &SimulationRequest) -> Result<SimulationResult> {
    let md = inst.fmu().model_description();
    let times = communication_points(req.start_time, req.stop_time, req.step)?;

    // Resolve everything before touching the FMU.
    let mut start_reals = Vec::new();
    let mut start_ints = Vec::new();
    let mut start_bools = Vec::new();
    for (name, value) in &req.start_values {
        let v = lookup(md, name)?;
        if v.causality == Causality::Independent || v.causality == Causality::CalculatedParameter {
            return Err(HostError::Request(format!(
                "'{name}' is {:?}: cannot be set",
                v.causality
            )));
        }
        match (v.kind, value) {
            (VarKind::Real, Value::Real(x)) => start_reals.push((v.value_reference, *x)),
            (VarKind::Integer | VarKind::Enumeration, Value::Real(x))
                if x.fract() == 0.0 && x.abs() < 2.1e9 =>
            {
                start_ints.push((v.value_reference, *x as i32))
            }
            (VarKind::Boolean, Value::Boolean(b)) => start_bools.push((v.value_reference, *b)),
            (kind, value) => {
                return Err(HostError::Request(format!(
                    "'{name}' is {kind:?}: cannot take the value {value:?}"
                )))
            }
        }
    }
    let series = &req.inputs;
    let mut inputs = Vec::new(); // (kind, vr, column index)
    for (col, (name, values)) in series.columns.iter().enumerate() {
        let v = lookup(md, name)?;
        if v.causality != Causality::Input {
            return Err(HostError::Request(format!(
                "'{name}' is not an input of the FMU"
            )));
        }
        if values.len() != series.time.len() {
            return Err(HostError::Request(format!(
                "input '{name}' has {} samples for {} times",
                values.len(),
                series.time.len()
            )));
        }
        inputs.push((v.kind, v.value_reference, col));
    }
    if !series.columns.is_empty() && series.time.is_empty() {
        return Err(HostError::Request("input series has no samples".into()));
    }
    let out_names: Vec<String> = if req.outputs.is_empty() {
        md.output_names()
    } else {
        req.outputs.clone()
    };
    let mut outs = ByType::default();
    for (j, name) in out_names.iter().enumerate() {
        let v = lookup(md, name)?;
        match v.kind {
            VarKind::Real => outs.real.push((j, v.value_reference)),
            VarKind::Integer | VarKind::Enumeration => outs.integer.push((j, v.value_reference)),
            VarKind::Boolean => outs.boolean.push((j, v.value_reference)),
            VarKind::String => {
                return Err(HostError::Request(format!(
                    "'{name}' is a String: cannot be recorded"
                )))
            }
        }
    }

    let (rv, rx): (Vec<u32>, Vec<f64>) = start_reals.into_iter().unzip();
    if !rv.is_empty() {
        inst.set_real(&rv, &rx)?;
    }
    let (iv, ix): (Vec<u32>, Vec<i32>) = start_ints.into_iter().unzip();
    if !iv.is_empty() {
        inst.set_integer(&iv, &ix)?;
    }
    let (bv, bx): (Vec<u32>, Vec<bool>) = start_bools.into_iter().unzip();
    if !bv.is_empty() {
        inst.set_boolean(&bv, &bx)?;
    }

    let mut cursor = 0usize;
    // Real inputs go to the FMU in one fmi2SetReal call per communication point.
    let real_in_vrs: Vec<u32> = inputs
        .iter()
        .filter(|(k, _, _)| *k == VarKind::Real)
        .map(|&(_, vr, _)| vr)
        .collect();
    let mut real_in_buf = vec![0.0; real_in_vrs.len()];
    // All columns share one time axis, so one cursor serves them all.
    let mut set_inputs = |inst: &mut Instance<'_>, t: f64, cursor: &mut usize| -> Result<()> {
        let mut next = *cursor;
        let mut ri = 0;
        for &(kind, vr, col) in &inputs {
            next = *cursor;
            let x = interpolate(&series.time, &series.columns[col].1, t, &mut next);
            match kind {
                VarKind::Real => {
                    real_in_buf[ri] = x;
                    ri += 1;
                }
                VarKind::Boolean => {
                    inst.set_boolean(&[vr], &[x >= 0.5])?;
                }
                _ => {
                    inst.set_integer(&[vr], &[x.round() as i32])?;
                }
            }
        }
        if !real_in_vrs.is_empty() {
            inst.set_real(&real_in_vrs, &real_in_buf)?;
        }
        *cursor = next;
        Ok(())
    };

    set_inputs(inst, req.start_time, &mut cursor)?;
    inst.setup_experiment(req.tolerance, req.start_time, Some(req.stop_time))?;
    inst.enter_initialization_mode()?;
    inst.exit_initialization_mode()?;

    let n_out = out_names.len();
    let mut columns: Vec<Vec<f64>> = (0..n_out)
        .map(|_| Vec::with_capacity(times.len()))
        .collect();
    let rvrs: Vec<u32> = outs.real.iter().map(|&(_, vr)| vr).collect();
    let ivrs: Vec<u32> = outs.integer.iter().map(|&(_, vr)| vr).collect();
    let bvrs: Vec<u32> = outs.boolean.iter().map(|&(_, vr)| vr).collect();
    let mut rbuf = vec![0.0; rvrs.len()];
    let mut ibuf = vec![0i32; ivrs.len()];
    let mut bbuf = vec![false; bvrs.len()];
    let mut record = |inst: &mut Instance<'_>, columns: &mut Vec<Vec<f64>>| -> Result<()> {
        if !rvrs.is_empty() {
            inst.get_real(&rvrs, &mut rbuf)?;
            for (&(j, _), &x) in outs.real.iter().zip(&rbuf) {
                columns[j].push(x);
            }
        }
        if !ivrs.is_empty() {
            inst.get_integer(&ivrs, &mut ibuf)?;
            for (&(j, _), &x) in outs.integer.iter().zip(&ibuf) {
                columns[j].push(x as f64);
            }
        }
        if !bvrs.is_empty() {
            inst.get_boolean(&bvrs, &mut bbuf)?;
            for (&(j, _), &x) in outs.boolean.iter().zip(&bbuf) {
                columns[j].push(if x { 1.0 } else { 0.0 });
            }
        }
        Ok(())
    };
    record(inst, &mut columns)?;
    for k in 0..times.len().saturating_sub(1) {
        let (t, t1) = (times[k], times[k + 1]);
        if k > 0 {
            set_inputs(inst, t, &mut cursor)?;
        }
        inst.do_step(t, t1 - t, true)?;
        record(inst, &mut columns)?;
    }
    let _ = inst.terminate();
    Ok(SimulationResult {
        time: times,
        names: out_names,
        columns,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn communication_points_hit_stop_exactly_without_drift() {
        let t = communication_points(0.0, 1.0, 0.1).unwrap();
        assert_eq!(t.len(), 11);
        assert_eq!(t[3], 3.0 * 0.1);
        assert_eq!(*t.last().unwrap(), 1.0);
        let t = communication_points(0.0, 1.05, 0.1).unwrap();
        assert_eq!(t.len(), 12);
        assert_eq!(t[10], 1.0);
        assert_eq!(t[11], 1.05);
        let t = communication_points(2.0, 2.0, 0.1).unwrap();
        assert_eq!(t, vec![2.0]);
        assert!(communication_points(0.0, 1.0, 0.0).is_err());
        assert!(communication_points(0.0, 1.0, -0.1).is_err());
        assert!(communication_points(1.0, 0.0, 0.1).is_err());
        assert!(communication_points(0.0, f64::NAN, 0.1).is_err());
    }

    #[test]
    fn interpolation_is_linear_and_holds_the_ends() {
        let xs = [0.0, 1.0, 3.0];
        let ys = [0.0, 10.0, 30.0];
        let mut c = 0;
        assert_eq!(interpolate(&xs, &ys, -1.0, &mut c), 0.0);
        assert_eq!(interpolate(&xs, &ys, 0.5, &mut c), 5.0);
        assert_eq!(interpolate(&xs, &ys, 2.0, &mut c), 20.0);
        assert_eq!(interpolate(&xs, &ys, 3.0, &mut c), 30.0);
        assert_eq!(interpolate(&xs, &ys, 9.0, &mut c), 30.0);
        // going back in time resets the cursor
        assert_eq!(interpolate(&xs, &ys, 0.25, &mut c), 2.5);
    }
}
