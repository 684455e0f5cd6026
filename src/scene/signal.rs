//! A signal as a scene writes it (issue 30), parsed into a [`Signal`]:
//!
//! ```toml
//! effort = 0.5                                                   # a number
//! target = { sine = { amplitude = 0.5, frequency_hz = 0.5, phase = 0.0, offset = 0.2 } }
//! target = { smooth = { amplitude = 0.5, cutoff_hz = 1.0, offset = 0.0, seed = 7 } }   # random, smooth
//! target = { table = "trajectory.csv" }                          # columns `time` (s) and the joint's name
//! target = { log = "run.mcap", topic = "/joint_states" }         # a recorded log (actuators only)
//! target = { log = "run.mcap", topic = "/joints", joint = "arm/elbow" }   # the joint's name in the log
//! ```
//!
//! `phase` and `offset` default to 0 (`seed` too). A `smooth` signal is a seeded random smooth
//! input for exploring a robot's dynamics ([`smooth`]): `|s − offset| ≤ amplitude`, no
//! frequency above `cutoff_hz`. A table's or a log's path is relative to the scene file;
//! a table's `time` column must increase strictly, every value must be finite. A log is read by
//! [`super::signal_log`] (`joint` defaults to the actuator's joint). Every error names the key.

use super::signal_log;
use crate::sim::signal::Signal;
use anyhow::{Context, bail};
use std::path::Path;

/// Largest signal table read, bytes.
pub const TABLE_MAX_BYTES: u64 = 64 << 20;

/// Parses `value`, the key `key` (e.g. `scene.toml: model[0].actuator[1].target`), reading a
/// table's column `column` from a file relative to `base_dir`, and a log's joint and quantity
/// as `log` says (`None`: the key takes no log).
pub fn parse(
    key: &str,
    value: &toml::Value,
    base_dir: &Path,
    column: &str,
    log: Option<signal_log::Pick<'_>>,
) -> anyhow::Result<Signal> {
    let number = |k: &str, v: &toml::Value| -> anyhow::Result<f64> {
        let x = match v {
            toml::Value::Float(x) => *x,
            toml::Value::Integer(i) => *i as f64,
            _ => bail!("{k}: expected a number (got {v})"),
        };
        if !x.is_finite() {
            bail!("{k}: must be finite (got {x})");
        }
        Ok(x)
    };
    let table = match value {
        toml::Value::Table(t) => t,
        _ => return Ok(Signal::Constant(number(key, value)?)),
    };
    if table.contains_key("log") {
        return parse_log(key, table, base_dir, log);
    }
    let mut kinds = table.iter();
    let (Some((kind, body)), None) = (kinds.next(), kinds.next()) else {
        bail!(
            "{key}: expected a number, {{ sine = {{ ... }} }}, {{ smooth = {{ ... }} }}, \
             {{ table = \"file.csv\" }} or {{ log = \"file.mcap\", topic = \"...\" }}"
        );
    };
    match kind.as_str() {
        "sine" => {
            let toml::Value::Table(fields) = body else {
                bail!("{key}.sine: expected {{ amplitude, frequency_hz, phase, offset }}");
            };
            const KEYS: [&str; 4] = ["amplitude", "frequency_hz", "phase", "offset"];
            if let Some(other) = fields.keys().find(|k| !KEYS.contains(&k.as_str())) {
                bail!(
                    "{key}.sine.{other}: unknown key (expected one of: {})",
                    KEYS.join(", ")
                );
            }
            let field = |name: &str, required: bool| -> anyhow::Result<f64> {
                match fields.get(name) {
                    Some(v) => number(&format!("{key}.sine.{name}"), v),
                    None if required => bail!("{key}.sine.{name}: missing"),
                    None => Ok(0.0),
                }
            };
            Ok(Signal::Sine {
                amplitude: field("amplitude", true)?,
                frequency_hz: field("frequency_hz", true)?,
                phase: field("phase", false)?,
                offset: field("offset", false)?,
            })
        }
        "smooth" => {
            let toml::Value::Table(fields) = body else {
                bail!("{key}.smooth: expected {{ amplitude, cutoff_hz, offset, seed }}");
            };
            let params = SmoothParams::parse(&format!("{key}.smooth"), fields, true)?;
            Ok(smooth(&params, params.seed))
        }
        "table" => {
            let toml::Value::String(file) = body else {
                bail!("{key}.table: expected a file name (got {body})");
            };
            let path = base_dir.join(file);
            let text = crate::input::read_text(&path, TABLE_MAX_BYTES)
                .with_context(|| format!("{key}.table: cannot read {}", path.display()))?;
            read_table(&text, column).with_context(|| format!("{key}.table: {}", path.display()))
        }
        other => {
            bail!("{key}.{other}: unknown signal (expected a number, sine, smooth, table or log)")
        }
    }
}

/// Sines in a [`smooth`] signal.
pub const SMOOTH_TERMS: usize = 6;

/// The settings of a random smooth signal (`{ smooth = { ... } }`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothParams {
    /// Bound of `|s − offset|` (the target's unit: rad or m, rad/s or m/s, N m or N).
    pub amplitude: f64,
    /// Highest frequency in the signal, Hz (> 0).
    pub cutoff_hz: f64,
    pub offset: f64,
    /// The scene's `seed` (a dataset draws its own per run and joint).
    pub seed: u64,
}

impl SmoothParams {
    /// Reads `{ amplitude, cutoff_hz, offset = 0, seed = 0 }`; `seed` is refused unless
    /// `seeded` (a dataset seeds each run's signals itself). Errors name `key`.
    pub fn parse(key: &str, fields: &toml::Table, seeded: bool) -> anyhow::Result<Self> {
        let keys: &[&str] = if seeded {
            &["amplitude", "cutoff_hz", "offset", "seed"]
        } else {
            &["amplitude", "cutoff_hz", "offset"]
        };
        if let Some(other) = fields.keys().find(|k| !keys.contains(&k.as_str())) {
            bail!(
                "{key}.{other}: unknown key (expected one of: {})",
                keys.join(", ")
            );
        }
        let number = |name: &str, required: bool| -> anyhow::Result<f64> {
            let x = match fields.get(name) {
                None if required => bail!("{key}.{name}: missing"),
                None => return Ok(0.0),
                Some(toml::Value::Float(x)) => *x,
                Some(toml::Value::Integer(i)) => *i as f64,
                Some(v) => bail!("{key}.{name}: expected a number (got {v})"),
            };
            if !x.is_finite() {
                bail!("{key}.{name}: must be finite (got {x})");
            }
            Ok(x)
        };
        let amplitude = number("amplitude", true)?;
        if amplitude < 0.0 {
            bail!("{key}.amplitude: must be >= 0 (got {amplitude})");
        }
        let cutoff_hz = number("cutoff_hz", true)?;
        if cutoff_hz <= 0.0 {
            bail!("{key}.cutoff_hz: must be positive (got {cutoff_hz})");
        }
        let seed = match fields.get("seed") {
            None => 0,
            Some(toml::Value::Integer(i)) if *i >= 0 => *i as u64,
            Some(v) => bail!("{key}.seed: expected an integer >= 0 (got {v})"),
        };
        Ok(Self {
            amplitude,
            cutoff_hz,
            offset: number("offset", false)?,
            seed,
        })
    }
}

/// A random smooth signal seeded by `seed`: [`SMOOTH_TERMS`] sines
///
/// ```text
/// s(t) = offset + (amplitude / K) Σ_k sin(2π f_k t + φ_k),   K = SMOOTH_TERMS
/// f_k = cutoff · (k + u_k) / K,  u_k ~ U[0, 1)  (one frequency in each K-th of the band)
/// φ_k ~ U[0, 2π)
/// ```
///
/// so `|s − offset| ≤ amplitude` at every time, the signal is infinitely differentiable, no
/// frequency exceeds the cutoff, and its time average tends to `offset`; its RMS about the offset
/// is `amplitude / √(2K)` ≈ 0.29 · amplitude (the sines are incommensurate). Drawn from the
/// generator of `crate::scene::placement::rng`, so the same seed gives the same signal on every
/// machine.
pub fn smooth(params: &SmoothParams, seed: u64) -> Signal {
    let mut rng = crate::scene::placement::Rng::new(seed);
    let k_total = SMOOTH_TERMS as f64;
    let terms = (0..SMOOTH_TERMS)
        .map(|k| {
            let f = params.cutoff_hz * (k as f64 + rng.uniform01()) / k_total;
            let phase = std::f64::consts::TAU * rng.uniform01();
            [params.amplitude / k_total, f, phase]
        })
        .collect();
    Signal::Sines {
        offset: params.offset,
        terms,
    }
}

/// `{ log = "file.mcap", topic = "...", joint = "..." }` ([`super::signal_log`]).
fn parse_log(
    key: &str,
    table: &toml::Table,
    base_dir: &Path,
    log: Option<signal_log::Pick<'_>>,
) -> anyhow::Result<Signal> {
    let Some(pick) = log else {
        bail!(
            "{key}.log: a recorded log drives actuators only (here: a number, \
             {{ sine = {{ ... }} }} or {{ table = \"file.csv\" }})"
        );
    };
    const KEYS: [&str; 3] = ["log", "topic", "joint"];
    if let Some(other) = table.keys().find(|k| !KEYS.contains(&k.as_str())) {
        bail!(
            "{key}.{other}: unknown key of a log signal (expected: {})",
            KEYS.join(", ")
        );
    }
    let text = |name: &str| -> anyhow::Result<Option<&str>> {
        match table.get(name) {
            None => Ok(None),
            Some(toml::Value::String(s)) if !s.is_empty() => Ok(Some(s)),
            Some(v) => bail!("{key}.{name}: expected a non-empty string (got {v})"),
        }
    };
    let file = text("log")?.context("unreachable: `log` is present")?;
    let Some(topic) = text("topic")? else {
        bail!("{key}.topic: missing (the log's topic of joint states, e.g. \"/joint_states\")");
    };
    let joint = text("joint")?.unwrap_or(pick.joint);
    let path = base_dir.join(file);
    signal_log::read(
        &path,
        topic,
        signal_log::Pick {
            joint,
            quantity: pick.quantity,
        },
    )
    .with_context(|| format!("{key}.log: {}", path.display()))
}

/// The columns `time` and `column` of a CSV text (a header line, then rows of numbers), as a
/// [`Signal::Table`]: times strictly increasing, every value finite, at least one row.
pub fn read_table(text: &str, column: &str) -> anyhow::Result<Signal> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        bail!("empty file: expected a header line naming `time` and `{column}`");
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |name: &str| {
        names.iter().position(|n| *n == name).with_context(|| {
            format!(
                "no column `{name}` (the header has: {}){}",
                names.join(", "),
                crate::message::did_you_mean(name, names.iter().copied())
            )
        })
    };
    let (t_col, v_col) = (find("time")?, find(column)?);
    let (mut times_secs, mut values) = (Vec::new(), Vec::new());
    for (index, line) in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let cell = |c: usize, name: &str| -> anyhow::Result<f64> {
            let raw = cells
                .get(c)
                .with_context(|| format!("line {}: no `{name}` value", index + 1))?;
            let x: f64 = raw.parse().with_context(|| {
                format!("line {}: `{name}` is not a number: {raw:?}", index + 1)
            })?;
            if !x.is_finite() {
                bail!("line {}: `{name}` must be finite (got {raw})", index + 1);
            }
            Ok(x)
        };
        let (t, v) = (cell(t_col, "time")?, cell(v_col, column)?);
        if let Some(&before) = times_secs.last()
            && t <= before
        {
            bail!(
                "line {}: `time` must increase from row to row ({t} s after {before} s)",
                index + 1
            );
        }
        times_secs.push(t);
        values.push(v);
    }
    if times_secs.is_empty() {
        bail!("no rows after the header");
    }
    Ok(Signal::Table { times_secs, values })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(text: &str) -> toml::Value {
        toml::from_str::<toml::Table>(&format!("v = {text}")).unwrap()["v"].clone()
    }

    #[test]
    fn numbers_sines_and_tables_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        assert_eq!(
            parse("k", &value("2"), d, "j", None).unwrap(),
            Signal::Constant(2.0)
        );
        assert_eq!(
            parse("k", &value("-0.5"), d, "j", None).unwrap(),
            Signal::Constant(-0.5)
        );
        assert_eq!(
            parse(
                "k",
                &value("{ sine = { amplitude = 0.5, frequency_hz = 2 } }"),
                d,
                "j",
                None
            )
            .unwrap(),
            Signal::Sine {
                amplitude: 0.5,
                frequency_hz: 2.0,
                phase: 0.0,
                offset: 0.0
            }
        );
        std::fs::write(
            d.join("t.csv"),
            "time, elbow, wrist\n0, 1, 9\n0.5, 2, 9\n\n2, 4, 9\n",
        )
        .unwrap();
        assert_eq!(
            parse("k", &value("{ table = \"t.csv\" }"), d, "elbow", None).unwrap(),
            Signal::Table {
                times_secs: vec![0.0, 0.5, 2.0],
                values: vec![1.0, 2.0, 4.0]
            }
        );
    }

    /// Each mistake is one message naming the key and what is wrong.
    #[test]
    fn bad_signals_name_the_key_and_the_fault() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("back.csv"), "time,j\n0,1\n1,2\n1,3\n").unwrap();
        std::fs::write(d.join("nan.csv"), "time,j\n0,1\n1,nan\n").unwrap();
        std::fs::write(d.join("empty.csv"), "time,j\n").unwrap();
        for (text, needle) in [
            ("\"fast\"", "k: expected a number"),
            ("nan", "k: must be finite"),
            (
                "{ sine = { amplitude = 1 } }",
                "k.sine.frequency_hz: missing",
            ),
            (
                "{ sine = { amplitude = 1, frequency_hz = 1, freq = 2 } }",
                "k.sine.freq: unknown key",
            ),
            (
                "{ sine = { amplitude = inf, frequency_hz = 1 } }",
                "k.sine.amplitude: must be finite",
            ),
            ("{ square = 1 }", "k.square: unknown signal"),
            (
                "{ sine = { amplitude = 1, frequency_hz = 1 }, table = \"x\" }",
                "k: expected a number",
            ),
            ("{ table = \"missing.csv\" }", "k.table: cannot read"),
            ("{ table = \"back.csv\" }", "line 4: `time` must increase"),
            ("{ table = \"nan.csv\" }", "line 3: `j` must be finite"),
            ("{ table = \"empty.csv\" }", "no rows after the header"),
            (
                "{ smooth = { amplitude = 1 } }",
                "k.smooth.cutoff_hz: missing",
            ),
            (
                "{ smooth = { amplitude = -1, cutoff_hz = 1 } }",
                "k.smooth.amplitude: must be >= 0",
            ),
            (
                "{ smooth = { amplitude = 1, cutoff_hz = 0 } }",
                "k.smooth.cutoff_hz: must be positive",
            ),
            (
                "{ smooth = { amplitude = 1, cutoff_hz = 1, seed = -3 } }",
                "k.smooth.seed: expected an integer >= 0",
            ),
            (
                "{ smooth = { amplitude = 1, cutoff_hz = 1, std = 2 } }",
                "k.smooth.std: unknown key",
            ),
        ] {
            let e = format!("{:#}", parse("k", &value(text), d, "j", None).unwrap_err());
            assert!(e.contains(needle), "{text}: {e}");
        }
        std::fs::write(d.join("other.csv"), "time,wrist\n0,1\n").unwrap();
        let e = format!(
            "{:#}",
            parse("k", &value("{ table = \"other.csv\" }"), d, "j", None).unwrap_err()
        );
        assert!(
            e.contains("no column `j` (the header has: time, wrist)"),
            "{e}"
        );
        assert!(!e.contains("did you mean"), "{e}");
        // A misspelt joint's column: the closest header name is suggested.
        let e = format!(
            "{:#}",
            parse("k", &value("{ table = \"other.csv\" }"), d, "wirst", None).unwrap_err()
        );
        assert!(
            e.contains("no column `wirst` (the header has: time, wrist): did you mean `wrist`?"),
            "{e}"
        );
    }

    /// A smooth signal keeps its promises: |s − offset| ≤ amplitude at every sample, every
    /// frequency in (0, cutoff] with one per K-th of the band, the same seed the same signal and
    /// another seed another, its time average tends to the offset, and the scene's `seed` key is
    /// the one used.
    #[test]
    fn a_smooth_signal_is_bounded_band_limited_and_seeded() {
        let params = SmoothParams {
            amplitude: 0.5,
            cutoff_hz: 2.0,
            offset: 0.3,
            seed: 0,
        };
        let a = smooth(&params, 11);
        let Signal::Sines { offset, terms } = &a else {
            panic!("{a:?}")
        };
        assert_eq!(*offset, 0.3);
        assert_eq!(terms.len(), SMOOTH_TERMS);
        for (k, [amp, f, phase]) in terms.iter().enumerate() {
            let band = 2.0 / SMOOTH_TERMS as f64;
            assert!(
                *f >= band * k as f64 && *f < band * (k + 1) as f64,
                "{k}: {f}"
            );
            assert!((0.0..std::f64::consts::TAU).contains(phase));
            assert_eq!(*amp, 0.5 / SMOOTH_TERMS as f64);
        }
        // 200 s sampled every 1 ms: the largest excursion is within the bound (measured 0.44 of
        // 0.5), the RMS about the offset is amplitude/√(2K) = 0.1443 to sampling error (measured
        // 0.1440), and the mean is the offset to Σ a_k/(π f_k T) (< 2e-3 here; measured -1.7e-4).
        let n = 200_000;
        let (mut max, mut sum, mut sq) = (0.0f64, 0.0, 0.0);
        for i in 0..n {
            let d = a.at(i as f64 * 1e-3) - 0.3;
            max = max.max(d.abs());
            sum += d;
            sq += d * d;
        }
        assert!(max <= 0.5 && max > 0.25, "{max}");
        let rms = (sq / n as f64).sqrt();
        let expected = 0.5 / (2.0 * SMOOTH_TERMS as f64).sqrt();
        assert!((rms / expected - 1.0).abs() < 0.1, "{rms} vs {expected}");
        assert!((sum / n as f64).abs() < 2e-3, "{}", sum / n as f64);
        assert_eq!(smooth(&params, 11), a);
        assert_ne!(smooth(&params, 12), a);
        // The scene's seed key.
        let parsed = parse(
            "k",
            &value("{ smooth = { amplitude = 0.5, cutoff_hz = 2, offset = 0.3, seed = 11 } }"),
            Path::new("."),
            "j",
            None,
        )
        .unwrap();
        assert_eq!(parsed, a);
    }
}
