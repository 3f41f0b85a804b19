//! The variable table: every input, output and parameter of the model with its value reference,
//! unit, range, start and description, declared once. Names and value references are a fixed
//! interface: a new variable takes a new value reference.

use fmu_core::{Variability, Variable};

/// 8000 rpm in rad/s: maximum permissible input speed of the GP 26 A gearhead (paper sec. 6).
pub const RPM8000: f64 = 8000.0 * std::f64::consts::PI / 30.0;
/// Position P gain of Table 5 (0.0035) in SI: read as fraction of the maximum speed (8000 rpm)
/// per degree of twist error, `K = 0.0035 * 837.758 rad/s * (180/pi) / 19.2` per rad of motor
/// angle = 8.7501 1/s.
pub const POSITION_P_SI: f64 = 0.0035 * RPM8000 * (180.0 / std::f64::consts::PI) / 19.2;
/// Default effective string radius [m]: least-squares fit of eq. 9-10 with Table 3 (and the
/// default return spring) to the five string-length changes the paper measured over motor angle
/// 335.1 -> 2011 rad (sec. 6: 31.5, 30.5, 30.5, 29.0, 28.5 mm under 23..124 N); see the
/// documentation, section 2. The geometric value of four 1 mm strings is 1.2071 mm.
pub const STRING_RADIUS_FIT: f64 = 1.2127e-3;
/// Speed P gain of Table 5 (963) read as uA/rpm: 963e-6 A/rpm * 60/(2 pi) = 9.196e-3 A.s/rad.
pub const SPEED_P_SI: f64 = 963e-6 * 30.0 / std::f64::consts::PI;

fmu_core::declare_variables! {
    // ---- interface: mode, inputs, outputs -----------------------------------------------------
    INTERNAL_CONTROLLER = 0 => Variable::flag("internal_controller", true,
        "true: the cascade controller (Fig. 11, Table 5) tracks theta_motor_ref; false: the motor voltage is the input 'voltage'"),
    // Input ranges (the experiment design stays within them): the motor angle the paper drove
    // the strings to (2011 rad, sec. 6), twisted either way; the 24 V ESCON supply; loads up to
    // the paper's heaviest (124 N including the 23 N weight) and an upward pull down to slack
    // strings under the default load (documentation, section 9).
    THETA_MOTOR_REF = 1 => Variable::input("theta_motor_ref", 0.0, "rad",
        "Motor angle set point of the position loop (motor shaft, before the 19.2:1 gearhead)").range(-2011.0, 2011.0).display("deg"),
    VOLTAGE = 2 => Variable::input("voltage", 0.0, "V",
        "Armature voltage when internal_controller = false").range(-24.0, 24.0),
    F_LOAD = 3 => Variable::input("F_load", 0.0, "N",
        "Extra force pulling the load down (adds to its weight)").range(-40.0, 100.0),
    // nominal 0.01: p is ~0.09 m, its CVode weight rtol |p| dominates; 1 cm bounds the absolute part where p nears 0
    P = 4 => Variable::output("p", "m", "Load position = axial length of the twisted strings (eq. 9), grows downward").display("mm").nominal(0.01),
    // nominal 1.0: the angle runs over 0 to ~2000 rad; 1 rad near 0
    THETA_MOTOR = 5 => Variable::output("theta_motor", "rad", "Motor shaft angle").display("deg").nominal(1.0),
    // nominal 10.0: the speed reaches ~840 rad/s (8000 rpm); 10 rad/s near rest
    OMEGA_MOTOR = 6 => Variable::output("omega_motor", "rad/s", "Motor shaft speed").display("rpm").nominal(10.0),
    THETA_TWIST = 7 => Variable::output("theta_twist", "rad", "Twist angle of the bundle = gearhead output angle").display("deg"),
    // nominal 0.1: the armature current holding a load is some 0.05 A (median |i| 0.04 to 0.07 A
    // in the reference runs), peaks 0.3 to 2.5 A; with 1 A an importer's absolute tolerance
    // rtol * 1 A let CVode's current, and through it F_axial, stray by 1.25e-3 of its range
    // (the internal solver's own scale, plant::NOMINAL, is unchanged)
    CURRENT = 8 => Variable::output("current", "A", "Armature current").nominal(0.1),
    TAU_MOTOR = 9 => Variable::output("tau_motor", "N.m", "Electromagnetic motor torque k_t i"),
    F_STRING = 10 => Variable::output("F_string", "N", "Axial (strand) force of each string F_i = T/n (eq. 12)"),
    F_TANGENTIAL = 11 => Variable::output("F_tangential", "N", "Tangential force of the bundle F_tau = F_L theta r / p (eq. 15)"),
    ALPHA = 12 => Variable::output("alpha", "rad", "Helix slope alpha = acos(F_L / (n F_i)) (eq. 19)").display("deg"),
    TRANSMISSION_RATIO = 13 => Variable::output("transmission_ratio", "m/rad", "dp/dtheta_twist at constant tension (eq. 13), negative: twisting shortens"),
    STIFFNESS = 14 => Variable::output("stiffness", "N/m", "Axial stiffness of the bundle at the load dF_L/dp at fixed twist (Fig. 19)"),
    F_AXIAL = 15 => Variable::output("F_axial", "N", "Axial force of the bundle on the load F_L = T cos(alpha)"),
    // nominal 0.01: the load moves at cm/s
    V_LOAD = 16 => Variable::output("v_load", "m/s", "Load velocity dp/dt").display("mm/s").nominal(0.01),
    VOLTAGE_MOTOR = 17 => Variable::output("voltage_motor", "V", "Armature voltage applied (controller output or input)"),
    // The position loop's outputs change only at its samples (time events in Model Exchange).
    OMEGA_REF = 18 => discrete(Variable::output("omega_ref", "rad/s", "Speed set point from the position loop (held between samples)").display("rpm")),
    THETA_MOTOR_MEASURED = 19 => discrete(Variable::output("theta_motor_measured", "rad", "Encoder angle (1000 CPT read 4x) at the last position-loop sample (internal_controller only, else 0)").display("deg")),
    // ---- base parameters ---------------------------------------------------------------------
    LOAD_MASS = 20 => Variable::parameter("load_mass", 23.0 / 9.81, "kg",
        "[calibrate] Hanging load incl. moving bracket; the paper's loads 23/39/54/97/124 N are F/9.81").range(0.1, 20.0).tunable(),
    STRING_LENGTH = 21 => Variable::parameter("string_length", 0.0897, "m",
        "Unloaded untwisted string length L0 (Table 2 c1, Table 3)").range(0.03, 0.3).display("mm"),
    STRING_RADIUS = 22 => Variable::parameter("string_radius", STRING_RADIUS_FIT, "m",
        "[calibrate] Effective helix radius r of the bundle for the twist angle: eq. 9-10 (Table 3) fitted to the measured contractions of sec. 6 (geometric value of four 1 mm strings: 1.2071 mm)").range(0.3e-3, 3e-3).display("mm"),
    STRING_COUNT = 23 => Variable::parameter("string_count", 4.0, "1",
        "Number of strings n (eq. 19)").range(1.0, 12.0),
    STRING_STIFFNESS = 24 => Variable::parameter("string_stiffness", 1e6, "N/m",
        "Axial stiffness of the bundle with string_compliance off (nearly inextensible helix)").range(1e4, 1e8),
    STRING_DAMPING = 25 => Variable::parameter("string_damping", 2000.0, "N.s/m",
        "Axial damping of the bundle (Kelvin-Voigt)").range(0.0, 1e5),
    SPRING_STIFFNESS = 26 => Variable::parameter("spring_stiffness", 100.0, "N/m",
        "[calibrate] Return spring stiffness (Fig. 7 part 6)").range(0.0, 5000.0),
    SPRING_PRELOAD = 27 => Variable::parameter("spring_preload", 5.0, "N",
        "Return spring force at the untwisted length L0").range(0.0, 200.0),
    GUIDE_DAMPING = 28 => Variable::parameter("guide_damping", 20.0, "N.s/m",
        "[calibrate] Viscous friction of the 4 linear guides and bearings").range(0.0, 2000.0),
    MOTOR_RESISTANCE = 29 => Variable::parameter("motor_resistance", 2.32, "Ohm",
        "Terminal resistance (maxon RE 25, 20 W, 24 V class)").range(0.1, 50.0),
    MOTOR_INDUCTANCE = 30 => Variable::parameter("motor_inductance", 0.238e-3, "H",
        "Terminal inductance (maxon RE 25, 20 W, 24 V class)").range(1e-5, 1e-2).display("mH"),
    TORQUE_CONSTANT = 31 => Variable::parameter("torque_constant", 0.0234, "N.m/A",
        "Torque constant k_t (maxon RE 25, 24 V class)").range(1e-3, 0.5).display("mN.m/A"),
    BACK_EMF_CONSTANT = 32 => Variable::parameter("back_emf_constant", 0.0234, "V.s/rad",
        "Back-EMF constant k_e = 1/speed constant (408 rpm/V)").range(1e-3, 0.5),
    ROTOR_INERTIA = 33 => Variable::parameter("rotor_inertia", 1.09e-6, "kg.m2",
        "Rotor (10.3 g.cm2, RE 25 118752) + gearhead input (0.6 g.cm2, estimate) inertia at the motor shaft").range(1e-7, 1e-4),
    GEAR_RATIO = 34 => Variable::parameter("gear_ratio", 19.2, "1",
        "Planetary gearhead GP 26 A reduction N (paper sec. 3)").range(1.0, 200.0),
    GEAR_EFFICIENCY = 35 => Variable::parameter("gear_efficiency", 0.81, "1",
        "Gearhead efficiency (2-stage GP 26 A), applied in the direction of power flow").range(0.3, 1.0),
    ENCODER_CPT = 36 => Variable::parameter("encoder_cpt", 1000.0, "1",
        "Encoder counts per turn, read 4x (MR 1000 CPT, paper ref. 17)").range(16.0, 100000.0),
    SUPPLY_VOLTAGE = 37 => Variable::parameter("supply_voltage", 24.0, "V",
        "ESCON supply = maximum armature voltage").range(1.0, 60.0),
    CURRENT_LIMIT = 38 => Variable::parameter("current_limit", 3.0, "A",
        "ESCON current limit (saturation of the speed-PI output)").range(0.1, 20.0).tunable(),
    SPEED_LIMIT = 39 => Variable::parameter("speed_limit", RPM8000, "rad/s",
        "Speed set-point limit: 8000 rpm maximum gearhead input speed (paper sec. 6)").range(1.0, 2000.0).display("rpm").tunable(),
    CONTROLLER_CURRENT_P = 40 => Variable::parameter("controller_current_P", 0.165, "Ohm",
        "Current PI gain (Table 5: 165, read in mV/A)").range(1e-3, 100.0).tunable(),
    CONTROLLER_CURRENT_TI = 41 => Variable::parameter("controller_current_Ti", 69e-6, "s",
        "Current PI integration time (Table 5: 69 us)").range(1e-6, 1.0).tunable(),
    CONTROLLER_SPEED_P = 42 => Variable::parameter("controller_speed_P", SPEED_P_SI, "A.s/rad",
        "Speed PI gain (Table 5: 963, read in uA/rpm)").range(1e-5, 1.0).tunable(),
    CONTROLLER_SPEED_TI = 43 => Variable::parameter("controller_speed_Ti", 0.042, "s",
        "Speed PI integration time (Table 5: 42 ms)").range(1e-4, 10.0).tunable(),
    CONTROLLER_POSITION_P = 44 => Variable::parameter("controller_position_P", POSITION_P_SI, "1/s",
        "Position P gain (Table 5: 0.0035, read as fraction of 8000 rpm per degree of twist error)").range(0.01, 200.0).tunable(),
    CONTROLLER_POSITION_BAND = 45 => Variable::parameter("controller_position_band", 2.0 * std::f64::consts::PI / 180.0, "rad",
        "Hysteresis band of the position loop on the motor angle (eq. 20-21: 2 deg)").range(0.0, 1.0).display("deg"),
    CONTROLLER_POSITION_PERIOD = 46 => Variable::parameter("controller_position_period", 1e-3, "s",
        "Sample period of the position loop (sbRIO; choice: 1 kHz)").range(1e-4, 0.1),
    RTOL = 47 => Variable::parameter("rtol", 1e-6, "1", "Relative tolerance of the ODE solver; left at its start value, the tolerance the importer passes to fmi2SetupExperiment").range(1e-12, 1e-2),
    ATOL = 48 => Variable::parameter("atol", 1e-6, "1",
        "Absolute tolerance (dimensionless): state k gets atol*nominal_k, nominals i 1 A, theta 1 rad, omega 10 rad/s, p 1 cm, v 1 cm/s, z_i 1e-3 A.s, z_w 1 rad; left at its start value, the tolerance the importer passes to fmi2SetupExperiment").range(1e-14, 1e-2),
    // ---- candidate effects ------------------------------------------------------------------
    STRING_COMPLIANCE_ENABLED = 49 => Variable::flag("string_compliance.enabled", false,
        "String elongation Delta L = a1 theta_M + a2 theta_M^2 + a3 F_L (eq. 10, Table 3; theta_M motor angle)"),
    STRING_COMPLIANCE_A1 = 50 => Variable::parameter("string_compliance.a1", 8.1153e-6, "m/rad",
        "Elongation per motor radian of twist (Table 3 a1)").range(2e-6, 2e-5),
    STRING_COMPLIANCE_A2 = 51 => Variable::parameter("string_compliance.a2", 8.4427e-9, "m/rad2",
        "Quadratic elongation coefficient (Table 3 a2)").range(2e-9, 2e-8),
    STRING_COMPLIANCE_A3 = 52 => Variable::parameter("string_compliance.a3", 1.6914e-5, "m/N",
        "Axial compliance of the bundle (Table 3 a3)").range(5e-6, 5e-5).display("mm/N"),
    TWIST_HYSTERESIS_ENABLED = 53 => Variable::flag("twist_hysteresis.enabled", false,
        "Inter-strand friction: a torque mu T r tanh(omega_t/0.05) opposing the twist rate"),
    TWIST_HYSTERESIS_FRICTION_COEFFICIENT = 54 => Variable::parameter("twist_hysteresis.friction_coefficient", 0.1, "1",
        "Friction coefficient mu between the strands").range(0.02, 0.5),
    MOTOR_FRICTION_ENABLED = 55 => Variable::flag("motor_friction.enabled", false,
        "Coulomb + viscous friction of motor shaft and gearhead (at the motor shaft)"),
    MOTOR_FRICTION_COULOMB = 56 => Variable::parameter("motor_friction.coulomb", 1e-3, "N.m",
        "Coulomb friction torque at the motor shaft").range(2e-4, 5e-3).display("mN.m"),
    MOTOR_FRICTION_VISCOUS = 57 => Variable::parameter("motor_friction.viscous", 1e-6, "N.m.s/rad",
        "Viscous friction at the motor shaft").range(2e-7, 1e-5),
    GEAR_BACKLASH_ENABLED = 58 => Variable::flag("gear_backlash.enabled", false,
        "Backlash of the gearhead: the output (twist) has its own inertia and touches the flank the transmitted torque pushes it to; when that torque reverses, the motor crosses the gap"),
    GEAR_BACKLASH_ANGLE = 59 => Variable::parameter("gear_backlash.angle", 1.0 * std::f64::consts::PI / 180.0, "rad",
        "Total backlash at the gearhead output").range(0.5 * std::f64::consts::PI / 180.0, 3.0 * std::f64::consts::PI / 180.0).display("deg"),
    RADIUS_GROWTH_ENABLED = 60 => Variable::flag("radius_growth.enabled", false,
        "Effective bundle radius growing with twist r = r0 (1 + g theta_t / 2 pi)"),
    RADIUS_GROWTH_PER_TURN = 61 => Variable::parameter("radius_growth.per_turn", 0.005, "1",
        "Relative radius growth g per turn of twist").range(0.001, 0.02),
    // ---- energy balance (appended so earlier value references stay) -----------------------
    // E_electrical + W_external = E_dissipated + E_stored - E_stored(start) within the solver
    // tolerance (documentation section "Energy balance").
    // nominal 1.0: an energy state starts at 0 J and grows over a run; 1 J bounds its absolute error
    E_ELECTRICAL = 62 => Variable::output("E_electrical", "J",
        "Electrical energy into the armature since the start, integral of voltage_motor * current (ODE state)").nominal(1.0),
    // nominal 1.0: an energy state starts at 0 J and grows over a run; 1 J bounds its absolute error
    W_EXTERNAL = 63 => Variable::output("W_external", "J",
        "Work of the input F_load on the load since the start, sum of F_load * (change of p) over the steps (F_load held over each step)").nominal(1.0),
    // nominal 1.0: an energy state starts at 0 J and grows over a run; 1 J bounds its absolute error
    E_DISSIPATED = 64 => Variable::output("E_dissipated", "J",
        "Energy dissipated since the start (ODE states): copper, gearhead, motor and strand friction, guides, string damping, plus E_string_kinematic").nominal(1.0),
    E_STORED = 65 => Variable::output("E_stored", "J",
        "Stored energy: L i^2/2 + J omega^2/2 + m v^2/2 + gravity and spring potential (0 at p = L0) + elastic string energy"),
    // nominal 1.0: an energy state starts at 0 J and grows over a run; 1 J bounds its absolute error
    E_STRING_KINEMATIC = 66 => Variable::output("E_string_kinematic", "J",
        "Part of E_dissipated: work absorbed (>0) or released (<0) by the non-conservative string_compliance law (eq. 10 twist lengthening, elongation by the load); 0 with string_compliance off").nominal(1.0),
    // ---- Model Exchange: states that are not outputs, and the derivative of every state ------
    // (documentation section "Model Exchange")
    // nominal 1e-3: the current PI integral of i_ref - i, a current error over the loop time constant (ms): ~1e-3 A.s
    CURRENT_INTEGRAL = 67 => Variable::local("current_integral", "A.s",
        "State z_i = int (i_ref - i) dt of the current PI, with anti-windup (internal_controller only, else 0)").nominal(1e-3),
    // nominal 1.0: the speed PI integral of omega_ref - omega_motor: about 1 rad of lag
    SPEED_INTEGRAL = 68 => Variable::local("speed_integral", "rad",
        "State z_w = int (omega_ref - omega_motor) dt of the speed PI, with anti-windup (internal_controller only, else 0)").nominal(1.0),
    // nominal 1e-2: about the backlash gap (~1e-2 rad)
    BACKLASH_POSITION = 69 => Variable::local("backlash_position", "rad",
        "State delta = theta_motor / N - theta_twist: position of the gearhead output in the backlash gap (gear_backlash only, else 0)").display("deg").nominal(1e-2),
    // nominal 1.0: the gearhead output speed is omega_motor / 19.2 with the gap closed; 1 rad/s near rest
    OMEGA_TWIST = 70 => Variable::local("omega_twist", "rad/s",
        "State omega_t: speed of the gearhead output (gear_backlash only, else 0)").display("rpm").nominal(1.0),
    DER_CURRENT = 71 => Variable::local("der(current)", "A/s", "Derivative of current"),
    DER_THETA_MOTOR = 72 => Variable::local("der(theta_motor)", "rad/s", "Derivative of theta_motor"),
    DER_OMEGA_MOTOR = 73 => Variable::local("der(omega_motor)", "rad/s2", "Derivative of omega_motor"),
    DER_P = 74 => Variable::local("der(p)", "m/s", "Derivative of p"),
    DER_V_LOAD = 75 => Variable::local("der(v_load)", "m/s2", "Derivative of v_load"),
    DER_CURRENT_INTEGRAL = 76 => Variable::local("der(current_integral)", "A", "Derivative of current_integral"),
    DER_SPEED_INTEGRAL = 77 => Variable::local("der(speed_integral)", "rad/s", "Derivative of speed_integral"),
    DER_E_ELECTRICAL = 78 => Variable::local("der(E_electrical)", "W", "Derivative of E_electrical: electrical power voltage_motor * current"),
    DER_E_DISSIPATED = 79 => Variable::local("der(E_dissipated)", "W", "Derivative of E_dissipated: dissipated power"),
    DER_E_STRING_KINEMATIC = 80 => Variable::local("der(E_string_kinematic)", "W", "Derivative of E_string_kinematic"),
    DER_BACKLASH_POSITION = 81 => Variable::local("der(backlash_position)", "rad/s", "Derivative of backlash_position"),
    DER_OMEGA_TWIST = 82 => Variable::local("der(omega_twist)", "rad/s2", "Derivative of omega_twist"),
    DER_W_EXTERNAL = 83 => Variable::local("der(W_external)", "W", "Derivative of W_external: power F_load * v_load"),
}

/// An output whose value changes only at the position loop's samples (`variability="discrete"`).
const fn discrete(v: Variable) -> Variable {
    Variable {
        variability: Variability::Discrete,
        ..v
    }
}
