//! A [`Sink`] on its own thread: recording beside the stepping.
//!
//! [`Pipelined::new`] moves a sink to a thread of its own; [`Sink::write`] copies the frame into
//! an owned buffer and hands it over through a bounded channel of [`QUEUE_FRAMES`] frames, so the
//! stepping goes on while the sink encodes and compresses, and a sink slower than the stepping
//! holds the stepping back instead of queueing frames without bound (memory stays at most
//! `QUEUE_FRAMES + 2` frames per sink). The sink sees the same frames in the same order as it
//! would on the stepping thread, so its bytes are the same. An error of the sink is reported by
//! the next `write` (or by `finish` / `complete`), after which the sink is gone; dropping an
//! unfinished `Pipelined` drops the sink on its thread (removing its `.part` file) and joins it.

use super::{BodyState, Frame, JointState, MechanismState, Sink};
use anyhow::{Context, anyhow};
use nalgebra::Isometry3;
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

/// Frames queued per sink.
pub const QUEUE_FRAMES: usize = 4;

/// A frame owned by the channel.
struct OwnedFrame {
    step: u64,
    time_ns: i64,
    world_from_link: Vec<Isometry3<f64>>,
    bodies: Vec<BodyState>,
    joints: Vec<JointState>,
    mechanisms: Vec<MechanismState>,
}

enum Job {
    Write(OwnedFrame),
    /// `true`: complete (leave the `.part`), `false`: finish (rename too).
    End(bool),
}

/// A sink running on its own thread.
pub struct Pipelined {
    jobs: Option<SyncSender<Job>>,
    /// Buffers the thread has written, for reuse.
    spare: Receiver<OwnedFrame>,
    thread: Option<JoinHandle<anyhow::Result<()>>>,
    path: Option<PathBuf>,
}

impl Pipelined {
    /// Moves `sink` to a new thread named `name`.
    pub fn new(sink: Box<dyn Sink + Send>, name: &str) -> anyhow::Result<Self> {
        let path = sink.path();
        let (jobs, inbox) = sync_channel::<Job>(QUEUE_FRAMES);
        let (give_back, spare) = sync_channel::<OwnedFrame>(QUEUE_FRAMES + 2);
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || -> anyhow::Result<()> {
                let mut sink = sink;
                while let Ok(job) = inbox.recv() {
                    match job {
                        Job::Write(owned) => {
                            sink.write(&Frame {
                                step: owned.step,
                                time_ns: owned.time_ns,
                                world_from_link: &owned.world_from_link,
                                bodies: &owned.bodies,
                                joints: &owned.joints,
                                mechanisms: &owned.mechanisms,
                            })?;
                            let _ = give_back.try_send(owned);
                        }
                        Job::End(keep_part) => {
                            return if keep_part {
                                sink.complete()
                            } else {
                                sink.finish()
                            };
                        }
                    }
                }
                // The sender is gone without an end: dropped unfinished.
                Ok(())
            })
            .context("cannot start a recording thread")?;
        Ok(Self {
            jobs: Some(jobs),
            spare,
            thread: Some(thread),
            path,
        })
    }

    /// The thread's result (after its channel closed or it ended).
    fn join(&mut self) -> anyhow::Result<()> {
        self.jobs = None;
        match self.thread.take() {
            Some(thread) => thread
                .join()
                .map_err(|_| anyhow!("a recording thread panicked"))?,
            None => Err(anyhow!("the recording thread has already ended")),
        }
    }

    fn end(mut self, keep_part: bool) -> anyhow::Result<()> {
        let sent = self
            .jobs
            .as_ref()
            .is_some_and(|jobs| jobs.send(Job::End(keep_part)).is_ok());
        let result = self.join();
        if sent {
            result
        } else {
            Err(result
                .err()
                .unwrap_or_else(|| anyhow!("the recording thread ended early")))
        }
    }
}

impl Sink for Pipelined {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        let mut owned = self.spare.try_recv().unwrap_or(OwnedFrame {
            step: 0,
            time_ns: 0,
            world_from_link: Vec::new(),
            bodies: Vec::new(),
            joints: Vec::new(),
            mechanisms: Vec::new(),
        });
        owned.step = frame.step;
        owned.time_ns = frame.time_ns;
        owned.world_from_link.clear();
        owned
            .world_from_link
            .extend_from_slice(frame.world_from_link);
        owned.bodies.clear();
        owned.bodies.extend_from_slice(frame.bodies);
        owned.joints.clear();
        owned.joints.extend_from_slice(frame.joints);
        owned.mechanisms.clear();
        owned.mechanisms.extend_from_slice(frame.mechanisms);
        let sent = self
            .jobs
            .as_ref()
            .is_some_and(|jobs| jobs.send(Job::Write(owned)).is_ok());
        if sent {
            return Ok(());
        }
        // The thread stopped: its error.
        Err(self
            .join()
            .err()
            .unwrap_or_else(|| anyhow!("the recording thread ended early")))
    }

    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        self.end(false)
    }

    fn path(&self) -> Option<PathBuf> {
        self.path.clone()
    }

    fn complete(self: Box<Self>) -> anyhow::Result<()> {
        self.end(true)
    }
}

impl Drop for Pipelined {
    fn drop(&mut self) {
        if self.thread.is_some() {
            let _ = self.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// Keeps the steps it saw; fails at step `fail_at`.
    struct Log {
        steps: Arc<Mutex<Vec<u64>>>,
        fail_at: Option<u64>,
    }

    impl Sink for Log {
        fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
            if Some(frame.step) == self.fail_at {
                anyhow::bail!("disk full at step {}", frame.step);
            }
            self.steps.lock().unwrap().push(frame.step);
            Ok(())
        }
        fn finish(self: Box<Self>) -> anyhow::Result<()> {
            self.steps.lock().unwrap().push(u64::MAX);
            Ok(())
        }
    }

    fn frame(step: u64) -> Frame<'static> {
        Frame {
            step,
            time_ns: step as i64,
            world_from_link: &[],
            bodies: &[],
            joints: &[],
            mechanisms: &[],
        }
    }

    #[test]
    fn frames_arrive_in_order_and_finish_runs_on_the_thread() {
        let steps = Arc::new(Mutex::new(Vec::new()));
        let log = Log {
            steps: steps.clone(),
            fail_at: None,
        };
        let mut sink = Box::new(Pipelined::new(Box::new(log), "test").unwrap());
        for step in 0..100 {
            sink.write(&frame(step)).unwrap();
        }
        sink.finish().unwrap();
        let mut expected: Vec<u64> = (0..100).collect();
        expected.push(u64::MAX);
        assert_eq!(*steps.lock().unwrap(), expected);
    }

    #[test]
    fn an_error_on_the_thread_reaches_the_caller() {
        let log = Log {
            steps: Arc::default(),
            fail_at: Some(3),
        };
        let mut sink = Box::new(Pipelined::new(Box::new(log), "test").unwrap());
        let mut error = None;
        for step in 0..100 {
            if let Err(e) = sink.write(&frame(step)) {
                error = Some(e);
                break;
            }
        }
        let error = match error {
            Some(e) => e,
            None => sink.finish().unwrap_err(),
        };
        assert!(
            format!("{error:#}").contains("disk full at step 3"),
            "{error:#}"
        );
    }
}
