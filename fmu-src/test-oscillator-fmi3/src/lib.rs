//! The FMI 3.0 Co-Simulation binary of the test oscillator: exercises `fmi3-export` alone,
//! including the failed-step path (its `fail_at` parameter), as `test-oscillator` does for FMI 2.0.

fmi3_export::export_fmi3!(test_oscillator::Oscillator);
