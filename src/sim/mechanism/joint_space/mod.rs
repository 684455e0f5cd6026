//! Kinematic trees stepped in joint coordinates: the variational step of the maximal
//! formulation ([`super::step`]) restricted to the joints' configuration manifold.
//!
//! The discrete Lagrangian is the same sum of free-body discrete Lagrangians (exp-map
//! rotation, trapezoid potential), each body's pose now a function of the joint coordinates
//! `q` by forward kinematics: `L_d(q_k, q_{k+1}) = Σ_i L_d^i(g_i(q_k), g_i(q_{k+1}))`. Its
//! discrete Euler-Lagrange equations with the drives' discrete Lagrange-d'Alembert forcing,
//!
//! ```text
//! D₂L_d(q_{k−1}, q_k) + f⁺_{k−1} + D₁L_d(q_k, q_{k+1}) + f⁻_k = 0
//! ```
//!
//! are the maximal step's constrained equations with the constraints solved exactly: the same
//! discrete flow (Marsden & West, "Discrete mechanics and variational integrators", Acta
//! Numerica 2001, §3.5: a holonomically constrained discrete system is the discrete system of
//! the restricted Lagrangian), so the same order, the same bounded energy, the same momenta,
//! with the joints holding by construction. The residual is a discrete inverse dynamics, one
//! pass from the leaves, and the Newton update an articulated-body solve, both linear in the
//! bodies (J. Lee, C. K. Liu, F. C. Park, S. S. Srinivasa, "A Linear-Time Variational
//! Integrator for Multibody Systems", WAFR 2016).
//!
//! Files: `model.rs` (the tree read from a [`super::Mechanism`]), `kinematics.rs` (forward
//! kinematics, joint twists), `aba.rs` (the Newton matrix `h ∂r/∂q'` eliminated and solved
//! in linear time), `step.rs` (the step, its guards, the state carried between steps: `θ`
//! per joint).
//!
//! Taken today: mechanisms whose joints are hinges and sliders (continuous, revolute,
//! prismatic), with any drives and damping, fixed or floating base. Mechanisms with joint
//! limits or friction, mimic rows or compound joints stay on the maximal step
//! ([`model::NotATree`]).

mod aba;
mod kinematics;
mod model;
mod step;
mod stops;
#[cfg(test)]
mod tests;

pub use model::{NotATree, TreeJoint, TreeJointKind, TreeModel};
pub use step::{TreeState, TreeWarm, step};
