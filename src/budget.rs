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
//! "Performance").
//!
//! Memory ([`Population::memory_bytes`]) is a linear model of what `simulate` holds, fitted to
//! the peak resident memory (`VmHWM`) of runs from 1 000 to 100 000 copies (2026-12-04, this
//! machine): [`BASE_BYTES`] for the process, recorders and buffers; [`BYTES_PER_BODY`] per
//! simulated body and [`BYTES_PER_FRAME`] per recorded link frame (box copies: 1.39 KiB per copy;
//! a 7-link chain as free links: 8.98 KiB, as one rigid body: 5.6 KiB); and for articulated
//! models [`BYTES_PER_MECHANISM_BODY`] more per body of a mechanism and [`BYTES_PER_MECHANISM`]
//! per mechanism (its joints, rows and solver workspace: a 2-body pendulum 24.8 KiB per copy, the
//! 7-link chain 71.3 KiB, a 30-link chain 289 KiB). Before issue 28 the estimate was 2 KiB per
//! body whatever the model, so 100 000 copies of the 7-link chain were estimated at 1.3 GiB and
//! took 6.8 GiB. The scene's build checks the estimate after the first copy of each
//! `[[model]]` table, before it builds the others, so a scene too big for the machine is
//! refused before it takes the memory (`crate::scene`).

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
/// Memory of a run besides its bodies (binary, recorders, buffers), bytes: measured 13.2 to
/// 14.6 MiB for 1 to 1 000 boxes.
pub const BASE_BYTES: f64 = 14.0 * (1u64 << 20) as f64;
/// Estimated memory per simulated body (state, integrator scratch, attachments), bytes.
pub const BYTES_PER_BODY: f64 = 640.0;
/// Estimated memory per recorded link frame (layout, frame ids, recorders' columns), bytes.
pub const BYTES_PER_FRAME: f64 = 640.0;
/// Estimated memory per body of a mechanism (an articulated model) beyond [`BYTES_PER_BODY`]:
/// its joint rows, coordinates and step workspace, bytes (fitted: 8.0 KiB).
pub const BYTES_PER_MECHANISM_BODY: f64 = 8192.0;
/// Estimated memory per mechanism beyond its bodies, bytes (fitted: 6.2 KiB).
pub const BYTES_PER_MECHANISM: f64 = 6144.0;

/// What a world holds, for the memory estimate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Population {
    /// Simulated bodies, free or in mechanisms.
    pub bodies: f64,
    /// Recorded link frames.
    pub frames: f64,
    /// Bodies that belong to a mechanism.
    pub mechanism_bodies: f64,
    /// Mechanisms (articulated models).
    pub mechanisms: f64,
}

impl Population {
    /// Estimated peak memory of a run of this population, bytes (the module documentation).
    pub fn memory_bytes(&self) -> f64 {
        BASE_BYTES
            + self.bodies * BYTES_PER_BODY
            + self.frames * BYTES_PER_FRAME
            + self.mechanism_bodies * BYTES_PER_MECHANISM_BODY
            + self.mechanisms * BYTES_PER_MECHANISM
    }

    /// What `self` holds beyond `earlier`.
    pub fn minus(&self, earlier: &Population) -> Population {
        self.plus(earlier, -1.0)
    }

    /// `self` and `copies` more of `each`.
    pub fn plus(&self, each: &Population, copies: f64) -> Population {
        Population {
            bodies: self.bodies + copies * each.bodies,
            frames: self.frames + copies * each.frames,
            mechanism_bodies: self.mechanism_bodies + copies * each.mechanism_bodies,
            mechanisms: self.mechanisms + copies * each.mechanisms,
        }
    }

    /// `Err` when [`Population::memory_bytes`] passes half the machine's RAM; `what` names the
    /// request in the message.
    pub fn check_memory(&self, what: &str) -> anyhow::Result<()> {
        let limit = physical_memory_bytes() / 2.0;
        let need = self.memory_bytes();
        if within(need, limit) {
            return Ok(());
        }
        anyhow::bail!(
            "{what} would need about {} of memory ({} bodies, {} of them in {} mechanisms; \
             limit: half of this machine's {}): refused before building it. Use fewer copies or \
             models",
            human_bytes(need),
            human_number(self.bodies),
            human_number(self.mechanism_bodies),
            human_number(self.mechanisms),
            human_bytes(limit * 2.0)
        )
    }
}

/// A count as written by people: `700000`, `1.2e9` past a billion ([`readable`] for
/// fractions).
pub fn human_number(n: f64) -> String {
    if n.abs() >= 1e9 && n.is_finite() {
        format!("{n:e}")
    } else {
        readable(n)
    }
}

/// A number for a message, as short as it can be written and still read back exactly (what
/// the user typed: `0.001`, `1e-12`, `1e300`), with an exponent outside `[1e-4, 1e15)` so that
/// no value prints as hundreds of digits (`format!("{}", 1e300)` writes 301 of them); `NaN`,
/// `inf` and `-inf` as such.
pub fn readable(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e15).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A whole count with thousands separators: `2,000,000` (counts of triangles, bytes).
pub fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

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
            memory_bytes: Population {
                bodies,
                frames,
                ..Population::default()
            }
            .memory_bytes(),
            compute_secs: bodies * steps * NS_PER_BODY_STEP * 1e-9,
        }
    }

    /// The same run with the memory of `population` (a world with mechanisms).
    pub fn with_population(self, population: &Population) -> Self {
        Self {
            memory_bytes: population.memory_bytes(),
            ..self
        }
    }

    /// `Err` with the estimates when a limit is passed (see the module doc); `allow_huge` lifts
    /// the size and time limits.
    pub fn check(&self, allow_huge: bool) -> anyhow::Result<()> {
        let memory_limit = physical_memory_bytes() / 2.0;
        let mut over = Vec::new();
        if !within(self.steps, MAX_STEPS) {
            over.push(format!(
                "{} steps (at most {MAX_STEPS:e})",
                human_number(self.steps)
            ));
        }
        if !within(self.memory_bytes, memory_limit) {
            over.push(format!(
                "{} of memory for {} bodies (limit: half of this machine's {})",
                human_bytes(self.memory_bytes),
                human_number(self.bodies),
                human_bytes(memory_limit * 2.0)
            ));
        }
        if !allow_huge && !within(self.output_bytes, MAX_OUTPUT_BYTES) {
            over.push(format!(
                "{} of recordings ({} recorded steps; limit {})",
                human_bytes(self.output_bytes),
                human_number(self.recorded_steps),
                human_bytes(MAX_OUTPUT_BYTES)
            ));
        }
        if !allow_huge && !within(self.compute_secs, MAX_COMPUTE_SECS) {
            over.push(format!(
                "{} of computing ({} body-steps; limit {})",
                human_secs(self.compute_secs),
                human_number(self.compute_secs / (NS_PER_BODY_STEP * 1e-9)),
                human_secs(MAX_COMPUTE_SECS)
            ));
        }
        if over.is_empty() {
            return Ok(());
        }
        anyhow::bail!(
            "refusing a run of {} steps x {} bodies before starting: it would need {}. \
             Estimated: recordings {}, memory {}, computing {}. Shorten the duration, raise the step \
             size or log_every, or pass --allow-huge to lift the size and time limits",
            human_number(self.steps),
            human_number(self.bodies),
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

    /// The memory model against the peaks it was fitted to (VmHWM, MiB, measured 2026-12-04):
    /// every estimate within 1.5x (the bound), most within 1.15x.
    #[test]
    fn memory_model_matches_the_measured_peaks() {
        let mib = (1u64 << 20) as f64;
        let copies = |n: f64, bodies: f64, frames: f64, mbodies: f64, mechs: f64| {
            Population::default().plus(
                &Population {
                    bodies,
                    frames,
                    mechanism_bodies: mbodies,
                    mechanisms: mechs,
                },
                n,
            )
        };
        for (population, measured_mib) in [
            (copies(1e4, 1.0, 1.0, 0.0, 0.0), 26.1),     // boxes
            (copies(1e5, 1.0, 1.0, 0.0, 0.0), 145.2),    // boxes
            (copies(2e4, 8.0, 8.0, 0.0, 0.0), 190.0),    // 7-link chain, free links
            (copies(2e4, 1.0, 8.0, 0.0, 0.0), 124.1),    // 7-link chain, rigid
            (copies(2e4, 2.0, 2.0, 2.0, 1.0), 495.6),    // double pendulum, articulated
            (copies(1e4, 7.0, 7.0, 7.0, 1.0), 711.2),    // 7-link chain, articulated
            (copies(1e5, 7.0, 7.0, 7.0, 1.0), 6963.2),   // the case: 6.8 GiB
            (copies(2e3, 30.0, 30.0, 30.0, 1.0), 578.5), // 30-link chain, articulated
        ] {
            let ratio = population.memory_bytes() / (measured_mib * mib);
            assert!(
                (1.0 / 1.5..=1.5).contains(&ratio),
                "{population:?}: {ratio}"
            );
        }
    }

    #[test]
    fn too_big_a_world_is_refused_naming_its_size() {
        let huge = Population {
            bodies: 7e9,
            frames: 7e9,
            mechanism_bodies: 7e9,
            mechanisms: 1e9,
        };
        let err = huge.check_memory("100 copies").unwrap_err().to_string();
        assert!(err.starts_with("100 copies would need about "), "{err}");
        assert!(err.contains("refused before building it"), "{err}");
        assert!(err.contains("7e9 bodies"), "{err}");
        assert!(
            Population::default()
                .plus(&huge, 1e-9)
                .check_memory("x")
                .is_ok()
        );
        assert_eq!(human_number(700000.0), "700000");
        assert_eq!(human_number(1.5), "1.5");
        assert_eq!(human_number(2.5e9), "2.5e9");
        assert_eq!(human_number(999_999_999.0), "999999999");
        assert_eq!(human_number(1e9), "1e9");
        assert_eq!(human_number(-1e9), "-1e9");
        assert_eq!(human_number(f64::INFINITY), "inf");
    }

    /// What the user typed reads back as typed; huge and tiny magnitudes take an exponent.
    #[test]
    fn readable_numbers() {
        for (x, text) in [
            (0.0, "0"),
            (0.001, "0.001"),
            (1e-4, "0.0001"),
            (9.99e-5, "9.99e-5"),
            (1e-12, "1e-12"),
            (-2.5, "-2.5"),
            (100.0, "100"),
            (999_999_999_999_999.0, "999999999999999"),
            (1e15, "1e15"),
            (-1e300, "-1e300"),
            (f64::MAX, "1.7976931348623157e308"),
            (f64::NAN, "NaN"),
            (f64::INFINITY, "inf"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            assert_eq!(readable(x), text, "{x:e}");
            // Never more than the 17 significant digits of an f64 plus sign, point, exponent.
            assert!(readable(x).len() <= 24, "{}", readable(x));
        }
        assert_eq!(grouped(0), "0");
        assert_eq!(grouped(999), "999");
        assert_eq!(grouped(1000), "1,000");
        assert_eq!(grouped(2_000_000), "2,000,000");
        assert_eq!(grouped(12_345_678), "12,345,678");
        assert_eq!(grouped(u64::MAX), "18,446,744,073,709,551,615");
    }

    #[test]
    fn human_units() {
        assert_eq!(human_bytes(1536.0), "1.5 KiB");
        assert_eq!(human_bytes(64.0 * (1u64 << 30) as f64), "64.0 GiB");
        assert_eq!(human_secs(90.0), "90 s");
        assert_eq!(human_secs(7.0 * 86_400.0), "7.0 days");
    }
}
