//! HTML documentation of the TwistedString FMU (equations, sources, derivations, choices).

/// The documentation fragment written to `documentation/index.html`, the defaults written in
/// from the table.
pub fn html() -> String {
    fmu_core::html::with_start_values(DOC, crate::vars::VARIABLES)
        .expect("every placeholder of the documentation names a variable of the table")
}

const DOC: &str = r#"
<h1>TwistedString: linear twisted-string actuator</h1>
<p>Source: D. Urukalo, M. D. Jovanovic, A. Rodic, <i>Modeling, Development and Control of Linear
Twisted-String Actuator</i> (the paper; equations and tables are numbered as there). A maxon 20 W DC
motor with a GP 26 A 19.2:1 planetary gearhead twists four strings of 1 mm diameter; the twisted
bundle shortens and lifts a vertical load running on four linear guides; a return spring pushes the
load back. An ESCON module (current and speed PI) and an NI sbRIO (position P with a &plusmn;2&deg;
hysteresis band) form the cascade of Fig. 11. All quantities inside the model are SI.</p>

<h2>1. Angles, and which angle each equation means</h2>
<ul>
<li><code>theta_motor</code> &theta;<sub>m</sub>: motor shaft angle [rad]. <code>theta_twist</code>
&theta;<sub>t</sub> = &theta;<sub>m</sub>/N (N = <code>gear_ratio</code> = 19.2): gearhead output
angle = twist angle of the bundle.</li>
<li>Tables 2 and 3 (eq. 7 and 10) use the <b>motor</b> angle in rad: the paper's experiments
twist 0&ndash;6000&deg; of the bundle; 6000&deg; = 104.72 rad of twist = 2010.6 rad of motor angle,
and 1000&deg; gives 335.1 rad, exactly the "motor range 335.1&ndash;2011 rad" of section 6. With the
motor angle, Table 2 predicts p(335.1) &minus; p(2011) = 29.4 mm, matching the measured changes of
28.5&ndash;31.5 mm; with degrees the quadratic term alone would exceed L<sub>0</sub>.</li>
<li>Eq. 9 and 13&ndash;16 use &theta; r with the <b>twist</b> angle and the physical radius r
(equivalently motor angle times r/N; eq. 16 shows the i&sup2; of that substitution).</li>
</ul>

<h2>2. String radius: derivation</h2>
<p>Eq. 9 with eq. 10 and Table 3, p = &radic;((L<sub>0</sub>+a<sub>1</sub>&theta;<sub>M</sub>+a<sub>2</sub>&theta;<sub>M</sub>&sup2;+a<sub>3</sub>F)&sup2; &minus; (&theta;<sub>M</sub> r/N)&sup2;),
has one parameter the paper does not state: the effective radius r. Two data sets constrain it.</p>
<ul>
<li><b>Table 2 regression</b> p = c<sub>1</sub>+c<sub>2</sub>&theta;<sub>M</sub>+c<sub>3</sub>&theta;<sub>M</sub>&sup2;+c<sub>4</sub>F on the grid
&theta;<sub>M</sub> &isin; [0, 2010.6] rad (61 points) &times; F &isin; {23, 39, 54, 97, 124} N: least squares gives
r = 1.2060 mm (RMS 0.50 mm). The geometric radius of four round 1 mm strings packed in a square,
r = (1/&radic;2 + 1/2) d = 1.2071 mm (string centres at d/&radic;2 from the axis plus the string radius), is
within 0.1 % of it. The remaining difference is mostly at zero twist, where Table 2's load slope
c<sub>4</sub> = 3.21&middot;10<sup>-5</sup> m/N differs from Table 3's a<sub>3</sub> = 1.69&middot;10<sup>-5</sup> m/N (up to 1.9 mm at 124 N).</li>
<li><b>Section 6 measurements</b>: over motor angle 335.1&rarr;2011 rad the strings shorten by
31.5, 30.5, 30.5, 29.0, 28.5 mm under 23, 39, 54, 97, 124 N, and the reported speeds 1.58, 1.53, 1.53,
1.45, 1.42 cm/s are exactly these changes divided by 1675.9 rad / 837.76 rad/s = 2.000 s, the time the
<b>motor</b> (gearhead input, where the 8000 rpm limit applies; at the twist angle it would be 19.2 times
faster) needs at 8000 rpm.</li>
</ul>
<p>With r = 1.2071 mm the model's contraction is 29.7, 29.4, 29.1, 28.2, 27.7 mm (1.49, 1.47, 1.45, 1.41,
1.38 cm/s): 1.2 mm (4 %) short of the measurements on average and below 1.4 cm/s at 124 N. The time base is
not the cause: from rest at 335.1 rad the current-limited speed loop reaches 8000 rpm 25 ms after the step
(3.4 % overshoot, within 1 % after 85 ms) and the motor crosses the range at 99.7 % of 8000 rpm on average, so neither the speed loop's
rise time nor the set-point saturation matters; the string damping at speed changes p by &lt; 0.01 mm
(at constant load the stretch rate stays near zero). The shortfall is in the contraction itself:
Table 2 has no &theta;&middot;F term and gives 29.4 mm for every load, 0.6 mm below the measured mean of 30.0 mm,
so a radius calibrated to Table 2 inherits it, and eq. 9's contraction is very sensitive to r
(d&Delta;p/dr &asymp; 0.26 mm per 0.1 % of r).</p>
<p>The default <code>string_radius</code> is therefore fitted by least squares to the five <b>measured</b>
contractions (the direct measurements; eq. 9&ndash;10 with Table 3 and the default return spring):
<b>r = 1.2127 mm</b>, 0.46 % above the geometric value (equivalent to strings of 1.0046 mm instead of the
nominal 1 mm, well within the tolerance of a braided string). Residual 0.36 mm RMS; contractions 30.9,
30.6, 30.2, 29.4, 28.8 mm, i.e. 1.545, 1.528, 1.512, 1.467, 1.440 cm/s quasi-statically, falling with load
as measured; the Table 2 regression is still met within 0.64 mm RMS on the grid above (1 mm required).
Without the return spring the fit would give 1.2124 mm.
With this radius and <code>string_compliance</code> off, full twist (&theta;<sub>t</sub> r = L<sub>0</sub>)
is reached at &theta;<sub>m</sub> = 1420 rad, well before 2011 rad; with
<code>string_compliance</code> on, the strands lengthen with twist and p(2011 rad) &asymp; 6 cm.</p>

<h2>3. Strings (eq. 9&ndash;19)</h2>
<p>Twist arc a = &theta;<sub>t</sub> r(&theta;<sub>t</sub>), a' = da/d&theta;<sub>t</sub>
(r constant unless <code>radius_growth</code>: r = r<sub>0</sub>(1 + g |&theta;<sub>t</sub>|/2&pi;)).
State p is the load position (the axial length of the helix, growing downward).</p>
<ul>
<li>Strand length of the current configuration (Pythagoras, Fig. 12, eq. 9 read backward):
L = &radic;(p&sup2; + a&sup2;).</li>
<li>Unloaded strand length: L<sub>free</sub> = L<sub>0</sub>, or with <code>string_compliance</code>
L<sub>free</sub> = L<sub>0</sub> + a<sub>1</sub>|&theta;<sub>M</sub>| + a<sub>2</sub>&theta;<sub>M</sub>&sup2;
with &theta;<sub>M</sub> = N &theta;<sub>t</sub> (eq. 10, Table 3, motor-referred angle; the paper twists one
way only, &theta;<sub>M</sub> &ge; 0, and |&theta;<sub>M</sub>| makes strands twisted backward lengthen alike
instead of shortening).</li>
<li>Stretch s = L &minus; L<sub>free</sub>, its rate
&sdot;s = (p v + a a' &omega;<sub>t</sub>)/L &minus; (dL<sub>free</sub>/d&theta;<sub>t</sub>) &omega;<sub>t</sub>;
x = pos(s/c + d &sdot;s) (Kelvin-Voigt, d = <code>string_damping</code>, strings cannot push), with the
smooth positive part pos(x) = (x + &radic;(x&sup2;+w&sup2;))/2, w = 0.01 N (slack regularisation; error &le; w/2).</li>
<li><code>string_compliance</code> off (default): x is the total strand tension T of the nearly
inextensible bundle, c = 1/<code>string_stiffness</code> (10<sup>6</sup> N/m: the "ideal inextensible"
helix as a stiff penalty, 0.12 mm at 124 N); the load force is F<sub>L</sub> = T cos&alpha; = T p/L.</li>
<li><code>string_compliance</code> on: eq. 10 makes the elongation a<sub>3</sub> F<sub>L</sub>, proportional to the
axial <b>load</b> (that is how the paper fitted Table 3), so c = a<sub>3</sub> and x is the load:
F<sub>L</sub> = x p/q, T = x L/q with q = &radic;(p&sup2; + p<sub>&epsilon;</sub>&sup2;), p<sub>&epsilon;</sub> = 1 mm. For
p &gg; p<sub>&epsilon;</sub> (the paper's whole range has p &gt; 5 cm: relative effect &lt; 2&middot;10<sup>-4</sup>) this is
F<sub>L</sub> = (L &minus; L<sub>free</sub>)/a<sub>3</sub>, i.e. exactly eq. 9&ndash;10 at equilibrium; near p = 0 the load
force fades out as in the strand law, so a stalled motor cannot pull the load through the motor.
(Applying a<sub>3</sub> to the strand tension T = F<sub>L</sub>/cos&alpha; instead was tried first: it stretches the
strings 2.2 times more at 6000&deg; and misses Table 2 by 1.65 mm RMS.)</li>
<li>Eq. 12/19: T = n F<sub>i</sub> = &radic;(F<sub>L</sub>&sup2;+F<sub>&tau;</sub>&sup2;); tangential force
F<sub>&tau;</sub> = T sin&alpha; = T a/L (eq. 15: F<sub>L</sub>&theta;r/p);
helix slope &alpha; = atan2(a, p) = acos(F<sub>L</sub>/(n F<sub>i</sub>)).
Output <code>F_string</code> = T/n (n = <code>string_count</code> = 4), <code>F_axial</code> = F<sub>L</sub>.</li>
<li>Eq. 13&ndash;14: torque on the twisting shaft &tau;<sub>L</sub> = F<sub>&tau;</sub> a' = T a a'/L
(= F<sub>L</sub>&theta;r&sup2;/p for constant r). Written with T it stays finite at full twist
(p &rarr; 0); for a given load F<sub>L</sub> it grows without bound as p &rarr; 0, so the motor stalls
(current limit) with p small but positive. The twist terms of eq. 10 are taken as a kinematic
lengthening without a torque of their own, as in the paper's eq. 13&ndash;16.</li>
<li>Outputs: <code>transmission_ratio</code> = dp/d&theta;<sub>t</sub> at constant tension
= (L dL<sub>free</sub>/d&theta;<sub>t</sub> &minus; a a')/max(p, 0.1 mm) (= &minus;&theta;r&sup2;/p, eq. 13);
<code>stiffness</code> = &part;F<sub>L</sub>/&part;p at fixed twist (static part): strand law
(p/L)&sup2;/c + T a&sup2;/L&sup3; (falls as cos&sup2;&alpha;); <code>string_compliance</code> law
(p/L)(p/q)/a<sub>3</sub> + (s/a<sub>3</sub>) p<sub>&epsilon;</sub>&sup2;/q&sup3; (falls as cos&alpha;). Fig. 19's decrease with twist.</li>
</ul>

<h2>4. Load, spring, guides</h2>
<p>m dv/dt = m g + F<sub>load</sub> + F<sub>s</sub> &minus; F<sub>L</sub> &minus; c<sub>g</sub> v,
dp/dt = v, g = 9.81 m/s&sup2;, m = <code>load_mass</code> (paper loads: m = F/9.81).
Return spring (Fig. 7 part 6, pushing the load away from the motor toward the untwisted length):
F<sub>s</sub> = F<sub>0</sub> + k<sub>s</sub>(L<sub>0</sub> &minus; p), defaults k<sub>s</sub> = 100 N/m,
F<sub>0</sub> = 5 N (the paper gives no values; "powerful enough to overcome friction losses").
Guides: viscous c<sub>g</sub> = 20 N&middot;s/m (choice: the paper gives no friction model for the guides).</p>

<h2>5. Motor and gearhead</h2>
<p>L di/dt = u &minus; R i &minus; k<sub>e</sub>&omega;<sub>m</sub>;
J d&omega;<sub>m</sub>/dt = k<sub>t</sub> i &minus; &tau;<sub>in</sub> &minus; &tau;<sub>f</sub>;
d&theta;<sub>m</sub>/dt = &omega;<sub>m</sub> (N. Mohan, Electrical Drives, ref. [22]).
Gearhead: &tau;<sub>in</sub> = f &tau;<sub>out</sub>/N,
&tau;<sub>out</sub> = &tau;<sub>L</sub> (+ strand friction; with <code>gear_backlash</code> the flank torque
&tau;<sub>gear</sub> of section 7.1 instead, and P below at &omega;<sub>m</sub>/N), where f = 1/&eta; when the motor drives
(P = &tau;<sub>out</sub>&omega;<sub>t</sub> &gt; 0) and &eta; when the load drives, blended smoothly:
f = (1/&eta;+&eta;)/2 + (1/&eta;&minus;&eta;)/2 tanh(P/0.1 W). The blend width 0.1 W (about 60 rpm of motor speed at the highest loads) is a choice: a sharper switch acts near standstill as a huge damper that, against the slow speed-PI integrator, made the held motor creep for seconds out of the 2&deg; band.</p>
<table border="1"><tr><th>parameter</th><th>value</th><th>source / rationale</th></tr>
<tr><td>motor_resistance</td><td>{{motor_resistance}} &Omega;</td><td rowspan="5">maxon RE 25, &empty;25 mm, graphite brushes,
20 W, 24 V winding (order no. 118752); the paper names only "Maxon DC motor (20 W)" [15]. Checked against the
public motor-model file <code>digital/asserv/models/motor.m</code> of the GitHub repository
<code>oliv5/apbteam</code> (commit 4839708f, entry "Maxon RE25G 20W 24V 118752", catalogue values):
terminal resistance 2.32 &Omega; (agrees), terminal inductance 0.24 mH (agrees with 0.238 mH to its two
digits), torque constant 23.4 mN&middot;m/A (agrees), speed constant 407 rpm/V (k<sub>e</sub> = 0.02346 V&middot;s/rad;
the model keeps k<sub>e</sub> = k<sub>t</sub> = 0.0234 in SI, i.e. 408 rpm/V, as for an ideal machine: 0.3 %
difference, within catalogue rounding), rotor inertia 10.3 g&middot;cm&sup2; (<b>corrected</b>: the model
used a recalled 10.8 g&middot;cm&sup2; before). rotor_inertia = 10.3 g&middot;cm&sup2; rotor + an estimated
0.6 g&middot;cm&sup2; for the gearhead input stage (not checked). Derived: no-load speed 24 V &middot; 408 rpm/V
&asymp; 9800 rpm, stall torque k<sub>t</sub>&middot;24 V/R &asymp; 0.24 N&middot;m.</td></tr>
<tr><td>motor_inductance</td><td>{{motor_inductance in mH:.3}} mH</td></tr>
<tr><td>torque_constant</td><td>{{torque_constant in mN.m/A:.1}} mN&middot;m/A</td></tr>
<tr><td>back_emf_constant</td><td>{{back_emf_constant}} V&middot;s/rad (408 rpm/V)</td></tr>
<tr><td>rotor_inertia</td><td>{{rotor_inertia*1e6:.2}}&middot;10<sup>-6</sup> kg&middot;m&sup2;</td></tr>
<tr><td>gear_ratio</td><td>{{gear_ratio}}</td><td>paper sec. 3, maxon GP 26 A [16]</td></tr>
<tr><td>gear_efficiency</td><td>{{gear_efficiency}}</td><td>2-stage planetary gearhead, maxon catalogue class value as recalled;
<b>not verified</b>: no GP 26 A data sheet was reachable with the public sources searched</td></tr>
<tr><td>encoder_cpt</td><td>{{encoder_cpt}} (read 4x)</td><td>paper sec. 6, encoder MR 1000 CPT [17]</td></tr>
<tr><td>speed_limit</td><td>{{speed_limit in rpm:.0}} rpm</td><td>paper sec. 6: maximum permissible gearhead input speed</td></tr>
<tr><td>supply_voltage / current_limit</td><td>{{supply_voltage}} V / {{current_limit}} A</td><td>ESCON module [19] supply for a 24 V winding; current limit a choice (about 2x the nominal current of the winding)</td></tr>
</table>

<h2>6. Cascade controller (Fig. 11, Table 5)</h2>
<p>The ESCON runs the current loop at 53.6 kHz and the speed loop at 5.36 kHz. Both are modelled
<b>continuous</b> (their integrators are ODE states z<sub>i</sub>, z<sub>&omega;</sub>): their sample
delays (19 &micro;s, 187 &micro;s) are far below the mechanical time scales, and continuous loops keep
both the FMU and the SciPy reference fast. PI law u = K(e + z/T<sub>i</sub>), output clamped to its limit; anti-windup by conditional
integration (clamping): dz/dt = e(1 &minus; s), s = 0 unless e&middot;u &gt; 0 (the error drives the
output further out), then s = clamp((|u| &minus; u<sub>max</sub>)/(0.01 u<sub>max</sub>), 0, 1): integration fades
out over the first 1 % beyond the limit (continuous right-hand side). Back-calculation was tried first
and let the speed overshoot 8000 rpm by 10 % after a current-limited acceleration.</p>
<ul>
<li>Speed PI: e<sub>&omega;</sub> = &omega;<sub>ref</sub> &minus; &omega;<sub>m</sub>, i<sub>ref</sub> saturated at &plusmn;<code>current_limit</code>.
Table 5 "963" read in &micro;A/rpm: K<sub>&omega;</sub> = 9.196&middot;10<sup>-3</sup> A&middot;s/rad, T<sub>i</sub> = 42 ms
(crossover K<sub>&omega;</sub>k<sub>t</sub>/J &asymp; 197 rad/s, PI zero 24 rad/s).</li>
<li>Current PI: e<sub>i</sub> = i<sub>ref</sub> &minus; i, u saturated at &plusmn;<code>supply_voltage</code>.
Table 5 "165" read in mV/A: K<sub>i</sub> = 0.165 V/A, T<sub>i</sub> = 69 &micro;s (closed-loop poles
&asymp; &minus;1.07&middot;10<sup>3</sup> and &minus;9.4&middot;10<sup>3</sup> rad/s).</li>
<li>Position P on the sbRIO, <b>sampled</b> every <code>controller_position_period</code> = 1 ms at
t<sub>k</sub> = t<sub>0</sub> + k T<sub>s</sub> (integer counter) on the encoder angle
&theta;<sub>meas</sub> = floor(&theta;<sub>m</sub> 4000/2&pi;) 2&pi;/4000. Table 5 "0.0035" read as
fraction of the 8000 rpm maximum speed per degree of twist error: K<sub>p</sub> = 0.0035 &middot; 837.76 &middot; (180/&pi;)/19.2 = 8.750 s<sup>-1</sup>
per rad of motor error. Hysteresis of eq. 20&ndash;21: while SP &minus; 2&deg; &lt; PV &lt; SP + 2&deg;
(motor angle) the output is &omega;<sub>ref</sub> = 0 and the speed loop holds the motor; outside,
&omega;<sub>ref</sub> = clamp(K<sub>p</sub>(SP &minus; PV), &plusmn;8000 rpm). The motor thus stops at the first
sample inside the band: steady-state error &lt; 2&deg;, its value depending on the approach.
&omega;<sub>ref</sub> is held between samples. A sample falling on a communication point is
taken at the start of the next step, with the inputs set for it (FMI 2.0.4 section 4.2.1: inputs set
before the step hold at the communication point), and the outputs at that point show the set point
before it; a sample inside a step sees the inputs held over the step. Instants within
10<sup>-9</sup>T<sub>s</sub> of a communication point count as on it. The sample at the start time is taken in
initialization with the inputs given there (the outputs at the start show it, as after a Model
Exchange importer's initial event iteration) and again by the first step with the inputs set for
it.</li>
<li>Gain units are a reading, not stated by the paper: they give the cascade ordering the paper
describes (current loop fastest, position loop slowest: &asymp;1000, 200, 9 rad/s).</li>
</ul>
<p>With <code>internal_controller</code> = false the armature voltage is the input <code>voltage</code>
and the controller states are frozen.</p>

<h2>7. Candidate effects (off by default)</h2>
<ul>
<li><code>string_compliance</code>: eq. 10 with Table 3 defaults (a1, a2 per motor rad, a3 per N),
see section 3. Makes the whole paper range 0&ndash;2011 rad reachable.</li>
<li><code>twist_hysteresis</code>: inter-strand friction torque &mu; T a' tanh(&omega;<sub>t</sub>/0.05 rad/s)
opposing the twist rate: twisting needs more torque than untwisting under the same load.</li>
<li><code>motor_friction</code>: &tau;<sub>f</sub> = &tau;<sub>c</sub> tanh(&omega;<sub>m</sub>/1 rad/s) + b &omega;<sub>m</sub> at the motor shaft
(no-load current of the RE 25 class, 20&ndash;30 mA, is about 0.6 mN&middot;m).</li>
<li><code>gear_backlash</code>: a gap of total width b (<code>gear_backlash.angle</code>, at the
gearhead output; GP 26 A class about 1&deg;, range 0.5&ndash;3&deg;) between the gear flanks, with the
output's own inertia and a contact law: the flank in contact follows the sign of the torque through
the gear, and when it reverses the motor crosses the gap before it drives the output again.
Section 7.1.</li>
<li><code>radius_growth</code>: r = r<sub>0</sub>(1 + g |&theta;<sub>t</sub>|/2&pi;) (the radius varies
with twist, paper ref. [13]).</li>
</ul>

<h3>7.1 gear_backlash: the gap as a contact</h3>
<p><b>Which flank carries the load.</b> The gear passes a torque to its output; the flank in contact is
the one that pushes in the direction of that torque. The output (planet carrier, shaft, string clamp:
inertia J<sub>out</sub>) obeys J<sub>out</sub> d&omega;<sub>t</sub>/dt = &tau;<sub>gear</sub> &minus; &tau;<sub>out</sub>
with &tau;<sub>out</sub> = &tau;<sub>L</sub> + &tau;<sub>h</sub> (strings, eq. 13&ndash;14, and strand friction), so the
torque through the gear is &tau;<sub>gear</sub> = &tau;<sub>L</sub> + &tau;<sub>h</sub> + J<sub>out</sub> d&omega;<sub>t</sub>/dt.
The strings alone always pull toward zero twist (&tau;<sub>L</sub> = T a a'/L has the sign of &theta;<sub>t</sub>),
so with a twisted bundle, no strand friction and slow moves the flank toward zero carries the load and
the backlash is only the constant offset b/2 of the twist angle, which <code>string_radius</code> absorbs.
(The model before this one took that for granted, &theta;<sub>t</sub> = dz(&theta;<sub>m</sub>/N, b/2), and
backlash could not be told from a slightly different radius.) Three things reverse the torque:</p>
<ul>
<li><b>Strand friction near zero twist.</b> |&tau;<sub>h</sub>| = &mu; T a' against &tau;<sub>L</sub> = T a a'/L:
their ratio &tau;<sub>L</sub>/|&tau;<sub>h</sub>| = a/(&mu; L) &asymp; r &theta;<sub>t</sub>/(&mu; L) is below 1 for
&theta;<sub>t</sub> &lt; &mu; L<sub>0</sub>/r = 7.4 rad of twist (142 rad at the motor, &mu; = 0.1). Untwisting there,
the strings cannot overcome the friction: the motor must push the output toward zero, on the other
flank.</li>
<li><b>Moves through zero twist</b>: &tau;<sub>L</sub> changes sign with &theta;<sub>t</sub>.</li>
<li><b>The output's inertia</b>: near zero twist the strings accelerate the output at only
&tau;<sub>L</sub>/J<sub>out</sub> &asymp; 2400 rad/s&sup2; (5 rad of twist, 39 N), while the motor side can
accelerate at k<sub>t</sub> i<sub>max</sub>/(J N) &asymp; 3350 rad/s&sup2;: a fast untwist leaves the output
behind, and it returns to the flank toward zero some 20 ms later.</li>
</ul>
<p><b>Equations</b> (two states, only when the effect is on: &delta; = &theta;<sub>m</sub>/N &minus; &theta;<sub>t</sub>,
the position of the output in the gap, and &omega;<sub>t</sub>; the twist angle is
&theta;<sub>t</sub> = &theta;<sub>m</sub>/N &minus; &delta; and every string equation of section 3 uses
&theta;<sub>t</sub>, &omega;<sub>t</sub>):</p>
<ul>
<li>d&delta;/dt = &omega;<sub>m</sub>/N &minus; &omega;<sub>t</sub>;
J<sub>out</sub> d&omega;<sub>t</sub>/dt = &tau;<sub>gear</sub> &minus; &tau;<sub>L</sub> &minus; &tau;<sub>h</sub>;
J d&omega;<sub>m</sub>/dt = k<sub>t</sub> i &minus; f &tau;<sub>gear</sub>/N &minus; &tau;<sub>f</sub>, with the efficiency factor
f of section 5 taken at the power through the gear P = &tau;<sub>gear</sub> &omega;<sub>m</sub>/N.</li>
<li>Flanks: &tau;<sub>gear</sub> = F(&delta;, d&delta;/dt) &minus; F(&minus;&delta;, &minus;d&delta;/dt), where the flank at
&delta; = +b/2 (the motor side pushing toward positive twist) gives
F(&delta;, &delta;&#775;) = pos(k pos(&delta; &minus; b/2) + d pos'(&delta; &minus; b/2) &delta;&#775;, w<sub>&tau;</sub>), the inner pos of width
w<sub>pen</sub> (section 3's smooth positive part). This is the dead-zone model of a backlash with
inertia on both sides (Nordin and Gutman, "Controlling mechanical systems with backlash &mdash; a
survey", Automatica 38, 2002): a stiff spring-damper acting only past the flank. Two corrections
of the plain form k dz(&delta;) + d &delta;&#775;: the damper acts only in contact (pos'(pen) switches it on with
the penetration), and the outer pos lets a flank push but never pull, since the plain Kelvin-Voigt
contact pulls while the teeth separate (Hunt and Crossley, J. Appl. Mech. 42, 1975), which would
drag the light output (J<sub>out</sub>/d = 19 &micro;s) along with a motor pulling away from it.</li>
</ul>
<table border="1"><tr><th>constant</th><th>value</th><th>derivation</th></tr>
<tr><td>J<sub>out</sub></td><td>1.5&middot;10<sup>-6</sup> kg&middot;m&sup2;</td><td>Estimate, not measured (the paper
gives none): output planet carrier as a steel disc &empty;22 &times; 6 mm 1.1&middot;10<sup>-6</sup>, less its cut-outs;
three planets of about 2 g orbiting at 6 mm 0.2&middot;10<sup>-6</sup>; output shaft &empty;6 &times; 25 mm
0.02&middot;10<sup>-6</sup>; aluminium string clamp &empty;16 &times; 20 mm 0.35&middot;10<sup>-6</sup>; the four strings
themselves 10<sup>-10</sup>. Reflected to the motor J<sub>out</sub>/N&sup2; = 4.1&middot;10<sup>-9</sup> kg&middot;m&sup2;, 0.4 % of
<code>rotor_inertia</code>: in contact the motor hardly feels it.</td></tr>
<tr><td>k</td><td>1000 N&middot;m/rad</td><td>Mesh stiffness at the output: a choice (the GP 26 A data
give none; small planetary gearheads lie at 10<sup>2</sup>&ndash;10<sup>4</sup> N&middot;m/rad). What matters is that it
is far stiffer than what it drives: the strings' torsional stiffness is at most about 1.5 N&middot;m/rad
(k<sub>string</sub>(a a'/L)&sup2; at full twist), so the mesh adds 0.15 % compliance in series; at the largest
output torque (3 A: 0.070 N&middot;m &times; 19.2 &times; 0.81 = 1.09 N&middot;m) the teeth yield 1.1&middot;10<sup>-3</sup> rad
(0.06&deg;), below the smallest backlash of the range (0.5&deg;). Contact frequency &radic;(k/J<sub>out</sub>) =
2.6&middot;10<sup>4</sup> rad/s: above the current loop (9.4&middot;10<sup>3</sup> rad/s), taken in large steps by the
L-stable integrator while the flank stays in contact.</td></tr>
<tr><td>d</td><td>2&radic;(k J<sub>out</sub>) = 0.0775 N&middot;m&middot;s/rad</td><td>Critical damping of the output on the
270 times heavier motor side (J N&sup2; = 4.0&middot;10<sup>-4</sup> kg&middot;m&sup2;): impacts are nearly plastic. With
the push-only law, an impact at speed v<sub>0</sub> gives x = v<sub>0</sub> t e<sup>-&omega;t</sup>, the flank torque
k x + d x' = v<sub>0</sub>k e<sup>-&omega;t</sup>(2/&omega; &minus; t) vanishes at &omega;t = 2, where x' = &minus;v<sub>0</sub> e<sup>-2</sup>:
restitution 0.135. A choice: real meshes are lighter damped (and rattle); a rattling output would
need many tiny steps and make the trace depend on impact details, while the signature the sensors
see, the motor crossing the gap unloaded, does not depend on it.</td></tr>
<tr><td>w<sub>pen</sub>, w<sub>&tau;</sub></td><td>10<sup>-6</sup> rad, 10<sup>-5</sup> N&middot;m</td><td>Smoothing widths (a
continuous right-hand side for the integrator). Inside the gap each flank leaves a tail
k w<sub>pen</sub>&sup2;/(4|pen|) + d |&delta;&#775;| w<sub>pen</sub>&sup2;/(4 pen&sup2;): below 10<sup>-8</sup> N&middot;m at the centre,
0.7 &micro;N&middot;m at 0.05&deg; from a flank approached at 40 rad/s; while one flank is in contact the other
leaves &minus;w<sub>&tau;</sub>/2 = &minus;5 &micro;N&middot;m (strings near zero twist: 10<sup>-4</sup>&ndash;10<sup>-3</sup> N&middot;m).</td></tr>
</table>
<p><b>Start and energy.</b> At rest untwisted the strings exert no torque: the output starts in the middle
of the gap (&delta; = 0, &omega;<sub>t</sub> = 0, &theta;<sub>t</sub> = 0 as before), and the first twist crosses b/2.
Stored energy adds J<sub>out</sub>&omega;<sub>t</sub>&sup2;/2 and the flanks' k(&Phi;(&delta; &minus; b/2) + &Phi;(&minus;&delta; &minus; b/2))
(&Phi; of section 9, width w<sub>pen</sub>, whose derivative is the elastic part &tau;<sub>el</sub> = k(pos(&delta; &minus; b/2) &minus; pos(&minus;&delta; &minus; b/2)));
the losses add (&tau;<sub>gear</sub> &minus; &tau;<sub>el</sub>) d&delta;/dt, the flank damping (&ge; 0 but for the w<sub>&tau;</sub> smoothing).</p>
<p><b>What reveals it.</b> A load reversal: untwisting near zero twist with strand friction, moves
through zero twist, fast untwists at small twist. There the motor turns by b N (0.34 rad for 1&deg;)
unloaded, and current, motor angle and (through the twist) p differ from a model without backlash by
more than a constant: on the two reference load reversals by 2.4&middot;10<sup>-3</sup> and 2.0&middot;10<sup>-3</sup> of the
current's range, 4.3&middot;10<sup>-3</sup> and 1.7&middot;10<sup>-2</sup> of p's, 17 and 9 mrad of motor angle beyond the best
constant offset (the dead-zone model gave 3.8&middot;10<sup>-4</sup> and 2&middot;10<sup>-5</sup> of the current's range).
Large strokes far from zero twist still show only the offset b/2.</p>

<h2>8. Initial state, numerics</h2>
<p>At rest, untwisted: i = &theta;<sub>m</sub> = &omega;<sub>m</sub> = v = z = 0 and p<sub>0</sub>
from F<sub>L</sub>(p<sub>0</sub>) = m g + F<sub>load</sub> + F<sub>s</sub>(p<sub>0</sub>) at zero twist (a = 0, L = p),
solved for x = (p<sub>0</sub> &minus; L<sub>0</sub>)/c by Newton. Integrator: the
workspace's Rosenbrock solver (Rodas5P) with rtol = <code>rtol</code> and absolute tolerances
atol&middot;nominal (<code>rtol</code> and <code>atol</code>, left at their start value 10<sup>-6</sup>, take the
tolerance the importer passes to fmi2SetupExperiment, clamped into their range): i 1 A, &theta;<sub>m</sub> 1 rad, &omega;<sub>m</sub> 10 rad/s, p 1 cm, v 1 cm/s,
z<sub>i</sub> 10<sup>-3</sup> A&middot;s, z<sub>&omega;</sub> 1 rad, energy integrals 1 J (with <code>gear_backlash</code>
also &delta; 10<sup>-2</sup> rad, &omega;<sub>t</sub> 1 rad/s). The solver's error norm is
the RMS over all 10 components; so that the three nearly error-free energy quadratures do not loosen the
control of the seven dynamic states by &radic;(10/7), both tolerances are handed to the solver multiplied by
&radic;(7/10) = 0.8367. With <code>gear_backlash</code> the solver integrates 12 states (the effect's two follow
the energy integrals, which are then not declared quadratures to it) and the factor is &radic;(9/12) = 0.8660;
without it, the same 10 states and the same steps as a model that does not have the effect. The motor angle is integrated relative to its value at the start of each
interval between position-loop samples (the plant sees &theta;<sub>m</sub> = offset + y<sub>1</sub>, the offset being
added back after each interval), so its error control is absolute (atol&middot;1 rad) instead of
rtol&middot;|&theta;<sub>m</sub>| &asymp; 10<sup>-3</sup> rad at 2000 rad, comparable to one encoder count (1.6&middot;10<sup>-3</sup> rad):
the quantized encoder decisions of the position loop then agree with a tight reference. The step-size
selection restarts at every jump of the right-hand side: a new speed set point from the position loop
(a jump of the speed-loop error), a jump of F<sub>load</sub> (or, in open loop, the voltage) and a change of
a tunable parameter.
The Jacobian is analytic (chain rule through every equation above,
unit-tested against central differences for every effect and both controller modes).</p>
<p>A communication step spanning more than 2&middot;10<sup>5</sup> position-loop samples is refused
with fmi2Error (a huge step must not hang the importer).</p>

<h2>9. Energy balance</h2>
<p>Outputs <code>E_electrical</code>, <code>W_external</code>, <code>E_dissipated</code>,
<code>E_stored</code> [J] (and <code>E_string_kinematic</code>, a part of <code>E_dissipated</code>)
let an importer check over any run that
<b>E_electrical + W_external = E_dissipated + E_stored(t) &minus; E_stored(t<sub>0</sub>)</b>.
Derivation (multiply each equation of sections 3&ndash;6 by its flow variable):</p>
<ul>
<li>Armature &times; i: d(&frac12;L i&sup2;)/dt = u i &minus; R i&sup2; &minus; k<sub>e</sub>&omega;<sub>m</sub> i.
Rotor &times; &omega;<sub>m</sub>: d(&frac12;J&omega;<sub>m</sub>&sup2;)/dt = k<sub>t</sub> i &omega;<sub>m</sub> &minus; &tau;<sub>in</sub>&omega;<sub>m</sub> &minus; &tau;<sub>f</sub>&omega;<sub>m</sub>.
The conversion terms cancel when k<sub>e</sub> = k<sub>t</sub> (SI, the default); a user-set mismatch
(k<sub>e</sub> &minus; k<sub>t</sub>) i &omega;<sub>m</sub> is booked as a loss.</li>
<li>Gearhead: &tau;<sub>in</sub>&omega;<sub>m</sub> = f &tau;<sub>out</sub>&omega;<sub>t</sub> = &tau;<sub>out</sub>&omega;<sub>t</sub> + (f &minus; 1)&tau;<sub>out</sub>&omega;<sub>t</sub>;
the gear loss (f &minus; 1)P (P = &tau;<sub>out</sub>&omega;<sub>t</sub>) is &ge; 0 except inside the smoothed
direction switch, where f passes 1 at a small negative P: there it is &ge; &minus;5.9&middot;10<sup>-5</sup> W
at &eta; = 0.81 (&ge; &minus;0.011 W at the minimum &eta; = 0.3), a property of the smoothing, booked as it is.
&tau;<sub>out</sub> = &tau;<sub>L</sub> + &tau;<sub>h</sub>; the strand friction &tau;<sub>h</sub>&omega;<sub>t</sub> &ge; 0 is a loss.
With <code>gear_backlash</code> the gear passes &tau;<sub>gear</sub> at &omega;<sub>m</sub>/N (gear loss
(f &minus; 1)&tau;<sub>gear</sub>&omega;<sub>m</sub>/N), the flanks take &tau;<sub>gear</sub>(&omega;<sub>m</sub>/N &minus; &omega;<sub>t</sub>)
= d/dt[flank energy] + (&tau;<sub>gear</sub> &minus; &tau;<sub>el</sub>) d&delta;/dt, and the output
J<sub>out</sub>&omega;<sub>t</sub> d&omega;<sub>t</sub>/dt = &tau;<sub>gear</sub>&omega;<sub>t</sub> &minus; &tau;<sub>out</sub>&omega;<sub>t</sub> (section 7.1).</li>
<li>Load &times; v: d(&frac12;m v&sup2;)/dt = (m g + F<sub>s</sub>) v + F<sub>load</sub> v &minus; F<sub>L</sub> v &minus; c<sub>g</sub> v&sup2;, with
(m g + F<sub>s</sub>) v = &minus;dV/dt, V = (m g + F<sub>0</sub>)(L<sub>0</sub> &minus; p) + &frac12;k<sub>s</sub>(L<sub>0</sub> &minus; p)&sup2;
(zero at p = L<sub>0</sub>, positive when the load is lifted).</li>
<li>Strings: the power they take from shaft and load is P<sub>str</sub> = &tau;<sub>L</sub>&omega;<sub>t</sub> + F<sub>L</sub> v.
Strand law: &tau;<sub>L</sub> = T a a'/L, F<sub>L</sub> = T p/L give P<sub>str</sub> = T (a a' &omega;<sub>t</sub> + p v)/L = T dL/dt = T &sdot;s
(L<sub>free</sub> constant). With the elastic part T<sub>e</sub> = pos(s/c) and &Phi;(x) = &int;<sub>0</sub><sup>x</sup>pos
= (x&sup2; + x&radic;(x&sup2;+w&sup2;) + w&sup2; asinh(x/w))/4:
P<sub>str</sub> = d/dt[c &Phi;(s/c)] + (T &minus; T<sub>e</sub>)&sdot;s, and the damping term is &ge; 0 because pos is
monotone (T &minus; T<sub>e</sub> has the sign of d&sdot;s). The elastic energy c&Phi;(s/c) is slightly negative when
slack (&Phi; &lt; 0 for x &lt; 0), which is only an offset of the reference.</li>
<li><code>string_compliance</code> law: T = x L/q, F<sub>L</sub> = x p/q give P<sub>str</sub> = x (L/q) dL/dt
= x (L/q)(&sdot;s + &sdot;L<sub>free</sub>), which is <b>not</b> the rate of an elastic energy: eq. 10 is a
kinematic relation. Split: P<sub>str</sub> = d/dt[a<sub>3</sub>&Phi;(s/a<sub>3</sub>)] + (x &minus; T<sub>e</sub>)&sdot;s + P<sub>kin</sub>,
P<sub>kin</sub> = x[(L/q &minus; 1)&sdot;s + (L/q)&sdot;L<sub>free</sub>]. Its first part comes from the elongation
proportional to the load F<sub>L</sub> instead of the strand tension T (L/q &asymp; 1/cos&alpha;); its second from the
twist lengthening a<sub>1</sub>&theta;<sub>M</sub> + a<sub>2</sub>&theta;<sub>M</sub>&sup2;, which slackens the strands without
a torque of its own (section 3): positive while twisting, negative while untwisting, cancelling over a
cycle at constant load. P<sub>kin</sub> is integrated into <code>E_string_kinematic</code> and booked in
<code>E_dissipated</code> (so <code>E_dissipated</code> may decrease while untwisting with
<code>string_compliance</code> on); it is 0 with <code>string_compliance</code> off.</li>
</ul>
<p>Together: dE<sub>stored</sub>/dt = u i + F<sub>load</sub> v &minus; P<sub>loss</sub> &minus; P<sub>kin</sub> with
E<sub>stored</sub> = &frac12;L i&sup2; + &frac12;J&omega;<sub>m</sub>&sup2; + &frac12;m v&sup2; + V + c&Phi;(s/c) and
P<sub>loss</sub> = R i&sup2; + (k<sub>e</sub> &minus; k<sub>t</sub>) i &omega;<sub>m</sub> + (f &minus; 1)&tau;<sub>out</sub>&omega;<sub>t</sub>
+ &tau;<sub>f</sub>&omega;<sub>m</sub> + &tau;<sub>h</sub>&omega;<sub>t</sub> + c<sub>g</sub>v&sup2; + (x &minus; T<sub>e</sub>)&sdot;s
(a unit test checks this identity at random states for every effect and both controller modes).
The controller states carry no energy; u i is the power from the ESCON bridge (negative when regenerating).</p>
<p>Integration: E<sub>electrical</sub> = &int;u i dt, &int;P<sub>loss</sub> dt and &int;P<sub>kin</sub> dt are three
extra ODE states (nominal 1 J, absolute tolerance atol&middot;1 J, analytic Jacobian rows) under the same error
control as the physics. Like the motor angle (section 8) they are integrated relative to their value at the
start of each integration call (from 0, the total added back after it): with the accumulated totals in the
state, the relative part rtol&middot;|E| of their tolerance grew with the run (0.8 mJ per step after 1 kJ) and
made them invisible to the error norm, so the step size across a slack-to-taut catch (the load falling
onto the strings at up to 1.6 m/s: a damping-power spike of some 100 W in about 1 ms) was chosen by the
dynamic states alone and each catch left up to 2&middot;10<sup>-3</sup> J in the residual late in a soak run
(10<sup>-5</sup> J early in it). Integrated from 0 they are held to rtol times the energy of one interval
plus atol&middot;1 J, and the same catch leaves 1&middot;10<sup>-5</sup> J (the error of the stored energy
itself: the 600 N peak tension times the absolute tolerance of p); <code>W_external</code> = &Sigma; F<sub>load</sub>(p(t<sub>k+1</sub>) &minus; p(t<sub>k</sub>)) is exact
because F<sub>load</sub> is held over each communication step. The exact flow conserves the residual
r = E<sub>electrical</sub> + W<sub>external</sub> &minus; E<sub>dissipated</sub> &minus; &Delta;E<sub>stored</sub> = 0, so its
numerical value is the global integration error of energies of size &le; the throughput
E<sub>electrical</sub> + |W<sub>external</sub>| + E<sub>dissipated</sub>; with local errors held below
rtol&middot;|y| + atol&middot;nominal the expected bound is |r| &le; rtol &times; throughput (the atol floor,
10<sup>-6</sup> J per state, is far below it). Measured over 6 s of varied set points, voltages and F<sub>load</sub>
with every effect on under 97 N: |r|/throughput = 7&middot;10<sup>-9</sup> (closed loop) and
2.6&middot;10<sup>-8</sup> (voltage mode) at rtol = 10<sup>-6</sup>, 2&middot;10<sup>-10</sup> and 1.4&middot;10<sup>-9</sup>
at rtol = 10<sup>-8</sup>: it falls with the tolerance, so it is integration error, not a modelling leak.
Soak (FMPy, 10<sup>6</sup> steps of 1 ms, random set points 0&ndash;2011 rad, voltages
&plusmn;24 V and F<sub>load</sub> &minus;40&hellip;60 N held 0.5 s, every effect on, 54 N): |r|/throughput =
1.1&middot;10<sup>-8</sup> (closed loop, throughput 5.5 kJ) and 1.6&middot;10<sup>-8</sup> (voltage mode, 13.2 kJ).
In voltage mode the motor is also driven into negative twist, where eq. 10 (fitted for &theta;<sub>M</sub> &ge; 0)
is used outside its range and <code>E_string_kinematic</code> drifts (&minus;274 J in that run); the balance
still closes because the term is booked.</p>

<h2>10. What the model reproduces (tests/test_twisted_string.py, FMPy)</h2>
<ul>
<li>Table 2: with <code>string_compliance</code> on, quasi-static p after position steps of 1000&deg;
of twist up to 6000&deg; under 23, 39, 54, 97, 124 N: 0.71 mm RMS from the regression (max 1.8 mm at
zero twist and 124 N, where c<sub>4</sub> and a<sub>3</sub> disagree).</li>
<li>Section 6 speeds at the 8000 rpm limit over 335.1&rarr;2011 rad (step from rest at 335.1 rad to
2100 rad, measured between leaving 335.1 and reaching 2011 rad): 1.543, 1.526, 1.509, 1.464, 1.435 cm/s
for the five loads (paper: 1.58, 1.53, 1.53, 1.45, 1.42), slower for heavier loads, mean motor speed
99.7 % of 8000 rpm (section 2).</li>
<li>Eq. 20&ndash;21: the encoder angle ends inside SP &plusmn; 2&deg; (true angle within one count more).</li>
<li>Fig. 19: <code>stiffness</code> falls from 59 kN/m untwisted to 25&ndash;27 kN/m at 6000&deg;.</li>
<li>Every output agrees with the SciPy reference traces within 3&middot;10<sup>-5</sup> of its range at the default
tolerances, except the force-steps case, where <code>current</code> and <code>tau_motor</code> differ by up to
8&middot;10<sup>-4</sup> of their range (the test demands 10<sup>-3</sup>).</li>
<li><code>gear_backlash</code> (section 7.1), two load reversals against their SciPy traces within
1.5&middot;10<sup>-5</sup> of range (the test demands 10<sup>-4</sup>): with strand friction the output rests on the
&minus;b/2 flank while the strings untwist near zero twist and on +b/2 again once they are twisted (without
strand friction on +b/2 throughout); while the motor side crosses the gap the output turns less than
5 % of it.</li>
</ul>
<p>Reference: <code>tests/reference/twisted_string_ref.py</code> writes the same equations again in
Python and integrates them with SciPy <code>solve_ivp</code> (Radau, rtol 1e-10).</p>

<h2>11. Model Exchange</h2>
<p>With Model Exchange the importer's solver integrates the same right-hand side (sections 3&ndash;7 and the
continuous current and speed PI of section 6) and the position loop of section 6 runs at time events.
<b>States</b> (13, the same number whatever the effects; a state an effect does not use keeps its value
and has derivative 0): <code>current</code>, <code>theta_motor</code>, <code>omega_motor</code>, <code>p</code>,
<code>v_load</code>, <code>current_integral</code> z<sub>i</sub>, <code>speed_integral</code> z<sub>&omega;</sub>,
<code>E_electrical</code>, <code>E_dissipated</code>, <code>E_string_kinematic</code>,
<code>backlash_position</code> &delta; and <code>omega_twist</code> &omega;<sub>t</sub> (<code>gear_backlash</code> only),
<code>W_external</code> = &int; F<sub>load</sub> v dt; each with its local <code>der(&hellip;)</code>. Nominals
(<code>nominal</code> in the description, returned by fmi2GetNominalsOfContinuousStates) as in
section 8 (1 J for the energies) except the current's, 0.1 A: holding a load the current is some
0.05 A, and at 1 A an importer's absolute tolerance rtol&middot;1 A let FMPy's CVode move
F_axial by 1.25&times;10<sup>-3</sup> of its range at rtol 10<sup>-6</sup> (0.03&times;10<sup>-3</sup> at 0.1 A). Unlike Co-Simulation (section 8), the motor angle is one absolute state:
the importer's relative tolerance applies to |&theta;<sub>m</sub>| (at 2000 rad and rtol 10<sup>-6</sup> about
one encoder count), and the energy integrals hold the totals since the start.</p>
<p><b>Position loop as time events.</b> The next event time is the next sample t<sub>0</sub> + k T<sub>s</sub>
(<code>controller_position_period</code>; none in open loop). At the event the encoder angle is quantised and the
P law with its band gives the new speed set point, exactly as in Co-Simulation, from the set point
<code>theta_motor_ref</code> the importer has set at that instant; <code>omega_ref</code> and
<code>theta_motor_measured</code> are discrete outputs (they change only at samples, in both interfaces).
The two interfaces sample at the same instants with the same inputs: the Co-Simulation step starting at
a communication point t takes the sample at t with the inputs set at t (section 6), as the time event at t
sees the set point the importer has set at t, and the outputs at t are those before the sample there,
the left limit a Model Exchange importer reads before its time event (at the start time, those after
the first sample in both). A moving or jumping set point gives
the same trace in both (tests/test_twisted_string.py compares every output on every row of a ramp,
and the reference cases with set-point steps).</p>
<p><b>Non-smooth terms.</b> Smooth by construction: slack strings and the gear flanks (the smooth positive part
of section 3), the direction of the gearhead efficiency, Coulomb motor friction and strand friction (tanh).
Continuous with a kink (no event needed, the solver sees a continuous right-hand side): the PI output limits
(current limit, supply voltage) and their anti-windup, which fades out over 1 % of the limit; the
<code>radius_growth</code> radius r<sub>0</sub>(1 + g|&theta;<sub>t</sub>|/2&pi;), whose twist arc and slope are
continuous. One true discontinuity: with <code>string_compliance</code> the free length
L<sub>0</sub> + a<sub>1</sub>|&theta;<sub>M</sub>| + a<sub>2</sub>&theta;<sub>M</sub><sup>2</sup> has a kink at zero
twist, so the strand stretch rate, and with it the string damping force, jumps by
2 d a<sub>1</sub> N |&omega;<sub>t</sub>| when the twist crosses zero (0.6 N per rad/s of twist speed). It is an
event indicator: the twist angle &theta;<sub>t</sub> while <code>string_compliance</code> is on (the constant 1
otherwise), so the importer's solver stops at the crossing instead of stepping over the jump. The encoder
quantisation, the band and the speed-limit clamp act only at the time events.</p>
<p><b>Directional derivatives</b> (<code>providesDirectionalDerivative</code>, Model Exchange, and Co-Simulation at the communication point): the
derivatives with respect to the states are the plant's analytic Jacobian (section 8) carried through
the linear maps between the solver's state vector and the 13 states (E_dissipated is the loss integral
plus E_string_kinematic; der(W_external) = F<sub>load</sub> v adds the row F<sub>load</sub> at v); they agree
with central differences of the derivatives within 2&middot;10<sup>-8</sup> of each row's scale, every effect on.
At zero twist, the kink of <code>string_compliance</code> and <code>radius_growth</code>, the Jacobian is the
one for positive twist. <code>&lt;Derivatives&gt;</code> lists what each derivative depends on under any
setting: der(theta_motor) on omega_motor, der(p) on v_load, der(W_external) on v_load and F_load, the
current and E_electrical on the armature voltage (the current PI's i, &omega;<sub>m</sub>, z<sub>i</sub>,
z<sub>&omega;</sub>, or the input <code>voltage</code>), the mechanics on &theta;<sub>m</sub>, &omega;<sub>m</sub>, p, v,
&delta;, &omega;<sub>t</sub> (and F<sub>load</sub> for v); no derivative depends on an energy integral or on
<code>theta_motor_ref</code> (it acts at the samples only). The FMI 3.0 description also lists the
parameters among each output's and derivative's dependencies (FMI 3.0.2 section 2.4.8), by the parts
of the model they enter: the gear (ratio, backlash), the helix (radius, its growth), the strings
(length, stiffness, damping, compliance law), friction, the armature, the current and speed PI loops
and the position loop (its set point and encoder reading are computed at the samples and held, so
their parameters act in Event Mode); <code>fmi3GetDirectionalDerivative</code> takes a Float64 parameter
as known (central differences of the model with the parameter moved).</p>
<p><b>Measured</b> (FMPy's CVode, tests/test_twisted_string.py): against the SciPy reference within
7&middot;10<sup>-5</sup> (voltage steps), 8&middot;10<sup>-4</sup> (F<sub>load</sub> steps in closed loop, as
Co-Simulation) and 7&middot;10<sup>-4</sup> (a set-point step) of each output's range; against Co-Simulation with
every effect on within 2&middot;10<sup>-5</sup> (open loop through zero twist) and 10<sup>-4</sup> (closed loop) of
range, energy balance within 1.3&middot;10<sup>-5</sup> of the throughput, and under a set point ramping at
400 rad/s within 10<sup>-4</sup> of range on every output point; at the ends of the Table 2 staircase the same encoder counts and
p, string force and stiffness within 10<sup>-7</sup> relative; the paper's band, speeds, Table 2 and stiffness
trend hold in both interfaces. With a time event every millisecond FMPy's CVode restarts 1000 times per
simulated second: Model Exchange takes about 10 times the time of Co-Simulation there (2.3 s against
0.26 s for a 4.5 s position step).</p>
"#;
