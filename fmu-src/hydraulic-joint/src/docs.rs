//! The HTML documentation of the model (equations, sources, derivations, parameter tables).

/// HTML fragment for `documentation/index.html`, the defaults written in from the table.
pub fn html() -> String {
    fmu_core::html::with_start_values(DOC, crate::vars::VARIABLES)
        .expect("every placeholder of the documentation names a variable of the table")
}

const DOC: &str = r#"
<h2>Source and scope</h2>
<p>Paper: <i>Description, Characterization and Assessment of a Bio-Inspired Shoulder Joint-First
Link Robot for Neuro-Robotic Applications</i> (NEUROexos shoulder prototype). Equation numbers
(1)-(26) below are the paper's. The figures of the paper are not available (text extraction), so
Fig. 6 (voltage-velocity curve) and Fig. 8 (catching response) are used only through the numbers
stated in the text: dead band -1.8 V to 1.5 V, faster extension than retraction, 40 Hz control,
lag 0.125 s, maximum error 10 deg. Textbooks: H. E. Merritt, <i>Hydraulic Control Systems</i>
(1967); N. D. Manring, <i>Hydraulic Control Systems</i> (2005).</p>
<p>The joint: a link (upper-arm-like, with a mass standing for forearm and hand) on a pulley of
radius R, pulled by two Bowden cables; each cable is driven by a Parker CHL single-rod
double-acting cylinder through a series spring; each cylinder is fed by a Parker D1FP
three-land four-way zero-lapped proportional valve from a 100 bar supply. The link moves in a
horizontal plane (eq. 1 has no gravity term); use <code>tau_ext</code> for gravity or a
co-simulated arm.</p>

<h2>Coordinates and signs</h2>
<ul>
<li><code>x_left</code>, <code>x_right</code>: piston position from the fully retracted end
(0) to the stroke s; <code>v = dx/dt</code>, positive extending.</li>
<li>A positive valve voltage opens P&rarr;A and B&rarr;T: oil flows to the piston (cap) side and
the piston extends (paper sec. III).</li>
<li>Extending a piston pulls its cable. <b>The left piston's pull makes <code>theta</code>
grow</b>; the right piston's pull makes it decrease. So the spring elongations are
<code>e_L = e0 + (x_L - x0) - R theta</code>, <code>e_R = e0 + (x_R - x0) + R theta</code>.</li>
<li><code>tau_ext</code> is positive in the direction of <code>theta</code>. Pressures are gauge
pressures [Pa] (display bar).</li>
</ul>

<h2>Equations (SI units inside)</h2>
<h3>Link, eq. (1)</h3>
<p><code>I theta'' + b theta' = (T_L - T_R) R + tau_ext</code>, with
<code>I = link_inertia + load_mass load_radius^2</code>. The paper writes eq. (1) with the piston
forces F_L, F_R; with a spring in series they reach the link as the cable tensions T_L, T_R
(equal to the piston forces in steady state).</p>
<h3>Pistons, eq. (2)-(6)</h3>
<p><code>M x'' = F - T_spring - g(x') + F_stop</code>, <code>F = P1 A1 - P2 A2</code> (eq. 2-3,
output <code>F_left/F_right</code>), <code>g(v) = piston_damping v</code> (+ seal friction when
that effect is on). End stops at 0 and s: <code>F_stop</code> is a stiff penalty contact,
<code>k smooth_pos(d, w) -/+ c v min(d/w, 1)</code> on the penetration d, never pulling
(k = 1e8 N/m, c = 5e3 N s/m, w = 10 um).</p>
<h3>Chambers, eq. (7)-(12)</h3>
<p><code>V1 = V1(0) + x A1</code>, <code>V2 = V2(0) + (s - x) A2</code>,
<code>P1' = beta/V1 (Q1 - A1 v)</code>, <code>P2' = beta/V2 (Q2 + A2 v)</code>.</p>
<h3>Oil balance (diagnostic outputs <code>V_supplied</code>, <code>V_returned</code>, <code>V_stored</code>)</h3>
<p>What eq. (7)-(10) conserve: the bulk modulus is <code>beta = rho dP/drho</code> (Merritt eq. 2-3),
so the density ratio <code>r(P) = rho(P)/rho(0)</code> solves <code>dr/dP = r/beta</code>,
<code>r(P) = exp(integral_0^P dp/beta(p))</code>. With <code>dP/dt = beta/V (Q - dV/dt)</code>,
<code>d(r V)/dt = r dV/dt + V r/beta dP/dt = r Q</code>: the conserved quantity is the oil mass
<code>rho V</code>, here expressed as the volume <code>r(P) V</code> the chamber's oil would occupy at
0 gauge, and <code>Q</code> is a volume flow at the chamber's pressure. The linear form
<code>V (1 + P/beta)</code> is not conserved (its rate leaves <code>P/beta dV/dt</code>, up to 1 % of the
piston's displacement flow at 100 bar). Constant beta: <code>r = exp(P/beta)</code>; with
<code>entrained_air</code>: <code>r = v(0)/v(P)</code> with the mixture's specific volume
<code>v</code> below. Summed over the four chambers:</p>
<p><code>V_stored = sum_k V_k r(P_k)</code>,
<code>V_supplied = integral sum_valves r(P_fed) Q_supply dt</code> (the chamber the P edge feeds:
chamber 1 for <code>u_eff &gt;= 0</code>, chamber 2 otherwise),
<code>V_returned = integral sum_valves r(P_drained) Q_tank dt</code>, and exactly
<code>V_supplied - V_returned = V_stored(t) - V_stored(0)</code>. Internal leakage is written
mass-conserving (it leaves chamber 1 as <code>Q_leak</code> and enters chamber 2 as
<code>Q_leak r(P1)/r(P2)</code>), so it cancels from the balance. The two integrals are ODE states
under the same error control as the others (nominal 1e-8 m3; they restart at 0 in each
integration call and are summed in the model, so their relative tolerance applies to the
increment rather than to the growing total); the residual of the balance is therefore the
solver's error, of order <code>rtol</code> times the oil moved, and shrinks with <code>rtol</code>
(<code>tests/test_hydraulic_joint.py::test_oil_balance</code>). These outputs are diagnostics
for soak tests; the SciPy reference does not compute them. Pressures are gauge, so
<code>r</code> is taken relative to atmospheric pressure; <code>beta</code> lumps the hose
compliance, so <code>V_stored</code> is the model's oil content, not a measurable tank level.</p>
<h3>Valve, eq. (13)-(17)</h3>
<p>With <code>a = u_eff &gt;= 0</code>: <code>Q1 = c1 a ssqrt(Ps - P1)</code> into chamber 1
(P&rarr;A), <code>Q2 = -c3 a ssqrt(P2 - Pr)</code> out of chamber 2 (B&rarr;T). With
<code>u_eff &lt; 0</code>, <code>a = |u_eff|</code>: <code>Q2 = c2 a ssqrt(Ps - P2)</code> into
chamber 2 (P&rarr;B), <code>Q1 = -c4 a ssqrt(P1 - Pr)</code> out of chamber 1 (A&rarr;T). The
paper's eq. (15)-(16) carry <code>-c u</code>; with <code>u &lt; 0</code> that would make the
drain of chamber 1 an inflow, so the physically consistent reading with <code>|u|</code> is used.
The supply flow (<code>Q_left</code>, <code>Q_right</code>) is the flow through the P edge that is
open. <code>ssqrt(dp) = sign(dp) sqrt|dp|</code> for <code>|dp| &gt;= 1e4 Pa</code>, and the odd cubic
<code>sqrt(p_t) (5/4 r - 1/4 r^3)</code>, <code>r = dp/p_t</code>, <code>p_t = 1e4 Pa</code>,
below (laminar regularisation: same value and slope at p_t, finite slope at 0). Flows reverse
when the pressure drop does. With <code>valve_use_mean</code> all four coefficients are replaced
by their mean (the paper's merged coefficient); <code>valve_flow_scale</code> multiplies them.</p>
<p>The spool is fast (3.5 ms step response) and taken as proportional to the command (paper,
after eq. 18): <code>u_eff = deadband(u)</code>. The effect <code>valve_dynamics</code> puts
eq. (18) in between.</p>

<h3>Unit system of Table I</h3>
<p>Table I gives c1..c4 = 0.3667e-8, 0.3404e-8, 0.3282e-8, 0.3276e-8 without units. Reading
them in SI, <code>Q [m3/s] = c [m3 s^-1 V^-1 Pa^-1/2] u [V] sqrt(dP [Pa])</code>: at 10 V and the
35 bar per metering edge at which D1FP spools are rated, <code>Q = 0.3667e-8 * 10 * sqrt(3.5e6)
= 6.9e-5 m3/s = 4.1 L/min</code>; at 10 V and the full 100 bar, 11.6 L/min. A few L/min per metering
edge is the order of a small direct-operated NG6 proportional valve such as the D1FP, and of
what a 1.1 kW / 1390 rpm power unit (with its accumulator) can feed to six valves. Other readings fail: pressure in bar
(<code>sqrt(35) = 5.9</code>) gives 2e-7 m3/s = 0.013 L/min, three orders too small to move a
cylinder at the speeds of sec. V; flow in L/min with pressure in Pa gives 1e-3 L/min. The FMI
unit of c cannot be declared (half-integer exponent of Pa), so the coefficients carry no unit
attribute and the description states it.</p>

<h3>Valve command dead band (base model)</h3>
<p>Fig. 6 shows no piston motion for commands between -1.8 V and 1.5 V; the paper attributes it
to stiction. With a zero-lapped valve that cannot hold: any opening lets the chamber pressure
climb toward supply within milliseconds (chamber capacitance V/beta ~ 1e-14 m3/Pa, flow ~ 1e-6
m3/s at 0.1 V), and the resulting force (hundreds of N on a 16 mm bore) breaks any plausible seal
stiction (tens of N). So the base model puts the measured dead band where it acts, on the
command: <code>u_eff = smooth_pos(u - 1.5, w)</code> above, <code>-smooth_pos(-1.8 - u, w)</code>
below, exactly 0 in between (the valve's electronics/spool overlap around null, as measured on
the bench), with the C1 blend <code>smooth_pos(d, w) = d^2/(2w)</code> for <code>0 &lt; d &lt; w</code>,
<code>d - w/2</code> beyond, <code>w = 0.02 V</code>. The candidate <code>valve_overlap</code>
widens this band by its width on each side (spool overlap beyond the base behaviour) and
<code>seal_friction</code> adds the stiction the paper mentions. The dead band edges are not
calibrated by default (they are measured).</p>
<h3>Why extension is faster</h3>
<p>For a free piston without load, steady flow through the two open edges and the force
balance <code>P1 A1 = P2 A2</code> give the slopes of the Fig. 6 curve outside the band:
<code>k_ext = sqrt((Ps - alpha Pr)/(A1^2/c1^2 + alpha A2^2/c3^2))</code> and
<code>k_ret = sqrt((Ps - Pr/alpha)/(A2^2/c2^2 + A1^3/(A2 c4^2)))</code>, <code>alpha = A2/A1</code>.
With matched orifices <code>k_ext/k_ret = 1/sqrt(alpha)</code> &gt; 1: the velocity is higher when
oil flows to the piston side (paper, Fig. 6). With the defaults: k_ext = 0.0509 m/s/V,
k_ret = 0.0366 m/s/V (ratio 1.39), i.e. 0.43 m/s at +10 V and -0.30 m/s at -10 V.</p>

<h3>Series spring and cable</h3>
<p><code>T_spring = k_s smooth_pos(e, 10 um)</code>: a cable cannot push; slack is possible.
At rest <code>e = e0</code> with <code>k_s smooth_pos(e0) = spring_pretension</code>.
<code>cables_attached = false</code> frees both pistons (T = 0) and leaves the link alone: the
Fig. 6 bench test of a single piston. Outputs <code>T_left/T_right</code> are the tensions at the
joint end (the load cells of sec. II), equal to the spring tensions unless
<code>cable_friction</code> is on.</p>

<h3>Position controller, sec. IV, eq. (23)-(26)</h3>
<p>Sampled at <code>t0 + j/f</code> (f = <code>controller_rate</code> = 40 Hz, j an integer
counter, so samples are hit exactly whatever the communication step): <code>e = theta_ref -
theta</code>, desired piston speeds <code>xdot_L = e f R + c</code>, <code>xdot_R = -e f R + c</code>
(eq. 23-24 plus the common speed <code>c</code> of the co-contraction loop below), voltages
<code>V_i = f_inv(K xdot_i)</code> held until the next sample, saturated to +-10 V, where
<code>f_inv</code> inverts the Fig. 6 curve: 0 for 0, <code>1.5 + w/2 + y</code> (extending) or
<code>-1.8 - w/2 - y</code> (retracting) with <code>y = |speed|/k_side</code> (the exact inverse of
the blended dead band inside the blend). The paper writes <code>V = K f(xdot)</code>; applying
K to the speed rather than to the voltage is the reading that keeps the dead-band compensation
exact for any K: with <code>K &lt; 1</code> on the voltage, small errors would be mapped back into the
dead band and the joint would stall with a standing error. A sample falling on the start of a
communication step uses that step's <code>theta_ref</code>; one strictly inside a step
interrupts the integration there. With <code>internal_controller = false</code> the valves get
<code>u_left</code>, <code>u_right</code> (saturated to +-10 V) over each step.</p>

<h3>Co-contraction loop (holding the pretension)</h3>
<p>The paper keeps the cables "always in tense" by moving the pistons "with the same velocity
but in different directions" (sec. IV), with the pretension set by the series springs "during
the cocontraction" (sec. II). The sum of the two spring elongations,
<code>e_L + e_R = 2 e0 + (x_L - x0) + (x_R - x0) = 2 e0 + 2 m</code>, does not depend on
<code>theta</code>: both cables keep their pretension on average only while the mean piston offset
<code>m = (x_L + x_R)/2 - x0</code> stays 0. Equal and opposite <i>commanded</i> speeds keep
<code>m</code> constant only if both valves deliver them, but the Fig. 6 curve the controller inverts
was measured on a free piston: under load the pulling piston's metering edge sees a smaller
pressure drop (it extends slower than commanded) and the pulled piston's a larger one (it retracts
faster). So <code>m</code> drifts negative whenever the joint tracks a moving reference against
the link's inertia and damping. Measured on the model with eq. 23-24 alone
(<code>controller_cocontraction = 0</code>), tracking <code>0.5 sin(2 pi 0.7 t)</code> rad: both
pistons creep toward retraction (the mean offset reaches -15 mm after 10 s), the cables go slack
in every half cycle, and the RMS tracking error grows from 0.18 to 0.34 rad over 10 s.</p>
<p>The rig measures both piston positions (potentiometers, sec. II), so the model's controller
closes a second, common-mode loop on them: both pistons get the common speed
<code>c = -K_c f m</code>, the same form as eq. 23 (the mean offset corrected at the sample rate,
scaled by <code>K</code> through <code>f_inv(K xdot)</code>) with gain
<code>K_c = controller_cocontraction</code> (default 1: the common mode converges like the joint
error, time constant <code>1/(K K_c f)</code> = 0.125 s). It does not act on
<code>theta</code> (the two common speeds pull the link equally) and is 0 at rest. With it, the
same sinusoid leaves <code>m</code> within 2 mm, both cable tensions above 25 N from 1.5 s on (the
first acceleration from rest asks for more torque than twice the pretension can give, so the right
cable slackens for about 60 ms near 0.2 s), and the RMS tracking error steady at 0.18&ndash;0.19 rad
over 2 s windows: the lag of the sampled loop (with ideal velocity-source pistons <code>theta_(k+1) = theta_k + K e_k</code>, error
amplitude <code>|z - 1| / |z - 1 + K|</code> at <code>z = exp(j w / f)</code>: 0.174 rad RMS) plus
the lag of the springs, oil columns and link inertia. <code>controller_cocontraction = 0</code>
gives the paper's law as written.</p>

<h3>Tuning to the paper's catching result (K, b)</h3>
<p>With the pistons acting as velocity sources, the loop <code>theta' = K f e</code> is first
order with time constant <code>1/(K f)</code>; on a ramp it lags by that time constant and the
error is the lag times the speed. A minimum-jerk reach of 45 deg in 1 s peaks at 84 deg/s, so a
0.125 s lag gives about 10.5 deg: the paper's two numbers are consistent with each other and
with <code>K f = 8 1/s</code>, <code>K = 0.2</code> at 40 Hz. The series springs
(<code>2 k_s R^2 = 90 N m/rad</code>) and the link inertia (0.236 kg m2) form a 3 Hz mode that a
lightly damped link turns into a growing oscillation under this loop (tried: b = 0.5 N m s/rad
oscillates). The link damping b = 3 N m s/rad (damping ratio 0.33 of that mode; it stands for
the bearing, the Bowden cables' viscous losses and the co-contracted springs) makes the loop
well damped. Result at defaults (FMU, 1 ms steps): lag 0.124 s, peak error 10.1 deg. K and b
are the unknowns tuned; b is tagged for calibration.</p>

<h2>Candidate effects (off by default)</h2>
<table>
<tr><th>effect</th><th>equation</th><th>source</th></tr>
<tr><td><code>seal_friction</code></td><td><code>g += (Fc + Fex exp(-(v_m/vs)^2)) tanh(v/1e-4 m/s) + sigma v</code>, <code>v_m' = (v - v_m)/tau_L</code> (<code>tau_L</code> = <code>seal_friction.memory_time</code>; one state per piston, 0 at rest)</td><td>Stribeck curve with frictional memory: Armstrong-Helouvry, Dupont, Canudas de Wit, Automatica 1994 (seven-parameter model); Hess &amp; Soom, ASME J. Tribology 1990; Manring 2005 sec. 6</td></tr>
<tr><td><code>valve_overlap</code></td><td>dead band edges moved to <code>-1.8 - width</code>, <code>1.5 + width</code></td><td>Merritt sec. 5.2 (overlapped spool)</td></tr>
<tr><td><code>internal_leakage</code></td><td><code>Q_leak = C_ip (P1 - P2)</code> out of chamber 1, <code>Q_leak r(P1)/r(P2)</code> into chamber 2 (same mass; see the oil balance)</td><td>Merritt eq. 5-32</td></tr>
<tr><td><code>cable_friction</code></td><td><code>T_joint = T_spring exp(-mu phi tanh(v_slide/1e-3 m/s))</code>, <code>v_slide = +-R theta'</code> toward the piston, <code>mu = cable_friction.mu</code>, <code>phi = bowden_wrap_angle</code></td><td>capstan equation; Kaneko et al. IEEE TRA 1991</td></tr>
<tr><td><code>entrained_air</code></td><td>mixture specific volume per unit gas-free oil at 0 gauge <code>v(P) = exp(-P/beta) + x0 (p_atm/p_a)^(1/n)</code>, <code>beta_e = -v/(dv/dP)</code>, <code>r = v(0)/v(P)</code>; <code>p_a = 0.5 (q + sqrt(q^2 + (0.1 p_atm)^2))</code>, <code>q = P + p_atm</code> (absolute pressure smoothly kept &gt; 0). Equal to the textbook <code>beta_e = beta (1+X)/(1 + X beta/(n p_a))</code>, <code>X = x0 (p_atm/p_a)^(1/n)</code>, except that the oil's own compression (<code>P/beta</code>, &lt; 2 %) is kept in X and the smooth max's slope in dv/dP; this exact form has the closed-form density ratio the oil balance needs</td><td>Merritt sec. 2.6; Manring eq. 1.29</td></tr>
<tr><td><code>valve_dynamics</code></td><td><code>xv'' + 2 zeta omega xv' + omega^2 xv = omega^2 u</code>, <code>u_eff = deadband(xv)</code></td><td>paper eq. (18); omega = 1300 rad/s, zeta = 0.7 reach 95 % in about 3.3 ms (paper: 3.5 ms step response)</td></tr>
</table>
<h3>Seal friction: stiction, Stribeck curve and frictional memory</h3>
<p>In steady sliding (<code>v_m = v</code>) the friction is the static Stribeck curve: breakaway
force <code>Fc + Fex</code> at the start of motion, falling to <code>Fc</code> above the Stribeck speed,
plus viscous <code>sigma v</code>. Stiction: <code>tanh(v/v_eps)</code>, <code>v_eps = 1e-4 m/s</code>, is the
smooth sign; below the breakaway force the seal creeps at <code>v_eps atanh(F/Fs)</code> (under
0.1 mm/s for forces below 75 % of breakaway, 3 um per 30 ms controller period, below what the
joint's sensors resolve), and the slope <code>(Fc + Fex)/v_eps</code> at zero speed is a stiff but
linear damper the L-stable solver steps over. <b>Frictional memory</b>: a memoryless Stribeck curve
acts as a negative damper of slope up to <code>0.86 Fex/vs</code> (2.6e3 N s/m at the defaults,
8.6e4 at the range ends) at every frequency. Against the 0.3 kg piston on its oil column (about
580 Hz) it exceeds the 800 N s/m of positive damping, and the memoryless model chattered in a
500 Hz stick-slip limit cycle whenever a piston moved slower than a few cm/s (velocity jumping
between 0.1 and 25 mm/s each millisecond), which the paper does not report and which cost the
solver 60-90 steps per millisecond (10 s of catching: 1.09 s of CPU, 183 000 steps, against
0.12 s without friction). Real lubricated contacts do not respond instantly: friction lags
velocity changes by milliseconds (Hess &amp; Soom 1990), which the seven-parameter model of
Armstrong-Helouvry et al. (1994) writes as the Stribeck term evaluated at <code>v(t - tau_L)</code>.
The first-order lag <code>v_m</code> is its smooth form: the steady-state curve, the breakaway force
and stiction are unchanged, slow stick-slip (below <code>1/(2 pi tau_L)</code>, 30 Hz at 5 ms) remains
possible, and at the oil-column frequency the negative damping is divided by
<code>1 + (omega tau_L)^2</code> (about 300). Same 10 s: 0.13 s, 17 000 steps (<code>cargo run --release
-p hydraulic-joint --example explore perf</code>). <code>tau_L</code> is a parameter (1-50 ms, default
5 ms) because the lag is seal-specific.</p>
<p>Ranges: Coulomb 5-200 N and breakaway excess 0-200 N (1-10 % of the 2 kN a 16 mm bore gives at
100 bar); Stribeck speed 2-50 mm/s; frictional memory 1-50 ms (lags of milliseconds to tens of
milliseconds; at 1 ms the Stribeck damping at the oil-column frequency is still divided by about 14); leakage 1e-14-5e-12 m3/(s Pa) (0.0006-0.3 L/min at 10 bar,
new to worn seals); PTFE-lined Bowden mu 0.02-0.3 over <code>bowden_wrap_angle</code> 0.5-6.3 rad of bends (the capstan law depends on mu and phi only through their product, so only <code>cable_friction.mu</code> is an effect parameter the gap workflow fits; the wrap angle is routing geometry, a base parameter that is measured, not calibrated); air 0.5-10 % by
volume; spool 400-2000 rad/s (step responses of direct-operated proportional valves, 2-10 ms).</p>

<h2>Initialization at rest</h2>
<p>At <code>fmi2ExitInitializationMode</code>: theta = 0, omega = 0, both pistons at s/2
(5 cm from each stop at the default stroke; the stroke's minimum 6 cm keeps 3 cm), v = 0, spring
elongation e0 giving the pretension, valves closed (zero command lies inside the dead band).
Chamber pressures from the static equilibrium <code>P1 A1 - P2 A2 = T0</code>: the trapped
pressures of a closed valve are not unique, so the rod side is taken at the null pressure of a
matched zero-lapped valve, <code>P2 = (Ps + Pr)/2</code>, and <code>P1 = (T0 + P2 A2)/A1</code>
(37.9 bar at the defaults). With <code>internal_leakage</code> on, the only rest state has
<code>P1 = P2 = T0/(A1 - A2)</code>. Refused at initialization (the message names the parameter):
<code>annulus_area &gt;= piston_area</code>, <code>return_pressure &gt;= supply_pressure</code>, a
<code>spring_pretension</code> needing more than the supply pressure.</p>

<h2>Parameters the paper omits: values and why</h2>
<table>
<tr><th>parameter</th><th>value</th><th>why</th></tr>
<tr><td>piston_area, annulus_area</td><td>{{piston_area:.3e}}, {{annulus_area:.3e}} m2</td><td>Parker CHL, 16 mm bore, 10 mm rod (smallest bore: 2 kN at 100 bar is ample for a 1 N m, 30 mm pulley joint; alpha = 0.61 gives the paper's faster extension)</td></tr>
<tr><td>stroke</td><td>{{stroke}} m</td><td>a catalogue stroke; +-45 deg on R = 30 mm needs +-24 mm from mid-stroke</td></tr>
<tr><td>dead_volume_cap, dead_volume_rod</td><td>{{dead_volume_cap:e}} m3</td><td>ports, fittings and about 0.3 m of 3 mm bore hose between valve and cylinder</td></tr>
<tr><td>piston_mass</td><td>{{piston_mass}} kg</td><td>piston, 10 mm steel rod, rod eye and spring end</td></tr>
<tr><td>piston_damping</td><td>{{piston_damping}} N s/m</td><td>viscous seal and oil drag; damps the oil-column mode (about 650 Hz) to a ratio of about 0.2</td></tr>
<tr><td>bulk_modulus</td><td>{{bulk_modulus:.1e}} Pa</td><td>mineral oil 1.4-1.6e9 Pa lowered by hoses and some air; calibrated by default</td></tr>
<tr><td>supply_pressure, return_pressure</td><td>{{supply_pressure in bar:.0}} bar, {{return_pressure in bar:.0}} bar gauge</td><td>cylinders' maximum pressure (sec. III), tank return</td></tr>
<tr><td>pulley_radius</td><td>{{pulley_radius}} m</td><td>a pulley fitting a shoulder-sized joint</td></tr>
<tr><td>link_inertia</td><td>{{link_inertia}} kg m2</td><td>upper arm of a 75 kg adult, 2.1 kg, 0.30 m, radius of gyration about the shoulder 0.163 m (Winter, Biomechanics and Motor Control of Human Movement, 2009)</td></tr>
<tr><td>load_mass, load_radius</td><td>{{load_mass:.1}} kg at {{load_radius:.2}} m</td><td>forearm and hand (1.65 kg for 75 kg) with their own inertia lumped at the elbow (sec. V: "a mass has been calculated and fixed on the link")</td></tr>
<tr><td>link_damping</td><td>{{link_damping}} N m s/rad</td><td>see the tuning section</td></tr>
<tr><td>spring_stiffness, spring_pretension</td><td>{{spring_stiffness:e}} N/m, {{spring_pretension}} N</td><td>a 50 N/mm safety spring; 150 N co-contraction keeps the cables taut up to about 9 N m of torque imbalance</td></tr>
<tr><td>bowden_wrap_angle</td><td>{{bowden_wrap_angle}} rad ({{bowden_wrap_angle in deg:.0}} deg)</td><td>total bend of each Bowden cable from cylinder to joint: about a half turn of routing around a shoulder; only used by <code>cable_friction</code>, which identifies <code>cable_friction.mu</code> at this angle (the law sees <code>mu phi</code> only); range 0.5-6.3 rad, measured on the hardware, not calibrated</td></tr>
<tr><td>controller_gain</td><td>{{controller_gain}}</td><td>see the tuning section</td></tr>
<tr><td>controller_cocontraction</td><td>{{controller_cocontraction}}</td><td>choice: the common mode converges like the joint error (see the co-contraction loop)</td></tr>
<tr><td>c1..c4, valve_use_mean, valve_flow_scale</td><td>Table I, {{valve_use_mean}}, {{valve_flow_scale}}</td><td>from the paper (SI reading derived above); the mean is the paper's merged coefficient; the scale is the calibration handle</td></tr>
<tr><td>valve_deadband_low/high, controller_deadband_low/high</td><td>{{valve_deadband_low}} V, {{valve_deadband_high}} V</td><td>Fig. 6 (paper text); not calibrated by default</td></tr>
<tr><td>controller_rate</td><td>{{controller_rate in Hz}} Hz</td><td>paper sec. V</td></tr>
<tr><td>rtol, atol</td><td>{{rtol:e}}, {{atol:e}}</td><td>agree with the Radau reference within 1e-3 of each output's range</td></tr>
<tr><td>controller_slope_extend / _retract</td><td>{{controller_slope_extend}} / {{controller_slope_retract}} m/(s V)</td><td>the closed-form Fig. 6 slopes above, i.e. the curve the controller would have measured on the bench</td></tr>
</table>

<h2>Regularisations (numerical constants)</h2>
<p>Laminar transition 1e4 Pa; cable slack blend 10 um; end-stop blend 10 um with 1e8 N/m and
5e3 N s/m; dead band blend 0.02 V; stiction speed 1e-4 m/s; capstan direction speed 1e-3 m/s;
atmospheric pressure 101325 Pa. Each keeps the right-hand side continuously differentiable
(or continuous) so the error-controlled solver does not collapse its step.</p>

<h2>Solver</h2>
<p>L-stable Rosenbrock (crate <code>ode</code>, Rodas5P) with relative tolerance <code>rtol</code> and
absolute tolerance <code>atol</code> (both, left at their start value 1e-6, the tolerance the importer
passes to fmi2SetupExperiment, clamped into their range) times each state's nominal scale: theta 0.01 rad, omega
0.01 rad/s, x 1 mm, piston speed 1 cm/s, pressures 1e5 Pa, oil integrals 1e-8 m3, spool 0.01 V
and 10 V/s, remembered speed 1 cm/s (at the default atol 1e-6 all are about 1e5 times finer than
the 1e-3-of-range agreement with the reference; a 1 mm/s speed scale cost up to 18 % more steps
for nothing). The step-size history is forgotten when the held valve commands or the external
torque change. The Jacobian is analytic (chain rule through the laws above, friction and
compressibility slopes in closed form; unit-tested against central differences). No heap
allocation per step (<code>tests/alloc.rs</code>).</p>
<p>Cost, 10 s at 1 ms communication steps, default tolerances, CPU time (<code>perf stat -e
task-clock target/release/examples/explore perf CASE once</code>, best of 3, on a shared 2-core
machine): closed-loop reach out and back 59 ms (18 200 steps), with seal_friction 63 ms,
valve_overlap 44 ms, internal_leakage 53 ms, cable_friction 74 ms, entrained_air 74 ms,
valve_dynamics 78 ms; open-loop voltage steps 40 ms (11 900 steps). The floor is one step per
communication step (10 000); the rest resolves the oil-column ringing (about 580 Hz, damping
ratio 0.2) after each 40 Hz command step. About three quarters of the time is the integrator's
dense LU and triangular solves, one quarter this model's right-hand side and Jacobian.</p>

<h2>Model Exchange</h2>
<p>The same archive offers FMI 2.0 Model Exchange: the importer's solver integrates the plant's
states with the right-hand side above. The state vector has 18 entries whatever the effects:
<code>theta, omega, x_left, v_left, p1_left, p2_left, x_right, v_right, p1_right, p2_right,
V_supplied, V_returned</code>, the spools <code>spool_left, spool_rate_left, spool_right,
spool_rate_right</code> (valve_dynamics) and the remembered piston speeds <code>v_memory_left,
v_memory_right</code> (seal_friction); the state of an effect that is off stays 0 with derivative
0. Each derivative is the variable <code>der(&lt;state&gt;)</code>; the oil integrals are the totals
since initialization. Nominals are the scales of the Solver section.</p>
<p>The 40 Hz controller is sampled as in Co-Simulation: each sample <code>t0 + k/f</code> is a time
event (<code>nextEventTime</code>); in Event Mode the controller runs on the state at that instant
with the set point <code>theta_ref</code> there, and its valve commands (<code>u_valve_left</code>,
<code>u_valve_right</code>) are held until the next sample. A set point changed between samples
acts at the next one. Open loop the valve commands are the inputs <code>u_left</code>,
<code>u_right</code> (saturated) and act at once, so <code>u_valve_*</code> and <code>Q_*</code>
list them in their dependencies; every output lists every state. <code>&lt;Derivatives&gt;</code>
lists what each derivative depends on under any setting: <code>der(theta)</code> on omega;
<code>der(omega)</code> on theta, omega, both piston positions (cable tensions; omega for the
capstan) and <code>tau_ext</code>; a piston's <code>der(v)</code> on theta, its position, speed,
pressures and remembered speed; its pressures' derivatives on its position, speed, pressures,
spool and valve input; the oil integrals on the four pressures, both spools and both valve
inputs; a spool's rate on its position, rate and valve input; a remembered speed on the piston
speed and itself (<code>tests/test_model_exchange_hydraulic_joint.py</code> moves every other
state and input and finds the derivative unchanged to the bit). The right-hand side is smooth
by the regularisations above (no discontinuity remains), so the model has no event indicators.
The FMI 3.0 description also lists the parameters among each output's and derivative's
dependencies (FMI 3.0.2 section 2.4.8), by the parts of the model they enter: the valve command
(open loop the input, closed loop the controller's parameters, the pulley radius and the stroke,
acting at the samples), the spool, the orifices, the oil, the chambers, the leakage, the cable and
capstan, the piston and the link; <code>fmi3GetDirectionalDerivative</code> takes a Float64
parameter as known (central differences of the model with the parameter moved).
Step inputs should be given to the importer as events (FMPy: the jump's time repeated), or its
solver integrates across the jump with the old value.</p>
<p>Directional derivatives (<code>providesDirectionalDerivative</code>, Model Exchange, and Co-Simulation at the communication point): the
derivatives with respect to the states come from the analytic Jacobian of the Solver section,
mapped to the 18 states (the oil integrals are quadratures: their columns are 0); entries with an
output as unknown or an input as known are central differences of the same equations (step 6e-6
of the variable's magnitude or nominal). Tested against central differences of
<code>fmi2GetDerivatives</code> at rest, moving, and in the end stop with a slack cable, every
effect on: within 1e-6 of each row's scale.</p>
<p>Agreement (<code>tests/test_model_exchange_hydraulic_joint.py</code>): FMPy's CVode on the Model
Exchange interface and this FMU's own solver in Co-Simulation, both at the default tolerance
1e-6, agree within 2e-4 of each output's range on the catching reach (with and without every
effect), open-loop valve and torque steps into the end stops with every effect on, and the Fig. 6
bench; the Fig. 6 and catching findings of <code>tests/test_hydraulic_joint.py</code> hold on both
interfaces.</p>

<h2>Validation</h2>
<p><code>tests/reference/hydraulic_joint_ref.py</code> re-implements these equations with SciPy
<code>solve_ivp</code> (Radau, rtol 1e-10) and the same sampling; the FMU agrees within 1e-3 of
each output's range on open-loop steps, the Fig. 6 bench, the catching reach, a torque
disturbance and each effect switched on (<code>tests/test_hydraulic_joint.py</code>).</p>
"#;
