//! The vector units the free-body step can run on, found at run time (issue 34): one binary
//! uses AVX-512 or AVX2 where the CPU has them and SSE2 (every x86-64) otherwise, with no
//! `target-cpu` flag. Every unit steps the same bits (`sim::integrators::variational`'s
//! `vector.rs`: the same operations in the same order, never fused), so the choice changes the
//! speed only.
//!
//! `TUMBLE_SIMD=sse2|avx2|avx512` caps the unit used (for benchmarks and comparisons); the
//! default is the widest the CPU has.

use std::sync::OnceLock;

/// A vector unit, narrowest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Level {
    /// Two doubles per instruction (`[f64; 4]` lanes the compiler vectorizes); every x86-64 and
    /// every other architecture (where it is plain scalar or the target's own vectors).
    Sse2,
    /// AVX2: four doubles per register, 16 registers; 4 bodies per lane group.
    Avx2,
    /// AVX-512F: eight doubles per register, 32 registers; 8 bodies per lane group.
    Avx512,
}

impl Level {
    pub const ALL: [Level; 3] = [Level::Sse2, Level::Avx2, Level::Avx512];

    pub fn name(self) -> &'static str {
        match self {
            Level::Sse2 => "sse2",
            Level::Avx2 => "avx2",
            Level::Avx512 => "avx512",
        }
    }

    /// The level named `name` (as [`Level::name`] writes it, in any case: `AVX512` too).
    pub fn parse(name: &str) -> Option<Level> {
        Level::ALL
            .into_iter()
            .find(|l| l.name().eq_ignore_ascii_case(name))
    }
}

/// The widest unit this CPU has.
pub fn detected() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return Level::Avx512;
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            return Level::Avx2;
        }
    }
    Level::Sse2
}

/// Every unit this CPU has, narrowest first.
pub fn available() -> Vec<Level> {
    let top = detected();
    Level::ALL.into_iter().filter(|&l| l <= top).collect()
}

/// The unit the step uses: [`detected`], capped by `TUMBLE_SIMD` when it names a level (read
/// once per process; unset or empty: no cap; an unknown name is ignored with a warning on
/// stderr, as a tuning knob's typo should not stop a run).
pub fn active() -> Level {
    static ACTIVE: OnceLock<Level> = OnceLock::new();
    *ACTIVE.get_or_init(|| {
        let top = detected();
        match std::env::var("TUMBLE_SIMD") {
            Ok(name) if name.trim().is_empty() => top,
            Ok(name) => match Level::parse(name.trim()) {
                Some(cap) => cap.min(top),
                None => {
                    eprintln!(
                        "warning: TUMBLE_SIMD={name} is not one of sse2, avx2, avx512: using {}",
                        top.name()
                    );
                    top
                }
            },
            Err(_) => top,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_units_are_ordered() {
        for level in Level::ALL {
            assert_eq!(Level::parse(level.name()), Some(level));
        }
        assert_eq!(Level::parse("avx"), None);
        assert_eq!(Level::parse("AVX512"), Some(Level::Avx512));
        assert_eq!(Level::parse("Avx2"), Some(Level::Avx2));
        assert_eq!(Level::parse(""), None);
        assert!(Level::Sse2 < Level::Avx2 && Level::Avx2 < Level::Avx512);
        let units = available();
        assert_eq!(units.first(), Some(&Level::Sse2));
        assert_eq!(units.last(), Some(&detected()));
        assert!(active() <= detected());
    }
}
