//! Runtime dispatch of the hot kernels to code compiled for AVX2 where the CPU has it.
//!
//! The hot entry points — the planar kinematics, `M̄ C̄q̇ N̄`, the KKT factor and solve, and the
//! spatial forward dynamics — are compiled twice by [`multiversion!`]: once for the build's
//! target (x86-64's SSE2 baseline unless `RUSTFLAGS` says otherwise) and once with
//! `#[target_feature(enable = "avx2,fma")]`, their bodies and the `#[inline(always)]` kernels
//! they call compiled into each copy. Which copy runs is decided once per process
//! ([`path`]) and cached in an atomic.
//!
//! The two copies give the same bits: Rust never contracts `a * b + c` into a fused
//! multiply-add and LLVM reorders no floating-point reduction without fast-math flags, so
//! AVX2 changes the instructions (three-operand VEX forms, wider moves and shuffles), not the
//! arithmetic. `tests/cpu_dispatch.rs` compares both paths bit for bit.
//!
//! The choice, from the environment variable `SELFMANIP_SIMD` read once:
//! - `baseline`: the baseline copy;
//! - `avx2`: the AVX2 copy if the CPU has AVX2 and FMA (else the baseline);
//! - unset (or anything else): the AVX2 copy if the CPU has AVX2 and FMA and the process does
//!   not run under valgrind, else the baseline. Valgrind 3.19 does not decode every AVX2
//!   instruction LLVM emits (it stops the process with SIGILL), and instruction counts are
//!   compared with those of earlier builds: under valgrind the baseline copy runs.
//!
//! [`force_baseline`] switches the process to the baseline copy (for tests that compare the
//! two). On targets other than x86-64 only the baseline copy is compiled.
use std::sync::atomic::{AtomicU8, Ordering};

/// Which copy of the hot kernels runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimdPath {
    /// Compiled for the build's target (SSE2 on x86-64).
    Baseline,
    /// Compiled with AVX2 and FMA enabled.
    Avx2,
}

const UNKNOWN: u8 = 0;
const BASELINE: u8 = 1;
const AVX2: u8 = 2;

static PATH: AtomicU8 = AtomicU8::new(UNKNOWN);

/// The copy of the hot kernels this process runs (decided on the first call).
#[inline]
pub fn path() -> SimdPath {
    match PATH.load(Ordering::Relaxed) {
        AVX2 => SimdPath::Avx2,
        BASELINE => SimdPath::Baseline,
        _ => {
            let chosen = detect();
            PATH.store(chosen, Ordering::Relaxed);
            if chosen == AVX2 {
                SimdPath::Avx2
            } else {
                SimdPath::Baseline
            }
        }
    }
}

/// Whether the AVX2 copy runs: the dispatchers' test.
#[inline(always)]
pub fn avx2() -> bool {
    match PATH.load(Ordering::Relaxed) {
        AVX2 => true,
        BASELINE => false,
        _ => path() == SimdPath::Avx2,
    }
}

/// Runs the baseline copy from now on (`true`), or the choice of the environment and the CPU
/// (`false`). For tests that compare the two copies; other threads follow at their next call.
pub fn force_baseline(on: bool) {
    let chosen = if on { BASELINE } else { detect() };
    PATH.store(chosen, Ordering::Relaxed);
}

/// Whether the CPU can run the AVX2 copy.
pub fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

fn detect() -> u8 {
    let wanted = std::env::var("SELFMANIP_SIMD").ok();
    let use_avx2 = match wanted.as_deref() {
        Some("baseline") => false,
        Some("avx2") => avx2_available(),
        _ => avx2_available() && !running_on_valgrind(),
    };
    if use_avx2 {
        AVX2
    } else {
        BASELINE
    }
}

/// Valgrind's `RUNNING_ON_VALGRIND` client request: nonzero under valgrind. Natively the
/// rotations of the magic sequence sum to 128 bits (a no-op) and `xchg rbx, rbx` does
/// nothing, so the default 0 comes back.
#[cfg(target_arch = "x86_64")]
fn running_on_valgrind() -> bool {
    const RUNNING_ON_VALGRIND: u64 = 0x1001;
    let args: [u64; 6] = [RUNNING_ON_VALGRIND, 0, 0, 0, 0, 0];
    let mut result: u64 = 0;
    // SAFETY: the sequence reads `args` through rax and writes only rdx (and rdi, restored
    // by the rotations); it touches neither memory nor flags beyond those named.
    unsafe {
        std::arch::asm!(
            "rol rdi, 3",
            "rol rdi, 13",
            "rol rdi, 61",
            "rol rdi, 51",
            "xchg rbx, rbx",
            in("rax") args.as_ptr(),
            inout("rdx") result,
            inout("rdi") 0u64 => _,
            options(nostack, readonly)
        );
    }
    result != 0
}

#[cfg(not(target_arch = "x86_64"))]
fn running_on_valgrind() -> bool {
    false
}

/// Defines `fn NAME(args) -> R { body }` compiled twice — for the build's target and, on
/// x86-64, with AVX2 and FMA enabled — and dispatching by [`avx2`]. The body is an
/// `#[inline(always)]` function, so it and the `#[inline(always)]` kernels it calls are
/// compiled into each copy; a callee that is not inlined runs its baseline code from both.
/// Arguments are plain identifiers, lifetimes elided; type parameters `<T: Bound, ...>` are
/// allowed (each instantiation is dispatched).
macro_rules! multiversion {
    (
        $(#[$attr:meta])*
        $vis:vis fn $name:ident $(<$($g:ident : $b:path),+>)? ($($arg:ident : $ty:ty),* $(,)?)
            $(-> $ret:ty)? $body:block
    ) => {
        $(#[$attr])*
        $vis fn $name $(<$($g: $b),+>)? ($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            #[allow(clippy::too_many_arguments)]
            fn generic $(<$($g: $b),+>)? ($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,fma")]
                #[allow(clippy::too_many_arguments)]
                fn avx2 $(<$($g: $b),+>)? ($($arg: $ty),*) $(-> $ret)? {
                    generic($($arg),*)
                }
                if $crate::cpu::avx2() {
                    // SAFETY: `avx2()` holds only when the CPU has AVX2 and FMA
                    return unsafe { avx2($($arg),*) };
                }
            }
            generic($($arg),*)
        }
    };
}
pub(crate) use multiversion;
