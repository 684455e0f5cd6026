//! Joint limits and joint friction ([`JointStop`]): one-sided and bounded impulses on a joint
//! coordinate, solved with complementarity inside the mechanism's step
//! ([`super::step`], `step/stops.rs`).
//!
//! A coordinate `θ` (a hinge's angle or a slider's travel) with a URDF `<limit lower upper>`
//! and/or a `<dynamics friction F>` gets one row in its joint's block. Its unknown is one impulse
//! `ν` applied at the START of the step only, along `∇θ(q_k)` (as the joints' own impulses
//! `G(q_k)ᵀ λ`, and unlike a drive's, which has an end half too). The row's equation depends on
//! its mode, chosen by an active set inside the step's Newton iteration:
//!
//! ```text
//! free        ν = 0                                       (F = 0, no limit reached)
//! stick       θ_{k+1} − θ_k = 0,          |ν/h| ≤ F        (static friction)
//! slide(s)    ν = −s F h,                 s (θ_{k+1} − θ_k)/h > 0   (Coulomb, s = ±1)
//! upper       θ_{k+1} = upper,            ν/h ≤ F          (the limit holds the joint)
//! lower       θ_{k+1} = lower,            ν/h ≥ −F
//! ```
//!
//! A limit is a position-level, SHAKE-like one-sided constraint: the impulse that keeps
//! `θ_{k+1}` at the bound acts at the start of the step only, so the step that reaches the
//! bound ends there with the joint's rate along it removed. Nothing pushes back (a start and an
//! end half would restore the rate and bounce): the impact is inelastic, the energy lost its
//! kinetic energy along the joint at impact (to O(h): the step before the bound still moves at
//! the pre-impact rate for part of `h`). A joint already beyond its bound (placed there) may not
//! go further but is not thrown back in one step. The active set: a limit is activated when the
//! converged iterate crosses its bound and released when its impulse would pull the joint onto
//! the bound (`ν > F h` at the upper bound: `F h` is what friction can still hold); friction
//! slides when the impulse holding it exceeds `F h` and sticks again when the sliding direction
//! reverses. Each switch re-solves the step from the current iterate; the number of switches
//! per step is bounded.
//!
//! `∇θ` is a coordinate gradient: it pairs to zero with any rigid motion of the whole mechanism,
//! so a free-floating mechanism's total linear and angular momentum stay exact under its limits
//! and friction, as under its motors. A coordinate with no limit reached and no friction has the
//! row `ν = 0` and leaves the step unchanged to the bit.
//!
//! The energy a stop removes is accounted as the work of its impulse, `ν` times the mean of the
//! joint's rates before and after it, both read from the positions (`Δθ/h` of the previous step
//! and of this one): a joint resting on its limit or sticking loses nothing, a sliding one
//! `F |Δθ|` and an impact its kinetic energy, each to O(h) (`step/stops.rs`).

/// A limit and/or friction on one joint coordinate.
#[derive(Debug, Clone, PartialEq)]
pub struct JointStop {
    /// The mechanism coordinate it acts on (index into `MechanismModel::coordinates`).
    pub coordinate: usize,
    /// `[lower, upper]` (rad or m), `lower < upper`, when the limit is on.
    pub limits: Option<[f64; 2]>,
    /// Coulomb friction `F ≥ 0` (N m, or N for a prismatic joint): `|τ_F| ≤ F`.
    pub friction: f64,
}

/// The mode of a stop's row (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StopMode {
    #[default]
    Free,
    Stick,
    /// Sliding in the direction `+1` or `−1`, friction opposing.
    Slide(i8),
    Upper,
    Lower,
}

impl StopMode {
    /// Whether the row is a position constraint (`θ_{k+1}` fixed) rather than an impulse.
    pub fn holds_position(self) -> bool {
        matches!(self, StopMode::Stick | StopMode::Upper | StopMode::Lower)
    }

    /// Whether a limit holds the joint.
    pub fn at_limit(self) -> bool {
        matches!(self, StopMode::Upper | StopMode::Lower)
    }
}

impl JointStop {
    /// The mode a coordinate starts a run in: sticking if it has friction, else free.
    pub fn initial_mode(&self) -> StopMode {
        if self.friction > 0.0 {
            StopMode::Stick
        } else {
            StopMode::Free
        }
    }

    /// The bounds of the step from `theta_k`: `[lower, upper]`, but a joint beyond a bound by
    /// more than `slack` (the solver's tolerance on the row) may not go further and is not
    /// pushed back (`θ_k` is its bound); infinite without a limit. Within the slack the bound
    /// stays where it is, so that a joint held at it does not creep by a tolerance per step.
    pub fn bounds(&self, theta_k: f64, slack: f64) -> [f64; 2] {
        match self.limits {
            Some([lo, hi]) => [
                if theta_k < lo - slack { theta_k } else { lo },
                if theta_k > hi + slack { theta_k } else { hi },
            ],
            None => [f64::NEG_INFINITY, f64::INFINITY],
        }
    }

    /// The next mode, from a step solved in `mode` that ended at `theta_next` from `theta_k`
    /// with the impulse `nu`, for a step `h`; `theta_tol` and `nu_tol` the hysteresis (the
    /// solver's tolerances) that keep a mode from flipping on round-off. `None`: the mode holds.
    pub fn next_mode(
        &self,
        mode: StopMode,
        theta_k: f64,
        theta_next: f64,
        nu: f64,
        h: f64,
        theta_tol: f64,
        nu_tol: f64,
    ) -> Option<StopMode> {
        let [lo, hi] = self.bounds(theta_k, theta_tol);
        let hold = self.friction * h.abs();
        // `ν sgn(h) = τ |h|` with `τ = ν / h` the torque the row applied: the rules compare
        // torques, so they hold for the negative steps of the compositions too.
        let nu = nu * h.signum();
        let moving = |s: i8| {
            if self.friction > 0.0 {
                StopMode::Slide(s)
            } else {
                StopMode::Free
            }
        };
        let crossed = || {
            if theta_next > hi + theta_tol {
                Some(StopMode::Upper)
            } else if theta_next < lo - theta_tol {
                Some(StopMode::Lower)
            } else {
                None
            }
        };
        match mode {
            StopMode::Free => crossed(),
            StopMode::Stick => {
                if nu > hold + nu_tol {
                    Some(StopMode::Slide(-1))
                } else if nu < -hold - nu_tol {
                    Some(StopMode::Slide(1))
                } else {
                    None
                }
            }
            StopMode::Slide(s) => crossed().or_else(|| {
                (f64::from(s) * (theta_next - theta_k) * h.signum() <= 0.0)
                    .then_some(StopMode::Stick)
            }),
            StopMode::Upper => (nu > hold + nu_tol).then(|| moving(-1)),
            StopMode::Lower => (nu < -hold - nu_tol).then(|| moving(1)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stop(limits: Option<[f64; 2]>, friction: f64) -> JointStop {
        JointStop {
            coordinate: 0,
            limits,
            friction,
        }
    }

    /// The hysteresis: a bound or a friction limit exactly at its tolerance does not switch a
    /// mode (and within it neither), just past it does; the sliding direction is read from
    /// `θ_{k+1} − θ_k` wherever the joint is.
    #[test]
    fn modes_switch_only_past_the_tolerances() {
        let (h, tt, nt) = (0.01, 1e-9, 1e-12);
        let s = stop(Some([-1.0, 1.0]), 0.0);
        // A joint within the slack of a bound keeps the bound; exactly at the slack too.
        assert_eq!(s.bounds(-1.0 - tt, tt), [-1.0, 1.0]);
        assert_eq!(s.bounds(-1.0 - 0.5 * tt, tt), [-1.0, 1.0]);
        assert_eq!(s.bounds(1.0 + tt, tt), [-1.0, 1.0]);
        assert_eq!(s.bounds(1.0 + 0.5 * tt, tt), [-1.0, 1.0]);
        let next = |m, tk, tn, nu| s.next_mode(m, tk, tn, nu, h, tt, nt);
        assert_eq!(next(StopMode::Free, 0.9, 1.0 + tt, 0.0), None);
        assert_eq!(next(StopMode::Free, -0.9, -1.0 - tt, 0.0), None);
        assert_eq!(next(StopMode::Free, -0.9, -1.0 - 0.5 * tt, 0.0), None);
        assert_eq!(
            next(StopMode::Free, -0.9, -1.0 - 2.0 * tt, 0.0),
            Some(StopMode::Lower)
        );
        let f = stop(Some([-1.0, 1.0]), 2.0);
        let hold = 2.0 * h;
        let next = |m, tk, tn, nu| f.next_mode(m, tk, tn, nu, h, tt, nt);
        for nu in [hold + nt, hold + 0.5 * nt, -hold - nt, -hold - 0.5 * nt] {
            assert_eq!(next(StopMode::Stick, 0.0, 0.0, nu), None, "{nu}");
            assert_eq!(next(StopMode::Upper, 1.0, 1.0, nu.abs()), None, "{nu}");
            assert_eq!(next(StopMode::Lower, -1.0, -1.0, -nu.abs()), None, "{nu}");
        }
        // Friction holds a pull off the lower bound below F; the push into it always.
        assert_eq!(next(StopMode::Lower, -1.0, -1.0, -0.5 * hold), None);
        assert_eq!(next(StopMode::Lower, -1.0, -1.0, 0.5 * hold), None);
        assert_eq!(next(StopMode::Upper, 1.0, 1.0, 0.5 * hold), None);
        // Sliding back towards where it came from, away from 0: sticks.
        assert_eq!(
            next(StopMode::Slide(1), 0.5, 0.45, -hold),
            Some(StopMode::Stick)
        );
        assert_eq!(next(StopMode::Slide(1), 0.5, 0.55, -hold), None);
        assert_eq!(next(StopMode::Slide(-1), 0.5, 0.45, hold), None);
        // Stopped exactly: sticks.
        assert_eq!(
            next(StopMode::Slide(1), 0.5, 0.5, -hold),
            Some(StopMode::Stick)
        );
    }

    /// The active set's rules of the module doc, one transition at a time.
    #[test]
    fn modes_follow_the_complementarity_rules() {
        let h = 0.01;
        let s = stop(Some([-1.0, 1.0]), 0.0);
        assert_eq!(s.initial_mode(), StopMode::Free);
        let next = |m, tk, tn, nu| s.next_mode(m, tk, tn, nu, h, 1e-9, 1e-12);
        assert_eq!(next(StopMode::Free, 0.9, 1.1, 0.0), Some(StopMode::Upper));
        assert_eq!(next(StopMode::Free, -0.9, -1.1, 0.0), Some(StopMode::Lower));
        assert_eq!(next(StopMode::Free, 0.9, 0.95, 0.0), None);
        // Within the hysteresis: not crossed.
        assert_eq!(next(StopMode::Free, 0.9, 1.0 + 1e-10, 0.0), None);
        // The limit pushes (ν ≤ 0 at the upper bound): holds; pulls: released.
        assert_eq!(next(StopMode::Upper, 1.0, 1.0, -0.5), None);
        assert_eq!(next(StopMode::Upper, 1.0, 1.0, 0.5), Some(StopMode::Free));
        assert_eq!(next(StopMode::Lower, -1.0, -1.0, 0.5), None);
        assert_eq!(
            next(StopMode::Lower, -1.0, -1.0, -0.5),
            Some(StopMode::Free)
        );
        // Beyond the bound already: the bound is where the joint is.
        assert_eq!(s.bounds(1.5, 1e-9), [-1.0, 1.5]);
        assert_eq!(s.bounds(-1.5, 1e-9), [-1.5, 1.0]);
        assert_eq!(s.bounds(1.0 + 1e-10, 1e-9), [-1.0, 1.0]);
        assert_eq!(
            stop(None, 1.0).bounds(0.0, 0.0),
            [f64::NEG_INFINITY, f64::INFINITY]
        );

        let f = stop(Some([-1.0, 1.0]), 2.0);
        let hold = 2.0 * h;
        assert_eq!(f.initial_mode(), StopMode::Stick);
        let next = |m, tk, tn, nu| f.next_mode(m, tk, tn, nu, h, 1e-9, 1e-12);
        assert_eq!(next(StopMode::Stick, 0.0, 0.0, 0.9 * hold), None);
        assert_eq!(
            next(StopMode::Stick, 0.0, 0.0, 1.1 * hold),
            Some(StopMode::Slide(-1))
        );
        assert_eq!(
            next(StopMode::Stick, 0.0, 0.0, -1.1 * hold),
            Some(StopMode::Slide(1))
        );
        assert_eq!(next(StopMode::Slide(1), 0.0, 0.1, -hold), None);
        assert_eq!(
            next(StopMode::Slide(1), 0.0, -0.1, -hold),
            Some(StopMode::Stick)
        );
        assert_eq!(
            next(StopMode::Slide(1), 0.9, 1.1, -hold),
            Some(StopMode::Upper)
        );
        // At the limit, friction still holds a pull below F.
        assert_eq!(next(StopMode::Upper, 1.0, 1.0, 0.9 * hold), None);
        assert_eq!(
            next(StopMode::Upper, 1.0, 1.0, 1.1 * hold),
            Some(StopMode::Slide(-1))
        );
        assert_eq!(
            next(StopMode::Lower, -1.0, -1.0, -1.1 * hold),
            Some(StopMode::Slide(1))
        );
        // A negative step (the compositions' middle stage): the rules compare the torque
        // ν / h, so the same load slides the same way.
        let back = |m, tk, tn, nu| f.next_mode(m, tk, tn, nu, -h, 1e-9, 1e-12);
        assert_eq!(
            back(StopMode::Stick, 0.0, 0.0, -1.1 * hold),
            Some(StopMode::Slide(-1))
        );
        assert_eq!(
            back(StopMode::Stick, 0.0, 0.0, 1.1 * hold),
            Some(StopMode::Slide(1))
        );
        assert_eq!(back(StopMode::Slide(1), 0.0, -0.1, hold), None);
        assert_eq!(
            back(StopMode::Slide(1), 0.0, 0.1, hold),
            Some(StopMode::Stick)
        );
        assert_eq!(back(StopMode::Upper, 1.0, 1.0, 0.5), None);
        assert_eq!(
            back(StopMode::Upper, 1.0, 1.0, -0.5),
            Some(StopMode::Slide(-1))
        );
        assert!(StopMode::Stick.holds_position() && !StopMode::Slide(1).holds_position());
        assert!(StopMode::Upper.at_limit() && !StopMode::Stick.at_limit());
    }
}
