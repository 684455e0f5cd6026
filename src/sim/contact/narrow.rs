//! The narrow phase: contact points of a pair of colliders, or of a collider and the ground.
