//! The HTML documentation of the oscillator.

/// HTML fragment for `documentation/index.html`.
pub fn html() -> String {
    "<h2>Equations</h2><p><code>m x'' + c x' + k x = F</code>, RK4 on fixed sub-steps \
     (Co-Simulation). Model Exchange: states <code>(x, v)</code>, derivatives \
     <code>der(x) = v</code>, <code>der(v) = (F - c v - k x) / m</code>, no events.</p>"
        .into()
}
