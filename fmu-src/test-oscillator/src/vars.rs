//! The variable table: every input, output and parameter of the oscillator with its fixed value
//! reference, unit, range, start and description, declared once.

use fmu_core::{declare_variables, Variable};

declare_variables! {
    MASS = 0 => Variable::parameter("mass", 1.0, "kg", "Mass m").range(1e-3, 1e3),
    STIFFNESS = 1 => Variable::parameter("stiffness", 100.0, "N/m", "Spring stiffness k").range(0.0, 1e6),
    DAMPING = 2 => Variable::parameter("damping", 0.5, "N.s/m", "Viscous damping c").range(0.0, 1e4),
    X0 = 3 => Variable::parameter("x0", 0.01, "m", "Initial position").range(-1.0, 1.0).display("mm"),
    MAX_SUBSTEP = 4 => Variable::parameter("max_substep", 1e-4, "s", "Largest RK4 sub-step").range(1e-7, 1e-2),
    FAIL_AT = 5 => Variable::parameter("fail_at", 1e9, "s", "A step reaching this time fails on purpose (test of the error path)").range(0.0, 1e9),
    LOCKED = 6 => Variable::flag("locked", false, "When true the mass is held at x0"),
    FORCE = 7 => Variable::input("force", 0.0, "N", "External force F").range(-1e3, 1e3),
    // nominal 1e-2: the oscillator moves by cm
    X = 8 => Variable::output("x", "m", "Position").display("mm").nominal(1e-2),
    // nominal 1e-2: the oscillator moves at cm/s
    V = 9 => Variable::output("v", "m/s", "Velocity").nominal(1e-2),
    ENERGY = 10 => Variable::output("energy", "J", "Kinetic plus spring energy"),
    DER_X = 11 => Variable::local("der(x)", "m/s", "Derivative of the position (Model Exchange state x)"),
    DER_V = 12 => Variable::local("der(v)", "m/s2", "Derivative of the velocity (Model Exchange state v)"),
}
