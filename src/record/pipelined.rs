//! A [`Sink`] on its own thread: recording beside the stepping.
//!
//! [`Pipelined::new`] moves a sink to a thread of its own; [`Sink::write`] copies the frame into
//! an owned buffer and hands it over through a bounded channel of [`QUEUE_FRAMES`] frames, so the
//! stepping goes on while the sink encodes and compresses, and a sink slower than the stepping
//! holds the stepping back instead of queueing frames without bound. The sinks of one run share
//! their copies ([`FrameShare`], [`Pipelined::shared`]): a frame is copied once, whatever the
//! number of files, into a buffer every sink thread reads (an [`Arc`]) and that is reused once
//! all of them are done with it, so at most `queue + 2` frames are alive for all the sinks
//! together (the queue holds [`QUEUE_BYTES`] of frames, [`queue_frames`]). The sink sees the same frames in the same order as it would on the stepping
//! thread, so its bytes are the same. An error of the sink is reported by the next `write` (or
//! by `finish` / `complete`), after which the sink is gone; dropping an unfinished `Pipelined`
//! drops the sink on its thread (removing its `.part` file) and joins it.

use super::{BodyState, Frame, JointState, OwnedFrame, Sink};
use anyhow::{Context, anyhow};
use nalgebra::Isometry3;
use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::Arc;
use std::sync::mpsc::{SyncSender, sync_channel};
use std::thread::JoinHandle;

/// Frames queued per sink when nothing else is said ([`Pipelined::new`]).
pub const QUEUE_FRAMES: usize = 2;

/// What the queue of a sink may hold, bytes of frames ([`queue_frames`]).
pub const QUEUE_BYTES: usize = 4 << 20;

/// Frames queued per sink for frames of `frame_bytes` bytes: [`QUEUE_BYTES`] of them, at least 1
/// and at most 64. Small frames come often (1000 bodies: one every 0.4 ms), and a short queue
/// then makes the stepping wait for a sink thread's wake-up; big ones come seldom (10 000
/// bodies: 1.44 MB every 4 ms, 2 queued; 100 000 bodies: 14.4 MB every 40 ms, 1 queued), and a
/// long queue only holds memory (at 100 000 bodies each queued frame is 144 bytes per body).
pub fn queue_frames(frame_bytes: usize) -> usize {
    (QUEUE_BYTES / frame_bytes.max(1)).clamp(1, 64)
}

/// Bytes of a frame of `frames` link frames, `bodies` bodies and `joints` joints.
pub fn frame_bytes(frames: usize, bodies: usize, joints: usize) -> usize {
    frames * std::mem::size_of::<Isometry3<f64>>()
        + bodies * std::mem::size_of::<BodyState>()
        + joints * std::mem::size_of::<JointState>()
}

/// The frame copies the pipelined sinks of one run share (used on the stepping thread only).
#[derive(Default, Clone)]
pub struct FrameShare(Rc<RefCell<ShareState>>);

#[derive(Default)]
struct ShareState {
    /// The last frame copied: its step and where its poses were, and the copy.
    last: Option<(u64, usize, Arc<OwnedFrame>)>,
    /// Every buffer made, reused once no sink thread holds it.
    buffers: Vec<Arc<OwnedFrame>>,
}

impl FrameShare {
    /// The shared copy of `frame`: the one made for the previous sink when it is the same frame,
    /// else a copy into a free buffer (or a new one).
    fn copy(&self, frame: &Frame<'_>) -> Arc<OwnedFrame> {
        let mut state = self.0.borrow_mut();
        let key = (frame.step, frame.world_from_link.as_ptr() as usize);
        if let Some((step, at, owned)) = &state.last
            && (*step, *at) == key
        {
            return Arc::clone(owned);
        }
        state.last = None;
        let free = state
            .buffers
            .iter_mut()
            .position(|b| Arc::strong_count(b) == 1);
        let index = free.unwrap_or_else(|| {
            state.buffers.push(Arc::new(OwnedFrame::default()));
            state.buffers.len() - 1
        });
        let buffer = &mut state.buffers[index];
        let owned = Arc::get_mut(buffer).expect("a free buffer is held by no sink");
        owned.fill(frame);
        let shared = Arc::clone(buffer);
        state.last = Some((key.0, key.1, Arc::clone(&shared)));
        shared
    }

    /// Buffers made so far (at most the queue length + 2 per run, whatever the sink count).
    pub fn buffers(&self) -> usize {
        self.0.borrow().buffers.len()
    }
}

enum Job {
    Write(Arc<OwnedFrame>),
    Summary(Vec<(String, String)>),
    /// `true`: complete (leave the `.part`), `false`: finish (rename too).
    End(bool),
}

/// A sink running on its own thread.
pub struct Pipelined {
    jobs: Option<SyncSender<Job>>,
    /// `Some(keep_part)` once the end was sent ([`Sink::start_complete`]).
    ended: Option<bool>,
    share: FrameShare,
    thread: Option<JoinHandle<anyhow::Result<()>>>,
    path: Option<PathBuf>,
}

impl Pipelined {
    /// Moves `sink` to a new thread named `name` (its frame copies its own, a queue of
    /// [`QUEUE_FRAMES`]).
    pub fn new(sink: Box<dyn Sink + Send>, name: &str) -> anyhow::Result<Self> {
        Self::shared(sink, name, &FrameShare::default(), QUEUE_FRAMES)
    }

    /// [`Self::new`], sharing frame copies with the other sinks made with `share`, queueing up
    /// to `queue` frames ([`queue_frames`]).
    pub fn shared(
        sink: Box<dyn Sink + Send>,
        name: &str,
        share: &FrameShare,
        queue: usize,
    ) -> anyhow::Result<Self> {
        let path = sink.path();
        let (jobs, inbox) = sync_channel::<Job>(queue.max(1));
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || -> anyhow::Result<()> {
                let mut sink = sink;
                while let Ok(job) = inbox.recv() {
                    match job {
                        Job::Write(owned) => sink.write(&owned.as_frame())?,
                        Job::Summary(entries) => sink.write_summary(&entries)?,
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
            ended: None,
            share: share.clone(),
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

    /// Sends the end (once); whether the thread took it.
    fn send_end(&mut self, keep_part: bool) -> bool {
        if let Some(sent_keep) = self.ended {
            return sent_keep == keep_part;
        }
        self.ended = Some(keep_part);
        self.jobs
            .as_ref()
            .is_some_and(|jobs| jobs.send(Job::End(keep_part)).is_ok())
    }

    fn end(mut self, keep_part: bool) -> anyhow::Result<()> {
        let sent = self.send_end(keep_part);
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

impl Pipelined {
    /// Queues `job` for the sink's thread (waiting while the queue is full).
    fn send(&mut self, job: Job) -> anyhow::Result<()> {
        let sent = self
            .jobs
            .as_ref()
            .is_some_and(|jobs| jobs.send(job).is_ok());
        if sent {
            return Ok(());
        }
        // The thread stopped: its error.
        Err(self
            .join()
            .err()
            .unwrap_or_else(|| anyhow!("the recording thread ended early")))
    }
}

impl Sink for Pipelined {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        let owned = self.share.copy(frame);
        self.send(Job::Write(owned))
    }

    /// The buffer itself is queued: no copy.
    fn write_shared(&mut self, frame: &Arc<OwnedFrame>) -> anyhow::Result<()> {
        self.send(Job::Write(Arc::clone(frame)))
    }

    fn write_summary(&mut self, entries: &[(String, String)]) -> anyhow::Result<()> {
        self.send(Job::Summary(entries.to_vec()))
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

    fn start_complete(&mut self) {
        self.send_end(true);
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
            contacts: &[],
        }
    }

    /// Completes only once the other sink of the pair is completing too (or fails after 20 s).
    struct Rendezvous {
        path: PathBuf,
        started: std::sync::mpsc::Sender<()>,
        other_started: std::sync::mpsc::Receiver<()>,
    }

    impl Sink for Rendezvous {
        fn write(&mut self, _frame: &Frame<'_>) -> anyhow::Result<()> {
            Ok(())
        }
        fn finish(self: Box<Self>) -> anyhow::Result<()> {
            anyhow::bail!("finish is not expected")
        }
        fn path(&self) -> Option<PathBuf> {
            Some(self.path.clone())
        }
        fn complete(self: Box<Self>) -> anyhow::Result<()> {
            self.started.send(()).ok();
            self.other_started
                .recv_timeout(std::time::Duration::from_secs(20))
                .map_err(|_| {
                    anyhow!(
                        "{}: the other sink never started completing",
                        self.path.display()
                    )
                })
        }
    }

    fn rendezvous(
        path: &std::path::Path,
        started: std::sync::mpsc::Sender<()>,
        other_started: std::sync::mpsc::Receiver<()>,
        share: &FrameShare,
    ) -> Box<dyn Sink> {
        let sink = Rendezvous {
            path: path.to_path_buf(),
            started,
            other_started,
        };
        Box::new(Pipelined::shared(Box::new(sink), "rendezvous", share, 2).unwrap())
    }

    /// `finish_all` starts every pipelined sink's completion before waiting for any: two sinks
    /// that each complete only while the other completes too both succeed (one after the
    /// other, the first would wait for the second forever: the 20 s timeout fails it;
    /// checked by disabling `start_complete`).
    #[test]
    fn the_sinks_of_a_run_complete_at_the_same_time() {
        let dir = tempfile::tempdir().unwrap();
        let (a_started, a_seen) = std::sync::mpsc::channel();
        let (b_started, b_seen) = std::sync::mpsc::channel();
        let (a, b) = (dir.path().join("a.x"), dir.path().join("b.x"));
        for path in [&a, &b] {
            std::fs::write(crate::fsutil::part_path(path), b"done").unwrap();
        }
        let share = FrameShare::default();
        let sinks = vec![
            rendezvous(&a, a_started, b_seen, &share),
            rendezvous(&b, b_started, a_seen, &share),
        ];
        crate::record::finish_all(sinks, Ok(()), &[a.as_path(), b.as_path()]).unwrap();
        assert!(
            a.exists() && b.exists(),
            "both files renamed onto their names"
        );
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

    type Seen = Arc<Mutex<Vec<(u64, f64)>>>;

    /// Records each frame's step and first pose's x, slowly every 7th frame.
    struct Poses {
        seen: Seen,
    }

    impl Sink for Poses {
        fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
            if frame.step.is_multiple_of(7) {
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
            let x = frame.world_from_link[0].translation.x;
            self.seen.lock().unwrap().push((frame.step, x));
            Ok(())
        }
        fn finish(self: Box<Self>) -> anyhow::Result<()> {
            Ok(())
        }
    }

    /// Two sinks sharing their copies: each sees every frame's own values although the caller
    /// rewrites one buffer between frames (as the frame builder does), and no more than
    /// `QUEUE_FRAMES + 2` buffers are made for both (one per frame per sink before: 2 x 6).
    #[test]
    fn shared_copies_keep_every_frame_and_stay_bounded() {
        let share = FrameShare::default();
        let logs: Vec<Seen> = (0..2).map(|_| Arc::default()).collect();
        let mut sinks: Vec<Box<Pipelined>> = logs
            .iter()
            .map(|seen| {
                let sink = Poses { seen: seen.clone() };
                Box::new(Pipelined::shared(Box::new(sink), "test", &share, QUEUE_FRAMES).unwrap())
            })
            .collect();
        let mut poses = vec![Isometry3::identity(); 3];
        for step in 0..100u64 {
            poses[0].translation.x = step as f64 * 0.5;
            let frame = Frame {
                step,
                time_ns: step as i64,
                world_from_link: &poses,
                bodies: &[],
                joints: &[],
                mechanisms: &[],
                contacts: &[],
            };
            for sink in &mut sinks {
                sink.write(&frame).unwrap();
            }
        }
        assert!(
            share.buffers() <= QUEUE_FRAMES + 2,
            "{} buffers",
            share.buffers()
        );
        for sink in sinks {
            sink.finish().unwrap();
        }
        let expected: Vec<(u64, f64)> = (0..100).map(|s| (s, s as f64 * 0.5)).collect();
        for log in &logs {
            assert_eq!(*log.lock().unwrap(), expected);
        }
    }

    #[test]
    fn queues_hold_a_few_megabytes_of_frames() {
        // A pose is 7 doubles, a body state 11. 10 000 bodies: 1.44 MB frames, the minimum of
        // 2; 1000 bodies: 29 (4 MiB / 144 kB); tiny frames: 64.
        assert_eq!(frame_bytes(10_000, 10_000, 0), 10_000 * (56 + 88));
        // A joint state is 48 bytes (position, velocity, effort, an optional target: 16, the
        // saturation flag, padded); frames, bodies and joints add.
        assert_eq!(frame_bytes(3, 5, 7), 3 * 56 + 5 * 88 + 7 * 48);
        assert_eq!(queue_frames(frame_bytes(100_000, 100_000, 0)), 1);
        assert_eq!(queue_frames(frame_bytes(10_000, 10_000, 0)), 2);
        assert_eq!(queue_frames(frame_bytes(1000, 1000, 0)), 29);
        assert_eq!(queue_frames(frame_bytes(1, 1, 0)), 64);
        assert_eq!(queue_frames(0), 64);
    }
}
