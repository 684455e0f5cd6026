//! The distributions a `[vary]` key may follow, over a number or a 3-vector (componentwise):
//!
//! ```toml
//! dt = { uniform = [1e-3, 2e-3] }                       # U[lo, hi)
//! dt = { log_uniform = [1e-4, 1e-2] }                   # exp(U[ln lo, ln hi)), 0 < lo <= hi
//! duration = { choice = [0.5, 1.0, 2.0] }               # one of the values, equally likely
//! angvel = { normal = { mean = [0, 0, 0], std = [5, 5, 5] } }   # N(mean, std²) per component
//! position = { uniform = [[-1, -1, 0], [1, 1, 1]] }     # [lo vector, hi vector]
//! ```
//!
//! Components are drawn in the order x, y, z from the key's own stream ([`super::rng`]).

use super::rng::Rng;
use anyhow::{Context, bail};

/// A distribution over vectors of a fixed dimension (1 for numbers, 3 for vectors).
#[derive(Debug, Clone, PartialEq)]
pub enum Dist {
    Uniform { lo: Vec<f64>, hi: Vec<f64> },
    LogUniform { lo: Vec<f64>, hi: Vec<f64> },
    Normal { mean: Vec<f64>, std: Vec<f64> },
    Choice(Vec<Vec<f64>>),
}

/// The table keys naming a distribution.
pub const KINDS: &str = "uniform, log_uniform, normal, choice";

impl Dist {
    /// Parses `value` as a distribution over `dims`-vectors (`dims` = 1: plain numbers).
    /// Errors name `key`.
    pub fn parse(key: &str, value: &toml::Value, dims: usize) -> anyhow::Result<Self> {
        let shape = if dims == 1 {
            "a number"
        } else {
            "an array of 3 numbers"
        };
        let (kind, arg) = single_entry(key, value)?;
        let key = format!("{key}.{kind}");
        let dist = match kind {
            "uniform" | "log_uniform" => {
                let [lo, hi] = pair(&key, arg, dims, shape)?;
                for (l, h) in lo.iter().zip(&hi) {
                    if l > h {
                        bail!("{key}: lower bound {l} is above the upper bound {h}");
                    }
                    if kind == "log_uniform" && *l <= 0.0 {
                        bail!("{key}: bounds must be positive (got {l})");
                    }
                }
                if kind == "uniform" {
                    Dist::Uniform { lo, hi }
                } else {
                    Dist::LogUniform { lo, hi }
                }
            }
            "normal" => {
                let table = arg.as_table().with_context(|| {
                    format!("{key}: expected {{ mean = {shape}, std = {shape} }}")
                })?;
                if let Some(other) = table.keys().find(|k| *k != "mean" && *k != "std") {
                    bail!("{key}: unknown key {other:?} (expected mean, std)");
                }
                let get = |name: &str| -> anyhow::Result<Vec<f64>> {
                    let v = table
                        .get(name)
                        .with_context(|| format!("{key}: missing {name}"))?;
                    numbers(&format!("{key}.{name}"), v, dims, shape)
                };
                let (mean, std) = (get("mean")?, get("std")?);
                if let Some(s) = std.iter().find(|s| **s < 0.0) {
                    bail!("{key}.std must be >= 0 (got {s})");
                }
                Dist::Normal { mean, std }
            }
            "choice" => {
                let items = arg
                    .as_array()
                    .filter(|a| !a.is_empty())
                    .with_context(|| format!("{key}: expected a non-empty array of {shape}s"))?;
                let values = items
                    .iter()
                    .enumerate()
                    .map(|(i, v)| numbers(&format!("{key}[{i}]"), v, dims, shape))
                    .collect::<anyhow::Result<Vec<_>>>()?;
                Dist::Choice(values)
            }
            other => bail!("{key}: unknown distribution {other:?} (expected one of: {KINDS})"),
        };
        Ok(dist)
    }

    /// One draw.
    pub fn sample(&self, rng: &mut Rng) -> Vec<f64> {
        match self {
            Dist::Uniform { lo, hi } => lo
                .iter()
                .zip(hi)
                .map(|(l, h)| l + rng.uniform01() * (h - l))
                .collect(),
            Dist::LogUniform { lo, hi } => lo
                .iter()
                .zip(hi)
                .map(|(l, h)| {
                    let (a, b) = (libm::log(*l), libm::log(*h));
                    libm::exp(a + rng.uniform01() * (b - a)).clamp(*l, *h)
                })
                .collect(),
            Dist::Normal { mean, std } => mean
                .iter()
                .zip(std)
                .map(|(m, s)| m + s * rng.standard_normal())
                .collect(),
            Dist::Choice(values) => values[rng.below(values.len() as u64) as usize].clone(),
        }
    }

    /// The smallest value each draw can take (componentwise; `-inf` for a normal with std > 0).
    pub fn lower_bound(&self) -> Vec<f64> {
        match self {
            Dist::Uniform { lo, .. } | Dist::LogUniform { lo, .. } => lo.clone(),
            Dist::Normal { mean, std } => mean
                .iter()
                .zip(std)
                .map(|(m, s)| if *s > 0.0 { f64::NEG_INFINITY } else { *m })
                .collect(),
            Dist::Choice(values) => (0..values[0].len())
                .map(|d| values.iter().map(|v| v[d]).fold(f64::INFINITY, f64::min))
                .collect(),
        }
    }
}

/// A choice among strings: `{ choice = ["a", "b"] }`.
pub fn parse_string_choice(key: &str, value: &toml::Value) -> anyhow::Result<Vec<String>> {
    let (kind, arg) = single_entry(key, value)?;
    if kind != "choice" {
        bail!("{key}: expected {{ choice = [\"...\", ...] }} (got {kind:?})");
    }
    let items = arg
        .as_array()
        .filter(|a| !a.is_empty())
        .with_context(|| format!("{key}.choice: expected a non-empty array of strings"))?;
    items
        .iter()
        .enumerate()
        .map(|(i, v)| {
            v.as_str()
                .map(str::to_string)
                .with_context(|| format!("{key}.choice[{i}]: expected a string (got {v})"))
        })
        .collect()
}

/// `{ kind = arg }`: a table with exactly one entry.
fn single_entry<'a>(
    key: &str,
    value: &'a toml::Value,
) -> anyhow::Result<(&'a str, &'a toml::Value)> {
    let table = value.as_table().with_context(|| {
        format!(
            "{key}: expected a distribution table such as {{ uniform = [lo, hi] }} (one of: {KINDS}); \
             fixed values belong in [scene]"
        )
    })?;
    let mut entries = table.iter();
    match (entries.next(), entries.next()) {
        (Some((kind, arg)), None) => Ok((kind.as_str(), arg)),
        _ => bail!(
            "{key}: expected exactly one distribution (one of: {KINDS}), got {} keys",
            table.len()
        ),
    }
}

/// `[lo, hi]`, each of `dims` numbers.
fn pair(key: &str, v: &toml::Value, dims: usize, shape: &str) -> anyhow::Result<[Vec<f64>; 2]> {
    let items = v
        .as_array()
        .filter(|a| a.len() == 2)
        .with_context(|| format!("{key}: expected [lower, upper], each {shape}"))?;
    Ok([
        numbers(&format!("{key}[0]"), &items[0], dims, shape)?,
        numbers(&format!("{key}[1]"), &items[1], dims, shape)?,
    ])
}

/// A number (`dims` = 1) or an array of `dims` numbers, all finite.
fn numbers(key: &str, v: &toml::Value, dims: usize, shape: &str) -> anyhow::Result<Vec<f64>> {
    let values = if dims == 1 {
        vec![number(v)]
    } else {
        match v.as_array() {
            Some(a) if a.len() == dims => a.iter().map(number).collect(),
            _ => vec![None],
        }
    };
    values
        .into_iter()
        .map(|x| x.filter(|x| x.is_finite()))
        .collect::<Option<Vec<f64>>>()
        .with_context(|| format!("{key}: expected {shape}, finite (got {v})"))
}

fn number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(x) => Some(*x),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, dims: usize) -> anyhow::Result<Dist> {
        let value: toml::Table = toml::from_str(&format!("k = {text}")).unwrap();
        Dist::parse("vary.k", &value["k"], dims)
    }

    #[test]
    fn parses_every_kind() {
        assert_eq!(
            parse("{ uniform = [1, 2] }", 1).unwrap(),
            Dist::Uniform {
                lo: vec![1.0],
                hi: vec![2.0]
            }
        );
        assert!(matches!(
            parse("{ normal = { mean = [0, 0, 0], std = [1, 2, 3] } }", 3).unwrap(),
            Dist::Normal { .. }
        ));
        assert!(matches!(
            parse("{ choice = [[1, 2, 3], [4, 5, 6]] }", 3).unwrap(),
            Dist::Choice(v) if v.len() == 2
        ));
    }

    #[test]
    fn bad_tables_name_the_key() {
        for (text, dims, needle) in [
            ("0.1", 1, "vary.k: expected a distribution table"),
            ("{ uniform = [2, 1] }", 1, "vary.k.uniform: lower bound 2"),
            ("{ log_uniform = [0, 1] }", 1, "must be positive"),
            (
                "{ normal = { mean = 0, std = -1 } }",
                1,
                "vary.k.normal.std must be >= 0",
            ),
            ("{ normal = { mean = 0, sd = 1 } }", 1, "unknown key \"sd\""),
            ("{ gauss = [0, 1] }", 1, "unknown distribution \"gauss\""),
            (
                "{ uniform = [[0, 0], [1, 1]] }",
                3,
                "vary.k.uniform[0]: expected an array of 3",
            ),
            ("{ choice = [] }", 1, "non-empty"),
            (
                "{ uniform = [0, 1], choice = [1] }",
                1,
                "exactly one distribution",
            ),
        ] {
            let err = format!("{:#}", parse(text, dims).unwrap_err());
            assert!(err.contains(needle), "{text}: {err}");
        }
    }

    #[test]
    fn log_uniform_stays_within_its_bounds() {
        let d = parse("{ log_uniform = [1e-4, 1e-2] }", 1).unwrap();
        let mut rng = Rng::new(3);
        for _ in 0..1000 {
            let x = d.sample(&mut rng)[0];
            assert!((1e-4..=1e-2).contains(&x), "{x}");
        }
    }
}
