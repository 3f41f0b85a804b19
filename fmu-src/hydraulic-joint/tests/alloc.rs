//! `do_step` performs no heap allocation once the model is initialized and the integrator's
//! buffers exist (counted with a global allocator wrapper, on the test's own thread only: the
//! test harness's main thread may allocate concurrently). Closed and open loop, each effect on.
// The test's input signal may use the platform libm (workspace clippy.toml binds FMU code).
#![allow(clippy::disallowed_methods)]

use fmu_core::Model;
use hydraulic_joint::vars::{V, VARIABLES};
use hydraulic_joint::HydraulicJoint;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

struct Counting;
static ALLOCS: AtomicU64 = AtomicU64::new(0);

thread_local! {
    /// Count allocations made on this thread only.
    static COUNT_HERE: Cell<bool> = const { Cell::new(false) };
}

fn count() {
    if COUNT_HERE.with(|c| c.get()) {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn do_step_does_not_allocate() {
    COUNT_HERE.with(|c| c.set(true));
    let effects = [
        None,
        Some(V::SEAL_FRICTION_ENABLED),
        Some(V::VALVE_OVERLAP_ENABLED),
        Some(V::INTERNAL_LEAKAGE_ENABLED),
        Some(V::CABLE_FRICTION_ENABLED),
        Some(V::ENTRAINED_AIR_ENABLED),
        Some(V::VALVE_DYNAMICS_ENABLED),
    ];
    for closed in [true, false] {
        for effect in effects {
            let mut vars: Vec<f64> = VARIABLES.iter().map(|v| v.start).collect();
            vars[V::INTERNAL_CONTROLLER as usize] = if closed { 1.0 } else { 0.0 };
            if let Some(e) = effect {
                vars[e as usize] = 1.0;
            }
            let mut m = HydraulicJoint::new();
            m.initialize(&mut vars, 0.0).unwrap();
            // first step sizes the integrator's work buffers
            m.do_step(&mut vars, 0.0, 1e-3).unwrap();
            let before = ALLOCS.load(Ordering::Relaxed);
            for k in 1..400u32 {
                let t = k as f64 * 1e-3;
                vars[V::THETA_REF as usize] = 0.6 * (6.0 * t).sin();
                vars[V::U_LEFT as usize] = if k % 100 < 50 { 5.0 } else { -6.0 };
                vars[V::U_RIGHT as usize] = if k % 80 < 40 { -4.0 } else { 7.0 };
                vars[V::TAU_EXT as usize] = if k % 150 < 75 { 1.0 } else { -1.0 };
                m.do_step(&mut vars, t, 1e-3).unwrap();
            }
            let n = ALLOCS.load(Ordering::Relaxed) - before;
            assert_eq!(
                n, 0,
                "closed loop {closed}, effect {effect:?}: {n} allocations"
            );
            assert!(vars[V::THETA as usize].is_finite());
        }
    }
}
