//! The hostile-input corpus (`tests/hostile/`): malformed and adversarial URDFs, scenes and
//! meshes, each run through the `tumble` binary with the outcome `tests/hostile/expected.toml`
//! states for it, plus cases made at run time (huge counts, deep nesting, FIFOs, files over the
//! size caps) and calls of the library readers.
//!
//! Every run must: exit with the expected status; print the expected substrings (an error names
//! the file, and where there is one the link or element and the rule); never panic (no
//! "panicked", "RUST_BACKTRACE" or "stack overflow" on stderr); leave no recording under the
//! final name (nor a `.part` file) when it fails; and finish within [`HANG_LIMIT`] (hang
//! detection: the child is killed and the test fails; not a speed test).

use crate::common;
use crate::common::urdfs::write;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// A run still going after this is a hang: it is killed and the test fails.
const HANG_LIMIT: Duration = Duration::from_secs(60);

use common::limited::Limited as Run;

/// Runs `tumble args` in `cwd`, killing it after [`HANG_LIMIT`].
fn run_with_limit(args: &[String], cwd: &Path) -> Run {
    common::limited::run_limited(args, cwd, HANG_LIMIT)
}

/// What every run must satisfy whatever its case: no panic, no crash.
fn assert_no_panic(what: &str, run: &Run) {
    for bad in ["panicked", "RUST_BACKTRACE", "stack overflow", "SIGSEGV"] {
        assert!(
            !run.stderr.contains(bad),
            "{what}: stderr has {bad:?}:\n{}",
            run.stderr
        );
    }
    assert!(
        run.status.is_some(),
        "{what}: killed by a signal (crash):\n{}",
        run.stderr
    );
}

// ------------------------------------------------------------------------------ the corpus

#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Expected {
    case: Vec<Case>,
}

#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    /// Relative to `tests/hostile`.
    file: String,
    /// Arguments; `{file}` is the case file, `{out}` a temporary output stem, `{mesh_urdf}` a
    /// URDF whose one link has the case file as its collision (and visual) mesh. Default by
    /// folder: `urdf/` → `inspect {file}`, `scene/` → `simulate {file} --out {out}`,
    /// `mesh/` → `inspect {mesh_urdf} --inertia geometry`.
    #[serde(default)]
    run: Option<Vec<String>>,
    status: i32,
    #[serde(default)]
    stderr: Vec<String>,
    #[serde(default)]
    stdout: Vec<String>,
    /// For `mesh/` cases: a substring of the error `mesh_io::load_mass_properties` returns.
    #[serde(default)]
    reader: Option<String>,
    /// Why the case is here (documentation only).
    #[serde(default)]
    why: Option<String>,
}

fn hostile_dir() -> PathBuf {
    common::root().join("tests/hostile")
}

fn expected() -> Expected {
    let text = std::fs::read_to_string(hostile_dir().join("expected.toml")).unwrap();
    toml::from_str(&text).unwrap_or_else(|e| panic!("expected.toml: {e}"))
}

fn default_run(file: &str) -> Vec<&'static str> {
    match file.split('/').next() {
        Some("urdf") => vec!["inspect", "{file}"],
        Some("scene") => vec!["simulate", "{file}", "--out", "{out}"],
        Some("mesh") => vec!["inspect", "{mesh_urdf}", "--inertia", "geometry"],
        _ => panic!("{file}: a case must be under urdf/, scene/ or mesh/"),
    }
}

/// A URDF with one link whose collision and visual geometry is the mesh at `mesh`.
fn mesh_urdf(dir: &Path, mesh: &Path) -> PathBuf {
    let path = dir.join("mesh_holder.urdf");
    let mesh = mesh.display();
    std::fs::write(
        &path,
        format!(
            r#"<robot name="holder"><link name="holder">
                 <collision name="c"><geometry><mesh filename="{mesh}"/></geometry></collision>
                 <visual name="v"><geometry><mesh filename="{mesh}"/></geometry></visual>
               </link></robot>"#
        ),
    )
    .unwrap();
    path
}

/// Runs one case; returns what went wrong, if anything.
fn check_case(case: &Case) -> Result<(), String> {
    let dir = hostile_dir();
    let file = dir.join(&case.file);
    if !file.exists() {
        return Err(format!("{}: no such file", case.file));
    }
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out/rec");
    // The holder sits beside a copy of a mesh case: meshes are read only inside the URDF's
    // folder (src/model/confine.rs; tests/model/mesh_paths.rs).
    let mesh = if case.file.starts_with("mesh/") {
        let beside = tmp.path().join(file.file_name().unwrap());
        std::fs::copy(&file, &beside).unwrap();
        beside
    } else {
        file.clone()
    };
    let holder = mesh_urdf(tmp.path(), &mesh);
    let template: Vec<String> = match &case.run {
        Some(run) => run.clone(),
        None => default_run(&case.file)
            .into_iter()
            .map(String::from)
            .collect(),
    };
    let args: Vec<String> = template
        .iter()
        .map(|a| {
            a.replace("{file}", &case.file)
                .replace("{out}", &out.display().to_string())
                .replace("{mesh_urdf}", &holder.display().to_string())
        })
        .collect();
    let run = run_with_limit(&args, &dir);
    let what = format!("{} (tumble {})", case.file, args.join(" "));
    assert_no_panic(&what, &run);
    let mut wrong = Vec::new();
    if run.status != Some(case.status) {
        wrong.push(format!(
            "exit status {:?}, expected {}",
            run.status, case.status
        ));
    }
    for s in &case.stderr {
        if !run.stderr.contains(s.as_str()) {
            wrong.push(format!("stderr lacks {s:?}"));
        }
    }
    for s in &case.stdout {
        if !run.stdout.contains(s.as_str()) {
            wrong.push(format!("stdout lacks {s:?}"));
        }
    }
    if case.status == 2 {
        // An error names the file it is about.
        let name = file.file_name().unwrap().to_string_lossy();
        if !run.stderr.contains(name.as_ref()) {
            wrong.push(format!("the error does not name the file {name}"));
        }
        if !run.stderr.trim_start().starts_with("error:") && !run.stderr.contains("\nerror:") {
            wrong.push("no `error:` line".into());
        }
    }
    if case.status != 0 {
        for ext in ["mcap", "rrd", "mcap.part", "rrd.part"] {
            let p = tmp.path().join(format!("out/rec.{ext}"));
            if p.exists() {
                wrong.push(format!("a failed run left {}", p.display()));
            }
        }
    }
    if let Some(reader) = &case.reader {
        let result = tumble::model::geometry::mesh_io::load_mass_properties(
            &file,
            &nalgebra::Vector3::repeat(1.0),
            1000.0,
        );
        match result {
            Ok(_) => wrong.push("the mesh reader accepted it".into()),
            Err(e) if !e.to_string().contains(reader.as_str()) => {
                wrong.push(format!("the mesh reader's error {e:?} lacks {reader:?}"))
            }
            Err(_) => {}
        }
    }
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{what}:\n  {}\n--- stderr:\n{}--- stdout (first 2000 bytes):\n{}",
            wrong.join("\n  "),
            run.stderr,
            &run.stdout[..run.stdout.len().min(2000)]
        ))
    }
}

#[test]
fn every_corpus_case_gives_its_expected_outcome() {
    let expected = expected();
    let failures: Vec<String> = expected
        .case
        .iter()
        .filter_map(|c| check_case(c).err())
        .collect();
    assert!(
        failures.is_empty(),
        "{} of {} hostile cases failed:\n\n{}",
        failures.len(),
        expected.case.len(),
        failures.join("\n\n")
    );
}

/// Every file of the corpus has an expectation, and every expectation a file.
#[test]
fn the_manifest_covers_the_corpus() {
    let expected = expected();
    let listed: std::collections::BTreeSet<&str> =
        expected.case.iter().map(|c| c.file.as_str()).collect();
    let mut missing = Vec::new();
    for sub in ["urdf", "scene", "mesh"] {
        for entry in std::fs::read_dir(hostile_dir().join(sub)).unwrap() {
            let name = format!("{sub}/{}", entry.unwrap().file_name().to_string_lossy());
            if !listed.contains(name.as_str()) {
                missing.push(name);
            }
        }
    }
    // Helper files the cases use rather than cases themselves.
    missing.retain(|m| {
        !matches!(
            m.as_str(),
            "scene/ok.urdf" | "scene/nan_mass.urdf" | "mesh/cube.stl" | "mesh/dae_tetra_ok.dae"
        )
    });
    assert!(missing.is_empty(), "no expectation for {missing:?}");
    assert!(
        expected.case.len() >= 60,
        "only {} cases",
        expected.case.len()
    );
    for c in &expected.case {
        assert!(
            [0, 1, 2].contains(&c.status),
            "{}: status {}",
            c.file,
            c.status
        );
        assert!(
            c.status == 0 || !c.stderr.is_empty() || !c.stdout.is_empty(),
            "{}: a failing case must say what message it expects",
            c.file
        );
        let _ = &c.why;
    }
}

// ------------------------------------------------------------------------------ made at run time

fn args(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

const INERTIAL: &str = r#"<inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="2.5"/></inertial>"#;

/// A chain of `n` links (an `n`-deep kinematic tree), one revolute joint between neighbours.
fn chain_urdf(n: usize) -> String {
    let mut xml = String::from("<robot name=\"chain\">\n");
    for i in 0..n {
        xml.push_str(&format!("<link name=\"l{i}\">{INERTIAL}</link>\n"));
        if i > 0 {
            xml.push_str(&format!(
                "<joint name=\"j{i}\" type=\"revolute\"><origin xyz=\"0 0 0.01\"/>\
                 <parent link=\"l{}\"/><child link=\"l{i}\"/><axis xyz=\"0 1 0\"/>\
                 <limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>\n",
                i - 1
            ));
        }
    }
    xml.push_str("</robot>\n");
    xml
}

/// 100 000 links in one chain (a 100 000-deep kinematic tree) load and inspect without
/// recursion limits; 10 000 of them simulate (one step). (`simulate` at 100 000 bodies is
/// bounded by the Rerun SDK's encoder, which grows faster than linearly in the number of
/// entities: 6 s at 10 000, 18 s at 20 000 on the development machine.)
#[test]
fn a_hundred_thousand_links_in_a_chain() {
    let tmp = tempfile::tempdir().unwrap();
    let n = 100_000;
    write(&tmp.path().join("chain.urdf"), chain_urdf(n));
    let run = run_with_limit(&args(&["inspect", "chain.urdf", "--json"]), tmp.path());
    assert_no_panic("inspect chain", &run);
    assert_eq!(run.status, Some(0), "{}", run.stderr);
    let report: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    assert_eq!(report["links"].as_array().unwrap().len(), n);
    assert_eq!(report["total_mass"].as_f64(), Some(n as f64));
    let n = 10_000;
    write(&tmp.path().join("chain10k.urdf"), chain_urdf(n));
    let run = run_with_limit(
        &args(&[
            "simulate",
            "chain10k.urdf",
            "--duration",
            "0.001",
            "--out",
            "out/chain",
            "--no-ellipsoids",
        ]),
        tmp.path(),
    );
    assert_no_panic("simulate chain", &run);
    assert_eq!(run.status, Some(0), "{}", run.stderr);
    assert!(run.stdout.contains(&format!("simulated {n} bodies")));
}

/// 200 000 nested elements inside a link: an error or a load, never a stack overflow.
#[test]
fn deeply_nested_xml_is_refused_without_a_crash() {
    let tmp = tempfile::tempdir().unwrap();
    let depth = 200_000;
    let xml = format!(
        "<robot name=\"deep\"><link name=\"base\">{INERTIAL}{}{}</link></robot>\n",
        "<extra>".repeat(depth),
        "</extra>".repeat(depth)
    );
    write(&tmp.path().join("deep.urdf"), &xml);
    let run = run_with_limit(&args(&["inspect", "deep.urdf"]), tmp.path());
    assert_no_panic("deep urdf", &run);
    assert_eq!(run.status, Some(2), "{}", run.stderr);
    assert!(run.stderr.contains("deep.urdf"), "{}", run.stderr);

    let dae = format!(
        "<COLLADA version=\"1.4.1\">{}{}</COLLADA>",
        "<node>".repeat(depth),
        "</node>".repeat(depth)
    );
    write(&tmp.path().join("deep.dae"), &dae);
    let holder = mesh_urdf(tmp.path(), &tmp.path().join("deep.dae"));
    let run = run_with_limit(
        &args(&["inspect", holder.to_str().unwrap(), "--inertia", "geometry"]),
        tmp.path(),
    );
    assert_no_panic("deep dae", &run);
    assert_eq!(run.status, Some(2), "{}", run.stderr);
    assert!(run.stderr.contains("deep.dae"), "{}", run.stderr);

    let toml = format!(
        "[sim]\ngravity = {}0.0{}\n[[model]]\nurdf = \"x.urdf\"\n",
        "[".repeat(depth),
        "]".repeat(depth)
    );
    write(&tmp.path().join("deep.toml"), &toml);
    let run = run_with_limit(&args(&["simulate", "deep.toml", "--out", "o"]), tmp.path());
    assert_no_panic("deep toml", &run);
    assert_eq!(run.status, Some(2), "{}", run.stderr);
    assert!(run.stderr.contains("deep.toml"), "{}", run.stderr);
}

/// A FIFO (named pipe) as the scene, the URDF or a mesh is refused before it is opened: opening
/// it would wait for a writer for ever.
#[cfg(unix)]
#[test]
fn fifos_are_refused_not_waited_on() {
    let tmp = tempfile::tempdir().unwrap();
    for name in ["pipe.urdf", "pipe.toml", "pipe.stl"] {
        let status = Command::new("mkfifo")
            .arg(tmp.path().join(name))
            .status()
            .expect("mkfifo");
        assert!(status.success());
    }
    let rule = "not a regular file but a FIFO";
    let run = run_with_limit(&args(&["inspect", "pipe.urdf"]), tmp.path());
    assert_no_panic("fifo urdf", &run);
    assert_eq!(run.status, Some(2));
    assert!(
        run.stderr.contains("pipe.urdf") && run.stderr.contains(rule),
        "{}",
        run.stderr
    );
    let run = run_with_limit(&args(&["simulate", "pipe.toml", "--out", "o"]), tmp.path());
    assert_eq!(run.status, Some(2));
    assert!(
        run.stderr.contains("pipe.toml") && run.stderr.contains(rule),
        "{}",
        run.stderr
    );
    write(
        &tmp.path().join("scene.toml"),
        "[[model]]\nurdf = \"pipe.urdf\"\n",
    );
    let run = run_with_limit(&args(&["simulate", "scene.toml", "--out", "o"]), tmp.path());
    assert_eq!(run.status, Some(2));
    assert!(
        run.stderr.contains("pipe.urdf") && run.stderr.contains(rule),
        "{}",
        run.stderr
    );
    let holder = mesh_urdf(tmp.path(), &tmp.path().join("pipe.stl"));
    let run = run_with_limit(
        &args(&["inspect", holder.to_str().unwrap(), "--inertia", "geometry"]),
        tmp.path(),
    );
    assert_no_panic("fifo mesh", &run);
    assert_eq!(run.status, Some(2));
    assert!(
        run.stderr.contains("pipe.stl") && run.stderr.contains(rule),
        "{}",
        run.stderr
    );
    assert!(!tmp.path().join("o.mcap").exists());
}

/// Files over the size caps are refused from their size alone (sparse files: nothing is
/// written or read).
#[test]
fn files_over_the_size_caps_are_refused_unread() {
    let tmp = tempfile::tempdir().unwrap();
    let sparse = |name: &str, len: u64| {
        let f = std::fs::File::create(tmp.path().join(name)).unwrap();
        f.set_len(len).unwrap();
    };
    sparse("big.stl", tumble::input::MESH_MAX_BYTES + 1);
    sparse("big.urdf", tumble::input::URDF_MAX_BYTES + 1);
    sparse("big.toml", tumble::input::SCENE_MAX_BYTES + 1);
    let run = run_with_limit(&args(&["inspect", "big.urdf"]), tmp.path());
    assert_eq!(run.status, Some(2));
    assert!(
        run.stderr.contains("big.urdf") && run.stderr.contains("over the 256 MiB limit"),
        "{}",
        run.stderr
    );
    let run = run_with_limit(&args(&["simulate", "big.toml", "--out", "o"]), tmp.path());
    assert_eq!(run.status, Some(2));
    assert!(
        run.stderr.contains("big.toml") && run.stderr.contains("over the 16 MiB limit"),
        "{}",
        run.stderr
    );
    let holder = mesh_urdf(tmp.path(), &tmp.path().join("big.stl"));
    let run = run_with_limit(&args(&["inspect", holder.to_str().unwrap()]), tmp.path());
    assert_eq!(run.status, Some(1), "{}", run.stderr);
    assert!(
        run.stdout.contains("big.stl") && run.stdout.contains("over the 512 MiB limit"),
        "{}",
        run.stdout
    );
}

/// A symbolic link named like a mesh but pointing at a device is judged by its target: outside
/// the URDF's folder it is refused (src/model/confine.rs), and where reading it is allowed it is
/// still no regular file.
#[cfg(unix)]
#[test]
fn a_symlink_to_a_device_is_not_a_mesh() {
    let tmp = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink("/dev/zero", tmp.path().join("zero.stl")).unwrap();
    let err = tumble::model::geometry::mesh_io::load_mesh(&tmp.path().join("zero.stl"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("zero.stl") && err.contains("character device"),
        "{err}"
    );
    let holder = mesh_urdf(tmp.path(), &tmp.path().join("zero.stl"));
    let model = tumble::model::urdf::load(&holder, &Default::default()).unwrap();
    let problems = &model.links[0].problems;
    assert!(
        problems
            .iter()
            .any(|p| p.contains("real path /dev/zero") && p.contains("refused")),
        "{problems:?}"
    );
    assert!(model.check_meshes().is_err());
    let allowed = tumble::model::confine::MeshAccess {
        allowed: vec![PathBuf::from("/dev")],
        scene_folder: None,
    };
    let model = tumble::model::urdf::load(
        &holder,
        &tumble::model::urdf::LoadOptions {
            mesh_access: allowed,
            ..Default::default()
        },
    )
    .unwrap();
    let problems = &model.links[0].problems;
    assert!(
        problems.iter().any(|p| p.contains("character device")),
        "{problems:?}"
    );
}

/// A real robot's layout keeps working: `pkg/urdf/robot.urdf` reaching `../meshes/x.stl`, and
/// `package://pkg/urdf/../meshes/x.stl` (a `..` that stays inside the package).
#[test]
fn relative_parent_paths_inside_a_package_still_resolve() {
    let tmp = tempfile::tempdir().unwrap();
    let pkg = tmp.path().join("pkg");
    std::fs::create_dir_all(pkg.join("meshes")).unwrap();
    std::fs::copy(
        hostile_dir().join("mesh/cube.stl"),
        pkg.join("meshes/cube.stl"),
    )
    .unwrap();
    for uri in [
        "../meshes/cube.stl",
        "package://pkg/meshes/cube.stl",
        "package://pkg/urdf/../meshes/cube.stl",
    ] {
        let urdf = pkg.join("urdf/robot.urdf");
        write(
            &urdf,
            format!(
                r#"<robot name="r"><link name="base">
                     <collision><geometry><mesh filename="{uri}"/></geometry></collision>
                   </link></robot>"#
            ),
        );
        let run = run_with_limit(
            &args(&[
                "inspect",
                "urdf/robot.urdf",
                "--inertia",
                "geometry",
                "--json",
            ]),
            &pkg,
        );
        assert_eq!(run.status, Some(0), "{uri}: {}", run.stderr);
        let report: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
        let mass = report["total_mass"].as_f64().unwrap();
        assert!((mass - 1000.0).abs() < 1e-9, "{uri}: {mass}");
    }
}
