//! The transcendental functions of the FMUs' code (the integrator and both models), computed by
//! the `libm` crate (a port of musl's libm) compiled into the binary: the same bits on every
//! CPU and platform. The platform's libm is not: glibc picks FMA or non-FMA code paths by CPU,
//! and Windows and macOS have their own implementations.
//!
//! The feature `platform-math` routes them to the platform's libm instead; it exists only for
//! `scripts/bench`, which measures what the deterministic functions cost against it.
#![cfg_attr(feature = "platform-math", allow(clippy::disallowed_methods))]

macro_rules! unary {
    ($($(#[$doc:meta])* $name:ident => $std:ident;)*) => {$(
        $(#[$doc])*
        #[inline]
        pub fn $name(x: f64) -> f64 {
            #[cfg(feature = "platform-math")]
            return x.$std();
            #[cfg(not(feature = "platform-math"))]
            return libm::$name(x);
        }
    )*};
}

unary! {
    /// `e^x`.
    exp => exp;
    /// `tanh x`.
    tanh => tanh;
    /// `asinh x`.
    asinh => asinh;
}

/// `x^y`.
#[inline]
pub fn pow(x: f64, y: f64) -> f64 {
    #[cfg(feature = "platform-math")]
    return x.powf(y);
    #[cfg(not(feature = "platform-math"))]
    return libm::pow(x, y);
}

/// `atan2(y, x)`: the angle of the point `(x, y)` in `(-pi, pi]`.
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    #[cfg(feature = "platform-math")]
    return y.atan2(x);
    #[cfg(not(feature = "platform-math"))]
    return libm::atan2(y, x);
}
