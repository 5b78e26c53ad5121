//! The hot path allocates nothing: once a `SpatialData` has met a contact set, repeated
//! `forward_dynamics` and `crba` + `nonlinear_effects` calls make no heap allocation (counted
//! by a global allocator wrapper).
mod spatial_support;
use selfmanip_core::spatial::rigid_body::{crba, nonlinear_effects};
use selfmanip_core::spatial::*;
use spatial_support::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Counts only this thread's allocations (the test harness's own threads allocate too).
    static COUNTING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn count() {
    if COUNTING.with(|c| c.get()) {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
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
fn forward_dynamics_does_not_allocate() {
    COUNTING.with(|c| c.set(true));
    let model = quadruped_massless_shins();
    let mut data = SpatialData::new(&model);
    let contacts = feet(&model, [true; 4]);
    let mut rng = rng(13);
    let states: Vec<_> = (0..10).map(|_| random_state(&model, &mut rng)).collect();
    // warm up: sizes the contact buffers and the KKT factorization
    dynamics_at(
        &model,
        &mut data,
        &contacts,
        (&states[0].0, &states[0].1, &states[0].2),
    )
    .unwrap();
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    assert!(before > 0, "the counter counts (set-up allocates)");
    for (q, v, tau) in &states {
        dynamics_at(&model, &mut data, &contacts, (q, v, tau)).unwrap();
        crba(&model, &mut data, q.as_slice()).unwrap();
        nonlinear_effects(&model, &mut data, q.as_slice(), v.as_slice()).unwrap();
    }
    let made = ALLOCATIONS.load(Ordering::SeqCst) - before;
    COUNTING.with(|c| c.set(false));
    assert_eq!(made, 0, "{made} allocations in 10 evaluations");
}
