//! Many copies of a mechanism share the stepping threads (issue 15): `simulate --threads N`
//! cuts the batch between mechanisms (`tumble::sim::partition::ranges`), and what is recorded
//! does not depend on N, bit for bit, including where the guard stops a diverging run.

use crate::common;
use crate::common::urdfs::copy_models;

use common::{text, tumble};
use std::path::Path;

/// Fixed-base pendulums, floating chains and free boxes in one scene: 40 x 2 + 20 x 3 + 200
/// bodies, an estimated cost of 200 + 140 x 30 (`MECHANISM_BODY_COST`), enough for 3
/// partitions.
const MIXED: &str = r#"[sim]
dt = 0.002
duration = 0.4
integrator = "variational"
log_every = 5

[[model]]
urdf = "double_pendulum.urdf"
name = "pend"
bodies = "articulated"
base = "fixed"
copies = 40
seed = 7
position = { uniform = [[-5.0, -5.0, 1.0], [5.0, 5.0, 4.0]] }
joints = { shoulder = 2.0, elbow = 0.5 }
joint_velocities = { elbow = 1.0 }

[[model]]
urdf = "box.urdf"
name = "box"
copies = 200
seed = 9
orientation = "uniform"
angvel = { uniform = [[-5.0, -5.0, -5.0], [5.0, 5.0, 5.0]] }

[[model]]
urdf = "chain3_free.urdf"
name = "chain"
bodies = "articulated"
copies = 20
seed = 8
position = { uniform = [[-5.0, -5.0, 5.0], [5.0, 5.0, 8.0]] }
angvel = [0.0, 0.3, 0.5]
joints = { j1 = 0.4, j2 = -0.3 }
joint_velocities = { j1 = 2.0, j2 = -3.0 }
"#;

fn run(d: &Path, scene: &str, threads: &str) -> (std::process::Output, Vec<Vec<u8>>) {
    let stem = format!("t{threads}");
    let out = tumble(
        &[
            "simulate",
            scene,
            "--out",
            &stem,
            "--threads",
            threads,
            "--format",
            "mcap,rrd,ros2",
        ],
        d,
    );
    let files = ["mcap", "rrd", "ros2.mcap"]
        .iter()
        .filter_map(|ext| std::fs::read(d.join(format!("{stem}.{ext}"))).ok())
        .collect();
    (out, files)
}

/// 1, 2 and 3 threads: each run says it stepped on that many threads (the batch was really
/// cut), and the MCAP, Rerun and ROS 2 files are the same bytes.
#[test]
fn mechanisms_on_threads_write_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_models(d, &["double_pendulum", "chain3_free", "chain7", "box"]);
    std::fs::write(d.join("mixed.toml"), MIXED).unwrap();
    let (one, reference) = run(d, "mixed.toml", "1");
    assert!(one.status.success(), "{}", text(&one.stderr));
    assert_eq!(reference.len(), 3);
    for threads in ["2", "3"] {
        let (out, files) = run(d, "mixed.toml", threads);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let stdout = text(&out.stdout);
        assert!(
            stdout.contains(&format!("on {threads} threads")),
            "{stdout}"
        );
        for (k, ext) in ["mcap", "rrd", "ros2.mcap"].iter().enumerate() {
            assert!(
                files[k] == reference[k],
                "{ext} differs with {threads} threads"
            );
        }
        // The summary lines (energy, momenta, Newton counts) are the same too.
        let summary = |s: &str| {
            s.lines()
                .filter(|l| l.starts_with("energy") || l.starts_with("Newton"))
                .map(str::to_owned)
                .collect::<Vec<_>>()
        };
        assert_eq!(summary(&stdout), summary(&text(&one.stdout)));
    }
}

/// A whip spun far too fast for its step fails in a partition that does not start at body 0:
/// every thread count stops at the same step, names the same body by its batch index (120, the
/// first chain link after 60 pendulums) and writes the same truncated files.
#[test]
fn a_mechanism_failing_on_a_later_partition_stops_every_thread_count_alike() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_models(d, &["double_pendulum", "chain3_free", "chain7", "box"]);
    std::fs::write(
        d.join("whip.toml"),
        r#"[sim]
dt = 0.02
duration = 1.0
integrator = "variational"
log_every = 5

[[model]]
urdf = "double_pendulum.urdf"
name = "p"
bodies = "articulated"
base = "fixed"
copies = 60
seed = 1
position = { uniform = [[-5.0, -5.0, 1.0], [5.0, 5.0, 4.0]] }
joints = { shoulder = 2.0, elbow = 0.5 }

[[model]]
urdf = "chain7.urdf"
name = "w"
bodies = "articulated"
base = "fixed"
copies = 3
position = [0.0, 0.0, 4.0]
joints = { j1 = 1.5707963267948966 }
joint_velocities = { j7 = 3000.0 }
"#,
    )
    .unwrap();
    let mut reference: Option<(String, Vec<Vec<u8>>)> = None;
    for threads in ["1", "2", "3"] {
        let (out, files) = run(d, "whip.toml", threads);
        assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
        let stderr = text(&out.stderr);
        let error = stderr
            .lines()
            .find(|l| l.starts_with("error:"))
            .expect("an error line")
            .replace(&format!("t{threads}."), "STEM.");
        assert!(
            error.contains("body \"w_0/link1\" (index 120) failed at step 31"),
            "{error}"
        );
        assert_eq!(files.len(), 3, "every file finished");
        match &reference {
            None => reference = Some((error, files)),
            Some((e, r)) => {
                assert_eq!(&error, e);
                assert!(r == &files, "files differ with {threads} threads");
            }
        }
    }
}
