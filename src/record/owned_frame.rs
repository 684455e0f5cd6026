//! A recorded step that owns its buffers, shared between the sinks' threads without a copy.
//!
//! The run's frame builder ([`crate::simulation::FrameBuilder`]) builds each frame straight into one
//! of a few such buffers and hands the same [`Arc`] to every sink ([`super::Sink::write_shared`]):
//! a pipelined sink ([`super::pipelined`]) queues the `Arc` itself, so a frame is written once
//! and never copied, and the builder keeps no buffers of its own beside those in flight
//! (100 000 bodies: 14.4 MB and a 14.4 MB copy per recorded step less). A buffer is reused once
//! no sink holds it ([`FramePool`]).

use super::{BodyState, ContactState, Frame, JointState, MechanismState};
use nalgebra::Isometry3;
use std::sync::Arc;

/// A frame that owns its buffers ([`Frame`] borrows them).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OwnedFrame {
    pub step: u64,
    pub time_ns: i64,
    pub world_from_link: Vec<Isometry3<f64>>,
    pub bodies: Vec<BodyState>,
    pub joints: Vec<JointState>,
    pub mechanisms: Vec<MechanismState>,
    pub contacts: Vec<ContactState>,
}

impl OwnedFrame {
    /// The frame, borrowed.
    pub fn as_frame(&self) -> Frame<'_> {
        Frame {
            step: self.step,
            time_ns: self.time_ns,
            world_from_link: &self.world_from_link,
            bodies: &self.bodies,
            joints: &self.joints,
            mechanisms: &self.mechanisms,
            contacts: &self.contacts,
        }
    }

    /// Becomes a copy of `frame` (its buffers reused).
    pub fn fill(&mut self, frame: &Frame<'_>) {
        self.step = frame.step;
        self.time_ns = frame.time_ns;
        self.world_from_link.clear();
        self.world_from_link
            .extend_from_slice(frame.world_from_link);
        self.bodies.clear();
        self.bodies.extend_from_slice(frame.bodies);
        self.joints.clear();
        self.joints.extend_from_slice(frame.joints);
        self.mechanisms.clear();
        self.mechanisms.extend_from_slice(frame.mechanisms);
        self.contacts.clear();
        self.contacts.extend_from_slice(frame.contacts);
    }
}

/// The frame buffers of one producer: the current one (the last frame made), and the others,
/// reused once no sink holds them. As many exist as the sinks hold at once plus one, a bound the
/// sinks' queues set ([`super::pipelined::queue_frames`]).
#[derive(Debug, Default)]
pub struct FramePool {
    buffers: Vec<Arc<OwnedFrame>>,
    current: usize,
}

impl FramePool {
    /// A buffer no sink holds, now the current one, to be filled: its previous contents are
    /// those of an older frame (the first time, of the current one copied, so buffers keep
    /// their sizes), and every value of the new frame is to be written.
    pub fn next_free(&mut self) -> &mut OwnedFrame {
        let free = self
            .buffers
            .iter_mut()
            .position(|b| Arc::get_mut(b).is_some());
        self.current = match free {
            Some(k) => k,
            None => {
                let fresh = self
                    .buffers
                    .get(self.current)
                    .map_or_else(OwnedFrame::default, |b| OwnedFrame::clone(b));
                self.buffers.push(Arc::new(fresh));
                self.buffers.len() - 1
            }
        };
        Arc::get_mut(&mut self.buffers[self.current]).expect("a free buffer is held by no sink")
    }

    /// The current frame, shared (empty before the first [`Self::next_free`]).
    pub fn shared(&mut self) -> &Arc<OwnedFrame> {
        if self.buffers.is_empty() {
            self.buffers.push(Arc::default());
        }
        &self.buffers[self.current]
    }

    /// The current frame (empty before the first [`Self::next_free`]).
    pub fn current(&self) -> Option<&OwnedFrame> {
        self.buffers.get(self.current).map(|b| &**b)
    }

    /// Buffers made so far.
    pub fn buffers(&self) -> usize {
        self.buffers.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filled(pool: &mut FramePool, step: u64) {
        let f = pool.next_free();
        f.step = step;
        f.world_from_link.resize(2, Isometry3::identity());
        f.world_from_link[0].translation.x = step as f64;
    }

    /// A buffer a sink holds is never rewritten; one nobody holds is reused, so the pool stays
    /// at what is held plus one.
    #[test]
    fn held_buffers_are_kept_and_free_ones_reused() {
        let mut pool = FramePool::default();
        filled(&mut pool, 0);
        let held = Arc::clone(pool.shared());
        filled(&mut pool, 1);
        assert_eq!(pool.buffers(), 2);
        assert_eq!((held.step, held.world_from_link[0].translation.x), (0, 0.0));
        assert_eq!(pool.current().unwrap().step, 1);
        // Nothing held but `held`: the step-1 buffer is reused, no third one made.
        for step in 2..10 {
            filled(&mut pool, step);
            assert_eq!(pool.current().unwrap().step, step);
        }
        assert_eq!(pool.buffers(), 2);
        assert_eq!(held.step, 0);
        drop(held);
        let a = Arc::clone(pool.shared());
        filled(&mut pool, 10);
        let b = Arc::clone(pool.shared());
        filled(&mut pool, 11);
        assert_eq!((a.step, b.step, pool.current().unwrap().step), (9, 10, 11));
        assert_eq!(pool.buffers(), 3);
        // A new buffer starts as a copy of the current frame (its sizes kept).
        assert_eq!(a.world_from_link.len(), 2);
    }

    #[test]
    fn an_owned_frame_round_trips_a_frame() {
        let poses = [Isometry3::translation(1.0, 2.0, 3.0)];
        let joints = [JointState {
            position: 0.5,
            velocity: -1.0,
            effort: 2.5,
            target: Some(0.25),
            saturated: true,
            at_limit: true,
        }];
        let contacts = [ContactState {
            body_a: 1,
            body_b: None,
            point_world: nalgebra::Vector3::new(0.0, 0.5, 0.0),
            normal_world: nalgebra::Vector3::z(),
            force_world: nalgebra::Vector3::new(0.1, 0.0, 9.81),
            impulse_world: nalgebra::Vector3::new(1e-4, 0.0, 9.81e-3),
            gap_m: -1e-6,
        }];
        let frame = Frame {
            step: 7,
            time_ns: 7000,
            world_from_link: &poses,
            bodies: &[],
            joints: &joints,
            mechanisms: &[],
            contacts: &contacts,
        };
        let mut owned = OwnedFrame::default();
        owned.fill(&frame);
        let back = owned.as_frame();
        assert_eq!((back.step, back.time_ns), (7, 7000));
        assert_eq!(back.world_from_link, &poses);
        assert_eq!(back.joints, &joints);
        assert_eq!(back.contacts, &contacts);
        // Refilled from a frame without contacts, none are left over.
        owned.fill(&Frame {
            contacts: &[],
            ..frame
        });
        assert!(owned.contacts.is_empty());
    }
}
