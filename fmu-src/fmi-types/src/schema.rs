//! The vocabulary of `modelDescription.xml` (FMI 2.0.4 section 2.2.7): causality, variability,
//! initial and the type element of a scalar variable, their XML spellings, their defaults and the
//! combinations the standard allows. The exporter writes these spellings, the host parses them,
//! and the validator and the exporter's table check judge combinations with the same functions.

/// Defines a unit-only enum with its XML attribute spelling in both directions (also for the
/// host's FMI 3.0 vocabulary, which extends this one).
#[macro_export]
macro_rules! xml_enum {
    ($(#[$doc:meta])* $name:ident { $($(#[$vdoc:meta])* $variant:ident = $xml:literal),* $(,)? }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
        pub enum $name { $($(#[$vdoc])* #[serde(rename = $xml)] $variant),* }

        impl $name {
            /// Every value, in the order of the standard's table.
            pub const ALL: &'static [$name] = &[$($name::$variant),*];

            /// The spelling in `modelDescription.xml`.
            pub fn as_str(self) -> &'static str {
                match self { $($name::$variant => $xml),* }
            }

            /// Parses the spelling in `modelDescription.xml` (case-sensitive, as the schema is).
            pub fn parse(s: &str) -> Option<Self> {
                match s { $($xml => Some($name::$variant),)* _ => None }
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.as_str())
            }
        }
    };
}

xml_enum! {
    /// `causality` of a ScalarVariable (default `local`).
    Causality {
        /// parameter
        Parameter = "parameter",
        /// calculatedParameter
        CalculatedParameter = "calculatedParameter",
        /// input
        Input = "input",
        /// output
        Output = "output",
        /// local
        Local = "local",
        /// independent
        Independent = "independent",
    }
}

xml_enum! {
    /// `variability` of a ScalarVariable (default `continuous`).
    Variability {
        /// constant
        Constant = "constant",
        /// fixed
        Fixed = "fixed",
        /// tunable
        Tunable = "tunable",
        /// discrete
        Discrete = "discrete",
        /// continuous
        Continuous = "continuous",
    }
}

xml_enum! {
    /// `initial` of a ScalarVariable (no single default: see [`default_initial`]).
    Initial {
        /// exact
        Exact = "exact",
        /// approx
        Approx = "approx",
        /// calculated
        Calculated = "calculated",
    }
}

xml_enum! {
    /// Type element of a ScalarVariable.
    VarKind {
        /// `<Real>`
        Real = "Real",
        /// `<Integer>`
        Integer = "Integer",
        /// `<Boolean>`
        Boolean = "Boolean",
        /// `<String>`
        String = "String",
        /// `<Enumeration>`
        Enumeration = "Enumeration",
    }
}

/// Whether FMI 2.0 allows a causality with a variability (FMI 2.0.4 section 2.2.7, the table of
/// causality against variability; the cells marked "(1)".."(6)" are not allowed).
pub fn combination_allowed(c: Causality, v: Variability) -> bool {
    use Causality as C;
    use Variability as V;
    matches!(
        (c, v),
        (C::Parameter | C::CalculatedParameter, V::Fixed | V::Tunable)
            | (C::Input, V::Discrete | V::Continuous)
            | (C::Output, V::Constant | V::Discrete | V::Continuous)
            | (C::Local, _)
            | (C::Independent, V::Continuous)
    )
}

/// Allowed values of `initial` for an allowed combination (None in the list = attribute
/// absent), FMI 2.0.4 section 2.2.7 table of `initial` (cases A-E).
pub fn initial_allowed(c: Causality, v: Variability) -> &'static [Option<Initial>] {
    use Causality as C;
    use Initial as I;
    use Variability as V;
    match (c, v) {
        // (A) constant output/local, (B) parameter: exact only
        (C::Output | C::Local, V::Constant) | (C::Parameter, _) => &[None, Some(I::Exact)],
        // (B) calculatedParameter, fixed/tunable local: calculated or approx
        (C::CalculatedParameter, _) | (C::Local, V::Fixed | V::Tunable) => {
            &[None, Some(I::Calculated), Some(I::Approx)]
        }
        // (C) discrete/continuous output and local: calculated, exact or approx
        (C::Output | C::Local, _) => &[None, Some(I::Calculated), Some(I::Exact), Some(I::Approx)],
        // (D) input, (E) independent: no initial attribute
        (C::Input | C::Independent, _) => &[None],
    }
}

/// The `initial` that applies when the attribute is absent (FMI 2.0.4 section 2.2.7): exact for
/// constants and parameters, calculated for calculated parameters, outputs and locals, none for
/// inputs and the independent variable.
pub fn default_initial(c: Causality, v: Variability) -> Option<Initial> {
    match (c, v) {
        (Causality::Input, _) | (Causality::Independent, _) => None,
        (_, Variability::Constant) | (Causality::Parameter, _) => Some(Initial::Exact),
        _ => Some(Initial::Calculated),
    }
}

#[cfg(test)]
mod tests {
    use super::{
        combination_allowed, default_initial, initial_allowed, Causality, Initial, VarKind,
        Variability,
    };

    #[test]
    fn spellings_round_trip() {
        for c in Causality::ALL {
            assert_eq!(Causality::parse(c.as_str()), Some(*c));
        }
        for v in Variability::ALL {
            assert_eq!(Variability::parse(v.as_str()), Some(*v));
        }
        for i in Initial::ALL {
            assert_eq!(Initial::parse(i.as_str()), Some(*i));
        }
        for k in VarKind::ALL {
            assert_eq!(VarKind::parse(k.as_str()), Some(*k));
        }
        assert_eq!(Causality::parse("Parameter"), None);
    }

    #[test]
    fn the_standard_table_has_fifteen_allowed_cells() {
        // FMI 2.0.4 table in 2.2.7: of 6 causalities x 5 variabilities, allowed are parameter and
        // calculatedParameter x {fixed, tunable}, input x {discrete, continuous}, output x
        // {constant, discrete, continuous}, local x all five, independent x continuous.
        let n = Causality::ALL
            .iter()
            .flat_map(|c| Variability::ALL.iter().map(move |v| (*c, *v)))
            .filter(|(c, v)| combination_allowed(*c, *v))
            .count();
        assert_eq!(n, 15);
    }

    #[test]
    fn defaults_are_among_the_allowed_values() {
        for c in Causality::ALL {
            for v in Variability::ALL {
                if combination_allowed(*c, *v) {
                    let d = default_initial(*c, *v);
                    assert!(initial_allowed(*c, *v).contains(&d), "{c} {v}");
                }
            }
        }
    }
}
