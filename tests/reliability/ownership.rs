//! Files that no one can corrupt (issue 28, items 1, 2, 4, 5 and 7), each case reproduced
//! through the binary: two runs on one output, links planted at the `.part` names, a publish
//! that fails half-way, the file-size limit and SIGHUP, special files given as recordings,
//! and a signal while a model loads.

use crate::common;

use common::{exe, listing, scene, text, tumble};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The two runs of the concurrency test: different scenes, each long enough (about 0.3-0.6 s
/// of stepping and recording) that two started together overlap.
fn run_args(which: usize) -> Vec<String> {
    let (model, duration) = [("arm.toml", "4"), ("t_handle.toml", "20")][which];
    let model = scene(model);
    ["simulate", &model, "--duration", duration, "--out", "run"]
        .iter()
        .map(|s| s.to_string())
        .collect()
}

/// Issue 28, item 1: two runs on one output stem, started together, in both orders, with and
/// without `--force`, many times. Before: 6 of 7 trials published an MCAP mixed from both runs
/// while one run exited 0. Now every trial ends with the `.mcap` and the `.rrd` of one run,
/// byte for byte as that run writes them alone, and nothing else in the folder; a run that is
/// refused says why (the other run holds the output, or it exists) and exits 2; a run that
/// exits 0 is the one whose files are there, unless the other ran wholly after it.
#[test]
fn two_runs_on_one_output_never_mix() {
    // Each run's files written alone.
    let reference: Vec<(Vec<u8>, Vec<u8>)> = (0..2)
        .map(|which| {
            let dir = tempfile::tempdir().unwrap();
            let args = run_args(which);
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            let out = tumble(&args, dir.path());
            assert!(out.status.success(), "{}", text(&out.stderr));
            (
                bytes(&dir.path().join("run.mcap")),
                bytes(&dir.path().join("run.rrd")),
            )
        })
        .collect();
    assert_ne!(reference[0].0, reference[1].0);
    let mut outcomes = std::collections::BTreeMap::<String, usize>::new();
    for trial in 0..24 {
        let force = trial % 2 == 1;
        let first = (trial / 2) % 2;
        let dir = tempfile::tempdir().unwrap();
        if force {
            // Something to replace: an older pair of files.
            std::fs::write(dir.path().join("run.mcap"), "old").unwrap();
            std::fs::write(dir.path().join("run.rrd"), "old").unwrap();
        }
        let children: Vec<_> = [first, 1 - first]
            .into_iter()
            .map(|which| {
                let mut args = run_args(which);
                if force {
                    args.push("--force".into());
                }
                let child = Command::new(exe())
                    .args(&args)
                    .current_dir(dir.path())
                    .stdout(Stdio::null())
                    .stderr(Stdio::piped())
                    .spawn()
                    .unwrap();
                (which, child)
            })
            .collect();
        let results: Vec<(usize, Option<i32>, String)> = children
            .into_iter()
            .map(|(which, child)| {
                let out = child.wait_with_output().unwrap();
                (which, out.status.code(), text(&out.stderr))
            })
            .collect();
        let winners: Vec<usize> = results
            .iter()
            .filter(|r| r.1 == Some(0))
            .map(|r| r.0)
            .collect();
        for (which, code, err) in &results {
            assert!(!err.contains("panicked"), "{err}");
            if *code != Some(0) {
                assert_eq!(*code, Some(2), "run {which}: {err}");
                assert!(
                    // "(process N)", or "(another process)" when the holder let go between
                    // the refused lock and the look at /proc/locks (seen once in a loaded run).
                    err.contains("another tumble run (") || err.contains("exists; pass --force"),
                    "run {which}: {err}"
                );
            }
        }
        assert!(!winners.is_empty(), "trial {trial}: {results:?}");
        assert_eq!(listing(dir.path()), ["run.mcap", "run.rrd"], "{results:?}");
        let published = (
            bytes(&dir.path().join("run.mcap")),
            bytes(&dir.path().join("run.rrd")),
        );
        let whose = reference
            .iter()
            .position(|r| *r == published)
            .unwrap_or_else(|| panic!("trial {trial}: the files are of neither run alone"));
        assert!(winners.contains(&whose), "trial {trial}: {results:?}");
        let key = format!(
            "force={force} exit codes {:?}",
            results.iter().map(|r| r.1).collect::<Vec<_>>()
        );
        *outcomes.entry(key).or_default() += 1;
    }
    // The outcomes met (printed with --nocapture); with these run lengths most trials refuse
    // the second run: measured 24 of 24 at the last change.
    eprintln!("{outcomes:?}");
    let refused: usize = outcomes
        .iter()
        .filter(|(k, _)| k.contains("Some(2)"))
        .map(|(_, n)| n)
        .sum();
    assert!(refused > 0, "the runs never overlapped: {outcomes:?}");
}

/// Issue 28, item 2: a symbolic link planted at `STEM.mcap.part` or `.rrd.part` made
/// `simulate`, `convert` and `diff --rrd` truncate and overwrite its target, `--force` or not.
/// Now each refuses with a message naming the link, exit 2, and the target keeps its bytes.
#[test]
fn a_link_planted_at_a_part_name_is_never_followed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let made = tumble(
        &[
            "simulate",
            &scene("box.toml"),
            "--out",
            "a",
            "--duration",
            "0.2",
        ],
        d,
    );
    assert!(made.status.success(), "{}", text(&made.stderr));
    std::fs::write(d.join("victim"), "precious").unwrap();
    let model = scene("box.toml");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["simulate", &model, "--out", "s", "--duration", "0.2"],
            "s.mcap.part",
        ),
        (
            vec!["simulate", &model, "--out", "s", "--duration", "0.2"],
            "s.rrd.part",
        ),
        (vec!["convert", "a.mcap", "--rrd", "c.rrd"], "c.rrd.part"),
        (
            vec!["diff", "a.mcap", "a.mcap", "--rrd", "d.rrd"],
            "d.rrd.part",
        ),
    ];
    for (args, part) in cases {
        for force in [false, true] {
            std::os::unix::fs::symlink("victim", d.join(part)).unwrap();
            let mut args = args.clone();
            if force {
                args.push("--force");
            }
            let out = tumble(&args, d);
            let err = text(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
            assert!(
                err.contains(&format!("{part} is a symbolic link (to victim)")),
                "{args:?}: {err}"
            );
            assert_eq!(bytes(&d.join("victim")), b"precious", "{args:?}");
            std::fs::remove_file(d.join(part)).unwrap();
            assert_eq!(
                listing(d),
                ["a.mcap", "a.rrd", "victim"],
                "{args:?}: nothing else written"
            );
        }
    }
}

/// Issue 28, item 4: a directory at `STEM.rrd` was found only after the whole run, with the
/// new `.mcap` already in place and `.part` files left. Now it is refused before the first
/// step, and the previous `.mcap` stays.
#[test]
fn a_directory_at_an_output_is_refused_before_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("run.mcap"), "old").unwrap();
    std::fs::create_dir(d.join("run.rrd")).unwrap();
    let started = Instant::now();
    let out = tumble(
        &[
            "simulate",
            &scene("box.toml"),
            "--out",
            "run",
            "--force",
            "--dt",
            "1e-6",
            "--duration",
            "100",
        ],
        d,
    );
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("run.rrd is a directory"), "{err}");
    // 1e8 steps would take minutes: the refusal comes first (measured 0.02 s).
    assert!(started.elapsed() < Duration::from_secs(10));
    assert_eq!(bytes(&d.join("run.mcap")), b"old");
    assert_eq!(listing(d), ["run.mcap", "run.rrd"]);
}

/// Issue 28, item 4: when a file cannot be published after the run (a directory appeared at
/// `STEM.rrd` while it ran), the `.mcap` already renamed is rolled back: the previous files
/// stay, no `.part` or backup is left, exit 2.
#[test]
fn a_publish_that_fails_half_way_keeps_the_previous_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("run.mcap"), "old mcap").unwrap();
    let child = Command::new(exe())
        .args(["simulate", &scene("box.toml"), "--out", "run", "--force"])
        .args(["--dt", "1e-5", "--duration", "20", "--log-every", "1000"])
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Once the run records, a directory takes the `.rrd`'s name.
    let started = Instant::now();
    while std::fs::metadata(d.join("run.rrd.part"))
        .map(|m| m.len())
        .unwrap_or(0)
        == 0
    {
        assert!(started.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(10));
    }
    std::fs::create_dir(d.join("run.rrd")).unwrap();
    std::fs::write(d.join("run.rrd").join("keep"), "x").unwrap();
    let out = child.wait_with_output().unwrap();
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("no output was published"), "{err}");
    assert!(err.contains("run.rrd"), "{err}");
    assert_eq!(bytes(&d.join("run.mcap")), b"old mcap");
    assert_eq!(listing(d), ["run.mcap", "run.rrd"]);
}

/// Issue 28, item 5: `ulimit -f` killed tumble with SIGXFSZ (exit 153, no message, `.part`
/// files left). Now the write fails like on a full disk: exit 2, the message names the file
/// and the limit, nothing is left in the folder. (No `trap '' XFSZ` here: the test that
/// ignored the signal hid the defect.)
#[test]
fn the_file_size_limit_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let script = format!(
        "ulimit -f 64; exec '{}' simulate '{}' --out run",
        exe(),
        scene("arm.toml")
    );
    let out = Command::new("bash")
        .args(["-c", &script])
        .current_dir(d)
        .output()
        .unwrap();
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains(".part") && err.contains("File too large"),
        "{err}"
    );
    assert!(
        err.contains("the file-size limit, ulimit -f, is 65536 bytes"),
        "{err}"
    );
    assert_eq!(listing(d), Vec::<String>::new(), "{err}");
}

/// Issue 28, item 9: `convert` printed its cause twice ("writing x.rrd.part: Failed to write:
/// File too large (os error 27): File too large (os error 27)": Rerun's error already holds its
/// source). Now each cause is said once; the message still names the file and the limit.
#[test]
fn convert_says_its_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let made = tumble(
        &[
            "simulate",
            &scene("box.toml"),
            "--out",
            "b",
            "--duration",
            "0.5",
            "--format",
            "mcap",
        ],
        d,
    );
    assert!(made.status.success(), "{}", text(&made.stderr));
    let script = format!("ulimit -f 10; exec '{}' convert b.mcap --rrd x.rrd", exe());
    let out = Command::new("bash")
        .args(["-c", &script])
        .current_dir(d)
        .output()
        .unwrap();
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("x.rrd.part"), "{err}");
    assert_eq!(err.matches("File too large").count(), 1, "{err}");
    assert!(err.contains("ulimit -f, is 10240 bytes"), "{err}");
    assert_eq!(listing(d), ["b.mcap"]);
}

/// Issue 28, item 7: `info`, `convert` and `diff` given a FIFO blocked for ever in `open()`.
/// Now each refuses it at once, naming it.
#[test]
fn a_fifo_given_as_a_recording_is_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let made = Command::new("mkfifo")
        .arg(d.join("pipe.mcap"))
        .status()
        .unwrap();
    assert!(made.success());
    for args in [
        vec!["info", "pipe.mcap"],
        vec!["convert", "pipe.mcap", "--rrd", "out.rrd"],
        vec!["diff", "pipe.mcap", "pipe.mcap"],
    ] {
        let mut child = Command::new(exe())
            .args(&args)
            .current_dir(d)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let started = Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            if started.elapsed() > Duration::from_secs(20) {
                child.kill().ok();
                panic!("{args:?} blocked on the FIFO");
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        let err = text(&child.wait_with_output().unwrap().stderr);
        assert_eq!(status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("pipe.mcap is not a regular file but a FIFO (named pipe)"),
            "{args:?}: {err}"
        );
        assert_eq!(listing(d), ["pipe.mcap"], "{args:?}");
    }
}

/// Sends `signal` to `child` with the `kill` command.
fn kill(child: &std::process::Child, signal: &str) {
    let status = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
}

/// Issue 28, item 6: SIGINT was not acted on while a big mesh loaded (110 s). Now a signal
/// before the stepping starts ends the process at once: exit 130 within a second, one
/// message, nothing written.
#[test]
fn a_signal_while_loading_stops_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let urdf = big_mesh_urdf(d);
    let mut child = Command::new(exe())
        .args(["simulate"])
        .arg(&urdf)
        .args(["--inertia", "geometry", "--out", "run"])
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(500));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the load must still be running when the signal is sent"
    );
    let sent = Instant::now();
    kill(&child, "INT");
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if sent.elapsed() > Duration::from_secs(30) {
            child.kill().ok();
            panic!("SIGINT not acted on while loading");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let waited = sent.elapsed();
    let err = text(&child.wait_with_output().unwrap().stderr);
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(err.contains("stopped by SIGINT"), "{err}");
    // Measured: exit 5-20 ms after the signal.
    assert!(waited < Duration::from_secs(1), "{waited:?}");
    let mut left = listing(d);
    left.retain(|n| !n.starts_with("big"));
    assert_eq!(left, Vec::<String>::new());
}

/// A URDF with one link whose inertia comes from a binary STL of many triangles: seconds of
/// loading (a sphere-ish fan of 1.5 million triangles, 75 MB: under the per-mesh cap of
/// `tumble::scene` so that it is read, not refused from its header).
fn big_mesh_urdf(dir: &Path) -> PathBuf {
    let triangles: u32 = 1_500_000;
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&triangles.to_le_bytes());
    stl.reserve(triangles as usize * 50);
    for i in 0..triangles {
        let a = i as f32 * 1e-6;
        let tri = [
            [0.0f32, 0.0, 0.0],
            [a.cos(), a.sin(), 0.1],
            [(a + 1e-6).cos(), (a + 1e-6).sin(), -0.1],
        ];
        stl.extend_from_slice(&[0u8; 12]);
        for v in tri {
            for c in v {
                stl.extend_from_slice(&c.to_le_bytes());
            }
        }
        stl.extend_from_slice(&[0u8; 2]);
    }
    std::fs::write(dir.join("big.stl"), stl).unwrap();
    let urdf = dir.join("big.urdf");
    std::fs::write(
        &urdf,
        r#"<robot name="big"><link name="l"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
<visual><geometry><mesh filename="big.stl"/></geometry></visual>
<collision><geometry><mesh filename="big.stl"/></geometry></collision></link></robot>"#,
    )
    .unwrap();
    urdf
}

/// Issue 28, item 5: SIGHUP (the terminal closed) left `.part` files and no message. Now it
/// stops the run like SIGINT: the recordings end at a step, are complete, exit 129.
#[test]
fn sighup_finishes_the_recordings() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let child = Command::new(exe())
        .args(["simulate", &scene("box.toml"), "--out", "long"])
        .args(["--dt", "1e-6", "--duration", "1000", "--log-every", "1000"])
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while std::fs::metadata(d.join("long.mcap.part"))
        .map(|m| m.len())
        .unwrap_or(0)
        < 100_000
    {
        assert!(started.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(20));
    }
    kill(&child, "HUP");
    let out = child.wait_with_output().unwrap();
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(129), "{err}");
    assert!(err.contains("stopped by SIGHUP"), "{err}");
    assert!(err.contains("stopped after step "), "{err}");
    assert_eq!(listing(d), ["long.mcap", "long.rrd"]);
    let info = tumble(&["info", "long.mcap", "--json"], d);
    assert_eq!(info.status.code(), Some(0), "{}", text(&info.stderr));
    let info: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(info["complete"], true);
}

/// A run that cannot write stops cleanly when interrupted outside the stepping too: SIGTERM
/// during `convert` (which has no step boundaries) leaves no `.part` behind and says so.
#[test]
fn a_signal_during_convert_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let made = tumble(
        &[
            "simulate",
            &scene("swarm.toml"),
            "--out",
            "big",
            "--duration",
            "0.5",
            "--format",
            "mcap",
        ],
        d,
    );
    assert!(made.status.success(), "{}", text(&made.stderr));
    let child = Command::new(exe())
        .args(["convert", "big.mcap", "--rrd", "big.rrd"])
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !d.join("big.rrd.part").exists() {
        assert!(started.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(2));
    }
    kill(&child, "TERM");
    let out = child.wait_with_output().unwrap();
    let err = text(&out.stderr);
    if out.status.code() == Some(0) {
        // The conversion finished before the signal arrived: then it is whole.
        assert_eq!(listing(d), ["big.mcap", "big.rrd"]);
        return;
    }
    assert_eq!(out.status.code(), Some(143), "{err}");
    assert!(
        err.contains("stopped by SIGTERM; 1 unfinished file removed, nothing published"),
        "{err}"
    );
    assert_eq!(listing(d), ["big.mcap"]);
}

/// Issue 28, item 1, for datasets: a second `tumble dataset` on a folder another one is
/// writing is refused at once, naming the process, instead of removing (with `--force`) or
/// resuming the first one's files; the first completes untouched.
#[test]
fn two_datasets_on_one_folder_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The bundled spec with 10 times its runs: about 2 s, so that the first run is still
    // writing while the three others are refused (the bundled 1000 runs took 0.4 s, and a
    // quiet machine finished them before the third).
    common::urdfs::copy_models(d, &["box", "t_handle", "arm"]);
    let spec_text = std::fs::read_to_string(scene("dataset.toml"))
        .unwrap()
        .replace("runs = 1000 ", "runs = 10000 ");
    assert!(spec_text.contains("runs = 10000 "));
    std::fs::write(d.join("dataset.toml"), spec_text).unwrap();
    let spec = d.join("dataset.toml").display().to_string();
    let first = Command::new(exe())
        .args(["dataset", &spec, "--out", "ds", "-q"])
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    // The first run's first file appears after it took the folder's lock.
    while std::fs::read_dir(d.join("ds")).map_or(true, |mut e| e.next().is_none()) {
        assert!(started.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(2));
    }
    let pid = first.id();
    for extra in [None, Some("--force"), Some("--resume")] {
        let mut args = vec!["dataset", spec.as_str(), "--out", "ds", "-q"];
        args.extend(extra);
        let second = tumble(&args, d);
        let err = text(&second.stderr);
        assert_eq!(second.status.code(), Some(2), "{extra:?}: {err}");
        assert!(
            err.contains(&format!(
                "another tumble run (process {pid}) is writing into ds"
            )),
            "{extra:?}: {err}"
        );
    }
    let out = first.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", text(&out.stderr));
    // The first run's dataset is whole: its manifest lists every chunk, and `--resume` finds
    // nothing to redo.
    let resumed = tumble(&["dataset", &spec, "--out", "ds", "-q", "--resume"], d);
    assert!(resumed.status.success(), "{}", text(&resumed.stderr));
    let said = text(&resumed.stdout) + &text(&resumed.stderr);
    assert!(
        said.contains("10000 runs (100 chunks) were complete and checked; 0 chunks recomputed"),
        "{said}"
    );
}
