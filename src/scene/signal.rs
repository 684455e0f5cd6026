//! A signal as a scene writes it (issue 30), parsed into a [`Signal`]:
//!
//! ```toml
//! effort = 0.5                                                   # a number
//! target = { sine = { amplitude = 0.5, frequency_hz = 0.5, phase = 0.0, offset = 0.2 } }
//! target = { table = "trajectory.csv" }                          # columns `time` (s) and the joint's name
//! target = { log = "run.mcap", topic = "/joint_states" }         # a recorded log (actuators only)
//! target = { log = "run.mcap", topic = "/joints", joint = "arm/elbow" }   # the joint's name in the log
//! ```
//!
//! `phase` and `offset` default to 0. A table's or a log's path is relative to the scene file;
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
            "{key}: expected a number, {{ sine = {{ ... }} }}, {{ table = \"file.csv\" }} or \
             {{ log = \"file.mcap\", topic = \"...\" }}"
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
        "table" => {
            let toml::Value::String(file) = body else {
                bail!("{key}.table: expected a file name (got {body})");
            };
            let path = base_dir.join(file);
            let text = crate::input::read_text(&path, TABLE_MAX_BYTES)
                .with_context(|| format!("{key}.table: cannot read {}", path.display()))?;
            read_table(&text, column).with_context(|| format!("{key}.table: {}", path.display()))
        }
        other => bail!("{key}.{other}: unknown signal (expected a number, sine, table or log)"),
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
}
