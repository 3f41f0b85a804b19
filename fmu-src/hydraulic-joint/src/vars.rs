//! The variable table. Names and value references are a fixed interface: users, tests and
//! scripts address variables by them; a new variable takes a new value reference.

use fmu_core::Variable;

fmu_core::declare_variables! {
    // ---- mode flags
    INTERNAL_CONTROLLER = 0 => Variable::flag("internal_controller", true,
        "true: the 40 Hz controller (paper sec. IV) tracks theta_ref; false: valve voltages from u_left, u_right"),
    CABLES_ATTACHED = 1 => Variable::flag("cables_attached", true,
        "false frees both pistons from their cables (Fig. 6 bench test of a single piston)"),
    VALVE_USE_MEAN = 2 => Variable::flag("valve_use_mean", false,
        "Use the mean of the four Table I orifice coefficients for all orifices (matched, symmetric valve)"),
    // ---- inputs
    // Set-point range: +-90 deg keeps both pistons inside their stroke (+-50 mm on the 30 mm
    // pulley is +-95 deg); the experiment design stays within it.
    THETA_REF = 3 => Variable::input("theta_ref", 0.0, "rad", "Desired link angle theta_d (used when internal_controller)").range(-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2).display("deg"),
    U_LEFT = 4 => Variable::input("u_left", 0.0, "V", "Left valve voltage when internal_controller is false (saturated to +-10 V)").range(-10.0, 10.0),
    U_RIGHT = 5 => Variable::input("u_right", 0.0, "V", "Right valve voltage when internal_controller is false (saturated to +-10 V)").range(-10.0, 10.0),
    // +-20 N.m: three times the 2 kg load's torque at 0.3 m, a third of what one cylinder gives
    // at 10 MPa on its 30 mm pulley.
    TAU_EXT = 6 => Variable::input("tau_ext", 0.0, "N.m", "External torque on the link, positive in the direction of theta").range(-20.0, 20.0),
    // ---- outputs
    // nominal 0.01: the link angle swings by tenths of a rad to a rad; 0.01 rad bounds the absolute error near 0
    THETA = 7 => Variable::output("theta", "rad", "Link angle, eq. (1); grows when the left piston pulls").display("deg").nominal(0.01),
    // nominal 0.01: the link speed in rad/s, scaled as theta
    OMEGA = 8 => Variable::output("omega", "rad/s", "Link angular velocity").display("deg/s").nominal(0.01),
    // nominal 1e-3: piston positions in m, strokes of cm; 1 mm near the retracted end
    X_LEFT = 9 => Variable::output("x_left", "m", "Left piston position from the retracted end").display("mm").nominal(1e-3),
    // nominal 1e-3: piston positions in m, strokes of cm; 1 mm near the retracted end
    X_RIGHT = 10 => Variable::output("x_right", "m", "Right piston position from the retracted end").display("mm").nominal(1e-3),
    // nominal 1e-2: piston speeds of cm/s
    V_LEFT = 11 => Variable::output("v_left", "m/s", "Left piston velocity, positive extending").display("mm/s").nominal(1e-2),
    // nominal 1e-2: piston speeds of cm/s
    V_RIGHT = 12 => Variable::output("v_right", "m/s", "Right piston velocity, positive extending").display("mm/s").nominal(1e-2),
    // nominal 1e5: gauge chamber pressures of bars to the supply pressure; 1 bar
    P1_LEFT = 13 => Variable::output("p1_left", "Pa", "Left cap-side (piston-side) chamber pressure, gauge").display("bar").nominal(1e5),
    // nominal 1e5: gauge chamber pressures of bars to the supply pressure; 1 bar
    P2_LEFT = 14 => Variable::output("p2_left", "Pa", "Left rod-side chamber pressure, gauge").display("bar").nominal(1e5),
    // nominal 1e5: gauge chamber pressures of bars to the supply pressure; 1 bar
    P1_RIGHT = 15 => Variable::output("p1_right", "Pa", "Right cap-side chamber pressure, gauge").display("bar").nominal(1e5),
    // nominal 1e5: gauge chamber pressures of bars to the supply pressure; 1 bar
    P2_RIGHT = 16 => Variable::output("p2_right", "Pa", "Right rod-side chamber pressure, gauge").display("bar").nominal(1e5),
    F_LEFT = 17 => Variable::output("F_left", "N", "Left piston hydraulic force P1 A1 - P2 A2, eq. (2)"),
    F_RIGHT = 18 => Variable::output("F_right", "N", "Right piston hydraulic force P1 A1 - P2 A2, eq. (3)"),
    T_LEFT = 19 => Variable::output("T_left", "N", "Left cable tension at the joint (load cell)"),
    T_RIGHT = 20 => Variable::output("T_right", "N", "Right cable tension at the joint (load cell)"),
    U_VALVE_LEFT = 21 => Variable::output("u_valve_left", "V", "Voltage at the left valve"),
    U_VALVE_RIGHT = 22 => Variable::output("u_valve_right", "V", "Voltage at the right valve"),
    Q_LEFT = 23 => Variable::output("Q_left", "m3/s", "Flow drawn from the supply by the left valve").display("L/min"),
    Q_RIGHT = 24 => Variable::output("Q_right", "m3/s", "Flow drawn from the supply by the right valve").display("L/min"),
    // ---- link
    LOAD_MASS = 25 => Variable::parameter("load_mass", 2.0, "kg",
        "[calibrate] Mass fixed on the link standing for forearm and hand (paper sec. V)").range(0.0, 10.0).tunable(),
    LOAD_RADIUS = 26 => Variable::parameter("load_radius", 0.30, "m", "Distance of the load mass from the joint axis").range(0.05, 0.6),
    LINK_INERTIA = 27 => Variable::parameter("link_inertia", 0.056, "kg.m2",
        "Inertia of the bare link about the joint axis (human upper arm, Winter 2009)").range(0.005, 0.5),
    LINK_DAMPING = 28 => Variable::parameter("link_damping", 3.0, "N.m.s/rad",
        "[calibrate] Joint viscous friction b, eq. (1)").range(0.0, 10.0),
    PULLEY_RADIUS = 29 => Variable::parameter("pulley_radius", 0.03, "m", "Pulley radius R, eq. (1)").range(0.01, 0.1).display("mm"),
    // ---- cylinders (Parker CHL, 16 mm bore, 10 mm rod, 100 mm stroke)
    PISTON_AREA = 30 => Variable::parameter("piston_area", 2.010_619_298_297_467_7e-4, "m2", "Cap-side area A1, eq. (4)").range(5e-5, 2e-3),
    ANNULUS_AREA = 31 => Variable::parameter("annulus_area", 1.225_221_134_900_318_2e-4, "m2", "Rod-side area A2, eq. (5); must be < piston_area").range(2e-5, 2e-3),
    STROKE = 32 => Variable::parameter("stroke", 0.1, "m", "Stroke s, eq. (12); pistons start mid-stroke").range(0.06, 0.5).display("mm"),
    DEAD_VOLUME_CAP = 33 => Variable::parameter("dead_volume_cap", 2e-6, "m3", "V1(0): cap-side line and port volume, eq. (11)").range(1e-7, 1e-4),
    DEAD_VOLUME_ROD = 34 => Variable::parameter("dead_volume_rod", 2e-6, "m3", "V2(0): rod-side line and port volume at full extension, eq. (12)").range(1e-7, 1e-4),
    PISTON_MASS = 35 => Variable::parameter("piston_mass", 0.3, "kg", "Moving mass M of piston, rod and spring end, eq. (6)").range(0.05, 5.0),
    PISTON_DAMPING = 36 => Variable::parameter("piston_damping", 500.0, "N.s/m", "Viscous part of g(v) in eq. (6) always present").range(0.0, 1e4),
    // ---- oil and supply
    BULK_MODULUS = 37 => Variable::parameter("bulk_modulus", 1.0e9, "Pa", "[calibrate] Effective bulk modulus beta (oil, hoses), eq. (7)-(10)").range(2e8, 2e9),
    SUPPLY_PRESSURE = 38 => Variable::parameter("supply_pressure", 1.0e7, "Pa", "Supply pressure Ps (100 bar)").range(1e6, 2.1e7).display("bar"),
    RETURN_PRESSURE = 39 => Variable::parameter("return_pressure", 0.0, "Pa", "Return (reservoir) pressure Pr, gauge").range(0.0, 1e6).display("bar"),
    // ---- valve (Parker D1FP, Table I). The orifice coefficients have no FMI unit: the SI unit
    // m3 s^-1 V^-1 Pa^-1/2 has a half-integer exponent, which FMI `BaseUnit` cannot express; it
    // is stated in the description.
    C1 = 40 => Variable::parameter("c1", 0.3667e-8, "1", "Table I orifice coefficient c1, P->A [m3 s^-1 V^-1 Pa^-1/2], eq. (13)").range(5e-10, 5e-8).unit_not_expressible(),
    C2 = 41 => Variable::parameter("c2", 0.3404e-8, "1", "Table I orifice coefficient c2, P->B [m3 s^-1 V^-1 Pa^-1/2], eq. (14)").range(5e-10, 5e-8).unit_not_expressible(),
    C3 = 42 => Variable::parameter("c3", 0.3282e-8, "1", "Table I orifice coefficient c3, B->T [m3 s^-1 V^-1 Pa^-1/2], eq. (15)").range(5e-10, 5e-8).unit_not_expressible(),
    C4 = 43 => Variable::parameter("c4", 0.3276e-8, "1", "Table I orifice coefficient c4, A->T [m3 s^-1 V^-1 Pa^-1/2], eq. (16)").range(5e-10, 5e-8).unit_not_expressible(),
    VALVE_FLOW_SCALE = 44 => Variable::parameter("valve_flow_scale", 1.0, "1",
        "[calibrate] Common scale on the four orifice coefficients").range(0.2, 5.0),
    VALVE_DEADBAND_LOW = 45 => Variable::parameter("valve_deadband_low", -1.8, "V", "Lower edge of the valve command dead band (Fig. 6)").range(-5.0, 0.0),
    VALVE_DEADBAND_HIGH = 46 => Variable::parameter("valve_deadband_high", 1.5, "V", "Upper edge of the valve command dead band (Fig. 6)").range(0.0, 5.0),
    // ---- series springs
    SPRING_STIFFNESS = 47 => Variable::parameter("spring_stiffness", 5.0e4, "N/m", "Series spring stiffness between piston and cable").range(1e3, 1e6).display("N/mm"),
    SPRING_PRETENSION = 48 => Variable::parameter("spring_pretension", 150.0, "N", "Cable pretension at rest (co-contraction)").range(0.0, 2000.0),
    // ---- controller (sec. IV)
    CONTROLLER_RATE = 49 => Variable::parameter("controller_rate", 40.0, "1/s", "Sample rate f of the position controller, eq. (23)").range(1.0, 1000.0).display("Hz"),
    CONTROLLER_GAIN = 50 => Variable::parameter("controller_gain", 0.2, "1", "Gain K of eq. (25)-(26), on the desired piston speed").range(0.0, 5.0).tunable(),
    CONTROLLER_SLOPE_EXTEND = 51 => Variable::parameter("controller_slope_extend", 0.0509, "m/(s.V)",
        "Slope of the Fig. 6 curve the controller inverts, extending (above the dead band)").range(1e-3, 1.0),
    CONTROLLER_SLOPE_RETRACT = 52 => Variable::parameter("controller_slope_retract", 0.0366, "m/(s.V)",
        "Slope of the Fig. 6 curve the controller inverts, retracting (below the dead band)").range(1e-3, 1.0),
    CONTROLLER_DEADBAND_LOW = 53 => Variable::parameter("controller_deadband_low", -1.8, "V", "Dead band lower edge the controller compensates").range(-5.0, 0.0),
    CONTROLLER_DEADBAND_HIGH = 54 => Variable::parameter("controller_deadband_high", 1.5, "V", "Dead band upper edge the controller compensates").range(0.0, 5.0),
    // ---- solver
    RTOL = 55 => Variable::parameter("rtol", 1e-6, "1", "Relative tolerance of the integrator; left at its start value, the tolerance the importer passes to fmi2SetupExperiment").range(1e-12, 1e-2),
    ATOL = 56 => Variable::parameter("atol", 1e-6, "1", "Absolute tolerance, times the nominal scale of each state; left at its start value, the tolerance the importer passes to fmi2SetupExperiment").range(1e-12, 1e-2),
    // ---- candidate effects (off by default)
    SEAL_FRICTION_ENABLED = 57 => Variable::flag("seal_friction.enabled", false, "Coulomb + Stribeck + viscous piston seal friction with stiction"),
    SEAL_FRICTION_COULOMB = 58 => Variable::parameter("seal_friction.coulomb", 40.0, "N", "Coulomb seal friction force Fc").range(5.0, 200.0),
    SEAL_FRICTION_BREAKAWAY_EXCESS = 59 => Variable::parameter("seal_friction.breakaway_excess", 30.0, "N", "Breakaway (static) force above Coulomb, Fs - Fc").range(0.0, 200.0),
    SEAL_FRICTION_STRIBECK_VELOCITY = 60 => Variable::parameter("seal_friction.stribeck_velocity", 0.01, "m/s", "Stribeck speed vs").range(0.002, 0.05).display("mm/s"),
    SEAL_FRICTION_VISCOUS = 61 => Variable::parameter("seal_friction.viscous", 300.0, "N.s/m", "Viscous seal friction (added to piston_damping)").range(0.0, 3000.0),
    VALVE_OVERLAP_ENABLED = 62 => Variable::flag("valve_overlap.enabled", false, "Spool overlap beyond the measured command dead band"),
    VALVE_OVERLAP_WIDTH = 63 => Variable::parameter("valve_overlap.width", 0.4, "V", "Extra dead zone on each side of the dead band").range(0.1, 1.5),
    INTERNAL_LEAKAGE_ENABLED = 64 => Variable::flag("internal_leakage.enabled", false, "Leakage across the piston, proportional to P1 - P2"),
    INTERNAL_LEAKAGE_COEFFICIENT = 65 => Variable::parameter("internal_leakage.coefficient", 5e-13, "m3/(s.Pa)", "Cross-piston leakage coefficient C_ip").range(1e-14, 5e-12),
    CABLE_FRICTION_ENABLED = 66 => Variable::flag("cable_friction.enabled", false, "Bowden capstan friction T_j = T_p exp(-mu phi sign(v))"),
    CABLE_FRICTION_MU = 67 => Variable::parameter("cable_friction.mu", 0.1, "1", "Friction coefficient core/liner (PTFE liner)").range(0.02, 0.3),
    // Base (not calibrated, not an effect parameter): the capstan law depends only on mu * phi, so the
    // wrap angle is fixed hardware geometry and only cable_friction.mu is identified. Kept at the
    // value reference of the former `cable_friction.wrap_angle` so no other reference shifts.
    BOWDEN_WRAP_ANGLE = 68 => Variable::parameter("bowden_wrap_angle", 3.0, "rad", "Total bend angle phi of each Bowden cable along its routing (geometry; used by cable_friction, whose law depends only on mu phi)").range(0.5, 6.3).display("deg"),
    ENTRAINED_AIR_ENABLED = 69 => Variable::flag("entrained_air.enabled", false, "Effective bulk modulus falling at low pressure (air in the oil)"),
    ENTRAINED_AIR_FRACTION = 70 => Variable::parameter("entrained_air.fraction", 0.02, "1", "Air-to-oil volume ratio at atmospheric pressure").range(0.005, 0.1),
    ENTRAINED_AIR_POLYTROPIC_INDEX = 71 => Variable::parameter("entrained_air.polytropic_index", 1.2, "1", "Polytropic index of the air (1 isothermal, 1.4 adiabatic)").range(1.0, 1.4),
    VALVE_DYNAMICS_ENABLED = 72 => Variable::flag("valve_dynamics.enabled", false, "Spool second-order lag, eq. (18)"),
    VALVE_DYNAMICS_NATURAL_FREQUENCY = 73 => Variable::parameter("valve_dynamics.natural_frequency", 1300.0, "rad/s", "Spool natural frequency omega").range(400.0, 2000.0),
    VALVE_DYNAMICS_DAMPING_RATIO = 74 => Variable::parameter("valve_dynamics.damping_ratio", 0.7, "1", "Spool damping ratio zeta").range(0.4, 1.2),
    // ---- oil balance diagnostics (appended so earlier value references stay)
    // nominal 1e-8: the oil moved in 1 ms at 0.6 L/min
    V_SUPPLIED = 75 => Variable::output("V_supplied", "m3",
        "Oil drawn from the supply by both valves since initialization, as volume at 0 gauge (mass / rho(0)); diagnostic").display("cm3").nominal(1e-8),
    // nominal 1e-8: the oil moved in 1 ms at 0.6 L/min
    V_RETURNED = 76 => Variable::output("V_returned", "m3",
        "Oil returned to tank by both valves since initialization, as volume at 0 gauge; diagnostic").display("cm3").nominal(1e-8),
    V_STORED = 77 => Variable::output("V_stored", "m3",
        "Oil in the four chambers as volume at 0 gauge, sum V_i rho(P_i)/rho(0); V_supplied - V_returned = V_stored - V_stored(0) up to solver error").display("cm3"),
    // ---- appended effect parameters
    SEAL_FRICTION_MEMORY_TIME = 78 => Variable::parameter("seal_friction.memory_time", 5e-3, "s",
        "Frictional memory: lag of the Stribeck part behind the sliding speed (Hess & Soom 1990)").range(1e-3, 5e-2).display("ms"),
    // ---- appended after the first release, so earlier value references stay valid
    CONTROLLER_COCONTRACTION = 79 => Variable::parameter("controller_cocontraction", 1.0, "1",
        "Gain K_c of the co-contraction loop: both pistons get the common speed -K_c f m, m = mean piston offset from mid-stroke (holds the cable pretension; 0: eq. (23)-(24) alone)").range(0.0, 5.0).tunable(),
    // ---- Model Exchange: the states without an output of their own, then the derivative of
    // every state (documentation, 'Model Exchange'); appended so earlier references stay
    // nominal 0.01: the spool in volts of command; 0.01 V
    SPOOL_LEFT = 80 => Variable::local("spool_left", "V", "Left spool position in volts of command (valve_dynamics state; 0 when the effect is off)").nominal(0.01),
    // nominal 10.0: spool speed in V/s, fast through the valve bandwidth; 10 V/s
    SPOOL_RATE_LEFT = 81 => Variable::local("spool_rate_left", "V/s", "Left spool velocity (valve_dynamics state; 0 when the effect is off)").nominal(10.0),
    // nominal 0.01: the spool in volts of command; 0.01 V
    SPOOL_RIGHT = 82 => Variable::local("spool_right", "V", "Right spool position in volts of command (valve_dynamics state; 0 when the effect is off)").nominal(0.01),
    // nominal 10.0: spool speed in V/s, fast through the valve bandwidth; 10 V/s
    SPOOL_RATE_RIGHT = 83 => Variable::local("spool_rate_right", "V/s", "Right spool velocity (valve_dynamics state; 0 when the effect is off)").nominal(10.0),
    // nominal 1e-2: a remembered piston speed, as the piston speed
    V_MEMORY_LEFT = 84 => Variable::local("v_memory_left", "m/s", "Left piston speed remembered by the seal friction (seal_friction state; 0 when the effect is off)").display("mm/s").nominal(1e-2),
    // nominal 1e-2: a remembered piston speed, as the piston speed
    V_MEMORY_RIGHT = 85 => Variable::local("v_memory_right", "m/s", "Right piston speed remembered by the seal friction (seal_friction state; 0 when the effect is off)").display("mm/s").nominal(1e-2),
    DER_THETA = 86 => Variable::local("der(theta)", "rad/s", "Derivative of theta"),
    DER_OMEGA = 87 => Variable::local("der(omega)", "rad/s2", "Derivative of omega, eq. (1)"),
    DER_X_LEFT = 88 => Variable::local("der(x_left)", "m/s", "Derivative of x_left"),
    DER_V_LEFT = 89 => Variable::local("der(v_left)", "m/s2", "Derivative of v_left, eq. (6)"),
    DER_P1_LEFT = 90 => Variable::local("der(p1_left)", "Pa/s", "Derivative of p1_left, eq. (7)"),
    DER_P2_LEFT = 91 => Variable::local("der(p2_left)", "Pa/s", "Derivative of p2_left, eq. (8)"),
    DER_X_RIGHT = 92 => Variable::local("der(x_right)", "m/s", "Derivative of x_right"),
    DER_V_RIGHT = 93 => Variable::local("der(v_right)", "m/s2", "Derivative of v_right, eq. (6)"),
    DER_P1_RIGHT = 94 => Variable::local("der(p1_right)", "Pa/s", "Derivative of p1_right, eq. (9)"),
    DER_P2_RIGHT = 95 => Variable::local("der(p2_right)", "Pa/s", "Derivative of p2_right, eq. (10)"),
    DER_V_SUPPLIED = 96 => Variable::local("der(V_supplied)", "m3/s", "Derivative of V_supplied: oil drawn from the supply per second"),
    DER_V_RETURNED = 97 => Variable::local("der(V_returned)", "m3/s", "Derivative of V_returned: oil returned to tank per second"),
    DER_SPOOL_LEFT = 98 => Variable::local("der(spool_left)", "V/s", "Derivative of spool_left"),
    DER_SPOOL_RATE_LEFT = 99 => Variable::local("der(spool_rate_left)", "V/s2", "Derivative of spool_rate_left, eq. (18)"),
    DER_SPOOL_RIGHT = 100 => Variable::local("der(spool_right)", "V/s", "Derivative of spool_right"),
    DER_SPOOL_RATE_RIGHT = 101 => Variable::local("der(spool_rate_right)", "V/s2", "Derivative of spool_rate_right, eq. (18)"),
    DER_V_MEMORY_LEFT = 102 => Variable::local("der(v_memory_left)", "m/s2", "Derivative of v_memory_left"),
    DER_V_MEMORY_RIGHT = 103 => Variable::local("der(v_memory_right)", "m/s2", "Derivative of v_memory_right"),
}
