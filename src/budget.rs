//! Refusing absurd requests before any work: what a run would cost, estimated up front.
//!
//! A request (bodies, steps, recorded frames) is turned into an [`Estimate`] of the recordings'
//! size, the memory the bodies need and the computing time; [`Estimate::check`] refuses it with
//! one message giving the estimates when a limit is passed:
//!
//! | limit                                  | default                      | raised by            |
//! |----------------------------------------|------------------------------|----------------------|
//! | recordings (MCAP + RRD)                | [`MAX_OUTPUT_BYTES`] (64 GiB) | `--allow-huge`      |
//! | computing time                         | [`MAX_COMPUTE_SECS`] (7 days) | `--allow-huge`      |
//! | memory for the bodies and buffers      | half the machine's RAM       | (never)              |
//! | steps                                  | [`MAX_STEPS`] (1e15)         | (never)              |
//!
//! The per-unit figures are measured on this project's recordings (zstd MCAP, Rerun 0.36 `.rrd`):
//! about 80 + 95 n bytes of MCAP and 40 + 125 n bytes of RRD per recorded step with n recorded
//! frames and bodies (`models/box.toml`, `models/arm.toml` over 1e4 recorded steps), rounded up
//! to [`BYTES_PER_STEP`] + [`BYTES_PER_FRAME_STEP`] n for both files together. Computing:
//! [`NS_PER_BODY_STEP`], a pessimistic figure for the slowest integrator in one thread (docs/trade.md,
//! "Performance"). Memory: [`BYTES_PER_BODY`] per simulated body (state, integrator scratch,
//! layout, frame buffers).

/// Largest recordings accepted without `--allow-huge`, bytes.
pub const MAX_OUTPUT_BYTES: f64 = 64.0 * (1u64 << 30) as f64;
/// Longest estimated computing time accepted without `--allow-huge`, s.
pub const MAX_COMPUTE_SECS: f64 = 7.0 * 86_400.0;
/// Most steps of one run (a u64 and integer-ns timestamps would still hold more; no run needs it).
pub const MAX_STEPS: f64 = 1e15;
/// Recorded bytes per recorded step, both files, besides the per-frame part.
pub const BYTES_PER_STEP: f64 = 200.0;
/// Recorded bytes per recorded step and per recorded frame or body, both files.
pub const BYTES_PER_FRAME_STEP: f64 = 250.0;
/// Estimated cost of one body-step, ns (pessimistic: moser-veselov or rk4 in one thread).
pub const NS_PER_BODY_STEP: f64 = 200.0;
/// Estimated memory per simulated body, bytes.
pub const BYTES_PER_BODY: f64 = 2048.0;

/// `value <= limit`, false for NaN.
fn within(value: f64, limit: f64) -> bool {
    matches!(
        value.partial_cmp(&limit),
        Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
    )
}

/// What a request would cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub bodies: f64,
    pub steps: f64,
    /// Recorded steps (0 without recordings).
    pub recorded_steps: f64,
    /// MCAP + RRD bytes.
    pub output_bytes: f64,
    pub memory_bytes: f64,
    pub compute_secs: f64,
}

/// Recorded steps of a run of `steps` steps recording every `log_every`th (first and last
/// always).
pub fn recorded_steps(steps: f64, log_every: f64) -> f64 {
    let every = log_every.max(1.0);
    (steps / every).floor() + 1.0 + if steps % every != 0.0 { 1.0 } else { 0.0 }
}

impl Estimate {
    /// A run of `steps` steps of `bodies` bodies recording `frames` link frames every
    /// `log_every`th step (`None`: nothing recorded).
    pub fn run(bodies: f64, frames: f64, steps: f64, log_every: Option<f64>) -> Self {
        let recorded = log_every.map_or(0.0, |every| recorded_steps(steps, every));
        Self {
            bodies,
            steps,
            recorded_steps: recorded,
            output_bytes: recorded * (BYTES_PER_STEP + BYTES_PER_FRAME_STEP * (frames + bodies)),
            memory_bytes: bodies * BYTES_PER_BODY,
            compute_secs: bodies * steps * NS_PER_BODY_STEP * 1e-9,
        }
    }

    /// `Err` with the estimates when a limit is passed (see the module doc); `allow_huge` lifts
    /// the size and time limits.
    pub fn check(&self, allow_huge: bool) -> anyhow::Result<()> {
        let memory_limit = physical_memory_bytes() / 2.0;
        let mut over = Vec::new();
        if !within(self.steps, MAX_STEPS) {
            over.push(format!("{:.3e} steps (at most {MAX_STEPS:e})", self.steps));
        }
        if !within(self.memory_bytes, memory_limit) {
            over.push(format!(
                "{} of memory for {:.3e} bodies (limit: half of this machine's {})",
                human_bytes(self.memory_bytes),
                self.bodies,
                human_bytes(memory_limit * 2.0)
            ));
        }
        if !allow_huge && !within(self.output_bytes, MAX_OUTPUT_BYTES) {
            over.push(format!(
                "{} of recordings ({:.3e} recorded steps; limit {})",
                human_bytes(self.output_bytes),
                self.recorded_steps,
                human_bytes(MAX_OUTPUT_BYTES)
            ));
        }
        if !allow_huge && !within(self.compute_secs, MAX_COMPUTE_SECS) {
            over.push(format!(
                "{} of computing ({:.3e} body-steps; limit {})",
                human_secs(self.compute_secs),
                self.compute_secs / (NS_PER_BODY_STEP * 1e-9),
                human_secs(MAX_COMPUTE_SECS)
            ));
        }
        if over.is_empty() {
            return Ok(());
        }
        anyhow::bail!(
            "refusing a run of {:.3e} steps x {:.3e} bodies before starting: it would need {}. \
             Estimated: recordings {}, memory {}, computing {}. Shorten the duration, raise the step \
             size or log_every, or pass --allow-huge to lift the size and time limits",
            self.steps,
            self.bodies,
            over.join(", "),
            human_bytes(self.output_bytes),
            human_bytes(self.memory_bytes),
            human_secs(self.compute_secs),
        )
    }
}

/// `MemTotal` of `/proc/meminfo`, bytes; 16 GiB when it cannot be read.
pub fn physical_memory_bytes() -> f64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
            let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(kib * 1024.0)
        })
        .unwrap_or(16.0 * (1u64 << 30) as f64)
}

/// Peak resident memory of this process so far (`VmHWM` of `/proc/self/status`), bytes.
pub fn peak_memory_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// `1.5 GiB`, `3.2 PiB`, ... (binary units).
pub fn human_bytes(bytes: f64) -> String {
    const UNITS: [&str; 7] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    if !bytes.is_finite() {
        return format!("{bytes} B");
    }
    let mut value = bytes;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit + 1 == UNITS.len() && value >= 1024.0 {
        return format!("{bytes:.3e} B");
    }
    format!("{value:.1} {}", UNITS[unit])
}

/// `42 s`, `3.5 h`, `12.0 days`, `3.2e6 years`.
pub fn human_secs(secs: f64) -> String {
    if !within(secs, 3600.0) || secs == 3600.0 {
        let hours = secs / 3600.0;
        if hours < 48.0 {
            return format!("{hours:.1} h");
        }
        let days = hours / 24.0;
        if days < 1000.0 {
            return format!("{days:.1} days");
        }
        return format!("{:.2e} years", days / 365.25);
    }
    format!("{secs:.0} s")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recorded_steps_count_first_and_last() {
        assert_eq!(recorded_steps(3000.0, 10.0), 301.0);
        assert_eq!(recorded_steps(3001.0, 10.0), 302.0);
        assert_eq!(recorded_steps(0.0, 10.0), 1.0);
    }

    #[test]
    fn absurd_requests_are_refused_with_estimates_and_sane_ones_pass() {
        let e = Estimate::run(2.0, 2.0, 1e15, Some(10.0));
        let err = e.check(false).unwrap_err().to_string();
        assert!(err.contains("PiB") && err.contains("refusing"), "{err}");
        // 1e15 steps is also past the time limit even without recording.
        assert!(Estimate::run(1.0, 1.0, 1e15, None).check(false).is_err());
        let err = Estimate::run(1e9, 1e9, 1000.0, Some(10.0))
            .check(true)
            .unwrap_err()
            .to_string();
        assert!(err.contains("memory"), "{err}");
        assert!(
            Estimate::run(1e4, 1e4, 1e4, Some(10.0))
                .check(false)
                .is_ok()
        );
        assert!(
            Estimate::run(2.0, 2.0, 1e9, Some(1000.0))
                .check(false)
                .is_ok()
        );
        assert!(
            Estimate::run(2.0, 2.0, f64::NAN, Some(10.0))
                .check(true)
                .is_err()
        );
    }

    #[test]
    fn human_units() {
        assert_eq!(human_bytes(1536.0), "1.5 KiB");
        assert_eq!(human_bytes(64.0 * (1u64 << 30) as f64), "64.0 GiB");
        assert_eq!(human_secs(90.0), "90 s");
        assert_eq!(human_secs(7.0 * 86_400.0), "7.0 days");
    }
}
