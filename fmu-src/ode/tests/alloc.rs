//! After the first call has sized the work buffers, `integrate` performs no heap allocation
//! (counted with a global allocator wrapper, on the test's own thread only).

mod problems;

use ode::{Integrator, Method};
use problems::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU64, Ordering};

struct Counting;
static ALLOCS: AtomicU64 = AtomicU64::new(0);

thread_local! {
    /// Set on the measuring thread only: the test harness's own threads allocate at times of
    /// their choosing (output capture, timers), which must not count. A const-initialised
    /// thread local is read without allocating.
    static COUNTED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn count() {
    if COUNTED.with(|c| c.get()) {
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
fn no_allocation_after_first_call() {
    COUNTED.with(|c| c.set(true));
    for m in [Method::Rodas5P, Method::Rodas4] {
        let sys = Hydraulic {
            square: true,
            freq: 0.8,
        };
        let atol: Vec<f64> = HYD_NOMINAL.iter().map(|s| 1e-6 * s).collect();
        let mut ig = Integrator::new(1e-6, atol).with_method(m);
        let mut y = HYD_Y0;
        ig.integrate(&sys, 0.0, 1e-3, &mut y).unwrap();
        let before = ALLOCS.load(Ordering::Relaxed);
        // FD Jacobian path (Hydraulic has none) with rejections at the square-wave switch.
        for k in 1..1000u32 {
            ig.integrate(&sys, k as f64 * 1e-3, (k + 1) as f64 * 1e-3, &mut y)
                .unwrap();
        }
        let mid = ALLOCS.load(Ordering::Relaxed);
        // Analytic Jacobian path.
        let dc = DcMotor {
            amp: 12.0,
            freq: 5.0,
            held: None,
            analytic: true,
        };
        let mut ig2 =
            Integrator::new(1e-6, DC_NOMINAL.iter().map(|s| 1e-6 * s).collect()).with_method(m);
        let mut z = [0.0; 3];
        ig2.integrate(&dc, 0.0, 1e-3, &mut z).unwrap();
        let before2 = ALLOCS.load(Ordering::Relaxed);
        for k in 1..500u32 {
            ig2.integrate(&dc, k as f64 * 1e-3, (k + 1) as f64 * 1e-3, &mut z)
                .unwrap();
        }
        let after = ALLOCS.load(Ordering::Relaxed);
        assert!(ig.stats().steps > 1000 && ig2.stats().steps > 500);
        assert_eq!(
            mid, before,
            "{m:?}: allocations in the hot loop (FD Jacobian)"
        );
        assert!(
            before2 > mid,
            "the counter sees the first call's buffer allocation"
        );
        assert_eq!(
            after, before2,
            "{m:?}: allocations in the hot loop (analytic Jacobian)"
        );
    }
}
