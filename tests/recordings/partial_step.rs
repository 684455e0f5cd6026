//! A recording cut between a step's `/tf` and `/bodies` messages (what `kill -9` leaves when a
//! chunk boundary falls inside a step): `tumble info` and `tumble convert` report the same
//! recovered steps and the same span (issue 13: info used to count the dropped partial step and
//! reported 0 .. 3.98344 s where convert said 0 .. 3.98343 s).

use crate::common;

use std::path::Path;
use tumble::record::rerun::RerunOptions;

/// Byte offset just past the first chunk whose last message is on `/tf` (its step's `/bodies`
/// message opens the next chunk), and that chunk's last time.
fn cut_inside_a_step(bytes: &[u8]) -> Option<(usize, u64)> {
    let summary = mcap::Summary::read(bytes).unwrap().unwrap();
    for ci in &summary.chunk_indexes {
        let messages = summary.stream_chunk(bytes, ci).unwrap();
        let last = messages.map(|m| m.unwrap()).last()?;
        if last.channel.topic == "/tf" {
            let end = (ci.chunk_start_offset + ci.chunk_length) as usize;
            return Some((end, last.log_time));
        }
    }
    None
}

#[test]
fn info_and_convert_agree_on_a_file_cut_inside_a_step() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let models = common::root().join("models");
    let scene_path = d.join("scene.toml");
    std::fs::write(
        &scene_path,
        format!(
            "[sim]\ndt = 0.001\nduration = 4\nlog_every = 1\n\n[[model]]\nurdf = \"{}\"\n\
             angvel = [0.3, 4, 0.2]\n[[model]]\nurdf = \"{}\"\nname = \"arm\"\n",
            models.join("box.urdf").display(),
            models.join("arm.urdf").display()
        ),
    )
    .unwrap();
    let scene = tumble::scene::Scene::load(&scene_path).unwrap();
    let out =
        tumble::simulation::simulate(&scene, &d.join("run"), &RerunOptions::default()).unwrap();
    let bytes = std::fs::read(&out.mcap).unwrap();
    let (cut, tf_time) = cut_inside_a_step(&bytes).expect("a chunk ending on /tf");
    let cut_path = d.join("cut.mcap");
    std::fs::write(&cut_path, &bytes[..cut]).unwrap();

    let info = tumble::replay::info::info(&cut_path).unwrap();
    assert!(!info.complete);
    let rrd = d.join("cut.rrd");
    let converted =
        tumble::replay::convert::convert(&cut_path, &rrd, &RerunOptions::default()).unwrap();
    // The partial step at `tf_time` is dropped by convert: its last step is one step earlier.
    assert_eq!(converted.time_range_ns.1 as u64, tf_time - 1_000_000);
    let (a, b) = (info.truncation.unwrap(), converted.truncation.unwrap());
    let span = |w: &str| {
        w[w.find("(t = ").unwrap()..]
            .split(')')
            .next()
            .unwrap()
            .to_string()
    };
    assert_eq!(span(&a), span(&b), "info: {a}\nconvert: {b}");
    let steps = |w: &str| {
        w[w.find("recovered ").unwrap()..]
            .split_whitespace()
            .nth(1)
            .unwrap()
            .to_string()
    };
    assert_eq!(steps(&a), steps(&b), "info: {a}\nconvert: {b}");
    assert_eq!(steps(&b), converted.steps.to_string());
    assert_eq!(
        info.duration,
        (converted.time_range_ns.1 - converted.time_range_ns.0) as f64 / 1e9
    );
    assert!(Path::new(&rrd).exists());
}
