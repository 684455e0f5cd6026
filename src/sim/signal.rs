//! Time signals that drive inputs (issue 30: actuator efforts and targets, applied loads): a
//! constant, a sine, a sum of sines (the seeded random smooth inputs of issue 32, drawn by
//! `crate::scene::signal::smooth`), a table linear between its rows, or a value held from
//! outside between steps ([`Held`]: a controller in the loop, issue 33). Evaluated inside the
//! step, so plain numbers only; the scene parses them (`crate::scene::signal`).
//!
//! ```text
//! constant:  s(t) = c
//! sine:      s(t) = offset + amplitude · sin(2π f t + phase)
//! sines:     s(t) = offset + Σ_k a_k sin(2π f_k t + φ_k)
//! table:     s(t) = v_k + (v_{k+1} − v_k) (t − t_k) / (t_{k+1} − t_k)   for t_k ≤ t ≤ t_{k+1}
//!            s(t) = v_0 for t < t_0, v_{n−1} for t > t_{n−1}  (held beyond the ends)
//! held:      s(t) = the scene's signal until a value is set, then the last value set
//! ```

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// A signal of time (s).
#[derive(Debug, Clone, PartialEq)]
pub enum Signal {
    Constant(f64),
    Sine {
        amplitude: f64,
        frequency_hz: f64,
        /// rad
        phase: f64,
        offset: f64,
    },
    /// `offset + Σ_k a_k sin(2π f_k t + φ_k)`, terms `[a_k, f_k (Hz), φ_k (rad)]`.
    Sines {
        offset: f64,
        terms: Vec<[f64; 3]>,
    },
    /// Rows `(t_k, v_k)`, `t_k` strictly increasing (checked where the table is read), at
    /// least one row.
    Table {
        times_secs: Vec<f64>,
        values: Vec<f64>,
    },
    /// Set from outside between steps ([`Held`]).
    Held(Held),
}

/// An input a controller sets between steps (zero-order hold): the scene's signal until the
/// first [`Held::set`], then the last value set, whatever the time. Clones share the value
/// (the copies of a mechanism the partitions hold read the one the controller sets). A step
/// reads it at both ends of its interval, so a value set before a step is the step's constant
/// input: the trapezoid average of [`crate::sim::mechanism::JointDrive::step_effort`] is that
/// value exactly, the same bits as a [`Signal::Constant`] of it.
#[derive(Debug, Clone)]
pub struct Held(Arc<HeldCell>);

#[derive(Debug)]
struct HeldCell {
    /// The value's bits (`f64::to_bits`).
    bits: AtomicU64,
    /// Whether a value was set (else the scene's signal applies).
    set: AtomicBool,
    scene: Signal,
}

impl Held {
    /// A held input following `scene` until set.
    pub fn new(scene: Signal) -> Self {
        Self(Arc::new(HeldCell {
            bits: AtomicU64::new(0),
            set: AtomicBool::new(false),
            scene,
        }))
    }

    /// Holds `value` from the next step on. Steps read it after the stepping threads met the
    /// caller (a window starts after this call returns), so relaxed ordering suffices.
    pub fn set(&self, value: f64) {
        self.0.bits.store(value.to_bits(), Ordering::Relaxed);
        self.0.set.store(true, Ordering::Relaxed);
    }

    /// The value held, if one was set.
    pub fn value(&self) -> Option<f64> {
        self.0
            .set
            .load(Ordering::Relaxed)
            .then(|| f64::from_bits(self.0.bits.load(Ordering::Relaxed)))
    }

    /// The signal it follows until set.
    pub fn scene(&self) -> &Signal {
        &self.0.scene
    }
}

/// Two held inputs are equal when they are the same input (clones of one another).
impl PartialEq for Held {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Signal {
    /// The value at time `t_secs`.
    pub fn at(&self, t_secs: f64) -> f64 {
        match self {
            Signal::Constant(c) => *c,
            Signal::Sine {
                amplitude,
                frequency_hz,
                phase,
                offset,
            } => offset + amplitude * (std::f64::consts::TAU * frequency_hz * t_secs + phase).sin(),
            Signal::Sines { offset, terms } => {
                offset
                    + terms
                        .iter()
                        .map(|[a, f, p]| a * (std::f64::consts::TAU * f * t_secs + p).sin())
                        .sum::<f64>()
            }
            Signal::Table { times_secs, values } => {
                let last = times_secs.len() - 1;
                if t_secs <= times_secs[0] {
                    return values[0];
                }
                if t_secs >= times_secs[last] {
                    return values[last];
                }
                // The row k with t_k <= t < t_{k+1}.
                let k = times_secs.partition_point(|&tk| tk <= t_secs) - 1;
                let (t0, t1) = (times_secs[k], times_secs[k + 1]);
                let (v0, v1) = (values[k], values[k + 1]);
                v0 + (v1 - v0) * ((t_secs - t0) / (t1 - t0))
            }
            Signal::Held(h) => h.value().unwrap_or_else(|| h.scene().at(t_secs)),
        }
    }

    /// The time derivative at `t_secs` (a table's slope on its segment, 0 beyond its ends):
    /// a velocity target that follows a position target, or a servo's feed-forward.
    pub fn rate(&self, t_secs: f64) -> f64 {
        match self {
            Signal::Constant(_) => 0.0,
            Signal::Sine {
                amplitude,
                frequency_hz,
                phase,
                ..
            } => {
                let w = std::f64::consts::TAU * frequency_hz;
                amplitude * w * (w * t_secs + phase).cos()
            }
            Signal::Sines { terms, .. } => terms
                .iter()
                .map(|[a, f, p]| {
                    let w = std::f64::consts::TAU * f;
                    a * w * (w * t_secs + p).cos()
                })
                .sum(),
            Signal::Table { times_secs, values } => {
                let last = times_secs.len() - 1;
                if t_secs < times_secs[0] || t_secs >= times_secs[last] {
                    return 0.0;
                }
                let k = times_secs.partition_point(|&tk| tk <= t_secs) - 1;
                (values[k + 1] - values[k]) / (times_secs[k + 1] - times_secs[k])
            }
            Signal::Held(h) => match h.value() {
                Some(_) => 0.0,
                None => h.scene().rate(t_secs),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A held input follows its scene signal (value and rate) until set, then holds the value
    /// at every time with no rate; a clone sees the value set through the original.
    #[test]
    fn a_held_input_follows_the_scene_until_set_then_holds_the_last_value() {
        let scene = Signal::Sine {
            amplitude: 2.0,
            frequency_hz: 0.25,
            phase: 0.0,
            offset: 1.0,
        };
        let held = Held::new(scene.clone());
        let s = Signal::Held(held.clone());
        let copy = s.clone();
        assert_eq!((s.at(1.0), s.rate(0.0)), (scene.at(1.0), scene.rate(0.0)));
        assert_eq!(s.at(1.0), 3.0);
        assert_eq!(held.value(), None);
        held.set(-0.75);
        held.set(0.5);
        for t in [0.0, 1.0, 7.3] {
            assert_eq!((copy.at(t), copy.rate(t)), (0.5, 0.0));
        }
        assert_eq!(s, copy);
        assert_ne!(s, Signal::Held(Held::new(scene)));
    }

    #[test]
    fn a_constant_is_the_same_at_every_time_and_has_no_rate() {
        let s = Signal::Constant(0.5);
        for t in [-1.0, 0.0, 3.7, 1e9] {
            assert_eq!((s.at(t), s.rate(t)), (0.5, 0.0));
        }
    }

    /// offset + A sin(2π f t + φ) at the points where the sine is 0, 1 and −1, and its
    /// derivative A 2π f cos(2π f t + φ).
    #[test]
    fn a_sine_follows_its_closed_form() {
        let s = Signal::Sine {
            amplitude: 0.5,
            frequency_hz: 0.25,
            phase: 0.0,
            offset: 0.2,
        };
        // Period 4 s: quarter periods at 1, 2, 3 s. Round-off of sin near kπ: < 1e-15.
        assert!((s.at(0.0) - 0.2).abs() < 1e-15);
        assert!((s.at(1.0) - 0.7).abs() < 1e-15);
        assert!((s.at(2.0) - 0.2).abs() < 1e-15);
        assert!((s.at(3.0) + 0.3).abs() < 1e-15);
        let w = std::f64::consts::TAU * 0.25;
        assert!((s.rate(0.0) - 0.5 * w).abs() < 1e-15);
        assert!(s.rate(1.0).abs() < 1e-15);
        // A quarter-period phase is a cosine.
        let c = Signal::Sine {
            amplitude: 1.0,
            frequency_hz: 0.25,
            phase: std::f64::consts::FRAC_PI_2,
            offset: 0.0,
        };
        assert!((c.at(0.0) - 1.0).abs() < 1e-15 && c.at(1.0).abs() < 1e-15);
    }

    /// A sum of sines is the sum of its terms' closed forms, its rate the sum of their
    /// derivatives.
    #[test]
    fn a_sum_of_sines_is_the_sum_of_its_terms() {
        let s = Signal::Sines {
            offset: 0.1,
            terms: vec![[0.5, 0.25, 0.0], [0.2, 0.5, std::f64::consts::FRAC_PI_2]],
        };
        // t = 1 s: 0.5 sin(π/2) + 0.2 sin(π + π/2) = 0.5 − 0.2; rate 0.5·(π/2)·cos(π/2)
        // + 0.2·π·cos(3π/2) = 0 to round-off. t = 0: 0.2; rate 0.5·π/2.
        assert!((s.at(1.0) - 0.4).abs() < 1e-15);
        assert!(s.rate(1.0).abs() < 1e-15);
        assert!((s.at(0.0) - 0.3).abs() < 1e-15);
        assert!((s.rate(0.0) - 0.25 * std::f64::consts::PI).abs() < 1e-15);
    }

    /// Linear between rows (exact at the rows and at a midpoint), held beyond the ends, the
    /// segment's slope as the rate.
    #[test]
    fn a_table_is_linear_between_rows_and_held_beyond_its_ends() {
        let s = Signal::Table {
            times_secs: vec![0.0, 1.0, 3.0],
            values: vec![1.0, 3.0, -1.0],
        };
        assert_eq!(s.at(-5.0), 1.0);
        assert_eq!(s.at(0.0), 1.0);
        assert_eq!(s.at(0.5), 2.0);
        assert_eq!(s.at(1.0), 3.0);
        assert_eq!(s.at(2.0), 1.0);
        assert_eq!(s.at(2.5), 0.0);
        assert_eq!(s.at(3.0), -1.0);
        assert_eq!(s.at(10.0), -1.0);
        assert_eq!(s.rate(-1.0), 0.0);
        assert_eq!(s.rate(0.25), 2.0);
        assert_eq!(s.rate(1.0), -2.0);
        assert_eq!(s.rate(2.999), -2.0);
        assert_eq!(s.rate(3.0), 0.0);
        let one = Signal::Table {
            times_secs: vec![2.0],
            values: vec![7.0],
        };
        assert_eq!(
            (one.at(0.0), one.at(2.0), one.at(9.0), one.rate(2.0)),
            (7.0, 7.0, 7.0, 0.0)
        );
    }
}
