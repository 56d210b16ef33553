//! Run-time CPU dispatch of rodlog's vector kernels: the feature front end's integer
//! kernels (FAST, pyramid resize, smoothing, Hamming and L2 matching, in `calib`) and the
//! renderer's lane textures (`sim`). The `unsafe` of both crates' dispatch is here (calib
//! keeps its AVX-512 VBMI byte shuffles of the pyramid resize, gated by [`vbmi_allowed`]).
//!
//! The workspace builds for `x86-64-v2` (SSE4.2 + popcnt, ARCHITECTURE.md section 8) so the binary
//! runs on any recent x86-64. The kernels are plain safe Rust written as whole-row,
//! branch-free lane loops; [`dispatch`] runs such a kernel inside a function compiled with
//! wider vector units enabled (AVX2, or AVX-512 with `vpopcntq` when the CPU has them, as
//! detected at run time), so LLVM auto-vectorises the inlined kernel with 32/64-byte
//! registers instead of 16-byte ones. This is OpenCV's scheme too (baseline SSE build with
//! AVX2/AVX-512 dispatch of hot loops).
//!
//! Results do not depend on the path taken: the kernels are integer arithmetic or
//! element-wise IEEE float arithmetic in a fixed order (no float reassociation, no FMA
//! contraction in Rust), so every path computes the same bits; the tests compare the paths
//! ([`Level`], [`dispatch_at`]).

/// The instruction-set level a kernel runs at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// The build's baseline (`x86-64-v2`, or whatever the target is).
    Baseline,
    /// AVX2 with FMA, BMI1/2 and LZCNT (the vector part of `x86-64-v3`).
    Avx2,
    /// AVX-512 F/BW/DQ/VL/CD with `VPOPCNTDQ` and `BITALG` (x86-64-v4 and vector popcount).
    Avx512,
}

/// Environment variable capping the level for the whole process: `baseline`, `avx2` or
/// `avx512` (as OpenCV's `OPENCV_CPU_DISABLE`), for A/B benchmarks of the same build.
pub const LEVEL_ENV: &str = "RODLOG_SIMD";

/// The best level this CPU supports, capped by [`LEVEL_ENV`] (read once).
pub fn detected() -> Level {
    static LEVEL: std::sync::OnceLock<Level> = std::sync::OnceLock::new();
    *LEVEL.get_or_init(|| {
        let cap = match std::env::var(LEVEL_ENV).as_deref() {
            Ok("baseline") => Level::Baseline,
            Ok("avx2") => Level::Avx2,
            _ => Level::Avx512,
        };
        cpu_level().min(cap)
    })
}

/// The best level this CPU supports.
fn cpu_level() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512bw")
            && std::arch::is_x86_feature_detected!("avx512dq")
            && std::arch::is_x86_feature_detected!("avx512vl")
            && std::arch::is_x86_feature_detected!("avx512cd")
            && std::arch::is_x86_feature_detected!("avx512vpopcntdq")
            && std::arch::is_x86_feature_detected!("avx512bitalg")
            && avx2_detected()
        {
            return Level::Avx512;
        }
        if avx2_detected() {
            return Level::Avx2;
        }
    }
    Level::Baseline
}

#[cfg(target_arch = "x86_64")]
fn avx2_detected() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma")
        && std::arch::is_x86_feature_detected!("bmi1")
        && std::arch::is_x86_feature_detected!("bmi2")
        && std::arch::is_x86_feature_detected!("lzcnt")
        && std::arch::is_x86_feature_detected!("popcnt")
}

/// Whether the CPU has AVX-512 VBMI (byte permutes), beside [`Level::Avx512`]'s set.
#[cfg(target_arch = "x86_64")]
fn vbmi_detected() -> bool {
    static VBMI: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *VBMI.get_or_init(|| std::arch::is_x86_feature_detected!("avx512vbmi"))
}

/// Whether a kernel may use AVX-512 VBMI here: the CPU has it, and the vector level
/// (including [`with_max_level`]'s cap) is [`Level::Avx512`]. It reads this thread's cap,
/// not the level given to [`dispatch_at`]; results are the same bits either way.
pub fn vbmi_allowed() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        max_level() == Level::Avx512 && vbmi_detected()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

thread_local! {
    /// Cap on the level of [`dispatch`] on this thread (see [`with_max_level`]).
    static CAP: std::cell::Cell<Level> = const { std::cell::Cell::new(Level::Avx512) };
}

/// Runs `f` with [`dispatch`] capped at `level` on the current thread (the cap is restored
/// afterwards), so a test or a benchmark can compare whole pipelines across levels.
pub fn with_max_level<R>(level: Level, f: impl FnOnce() -> R) -> R {
    let old = CAP.with(|c| c.replace(level));
    let r = f();
    CAP.with(|c| c.set(old));
    r
}

/// The level [`dispatch`] runs at on this thread: [`detected`] capped by [`with_max_level`]
/// (hand it to [`dispatch_at`] in work spread over other threads).
pub fn max_level() -> Level {
    CAP.with(std::cell::Cell::get).min(detected())
}

/// A kernel run by [`dispatch`]: its arguments as fields, its body in [`Kernel::run`], which
/// must be `#[inline(always)]` (as the functions it calls) so that it is compiled inside the
/// wide-vector function (a closure would not be inlined there reliably).
pub trait Kernel {
    /// What the kernel returns.
    type Output;
    /// The kernel's body.
    fn run(self) -> Self::Output;
}

/// Runs `k` at the best level of this CPU (module docs), capped by [`with_max_level`].
#[inline]
pub fn dispatch<K: Kernel>(k: K) -> K::Output {
    dispatch_at(CAP.with(std::cell::Cell::get), k)
}

/// Runs `k` at `level`, or at the best level below it that this CPU supports (for tests
/// comparing the paths, and to force the baseline).
// Calling a `#[target_feature]` function, guarded by the run-time detection above it
// (module docs).
#[allow(unsafe_code)]
#[inline]
pub fn dispatch_at<K: Kernel>(level: Level, k: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    {
        let level = level.min(detected());
        match level {
            // SAFETY: `detected()` returned at least `Avx512`, so every feature enabled on
            // `run_avx512` is present on this CPU.
            Level::Avx512 => unsafe { run_avx512(k) },
            // SAFETY: as above, for the features of `run_avx2`.
            Level::Avx2 => unsafe { run_avx2(k) },
            Level::Baseline => k.run(),
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = level;
        k.run()
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
#[inline]
fn run_avx2<K: Kernel>(k: K) -> K::Output {
    k.run()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(
    enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt,avx512f,avx512bw,avx512dq,avx512vl,avx512cd,avx512vpopcntdq,avx512bitalg"
)]
#[inline]
fn run_avx512<K: Kernel>(k: K) -> K::Output {
    k.run()
}

#[cfg(test)]
mod tests {
    use super::*;

    struct PopSum(u64);

    impl Kernel for PopSum {
        type Output = u32;
        #[inline(always)]
        fn run(self) -> u32 {
            (0..self.0).map(|x| x.count_ones()).sum()
        }
    }

    #[test]
    fn every_level_runs_the_kernel() {
        for level in [Level::Baseline, Level::Avx2, Level::Avx512] {
            let v = dispatch_at(level, PopSum(1000));
            assert_eq!(v, (0u64..1000).map(|x| x.count_ones()).sum::<u32>());
            assert_eq!(
                with_max_level(level, || dispatch(PopSum(77))),
                PopSum(77).run()
            );
        }
        assert!(detected() >= Level::Baseline);
    }
}
