//! The variable table: every input, output and parameter of the EMPS model with its value
//! reference, unit, range, start and description, declared once. Names and value references are
//! a fixed interface: a new variable takes a new value reference. The derivation of every start
//! value and range is in the documentation ([`crate::docs`]).

use fmu_core::{Variability, Variable};

/// Drive gain of the benchmark files (`gtau`, N/V): force = gtau * controller voltage.
pub const DRIVE_GAIN: f64 = 35.150_651_882_485_47;
/// Position-loop gain `kp` of the benchmark files (1/s; description eq. 6).
pub const KP: f64 = 160.18;
/// Velocity-loop gain `kv` of the benchmark files (V/(m/s); description eq. 6).
pub const KV: f64 = 243.45;

fmu_core::declare_variables! {
    // ---- interface: mode, inputs, outputs -----------------------------------------------------
    INTERNAL_CONTROLLER = 0 => Variable::flag("internal_controller", true,
        "true: the logged 1 kHz controller drives the axis from qg (and force_pulse); false: open loop, the applied force is the input force_measured"),
    QG = 1 => Variable::input("qg", 0.0, "m",
        "Reference position of the position loop (benchmark signal qg, load side)").range(-0.1, 0.5).display("mm"),
    FORCE_PULSE = 2 => Variable::input("force_pulse", 0.0, "N",
        "Force pulse added to the controller output before its saturation (validation record: drive_gain * 1.0139 V * pulses_N)").range(-400.0, 400.0),
    FORCE_MEASURED = 3 => Variable::input("force_measured", 0.0, "N",
        "Applied force drive_gain * vir when internal_controller = false (open loop)").range(-400.0, 400.0),
    // nominal 1e-3: the axis moves over tenths of a metre; 1 mm bounds the absolute error
    QM = 4 => Variable::output("qm", "m",
        "Measured position: motor encoder on the load side (benchmark signal qm)").display("mm").nominal(1e-3),
    FORCE = 5 => Variable::output("force", "N",
        "Force applied to the axis, drive_gain * controller voltage (or force_measured); at a communication point the force held over the step just ended"),
    VELOCITY = 6 => discrete(Variable::output("velocity", "m/s",
        "The controller's velocity (qfm(k) - qfm(k-1)) / Ts, qfm(k) = (qm(k) + qm(k-1)) / 2, of the last sample before the communication point")),
    VOLTAGE = 7 => discrete(Variable::output("voltage", "V",
        "Controller output u = sat(nu + force_pulse / drive_gain) of the last sample (0 in open loop)")),
    // nominal 1e-2: axis speeds of cm/s to tenths of m/s; 1 cm/s
    V_MOTOR = 8 => Variable::output("v_motor", "m/s", "Velocity of the motor side dq/dt (load side units)").nominal(1e-2),
    Q_LOAD = 9 => Variable::output("q_load", "m",
        "Position of the load (carriage); equal to qm unless flexibility or backlash is on").display("mm"),
    // ---- base parameters ---------------------------------------------------------------------
    MASS = 10 => Variable::parameter("mass", 100.0, "kg",
        "[calibrate] Total moving mass M on the load side: carriage and payload plus rotor and screw inertia J (2 pi / lead)^2 (description eq. 1)").range(10.0, 1000.0),
    VISCOUS_FRICTION = 11 => Variable::parameter("viscous_friction", 100.0, "N.s/m",
        "[calibrate] Viscous friction Fv (description eq. 1); with asymmetric_friction the coefficient of positive velocities").range(0.0, 2000.0),
    OFFSET = 12 => Variable::parameter("offset", 0.0, "N",
        "[calibrate] Offset of the force: a constant force opposing the drive (description eq. 1)").range(-100.0, 100.0),
    Q0 = 13 => Variable::parameter("q0", 0.0, "m",
        "[initial] Position at the start time (the controller's history assumes constant velocity v0 before it)").range(-0.1, 0.5).display("mm"),
    V0 = 14 => Variable::parameter("v0", 0.0, "m/s",
        "[initial] Velocity at the start time").range(-0.5, 0.5).display("mm/s"),
    LOAD_MASS = 15 => Variable::parameter("load_mass", 10.0, "kg",
        "Part of mass beyond the screw-nut contact (carriage, payload): the second mass of flexibility and backlash").range(0.1, 100.0),
    CONTROLLER_KP = 16 => Variable::parameter("controller_kp", KP, "1/s",
        "Position-loop gain kp (description eq. 6; 20 Hz position bandwidth)").range(1.0, 2000.0),
    CONTROLLER_KV = 17 => Variable::parameter("controller_kv", KV, "V.s/m",
        "Velocity-loop gain kv (description eq. 6)").range(1.0, 5000.0),
    // N/V is not in the exporter's unit table; the unit is stated in the description.
    DRIVE_GAIN_VAR = 18 => Variable::parameter("drive_gain", DRIVE_GAIN, "N/V",
        "Drive gain gtau in N/V: force = gtau * voltage (description eq. 7, benchmark files)").range(1.0, 1000.0).unit_not_expressible(),
    VOLTAGE_LIMIT = 19 => Variable::parameter("voltage_limit", 10.0, "V",
        "Saturation of the controller output (Simulation_EMPS.m: viradm = 10 V)").range(0.1, 100.0),
    CONTROLLER_PERIOD = 20 => Variable::parameter("controller_period", 1e-3, "s",
        "Sample period Ts of the controller (dSPACE, 1 kHz)").range(1e-5, 0.1).display("ms"),
    FRICTION_SMOOTHING = 21 => Variable::parameter("friction_smoothing_velocity", 1e-4, "m/s",
        "v_s of the smooth sign tanh(v / v_s) of the Coulomb friction").range(1e-7, 1e-2).display("mm/s"),
    TRAVEL_MID = 22 => Variable::parameter("travel_mid", 0.125, "m",
        "Middle of the travel: position_friction changes the friction linearly about it").range(-1.0, 1.0).display("mm"),
    TRAVEL_HALF = 23 => Variable::parameter("travel_half", 0.125, "m",
        "Half the travel: position_friction.change is the relative change at travel_mid +- travel_half").range(1e-3, 1.0).display("mm"),
    RTOL = 24 => Variable::parameter("rtol", 1e-6, "1",
        "Relative tolerance of the ODE solver; left at its start value, the tolerance the importer passes to fmi2SetupExperiment").range(1e-12, 1e-2),
    ATOL = 25 => Variable::parameter("atol", 1e-6, "1",
        "Absolute tolerance (dimensionless): positions get atol * 1 mm (integrated relative to each interval's start), velocities atol * 1 cm/s; left at its start value, the importer's tolerance").range(1e-14, 1e-2),
    // ---- candidate effects ------------------------------------------------------------------
    COULOMB_FRICTION_ENABLED = 26 => Variable::flag("coulomb_friction.enabled", false,
        "Coulomb friction Fc sign(v) of the screw, nut, bearings and guides (description eq. 1)"),
    COULOMB_FRICTION_FORCE = 27 => Variable::parameter("coulomb_friction.force", 10.0, "N",
        "Coulomb friction force Fc (with asymmetric_friction: of positive velocities)").range(1.0, 200.0),
    ASYMMETRIC_FRICTION_ENABLED = 28 => Variable::flag("asymmetric_friction.enabled", false,
        "Friction of negative velocities with coefficients of its own (description eq. 12: fatigue of the screw)"),
    ASYMMETRIC_FRICTION_VISCOUS_NEGATIVE = 29 => Variable::parameter("asymmetric_friction.viscous_negative", 100.0, "N.s/m",
        "Viscous friction Fv- of negative velocities (viscous_friction is then Fv+)").range(0.0, 2000.0),
    ASYMMETRIC_FRICTION_COULOMB_NEGATIVE = 30 => Variable::parameter("asymmetric_friction.coulomb_negative", 10.0, "N",
        "Coulomb friction Fc- of negative velocities (coulomb_friction.force is then Fc+, 0 when off)").range(0.0, 200.0),
    FLEXIBILITY_ENABLED = 31 => Variable::flag("flexibility.enabled", false,
        "Axial compliance of screw, nut and bearings between the motor side and load_mass (two masses)"),
    FLEXIBILITY_STIFFNESS = 32 => Variable::parameter("flexibility.stiffness", 2e7, "N/m",
        "Axial stiffness k of the screw-nut-bearing chain").range(1e5, 1e9).display("N/mm"),
    FLEXIBILITY_DAMPING_RATIO = 33 => Variable::parameter("flexibility.damping_ratio", 0.05, "1",
        "Damping ratio of the two-mass mode: c = 2 zeta sqrt(k m_motor load_mass / mass)").range(0.005, 0.7),
    BACKLASH_ENABLED = 34 => Variable::flag("backlash.enabled", false,
        "Axial play between screw and nut (lost preload): load_mass is carried across a gap"),
    BACKLASH_WIDTH = 35 => Variable::parameter("backlash.width", 20e-6, "m",
        "Total axial play").range(1e-6, 500e-6).display("mm"),
    POSITION_FRICTION_ENABLED = 36 => Variable::flag("position_friction.enabled", false,
        "Friction varying along the screw: viscous and Coulomb friction times 1 + c (q - travel_mid) / travel_half"),
    POSITION_FRICTION_CHANGE = 37 => Variable::parameter("position_friction.change", 0.1, "1",
        "Relative change c of the friction at the ends of the travel").range(-0.5, 0.5),
    CONTROLLER_DELAY_ENABLED = 38 => Variable::flag("controller_delay.enabled", false,
        "Delay between the controller's sample and the force acting (computation, D/A, drive current loop)"),
    CONTROLLER_DELAY_TIME = 39 => Variable::parameter("controller_delay.time", 0.5e-3, "s",
        "Delay d of the force after its sample (at most 2 controller periods)").range(0.0, 2e-3).display("ms"),
    // ---- Model Exchange: the load's states and the derivative of every state -----------------
    // nominal 1e-3: as the axis position
    LOAD_POSITION = 40 => Variable::local("load_position", "m",
        "State q_l of the load (flexibility or backlash on; else it keeps q0 and q_load is qm)").display("mm").nominal(1e-3),
    // nominal 1e-2: as the axis speed
    LOAD_VELOCITY = 41 => Variable::local("load_velocity", "m/s",
        "State v_l of the load (flexibility or backlash on; else it keeps v0)").nominal(1e-2),
    DER_QM = 42 => Variable::local("der(qm)", "m/s", "Derivative of qm"),
    DER_V_MOTOR = 43 => Variable::local("der(v_motor)", "m/s2", "Derivative of v_motor"),
    DER_LOAD_POSITION = 44 => Variable::local("der(load_position)", "m/s", "Derivative of load_position"),
    DER_LOAD_VELOCITY = 45 => Variable::local("der(load_velocity)", "m/s2", "Derivative of load_velocity"),
}

/// An output whose value changes only at the controller's samples (`variability="discrete"`).
const fn discrete(v: Variable) -> Variable {
    Variable {
        variability: Variability::Discrete,
        ..v
    }
}
