//! Units known to the generator: SI base-unit exponents and display units.
//!
//! FMI 2.0 `UnitDefinitions` (standard section 2.2.2): every unit a variable names must be
//! defined with its `BaseUnit` exponents; a display unit is `display = factor * value + offset`.

/// Exponents of kg, m, s, A, K, mol, cd, rad and the factor to SI.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaseUnit {
    pub kg: i32,
    pub m: i32,
    pub s: i32,
    pub a: i32,
    pub k: i32,
    pub mol: i32,
    pub cd: i32,
    pub rad: i32,
    pub factor: f64,
}

/// A display unit: `display = factor * si_value + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisplayUnit {
    pub name: &'static str,
    pub factor: f64,
    pub offset: f64,
}

/// A unit with its base-unit decomposition and the display units offered for it.
#[derive(Clone, Copy, Debug)]
pub struct UnitDef {
    pub name: &'static str,
    pub base: BaseUnit,
    pub display: &'static [DisplayUnit],
}

const fn b(kg: i32, m: i32, s: i32, a: i32, rad: i32) -> BaseUnit {
    BaseUnit {
        kg,
        m,
        s,
        a,
        k: 0,
        mol: 0,
        cd: 0,
        rad,
        factor: 1.0,
    }
}

const fn du(name: &'static str, factor: f64) -> DisplayUnit {
    DisplayUnit {
        name,
        factor,
        offset: 0.0,
    }
}

/// 180/pi: radians to degrees.
pub const DEG_PER_RAD: f64 = 57.295_779_513_082_32;
/// 60/(2 pi): rad/s to revolutions per minute.
pub const RPM_PER_RAD_S: f64 = 9.549_296_585_513_72;

/// Every unit a model may name. Append here when a model needs a new one.
#[rustfmt::skip]
pub static KNOWN: &[UnitDef] = &[
    UnitDef { name: "1", base: b(0, 0, 0, 0, 0), display: &[du("%", 100.0)] },
    UnitDef { name: "s", base: b(0, 0, 1, 0, 0), display: &[du("ms", 1e3)] },
    UnitDef { name: "rad", base: b(0, 0, 0, 0, 1), display: &[du("deg", DEG_PER_RAD)] },
    UnitDef { name: "rad/s", base: b(0, 0, -1, 0, 1), display: &[du("rpm", RPM_PER_RAD_S), du("deg/s", DEG_PER_RAD)] },
    UnitDef { name: "rad/s2", base: b(0, 0, -2, 0, 1), display: &[du("deg/s2", DEG_PER_RAD)] },
    UnitDef { name: "m", base: b(0, 1, 0, 0, 0), display: &[du("mm", 1e3)] },
    UnitDef { name: "m/s", base: b(0, 1, -1, 0, 0), display: &[du("mm/s", 1e3)] },
    UnitDef { name: "m/s2", base: b(0, 1, -2, 0, 0), display: &[] },
    UnitDef { name: "m/rad", base: b(0, 1, 0, 0, -1), display: &[du("mm/rad", 1e3)] },
    UnitDef { name: "m2", base: b(0, 2, 0, 0, 0), display: &[du("mm2", 1e6)] },
    UnitDef { name: "m3", base: b(0, 3, 0, 0, 0), display: &[du("cm3", 1e6)] },
    UnitDef { name: "m3/s", base: b(0, 3, -1, 0, 0), display: &[du("L/min", 6e4)] },
    UnitDef { name: "m3/(s.Pa)", base: b(-1, 4, 1, 0, 0), display: &[du("L/(min.bar)", 6e9)] },
    UnitDef { name: "kg", base: b(1, 0, 0, 0, 0), display: &[du("g", 1e3)] },
    UnitDef { name: "kg.m2", base: b(1, 2, 0, 0, 0), display: &[] },
    UnitDef { name: "Pa", base: b(1, -1, -2, 0, 0), display: &[du("bar", 1e-5), du("MPa", 1e-6)] },
    UnitDef { name: "Pa/s", base: b(1, -1, -3, 0, 0), display: &[du("bar/s", 1e-5)] },
    UnitDef { name: "N", base: b(1, 1, -2, 0, 0), display: &[] },
    UnitDef { name: "N/m", base: b(1, 0, -2, 0, 0), display: &[du("N/mm", 1e-3)] },
    UnitDef { name: "N.s/m", base: b(1, 0, -1, 0, 0), display: &[] },
    UnitDef { name: "N.m", base: b(1, 2, -2, 0, 0), display: &[du("mN.m", 1e3)] },
    UnitDef { name: "N.m/rad", base: b(1, 2, -2, 0, -1), display: &[] },
    UnitDef { name: "N.m.s/rad", base: b(1, 2, -1, 0, -1), display: &[] },
    UnitDef { name: "N.m/A", base: b(1, 2, -2, -1, 0), display: &[du("mN.m/A", 1e3)] },
    UnitDef { name: "V", base: b(1, 2, -3, -1, 0), display: &[] },
    UnitDef { name: "V/s", base: b(1, 2, -4, -1, 0), display: &[] },
    UnitDef { name: "V/s2", base: b(1, 2, -5, -1, 0), display: &[] },
    UnitDef { name: "V/m", base: b(1, 1, -3, -1, 0), display: &[] },
    UnitDef { name: "V.s/rad", base: b(1, 2, -2, -1, -1), display: &[] },
    UnitDef { name: "V.s/m", base: b(1, 1, -2, -1, 0), display: &[] },
    UnitDef { name: "A", base: b(0, 0, 0, 1, 0), display: &[du("mA", 1e3)] },
    UnitDef { name: "A/s", base: b(0, 0, -1, 1, 0), display: &[] },
    UnitDef { name: "A.s", base: b(0, 0, 1, 1, 0), display: &[] },
    UnitDef { name: "Ohm", base: b(1, 2, -3, -2, 0), display: &[] },
    UnitDef { name: "H", base: b(1, 2, -2, -2, 0), display: &[du("mH", 1e3)] },
    UnitDef { name: "W", base: b(1, 2, -3, 0, 0), display: &[] },
    UnitDef { name: "J", base: b(1, 2, -2, 0, 0), display: &[] },
    UnitDef { name: "1/s", base: b(0, 0, -1, 0, 0), display: &[du("Hz", 1.0)] },
    UnitDef { name: "1/Pa", base: b(-1, 1, 2, 0, 0), display: &[] },
    UnitDef { name: "m/N", base: b(-1, 0, 2, 0, 0), display: &[du("mm/N", 1e3)] },
    UnitDef { name: "m/rad2", base: b(0, 1, 0, 0, -2), display: &[] },
    UnitDef { name: "A.s/rad", base: b(0, 0, 1, 1, -1), display: &[] },
    UnitDef { name: "m/(s.V)", base: b(-1, -1, 2, 1, 0), display: &[du("mm/(s.V)", 1e3)] },
];

/// The definition of `name`, if known.
pub fn lookup(name: &str) -> Option<&'static UnitDef> {
    KNOWN.iter().find(|u| u.name == name)
}
