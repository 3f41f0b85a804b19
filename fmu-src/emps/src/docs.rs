//! HTML documentation of the EMPS FMU (equations, sources, derivations, choices).

/// The documentation fragment written to `documentation/index.html`.
pub fn html() -> String {
    [
        INTRO,
        SIGNALS,
        PLANT,
        CONTROLLER,
        FRICTION_SIGN,
        BASE,
        EFFECTS,
        NUMBERS,
    ]
    .concat()
}

const INTRO: &str = r#"
<h1>EMPS: electro-mechanical positioning system</h1>
<p>Source: A. Janot, M. Gautier, M. Brunot, <i>Data Set and Reference Models of EMPS</i>,
Workshop on Nonlinear System Identification Benchmarks, Eindhoven, 2019 (&ldquo;the
description&rdquo;; equations numbered as there), and the benchmark files of its
<code>EMPS.zip</code> (nonlinearbenchmark.org): <code>DATA_EMPS.mat</code> (estimation record),
<code>DATA_EMPS_PULSES.mat</code> (validation record with force pulses). Asymmetric friction: A.
Janot, P. C. Young, M. Gautier, Int. J. Control 90(4):643&ndash;660, 2017. A Maxon DC motor with a
12500-line encoder (50000 counts per turn in quadrature) drives a Star ball-screw positioning unit
carrying a load in translation; dSPACE control at 1 kHz. Every quantity is SI on the load side
(positions in m, forces in N), as the benchmark writes them.</p>
"#;

const SIGNALS: &str = r#"
<h2>1. Signals</h2>
<table>
<tr><th>variable</th><th>benchmark</th><th>meaning</th></tr>
<tr><td><code>qg</code> (input)</td><td><code>qg</code></td><td>reference position [m]</td></tr>
<tr><td><code>force_pulse</code> (input)</td><td><code>pulses_N</code></td><td>force added to the controller output before its saturation, in N; the
validation file's <code>vir</code> holds <code>1.0139 pulses_N</code> volts beyond the controller law (least squares,
<code>scripts/emps_csv.py</code>), so <code>force_pulse = drive_gain &middot; 1.0139 &middot; pulses_N</code> (178.2 N for a pulse of 5)</td></tr>
<tr><td><code>force_measured</code> (input)</td><td><code>gtau&middot;vir</code></td><td>the applied force, driving the axis when <code>internal_controller = false</code></td></tr>
<tr><td><code>qm</code> (output)</td><td><code>qm</code></td><td>motor encoder position on the load side [m]</td></tr>
<tr><td><code>force</code> (output)</td><td><code>gtau&middot;vir</code></td><td>applied force [N]; <code>vir</code> is in volts although the description calls it a force</td></tr>
<tr><td><code>velocity</code> (output)</td><td>&ndash;</td><td>the controller's velocity (section 3)</td></tr>
</table>
<p>The encoder resolution gives the screw lead: <code>qm</code> of <code>DATA_EMPS.mat</code> moves in
multiples of 5&middot;10<sup>-8</sup> m, one count of 50000 per turn, so the lead is
p = 50000 &times; 5&middot;10<sup>-8</sup> m = 2.5 mm per motor turn (motor coupled directly to the
screw). The model does not quantise <code>qm</code>: one count is 50 nm, and the validation file's
<code>qm</code> is not quantised at all.</p>
"#;

const PLANT: &str = r#"
<h2>2. Plant</h2>
<p>Rigid axis (description eq. 1 and 3), states q, v = q':</p>
<p><code>M v' = F &minus; f(q, v) &minus; offset</code>,
<code>f(q, v) = &phi;(q) (F<sub>v</sub> v + F<sub>c</sub> sgn(v))</code>,</p>
<p>with F the applied force (description eq. 7, <code>F = g<sub>&tau;</sub> u</code>), F<sub>v</sub> =
<code>viscous_friction</code>, F<sub>c</sub> = <code>coulomb_friction.force</code> (0 when off), and
&phi;(q) = 1 unless <code>position_friction</code> is on. With <code>asymmetric_friction</code>, v &lt; 0 uses
F<sub>v</sub><sup>&minus;</sup>, F<sub>c</sub><sup>&minus;</sup> (description eq. 12).</p>
<p>Two masses (<code>flexibility</code> or <code>backlash</code> on), states q, v, q<sub>l</sub>, v<sub>l</sub>: the motor side
(rotor, screw: <code>mass &minus; load_mass</code>) carries the drive force, the friction and the offset; the load
(carriage and payload, <code>load_mass</code>) is pulled by the screw-nut force
<code>F<sub>s</sub> = k dz(q &minus; q<sub>l</sub>) + c (v &minus; v<sub>l</sub>)</code> (0 across the play):</p>
<p><code>(M &minus; m<sub>l</sub>) v' = F &minus; f(q, v) &minus; offset &minus; F<sub>s</sub></code>,
<code>m<sub>l</sub> v<sub>l</sub>' = F<sub>s</sub></code>,
<code>c = 2 &zeta; &radic;(k m<sub>r</sub>)</code>, m<sub>r</sub> = (M &minus; m<sub>l</sub>) m<sub>l</sub> / M.</p>
<p>Choices: the encoder is on the motor, so <code>qm</code> is the motor side's q; all friction is
placed on the motor side (the rigid identification attributes it to the motor velocity, and the
guides' share is not separable from these records); the load starts where the motor side is,
moving with it. At the start time q = <code>q0</code>, v = <code>v0</code> (the records begin in motion:
<code>DATA_EMPS.mat</code> at 7.45 &micro;m and 5.6 mm/s).</p>
"#;

const CONTROLLER: &str = r#"
<h2>3. Controller, as logged</h2>
<p>At sample k (t<sub>k</sub> = t<sub>0</sub> + k T<sub>s</sub>, T<sub>s</sub> = <code>controller_period</code> = 1 ms), from the
encoder reading qm(k) = q(t<sub>k</sub>) (description eq. 6, sec. 2.2):</p>
<p><code>qfm(k) = (qm(k) + qm(k&minus;1)) / 2</code>, <code>v&#770;(k) = (qfm(k) &minus; qfm(k&minus;1)) / T<sub>s</sub></code>,<br>
<code>u(k) = sat<sub>&plusmn;10 V</sub>(k<sub>v</sub> (k<sub>p</sub> (qg(k) &minus; qm(k)) &minus; v&#770;(k)) + force_pulse(k) / g<sub>&tau;</sub>)</code>,
<code>F = g<sub>&tau;</sub> u(k)</code> held until the next sample.</p>
<p>k<sub>p</sub> = 160.18 1/s, k<sub>v</sub> = 243.45 V/(m/s), g<sub>&tau;</sub> = 35.15065188 N/V (the files'
<code>kp</code>, <code>kv</code>, <code>gtau</code>), &plusmn;10 V (<code>Simulation_EMPS.m</code>: <code>viradm = 10</code>). This law
reproduces the logged <code>vir</code> from the logged <code>qg</code>, <code>qm</code> to 3.7 mV RMS with no sample of delay (24 839
samples of <code>DATA_EMPS.mat</code>; one sample of delay gives 54 mV), and, with the pulses added before the
saturation, the validation file's to 4.7 mV RMS (after the saturation: 16 mV). The authors'
Simulink model adds a sample of delay; here that is the candidate effect <code>controller_delay</code>.
The controller's history before the start assumes steady motion: qm(&minus;1) = q0 &minus; v0 T<sub>s</sub>,
qm(&minus;2) = q0 &minus; 2 v0 T<sub>s</sub>.</p>
<p><b>Values at a communication point.</b> In Co-Simulation the sample at a communication point is
taken at the start of the step from there, with the inputs set there (FMI 2.0.4 section 4.2.1); the
outputs at a communication point therefore show <code>force</code>, <code>velocity</code> and <code>voltage</code> held over the
step just ended (sample k&minus;1's at t<sub>k</sub>), and <code>qm</code> at t<sub>k</sub>. At the start time they show sample 0,
taken in initialization with the initial inputs. A measured record stamps <code>vir(k)</code> at t<sub>k</sub>;
<code>scripts/emps_csv.py</code> (default <code>--stamp held</code>) writes it at t<sub>k+1</sub>, where this FMU shows it.
In open loop (<code>internal_controller = false</code>) the force is the input <code>force_measured</code> held over each
step; the controller still samples the encoder, so <code>velocity</code> is the same measurement.</p>
"#;

const FRICTION_SIGN: &str = r#"
<h2>4. Coulomb friction: a smooth sign</h2>
<p>sgn(v) is <code>tanh(v / v<sub>s</sub>)</code>, v<sub>s</sub> = <code>friction_smoothing_velocity</code> = 0.1 mm/s, so that the
error-controlled solver integrates through a reversal without events (Co-Simulation). It departs
from sign(v) by more than 0.1 % only for |v| &lt; 0.38 mm/s; the records cross that band within about
a sample at each reversal (0.8 % of <code>DATA_EMPS.mat</code>'s samples have |v&#770;| &lt; 1 mm/s). Measured
on <code>DATA_EMPS.mat</code> with the published symmetric parameters against the event-exact
reference (<code>tests/reference/emps_ref.py</code>: closed form between reversals, sticking while
|F &minus; offset| &le; F<sub>c</sub>): force 0.13 N RMS apart (0.25 % of the force's 54 N RMS, 1.4 N at most, at
reversals), <code>qm</code> 74 nm RMS; the force's relative error against the measurement moves from
4.58 % (exact) to 4.51 % (smooth). Against the same smooth equations integrated by SciPy the FMU
agrees to 4&middot;10<sup>-6</sup> N RMS.</p>
"#;

const BASE: &str = r#"
<h2>5. Base parameters: start values and ranges</h2>
<ul>
<li><code>mass</code> M, start 100 kg, range 10&ndash;1000 kg: with the 2.5 mm lead a rotor inertia J appears
as J (2&pi;/p)<sup>2</sup> = 6.3&middot;10<sup>6</sup> J on the load side; a Maxon RE 40 class rotor (138 g&middot;cm<sup>2</sup>) gives 87 kg,
a 12 mm &times; 0.3 m steel screw 30 kg, carriage and payload a few kg: of the order of 100 kg.</li>
<li><code>viscous_friction</code> F<sub>v</sub>, start 100 N&middot;s/m, range 0&ndash;2000: a drive's viscous loss of the
order of 10 N at 0.1 m/s; the range spans the lubricated screw to a heavily preloaded one.</li>
<li><code>offset</code>, start 0 N, range &plusmn;100 N: an offset of the drive's voltage of up to about &plusmn;3 V.</li>
<li><code>q0</code>, <code>v0</code> (<code>[initial]</code>): the state at the start time, 0 at rest.</li>
<li><code>load_mass</code>, 10 kg: carriage and payload beyond the screw-nut contact (only with
<code>flexibility</code> or <code>backlash</code>).</li>
</ul>
"#;

const EFFECTS: &str = r#"
<h2>6. Candidate effects</h2>
<ul>
<li><b>coulomb_friction</b>: F<sub>c</sub> sgn(v) (description eq. 1). <code>force</code> start 10 N, range 1&ndash;200 N:
ball-screw drag torques of preloaded 12&ndash;16 mm screws are 0.01&ndash;0.08 N&middot;m, times 2&pi;/p = 2513 1/m
gives 25&ndash;200 N; brush friction of the motor a few mN&middot;m (5&ndash;10 N).</li>
<li><b>asymmetric_friction</b>: v &lt; 0 has its own F<sub>v</sub><sup>&minus;</sup> = <code>viscous_negative</code> (0&ndash;2000
N&middot;s/m) and F<sub>c</sub><sup>&minus;</sup> = <code>coulomb_negative</code> (0&ndash;200 N); <code>viscous_friction</code> and
<code>coulomb_friction.force</code> are then the coefficients of v &gt; 0 (description eq. 12; Janot, Young,
Gautier 2017 attribute the asymmetry to fatigue of the screw). Starts as the base's, ranges as
theirs.</li>
<li><b>flexibility</b>: the axial compliance of screw, nut and bearings (section 2) with
<code>stiffness</code> k, start 2&middot;10<sup>7</sup> N/m, range 10<sup>5</sup>&ndash;10<sup>9</sup> N/m: a 12 mm screw of 0.3 m has
E A / L = 5.5&middot;10<sup>7</sup> N/m, a small preloaded nut and its bearings 2&ndash;10&middot;10<sup>7</sup> N/m, in
series about 2&middot;10<sup>7</sup> (237 Hz with 10 kg beyond it); the range reaches from a soft coupling
(5 Hz) to beyond the 500 Hz the 1 kHz samples resolve. <code>damping_ratio</code> &zeta; 0.005&ndash;0.7, start
0.05 (steel structures 0.01&ndash;0.1). The description attributes the larger acceleration error of the
validation record to a flexibility the pulses excite.</li>
<li><b>backlash</b>: play between screw and nut (lost preload): <code>width</code> start 20 &micro;m, range
1&ndash;500 &micro;m (a worn ball nut without preload: 5&ndash;50 &micro;m). Without <code>flexibility</code> the contact is stiff
(10<sup>8</sup> N/m, damping ratio 0.1, 530 Hz).</li>
<li><b>position_friction</b>: friction varying along the screw (wear where the axis works most,
lead and alignment errors): &phi;(q) = 1 + c (q &minus; <code>travel_mid</code>) / <code>travel_half</code>, <code>change</code> c start
0.1, range &plusmn;0.5 (&plusmn;50 % at the ends of the 0.25 m the records travel).</li>
<li><b>controller_delay</b>: the force acts d after its sample (computation, D/A conversion, the
drive's current loop): <code>time</code> start 0.5 ms, range 0&ndash;2 ms; the authors' simulation uses one
sample (1 ms). The logged voltage itself has no delay (section 3): this is the delay between the
logged voltage and the force.</li>
</ul>
"#;

const NUMBERS: &str = r#"
<h2>7. Published parameters and what this model gives with them</h2>
<table>
<tr><th>IDIM-LS on DATA_EMPS</th><th>M kg</th><th>F<sub>v</sub> N&middot;s/m</th><th>F<sub>c</sub> N</th><th>offset N</th></tr>
<tr><td>symmetric (description sec. 3.4)</td><td>95.1089</td><td>203.5034</td><td>20.3935</td><td>&minus;3.1648</td></tr>
<tr><td>asymmetric (sec. 4.2)</td><td>95.1540</td><td>166.7061 (v&gt;0), 240.4236 (v&lt;0)</td><td>20.1440 (v&gt;0), 20.6277 (v&lt;0)</td><td>&ndash;</td></tr>
</table>
<p>Simulated in closed loop on the estimation record's <code>qg</code> with the symmetric set
(<code>coulomb_friction</code> on, start state from the record), the force's relative error
100 &Vert;y &minus; &ycirc;&Vert; / &Vert;y&Vert; (eq. 11) against <code>gtau&middot;vir</code> is 4.51 %; with <code>controller_delay</code> on at
1 ms, as in the authors' Simulink model, 5.77 % (the event-exact reference 5.86 %) against their
5.848 % (sec. 3.5); <code>qm</code> 0.0011 % (theirs 0.0138 %). The asymmetric set gives 3.65 %. On the
validation record (pulses as <code>force_pulse</code>) the symmetric set gives 5.09 % as logged; the
authors' 8.94 % is not reproduced with the delay placed here (after the pulse, which the drive
delays with the controller's output): 17.5 %, the 178 N pulse edges then a sample later than in
the logged <code>vir</code>.</p>
<h2>8. Numerics</h2>
<p>Rosenbrock integrator (Rodas5P, crate <code>ode</code>) between the controller's samples and the
delayed force changes, which are hit exactly (<code>ode::SampleClock</code>); the step-size selection restarts
where the force jumps. Positions are integrated relative to their value at the start of each
interval, so <code>atol</code> bounds the error of one interval's motion (1 mm &times; <code>atol</code>), not of the
travel. With <code>backlash</code> the contact switches the coupling's slope and damping; a step across a
switch is only as accurate as its error estimate there (0.15 &micro;m at the default tolerance on the
validation record's first pulse, 0.06 nm at 10<sup>-10</sup>).</p>
<p><b>Model Exchange</b>: states <code>qm</code>, <code>v_motor</code>, <code>load_position</code>, <code>load_velocity</code> (the load's
states keep q0, v0 without two masses), nominals 1 mm and 1 cm/s; the controller's samples and,
with <code>controller_delay</code>, the instants its forces start to act are time events; no state events
(the sign is smooth). In open loop <code>force</code> is the input <code>force_measured</code> (direct feedthrough).
FMPy's CVode at relative tolerance 10<sup>-8</sup> gives the Co-Simulation traces within 2&middot;10<sup>-8</sup> m and
0.04 N on the validation record's first 2 s.</p>
"#;
