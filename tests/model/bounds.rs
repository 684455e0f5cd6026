//! Bounded work and refused values (issue 28, items 6, 8 and 9): small hostile inputs that used
//! to cost gigabytes and minutes, and values that reached the solver instead of being refused,
//! each run through the `tumble` binary.
//!
//! Every refusal must: exit with status 2 within [`QUICK`] (the "before" figures are in each
//! test), name the file and the model, joint or key, state the cap or bound in readable form,
//! never print a number of more than 20 digits, and leave no recording behind.

use crate::common;
use crate::common::urdfs::write;

use std::path::{Path, PathBuf};

use std::time::Duration;

/// A refusal must come this fast. Generous for a loaded 2-core machine: every refusal here
/// measured under 0.1 s, against 4 s to minutes before.
const QUICK: Duration = Duration::from_secs(10);

/// A run still going after this is killed and fails the test.
const HANG_LIMIT: Duration = Duration::from_secs(120);

use common::limited::Limited as Run;

/// Runs `tumble args` in `cwd`, killed after [`HANG_LIMIT`].
fn run(args: &[&str], cwd: &Path) -> Run {
    common::limited::run_limited(args, cwd, HANG_LIMIT)
}

/// The longest run of digits in `text` (a number printed in full: `1e300` as 301 digits).
fn longest_digit_run(text: &str) -> usize {
    text.split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0)
}

/// `run` is a quick refusal (status 2) whose stderr holds every one of `needles`; no number
/// in it is longer than 20 digits; nothing is left under `dir/out`.
#[track_caller]
fn assert_refused(run: &Run, needles: &[&str], dir: &Path) {
    assert_eq!(run.status, Some(2), "stderr:\n{}", run.stderr);
    assert!(
        run.elapsed < QUICK,
        "refused after {:?}:\n{}",
        run.elapsed,
        run.stderr
    );
    for needle in needles {
        assert!(
            run.stderr.contains(needle),
            "stderr lacks {needle:?}:\n{}",
            run.stderr
        );
    }
    assert!(
        longest_digit_run(&run.stderr) <= 20,
        "a number in full:\n{}",
        run.stderr
    );
    for bad in ["panicked", "RUST_BACKTRACE"] {
        assert!(!run.stderr.contains(bad), "{}", run.stderr);
    }
    let out = dir.join("out");
    if out.exists() {
        let left: Vec<PathBuf> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        assert!(left.is_empty(), "a refused run left {left:?}");
    }
}

const INERTIAL: &str = r#"<inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>"#;

// ------------------------------------------------------------------------------ XML entities

/// Before: this 110 KB URDF (one 50 KB entity referenced 20 000 times in an attribute value)
/// took 4.0 s and 1.96 GB (`/usr/bin/time`), and with the references in text (quadratic
/// joining) it had not finished after 24 minutes at 1 GB. Now both are refused from a scan
/// of the text: the expansion passes the cap of 1 MiB (twice the file's size, at least 1 MiB)
/// by the 21st reference.
#[test]
fn entity_amplification_is_refused_before_parsing() {
    let tmp = tempfile::tempdir().unwrap();
    let entity = "x".repeat(50_000);
    let refs = "&e;".repeat(20_000);
    for (name, body) in [
        ("attribute.urdf", format!("<material name=\"{refs}\"/>")),
        (
            "text.urdf",
            format!("<material name=\"m\">{refs}</material>"),
        ),
    ] {
        let xml = format!(
            "<?xml version=\"1.0\"?>\n<!DOCTYPE robot [<!ENTITY e \"{entity}\">]>\n\
             <robot name=\"r\"><link name=\"a\">{INERTIAL}</link>{body}</robot>\n"
        );
        assert!((100_000..120_000).contains(&xml.len()));
        write(&tmp.path().join(name), &xml);
        for args in [
            vec!["inspect", name],
            vec!["simulate", name, "--out", "out/r"],
        ] {
            let r = run(&args, tmp.path());
            assert_refused(
                &r,
                &[
                    name,
                    "XML refused before parsing",
                    "entity bomb",
                    "over the limit of 1,048,576 bytes",
                ],
                tmp.path(),
            );
        }
    }
}

/// Joining many pieces of one run of text is quadratic in roxmltree: 80 000
/// `a<![CDATA[b]]>` in one element (1.1 MB) took 0.7 s, four times more per doubling (a 28 MB
/// file: over 7 minutes). Refused from the scan; the same pieces in separate elements load.
#[test]
fn many_pieces_of_text_in_one_run_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let one_run = format!(
        "<robot name=\"r\"><link name=\"a\">{INERTIAL}</link><material name=\"m\">{}</material></robot>",
        "a<![CDATA[b]]>".repeat(80_000)
    );
    write(&tmp.path().join("cdata.urdf"), one_run);
    let r = run(&["inspect", "cdata.urdf"], tmp.path());
    assert_refused(
        &r,
        &[
            "cdata.urdf",
            "XML refused before parsing",
            "one run has 160,000 pieces",
        ],
        tmp.path(),
    );
}

// ------------------------------------------------------------------------------ meshes

/// A URDF with one link whose visual and collision geometry is `mesh` (a file in the same
/// folder).
fn mesh_urdf(dir: &Path, name: &str, mesh: &str) {
    write(
        &dir.join(name),
        format!(
            r#"<robot name="holder"><link name="holder">{INERTIAL}
                 <visual><geometry><mesh filename="{mesh}"/></geometry></visual>
                 <collision><geometry><mesh filename="{mesh}"/></geometry></collision>
               </link></robot>"#
        ),
    );
}

/// A sparse binary STL whose header counts `n` triangles and whose size matches (`84 + 50 n`
/// bytes, all zero past the header: nothing on disk).
fn sparse_binary_stl(path: &Path, n: u32) {
    let mut header = vec![0u8; 84];
    header[80..84].copy_from_slice(&n.to_le_bytes());
    write(path, header);
    std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .unwrap()
        .set_len(84 + 50 * u64::from(n))
        .unwrap();
}

/// Before: a binary STL of 10^7 triangles (500 MB, under the 512 MiB size cap) as a visual
/// took 125 s and 5.6 GiB to simulate 10 steps (issue 28 measured 110 s without reaching step
/// 1). Now refused from its 84-byte header, for the recording (simulate) as for the mass
/// properties (inspect --inertia geometry). The file here is sparse: were it read, it would be
/// 500 MB of zeros.
#[test]
fn a_binary_stl_over_the_cap_is_refused_from_its_header() {
    let tmp = tempfile::tempdir().unwrap();
    sparse_binary_stl(&tmp.path().join("big.stl"), 10_000_000);
    mesh_urdf(tmp.path(), "holder.urdf", "big.stl");
    let needles = [
        "big.stl: STL mesh with 10,000,000 triangles (binary STL header, file not read)",
        "over the cap of 2,000,000 triangles per mesh",
        "simplify it",
    ];
    let r = run(
        &[
            "simulate",
            "holder.urdf",
            "--duration",
            "0.01",
            "--out",
            "out/r",
        ],
        tmp.path(),
    );
    assert_refused(&r, &needles, tmp.path());
    let r = run(
        &["inspect", "holder.urdf", "--inertia", "geometry"],
        tmp.path(),
    );
    assert_refused(&r, &needles, tmp.path());

    // A header claiming 10^7 triangles in a file of 134 bytes is no binary STL of 10^7
    // triangles: refused as what it is, at once.
    let mut small = vec![0u8; 134];
    small[80..84].copy_from_slice(&10_000_000u32.to_le_bytes());
    write(&tmp.path().join("liar.stl"), small);
    mesh_urdf(tmp.path(), "liar.urdf", "liar.stl");
    let r = run(
        &["inspect", "liar.urdf", "--inertia", "geometry"],
        tmp.path(),
    );
    assert_refused(
        &r,
        &[
            "liar.stl",
            "binary STL header says 10000000 triangles",
            "the file has 134 bytes",
        ],
        tmp.path(),
    );
}

/// ASCII STL (18 MB of `endfacet` lines) and OBJ (16 MB of faces) over the cap are refused
/// from a count made before parsing; the message names the file, the count and the cap.
#[test]
fn text_meshes_over_the_cap_are_refused_before_parsing() {
    let tmp = tempfile::tempdir().unwrap();
    let over = 2_000_001;
    write(
        &tmp.path().join("big_ascii.stl"),
        format!("solid a\n{}endsolid a\n", "endfacet\n".repeat(over)),
    );
    write(
        &tmp.path().join("big.obj"),
        format!("v 0 0 0\n{}", "f 1 1 1\n".repeat(over)),
    );
    for (mesh, how) in [
        ("big_ascii.stl", "ASCII STL facets counted"),
        ("big.obj", "OBJ faces counted"),
    ] {
        mesh_urdf(tmp.path(), "holder.urdf", mesh);
        for args in [
            vec!["inspect", "holder.urdf", "--inertia", "geometry"],
            vec![
                "simulate",
                "holder.urdf",
                "--duration",
                "0.01",
                "--out",
                "out/r",
            ],
        ] {
            let r = run(&args, tmp.path());
            assert_refused(
                &r,
                &[
                    mesh,
                    "more than 2,000,000 triangles",
                    how,
                    "over the cap of 2,000,000 triangles per mesh",
                ],
                tmp.path(),
            );
        }
    }
}

/// The recordings draw every copy's visuals: 11 copies of a model whose visual mesh has
/// 10^6 triangles are 1.1e7 to draw, over the 10^7 per scene. Refused before any file (the
/// mesh's header is all that is read: the file is sparse).
#[test]
fn the_triangles_a_scene_draws_are_capped() {
    let tmp = tempfile::tempdir().unwrap();
    sparse_binary_stl(&tmp.path().join("million.stl"), 1_000_000);
    mesh_urdf(tmp.path(), "holder.urdf", "million.stl");
    write(
        &tmp.path().join("many.toml"),
        "[sim]\nduration = 0.01\n[[model]]\nurdf = \"holder.urdf\"\ncopies = 11\n",
    );
    let r = run(&["simulate", "many.toml", "--out", "out/r"], tmp.path());
    assert_refused(
        &r,
        &[
            "many.toml: the recordings would draw 11,000,000 mesh triangles, over the cap of 10,000,000 per scene",
            "million.stl, 1,000,000 triangles drawn 11 times",
            "--format parquet",
        ],
        tmp.path(),
    );
}

// ------------------------------------------------------------------------------ values

/// `models/<name>` with `from` replaced by `to` (once, checked), written to `dir/file`.
fn edited_model(dir: &Path, name: &str, file: &str, edits: &[(&str, &str)]) {
    let mut text = std::fs::read_to_string(common::root().join("models").join(name)).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{name} lacks {from}");
        text = text.replacen(from, to, 1);
    }
    write(&dir.join(file), text);
}

/// A scene `file` of one model table `model` (TOML lines) after `sim` (TOML lines).
fn scene(dir: &Path, file: &str, sim: &str, model: &str) {
    write(
        &dir.join(file),
        if sim.contains("duration") {
            format!("[sim]\n{sim}\n[[model]]\n{model}\n")
        } else {
            format!("[sim]\nduration = 0.1\n{sim}\n[[model]]\n{model}\n")
        },
    );
}

/// Before: a kept joint whose axis is zero, NaN or infinite reached the solver, which failed
/// at step 1 (exit 3: "the implicit step's Newton solve did not converge"). Now refused naming
/// the file, the model, the joint and the axis; a huge but finite axis is a direction.
#[test]
fn joint_axes_without_a_direction_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    for (axis, shown) in [
        ("0 0 0", "[0, 0, 0]"),
        ("nan 0 0", "[NaN, 0, 0]"),
        ("0 inf 0", "[0, inf, 0]"),
        ("1e300 -inf 0", "[1e300, -inf, 0]"),
    ] {
        edited_model(
            tmp.path(),
            "cart_pole.urdf",
            "axis.urdf",
            &[("<axis xyz=\"0 1 0\"/>", &format!("<axis xyz=\"{axis}\"/>"))],
        );
        scene(
            tmp.path(),
            "axis.toml",
            "",
            "urdf = \"axis.urdf\"\nbodies = \"articulated\"\nbase = \"fixed\"",
        );
        let r = run(&["simulate", "axis.toml", "--out", "out/r"], tmp.path());
        assert_refused(
            &r,
            &[
                "axis.toml: model[0]: bodies = \"articulated\": model `cart_pole` (axis.urdf)",
                &format!(
                    "joint `hinge` moves about or along its axis {shown}, which has no direction"
                ),
                "locked_joints = [\"hinge\"]",
            ],
            tmp.path(),
        );
    }
    // [1e200, 1e200, 0] is the direction (1, 1, 0) / √2 (its squared norm overflows).
    edited_model(
        tmp.path(),
        "cart_pole.urdf",
        "axis.urdf",
        &[("<axis xyz=\"0 1 0\"/>", "<axis xyz=\"1e200 1e200 0\"/>")],
    );
    let r = run(&["simulate", "axis.toml", "--out", "ok/r"], tmp.path());
    assert_eq!(r.status, Some(0), "{}", r.stderr);
}

/// Before: `joint_velocities = { slide = 1e300 }` (a prismatic joint) failed at step 1 with a
/// NaN energy (exit 3), `linvel = -1e300` ran to the end recording an infinite energy (exit 0
/// in links mode, 3 articulated), `linvel = [1e308, 1e308, 0]` stopped with "grew to 1.000e0
/// times (limit 100)", `angvel = 1e308` failed at step 1 after a warning with `|Ω| = inf`.
/// Now each is refused naming the file, the model, the body and the key that set it.
#[test]
fn absurd_velocities_are_refused_naming_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    for file in ["box.urdf", "cart_pole.urdf", "chain3_free.urdf"] {
        std::fs::copy(
            common::root().join("models").join(file),
            tmp.path().join(file),
        )
        .unwrap();
    }
    for (model, needles) in [
        (
            "urdf = \"cart_pole.urdf\"\nbodies = \"articulated\"\nbase = \"fixed\"\njoint_velocities = { slide = 1e300 }",
            vec![
                "body `cart` starts 0 m from the origin at 1e300 m/s",
                "it would get 1e299 m away, beyond the 1e15 m",
                "set by joint_velocities.slide = 1e300",
            ],
        ),
        (
            "urdf = \"box.urdf\"\nlinvel = [-1e300, 0, 0]",
            vec![
                "body `box` starts 0 m from the origin at 1e300 m/s",
                "set by linvel = [-1e300, 0, 0]",
            ],
        ),
        (
            "urdf = \"chain3_free.urdf\"\nbodies = \"articulated\"\nlinvel = [-1e300, 0, 0]",
            vec![
                "body `link0`",
                "at 1e300 m/s",
                "set by linvel = [-1e300, 0, 0]",
            ],
        ),
        (
            "urdf = \"box.urdf\"\nlinvel = [1e308, 1e308, 0]",
            vec![
                "body `box` starts 0 m from the origin at 1.4142135623730951e308 m/s",
                "set by linvel = [1e308, 1e308, 0]",
            ],
        ),
        (
            "urdf = \"box.urdf\"\nangvel = [1e308, 0, 0]",
            vec![
                "body `box` starts with a kinetic energy of inf J (6 kg at 0 m/s, turning at 1e308 rad/s)",
                "divergence guard could not watch it",
                "set by angvel = [1e308, 0, 0]",
            ],
        ),
        (
            "urdf = \"chain3_free.urdf\"\nbodies = \"articulated\"\njoint_velocities = { j2 = 1e200, j1 = 2 }",
            vec![
                "body `link2` starts 1.5 m from the origin at 3.0000000000000005e199 m/s",
                "set by joint_velocities.j2 = 1e200, joint_velocities.j1 = 2",
            ],
        ),
        (
            "urdf = \"box.urdf\"\nposition = [2e15, 0, 0]",
            vec![
                "body `box` starts 2e15 m from the origin at 0 m/s",
                "set by position = [2e15, 0, 0]",
            ],
        ),
    ] {
        scene(tmp.path(), "v.toml", "", model);
        let r = run(&["simulate", "v.toml", "--out", "out/r"], tmp.path());
        let mut all = vec![
            "v.toml: model[0]: ",
            "docs/limits.md, \"Bounds on initial values\"",
        ];
        all.extend(needles);
        assert_refused(&r, &all, tmp.path());
    }
    // At the bound: 1e16 m/s for 0.1 s is 1e15 m, accepted (and run).
    scene(
        tmp.path(),
        "v.toml",
        "",
        "urdf = \"box.urdf\"\nlinvel = [1e16, 0, 0]",
    );
    let r = run(&["simulate", "v.toml", "--out", "ok/r"], tmp.path());
    assert_eq!(r.status, Some(0), "{}", r.stderr);
}

/// Before: a mimic joint mimicking itself, or two mimicking each other, failed at step 12 and
/// 35 (exit 3, Newton). Now refused naming the cycle, of any length.
#[test]
fn mimic_cycles_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let j1 = "<axis xyz=\"0 0 1\"/>";
    let j2 = "<axis xyz=\"0 1 0\"/>";
    for (edits, cycle) in [
        (
            vec![(j1, "<axis xyz=\"0 0 1\"/><mimic joint=\"j1\"/>")],
            "(`j1` mimics `j1`)",
        ),
        (
            vec![
                (j1, "<axis xyz=\"0 0 1\"/><mimic joint=\"j2\"/>"),
                (
                    j2,
                    "<axis xyz=\"0 1 0\"/><mimic joint=\"j1\" multiplier=\"-1\"/>",
                ),
            ],
            "(`j1` mimics `j2`, `j2` mimics `j1`)",
        ),
    ] {
        edited_model(tmp.path(), "chain3_free.urdf", "m.urdf", &edits);
        scene(
            tmp.path(),
            "m.toml",
            "",
            "urdf = \"m.urdf\"\nbodies = \"articulated\"\nangvel = [0, 0.3, 0.5]",
        );
        let r = run(&["simulate", "m.toml", "--out", "out/r"], tmp.path());
        assert_refused(
            &r,
            &[
                "m.toml: model[0]: bodies = \"articulated\": model `chain3_free` (m.urdf)",
                &format!("the mimic joints form a cycle {cycle}"),
                "remove the <mimic> of one of them",
            ],
            tmp.path(),
        );
    }
}

/// Before: `dt = 1e-12` with `log_every = 1` failed in the Rerun writer with "frame time 0 ns
/// is not after 0 ns" (no key, no file). Now refused before the run naming both keys and the
/// smallest log_every that works; and a run past the timestamps' 292 years is refused too.
#[test]
fn frames_closer_than_a_nanosecond_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::copy(
        common::root().join("models/box.urdf"),
        tmp.path().join("box.urdf"),
    )
    .unwrap();
    scene(
        tmp.path(),
        "dt.toml",
        "dt = 1e-12\nlog_every = 1",
        "urdf = \"box.urdf\"",
    );
    let r = run(
        &[
            "simulate",
            "dt.toml",
            "--out",
            "out/r",
            "--duration",
            "1e-10",
        ],
        tmp.path(),
    );
    assert_refused(
        &r,
        &[
            "dt.toml: sim.dt = 1e-12 s with sim.log_every = 1 records a frame every 1e-12 s",
            "recorded frames must be at least 1 ns apart (recording timestamps are whole nanoseconds)",
            "raise sim.log_every to at least 1000",
        ],
        tmp.path(),
    );
    // 1000 steps of 1e-12 s per frame: 1 ns apart, accepted (the file's values are judged
    // before command-line overrides, so the file says it).
    scene(
        tmp.path(),
        "dt_ok.toml",
        "dt = 1e-12\nlog_every = 1000",
        "urdf = \"box.urdf\"",
    );
    let r = run(
        &[
            "simulate",
            "dt_ok.toml",
            "--out",
            "ok/r",
            "--duration",
            "1e-8",
        ],
        tmp.path(),
    );
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    scene(
        tmp.path(),
        "long.toml",
        "dt = 1e6\nduration = 1e10",
        "urdf = \"box.urdf\"",
    );
    let r = run(&["simulate", "long.toml", "--out", "out/r"], tmp.path());
    assert_refused(
        &r,
        &["long.toml: sim.duration = 10000000000 s", "292 years"],
        tmp.path(),
    );
}

/// No warning prints a number in full: before, `dt = 1e300` printed "dt = 1000…000 s" (301
/// digits) in the step warning, and a URDF range of ±1e300 would have printed 301 digits in
/// the joint-range warning.
#[test]
fn warnings_print_numbers_readably() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::copy(
        common::root().join("models/box.urdf"),
        tmp.path().join("box.urdf"),
    )
    .unwrap();
    // 0 steps of 1e300 s (duration 0.1 s): the step warning names dt, the run writes step 0.
    scene(
        tmp.path(),
        "big_dt.toml",
        "dt = 1e300",
        "urdf = \"box.urdf\"\nangvel = [0, 1, 0.1]",
    );
    let r = run(&["simulate", "big_dt.toml", "--out", "out/a"], tmp.path());
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    assert!(
        r.stderr.contains("warning: dt = 1e300 s is too large"),
        "{}",
        r.stderr
    );
    assert!(longest_digit_run(&r.stderr) <= 20, "{}", r.stderr);
    // A range of [-1e300, -1e299]: the slide starts outside it, at 0.
    edited_model(
        tmp.path(),
        "cart_pole.urdf",
        "wide.urdf",
        &[(
            "lower=\"-100\" upper=\"100\"",
            "lower=\"-1e300\" upper=\"-1e299\"",
        )],
    );
    scene(
        tmp.path(),
        "wide.toml",
        "",
        "urdf = \"wide.urdf\"\nbodies = \"articulated\"\nbase = \"fixed\"",
    );
    let r = run(&["simulate", "wide.toml", "--out", "out/b"], tmp.path());
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    assert!(
        r.stderr
            .contains("left its URDF range [-1e300, -1e299] at t = 0 s (position 0.000000)"),
        "{}",
        r.stderr
    );
    assert!(longest_digit_run(&r.stderr) <= 20, "{}", r.stderr);
}

/// The joint-range warning fires only beyond round-off of the bounds (1e-9 of them, plus
/// 1e-9): a slide placed at -1e-12 in [0, 1] (a read-back "-0.000000") is at its bound and
/// stays quiet; at -1e-6 it warns, once. The sweeps of `trade` run many variants of a scene and
/// never warn.
#[test]
fn joint_range_warnings_need_more_than_round_off_and_stay_out_of_sweeps() {
    let tmp = tempfile::tempdir().unwrap();
    edited_model(
        tmp.path(),
        "cart_pole.urdf",
        "rail.urdf",
        &[("lower=\"-100\" upper=\"100\"", "lower=\"0\" upper=\"1\"")],
    );
    let model = |slide: &str| {
        format!(
            "urdf = \"rail.urdf\"\nbodies = \"articulated\"\nbase = \"fixed\"\n\
             joint_limits = false\njoints = {{ slide = {slide} }}"
        )
    };
    let needle = "joint \"slide\" left its URDF range [0, 1]";
    scene(tmp.path(), "round_off.toml", "", &model("-1e-12"));
    let r = run(
        &["simulate", "round_off.toml", "--out", "out/a"],
        tmp.path(),
    );
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    assert!(!r.stderr.contains("left its URDF range"), "{}", r.stderr);
    scene(tmp.path(), "outside.toml", "", &model("-1e-6"));
    let r = run(&["simulate", "outside.toml", "--out", "out/b"], tmp.path());
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    assert_eq!(r.stderr.matches(needle).count(), 1, "{}", r.stderr);
    let r = run(
        &[
            "trade",
            "outside.toml",
            "--out",
            "t",
            "--dt",
            "0.01",
            "--duration",
            "0.1",
            "--drift-horizon",
            "0.1",
            "--repeats",
            "1",
            "--integrators",
            "variational",
        ],
        tmp.path(),
    );
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    assert!(!r.stderr.contains("left its URDF range"), "{}", r.stderr);
}
