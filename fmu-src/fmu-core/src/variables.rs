//! The variable table: every variable of a model declared once, from which the C API,
//! `modelDescription.xml` and the HTML documentation are all derived.

/// Type element, causality, variability and initial of a variable: the FMI 2.0 vocabulary
/// shared with the host (the exporter writes Real, Integer and Boolean variables only).
pub use fmi_types::{Causality, Initial, VarKind as VarType, Variability};

/// One scalar variable. Its value reference is declared in the model's table and never moves;
/// its position in the table (the index into the value vector) is storage only.
#[derive(Clone, Copy, Debug)]
pub struct Variable {
    pub name: &'static str,
    /// The value reference of the C API and `modelDescription.xml`, set by
    /// [`declare_variables!`] from the table.
    pub value_reference: u32,
    pub vtype: VarType,
    pub causality: Causality,
    pub variability: Variability,
    pub initial: Option<Initial>,
    /// Start value; Booleans as 0.0/1.0. Ignored (not written) when `initial` is calculated.
    pub start: f64,
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// `nominal` of a Real: the magnitude an importer scales it by (its solver's absolute
    /// tolerance for a continuous state is `rtol * nominal`); a Model Exchange state's must equal
    /// what [`crate::ModelExchange::nominals`] returns for it (checked by `table_problems`).
    pub nominal: Option<f64>,
    pub unit: Option<&'static str>,
    pub display_unit: Option<&'static str>,
    pub description: &'static str,
    /// True for a Real whose SI unit FMI cannot express (`BaseUnit` exponents are integers);
    /// its description states the unit instead.
    pub unit_not_expressible: bool,
}

impl Variable {
    #[allow(clippy::too_many_arguments)]
    const fn base(
        name: &'static str,
        vtype: VarType,
        causality: Causality,
        variability: Variability,
        initial: Option<Initial>,
        start: f64,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        Variable {
            name,
            value_reference: 0,
            vtype,
            causality,
            variability,
            initial,
            start,
            min: None,
            max: None,
            nominal: None,
            unit,
            display_unit: None,
            description,
            unit_not_expressible: false,
        }
    }

    /// A Real parameter, fixed after initialization, with an exact start value.
    pub const fn parameter(
        name: &'static str,
        start: f64,
        unit: &'static str,
        description: &'static str,
    ) -> Self {
        Self::base(
            name,
            VarType::Real,
            Causality::Parameter,
            Variability::Fixed,
            Some(Initial::Exact),
            start,
            Some(unit),
            description,
        )
    }

    /// A Boolean parameter, fixed after initialization.
    pub const fn flag(name: &'static str, start: bool, description: &'static str) -> Self {
        Self::base(
            name,
            VarType::Boolean,
            Causality::Parameter,
            Variability::Fixed,
            Some(Initial::Exact),
            if start { 1.0 } else { 0.0 },
            None,
            description,
        )
    }

    /// An Integer parameter, fixed after initialization.
    pub const fn integer_parameter(
        name: &'static str,
        start: i32,
        description: &'static str,
    ) -> Self {
        Self::base(
            name,
            VarType::Integer,
            Causality::Parameter,
            Variability::Fixed,
            Some(Initial::Exact),
            start as f64,
            None,
            description,
        )
    }

    /// A continuous Real input (held constant over each communication step).
    pub const fn input(
        name: &'static str,
        start: f64,
        unit: &'static str,
        description: &'static str,
    ) -> Self {
        Self::base(
            name,
            VarType::Real,
            Causality::Input,
            Variability::Continuous,
            None,
            start,
            Some(unit),
            description,
        )
    }

    /// A continuous Real output computed by the model.
    pub const fn output(name: &'static str, unit: &'static str, description: &'static str) -> Self {
        Self::base(
            name,
            VarType::Real,
            Causality::Output,
            Variability::Continuous,
            Some(Initial::Calculated),
            0.0,
            Some(unit),
            description,
        )
    }

    /// A continuous Real local variable computed by the model (visible, not settable).
    pub const fn local(name: &'static str, unit: &'static str, description: &'static str) -> Self {
        Self::base(
            name,
            VarType::Real,
            Causality::Local,
            Variability::Continuous,
            Some(Initial::Calculated),
            0.0,
            Some(unit),
            description,
        )
    }

    /// Bounds `[min, max]` (inclusive).
    pub const fn range(mut self, min: f64, max: f64) -> Self {
        self.min = Some(min);
        self.max = Some(max);
        self
    }

    /// The nominal magnitude (`nominal` in both descriptions; positive).
    pub const fn nominal(mut self, nominal: f64) -> Self {
        self.nominal = Some(nominal);
        self
    }

    /// The display unit (must be one defined for `unit` in [`crate::units::KNOWN`]).
    /// A Real whose SI unit has a fractional exponent (e.g. m3 s^-1 V^-1 Pa^-1/2), which FMI
    /// `BaseUnit` cannot express: no unit attribute; the description must state the unit.
    pub const fn unit_not_expressible(mut self) -> Self {
        self.unit = None;
        self.unit_not_expressible = true;
        self
    }

    /// A parameter a running simulation may change in Step mode (`variability="tunable"`):
    /// the model applies it from the next step ([`crate::Model::tune`]).
    pub const fn tunable(mut self) -> Self {
        self.variability = Variability::Tunable;
        self
    }

    /// The value reference (set by [`declare_variables!`] from the table's `ID = vr` entry).
    pub const fn with_value_reference(mut self, vr: u32) -> Self {
        self.value_reference = vr;
        self
    }

    pub const fn display(mut self, display_unit: &'static str) -> Self {
        self.display_unit = Some(display_unit);
        self
    }

    /// True when the start value is written to the model description and used as initial value.
    pub fn has_start(&self) -> bool {
        !matches!(self.initial, Some(Initial::Calculated))
    }

    /// Whether `fmi2Set*` may change this variable before `fmi2ExitInitializationMode`.
    pub fn settable_before_init(&self) -> bool {
        match self.causality {
            Causality::Input => true,
            Causality::Parameter => self.variability != Variability::Constant,
            _ => {
                matches!(self.initial, Some(Initial::Exact) | Some(Initial::Approx))
                    && self.variability != Variability::Constant
            }
        }
    }

    /// Whether `fmi2Set*` may change this variable after initialization (step mode).
    pub fn settable_after_init(&self) -> bool {
        match self.causality {
            Causality::Input => true,
            Causality::Parameter => self.variability == Variability::Tunable,
            _ => false,
        }
    }

    /// The candidate effect this variable belongs to, if its name is `<effect>.<name>`.
    /// The derivative `der(<effect>.<name>)` of a state belongs to the state's effect.
    pub fn effect(&self) -> Option<&'static str> {
        let name = self
            .name
            .strip_prefix("der(")
            .and_then(|n| n.strip_suffix(')'))
            .unwrap_or(self.name);
        name.split_once('.').map(|(effect, _)| effect)
    }
}

/// Declare a model's variables once, each with its value reference. Generates `pub enum V`
/// whose discriminants are the positions in the table (the storage index into the value
/// vector), `pub static VARIABLES: &[Variable]` in the same order, each carrying its declared
/// value reference, and `pub struct Params` with a field per parameter named after its variable
/// and `Params::read` (see the `table-macros` crate). The value references are the interface
/// (C API, model description): a new variable takes a new number anywhere in the table, an
/// existing one keeps its number. A duplicate value reference fails to compile.
///
/// ```ignore
/// fmu_core::declare_variables! {
///     THETA = 12 => Variable::output("theta", "rad", "Link angle").display("deg"),
/// }
/// ```
#[macro_export]
macro_rules! declare_variables {
    ($($table:tt)*) => {
        $crate::variables::__table_macros::declare_variables! { $crate; $($table)* }
    };
}

/// The proc-macro behind [`declare_variables!`], named through this crate so that the
/// generated code names this crate as `$crate`.
#[doc(hidden)]
pub use table_macros as __table_macros;

/// True when no value reference occurs twice (evaluated at compile time by
/// [`declare_variables!`]), so a table with a duplicate does not build:
///
/// ```compile_fail
/// fmu_core::declare_variables! {
///     A = 1 => fmu_core::Variable::output("a", "m", "first"),
///     B = 1 => fmu_core::Variable::output("b", "m", "second"),
/// }
/// ```
///
/// ```
/// fmu_core::declare_variables! {
///     A = 1 => fmu_core::Variable::output("a", "m", "first"),
///     B = 0 => fmu_core::Variable::output("b", "m", "second"),
/// }
/// ```
pub const fn references_unique(vrs: &[u32]) -> bool {
    let mut i = 0;
    while i < vrs.len() {
        let mut j = i + 1;
        while j < vrs.len() {
            if vrs[i] == vrs[j] {
                return false;
            }
            j += 1;
        }
        i += 1;
    }
    true
}

/// The position in `table` (storage index) of the variable with value reference `vr`.
/// Tables numbered densely from 0 answer at once; others by a scan.
pub fn index_of(table: &[Variable], vr: u32) -> Option<usize> {
    match table.get(vr as usize) {
        Some(v) if v.value_reference == vr => Some(vr as usize),
        _ => table.iter().position(|v| v.value_reference == vr),
    }
}

/// An identifier of a model's variable table (the `V` that [`declare_variables!`] generates).
pub trait VarId: Copy {
    /// The position in the table: the index into the value vector (not the value reference).
    fn index(self) -> usize;
}

/// The variable values of a model addressed by its table's identifiers: how every model reads
/// its parameters and inputs (Booleans are stored as 0/1; an effect's parameters are read only
/// when its switch is on).
pub struct Values<'a>(pub &'a [f64]);

impl Values<'_> {
    /// A Real or Integer value.
    pub fn real(&self, v: impl VarId) -> f64 {
        self.0[v.index()]
    }

    /// A Boolean value.
    pub fn flag(&self, v: impl VarId) -> bool {
        self.0[v.index()] != 0.0
    }

    /// `Some(read(self))` when the effect's switch `<effect>.enabled` is on, else None.
    pub fn effect<T>(&self, switch: impl VarId, read: impl FnOnce(&Self) -> T) -> Option<T> {
        self.flag(switch).then(|| read(self))
    }
}

/// The variable values of a model, for writing its outputs by identifier.
pub struct ValuesMut<'a>(pub &'a mut [f64]);

impl ValuesMut<'_> {
    /// Sets one value.
    pub fn set(&mut self, v: impl VarId, x: f64) {
        self.0[v.index()] = x;
    }
}

#[cfg(test)]
mod tests {
    use super::{index_of, references_unique, Variable};

    crate::declare_variables! {
        A = 7 => Variable::parameter("a", 1.0, "m", "first"),
        B = 2 => Variable::output("b", "m", "second"),
    }

    #[test]
    fn a_duplicate_reference_is_detected() {
        assert!(references_unique(&[0, 1, 2, 7]));
        assert!(!references_unique(&[0, 1, 2, 1]));
        assert!(references_unique(&[]));
    }

    #[test]
    fn the_declared_reference_is_kept_and_found() {
        assert_eq!(VARIABLES[V::A as usize].value_reference, 7);
        assert_eq!(VARIABLES[V::B as usize].value_reference, 2);
        assert_eq!(index_of(VARIABLES, 7), Some(0));
        assert_eq!(index_of(VARIABLES, 2), Some(1));
        assert_eq!(index_of(VARIABLES, 0), None);
        assert_eq!(index_of(VARIABLES, 1), None);
    }
}
