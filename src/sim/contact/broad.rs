//! The broad phase: which colliders may touch this step.
