//! Mesh paths are confined (issue 28, item 3; `src/model/confine.rs`): a URDF cannot make tumble
//! read, or embed in any recording, a file outside the URDF's folder (or ROS package), the
//! package paths, `ROS_PACKAGE_PATH`, the scene's folder and the folders allowed with
//! `--allow-mesh-path` / `allow_mesh_paths`; links are resolved before the check. And a file
//! tumble's mesh reader rejects is never embedded, wherever it is.
//!
//! Every case runs the release binary and then looks for a marker string in every byte of every
//! file under the output folder (`.part` leftovers included).

use crate::common::urdfs::write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// In the secret file outside the model's folders (a `/etc/passwd` stand-in).
const SECRET: &str = "TUMBLE_SECRET_7f3a_root:x:0:0";
/// In a valid OBJ outside the model's folders (embedded once allowed).
const OUTSIDE_MESH: &str = "TUMBLE_OUTSIDE_MESH_51c2";
/// In a valid OBJ inside the URDF's folder, reached through a symbolic link.
const INSIDE_MESH: &str = "TUMBLE_INSIDE_MESH_9d04";
/// In files inside the URDF's folder whose content is no mesh tumble reads.
const REJECTED: &str = "TUMBLE_REJECTED_CONTENT_e6b8";

/// A one-triangle OBJ whose comment line holds `marker`.
fn obj(marker: &str) -> String {
    format!("# {marker}\nv 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 3\n")
}

/// A one-link URDF whose link has one visual per `meshes` entry.
fn urdf(meshes: &[&str]) -> String {
    let visuals: String = meshes
        .iter()
        .map(|m| format!("<visual><geometry><mesh filename=\"{m}\"/></geometry></visual>\n"))
        .collect();
    format!(
        r#"<robot name="r"><link name="base">
  <inertial><mass value="1"/><inertia ixx="0.1" iyy="0.2" izz="0.25" ixy="0" ixz="0" iyz="0"/></inertial>
  {visuals}</link></robot>"#
    )
}

/// The fixture: (the temporary folder, its real path).
///
/// ```text
/// secret/secret.txt            SECRET (a passwd stand-in), and secret/secret.obj, a copy
/// secret/valid.obj             a valid OBJ holding OUTSIDE_MESH
/// robot/model/passwd.obj   ->   /abs/secret/secret.txt (symbolic link)
/// robot/model/meshes/tri.obj    a valid OBJ holding INSIDE_MESH
/// robot/model/tri_link.obj ->   meshes/tri.obj (symbolic link inside the folder)
/// robot/model/notmesh.obj       REJECTED text, no mesh; notmesh.stl, notmesh.glb the same
/// ```
fn fixture() -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let base = tmp.path().canonicalize().unwrap();
    let secret = format!("{SECRET}:/root:/bin/bash\n");
    write(&base.join("secret/secret.txt"), &secret);
    write(&base.join("secret/secret.obj"), &secret);
    write(&base.join("secret/valid.obj"), obj(OUTSIDE_MESH));
    write(&base.join("robot/model/meshes/tri.obj"), obj(INSIDE_MESH));
    for ext in ["obj", "stl", "glb"] {
        write(
            &base.join(format!("robot/model/notmesh.{ext}")),
            format!("{REJECTED} this is not a mesh\n"),
        );
    }
    std::os::unix::fs::symlink(
        base.join("secret/secret.txt"),
        base.join("robot/model/passwd.obj"),
    )
    .unwrap();
    std::os::unix::fs::symlink("meshes/tri.obj", base.join("robot/model/tri_link.obj")).unwrap();
    (tmp, base)
}

/// Runs the release binary in `cwd`, with `ROS_PACKAGE_PATH` unset unless `ros` gives it.
fn tumble(args: &[&str], cwd: &Path, ros: Option<&Path>) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_tumble"));
    command.args(args).current_dir(cwd);
    match ros {
        Some(p) => command.env("ROS_PACKAGE_PATH", p),
        None => command.env_remove("ROS_PACKAGE_PATH"),
    };
    command.output().expect("cannot run tumble")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Every file under `dir` (recursively), with its bytes.
fn files_under(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let meta = std::fs::symlink_metadata(&path).unwrap();
        if meta.is_dir() {
            out.extend(files_under(&path));
        } else {
            out.push((path.clone(), std::fs::read(&path).unwrap_or_default()));
        }
    }
    out
}

fn contains(haystack: &[u8], needle: &str) -> bool {
    haystack
        .windows(needle.len())
        .any(|w| w == needle.as_bytes())
}

/// The files under `dir` holding `marker`.
fn holding(dir: &Path, marker: &str) -> Vec<PathBuf> {
    files_under(dir)
        .into_iter()
        .filter(|(_, bytes)| contains(bytes, marker))
        .map(|(p, _)| p)
        .collect()
}

/// `simulate INPUT` into `out/<name>/run` with every output format, plus `extra`.
fn simulate(base: &Path, input: &Path, name: &str, extra: &[&str]) -> (Output, PathBuf) {
    let out_dir = base.join("out").join(name);
    let stem = out_dir.join("run");
    let mut args = vec![
        "simulate",
        input.to_str().unwrap(),
        "--duration",
        "0.01",
        "--out",
        stem.to_str().unwrap(),
        "--format",
        "mcap,rrd,ros2,parquet",
    ];
    args.extend_from_slice(extra);
    (tumble(&args, base, None), out_dir)
}

/// Each way out of the URDF's folder: refused with exit 2 and one message naming the file,
/// the link, the mesh as written and the resolved (and real) path; nothing written, no byte of
/// the secret anywhere; `inspect` exits 1 and lists the mesh as refused.
#[test]
fn meshes_outside_the_model_folders_are_refused_and_never_embedded() {
    let (_tmp, base) = fixture();
    let secret_obj = base.join("secret/secret.obj");
    let file_uri = format!("file://{}", secret_obj.display());
    let cases: Vec<(&str, String, PathBuf, PathBuf)> = vec![
        // (name, mesh as written, resolved path, real path)
        (
            "symlink",
            "passwd.obj".into(),
            base.join("robot/model/passwd.obj"),
            base.join("secret/secret.txt"),
        ),
        (
            "absolute",
            secret_obj.display().to_string(),
            secret_obj.clone(),
            secret_obj.clone(),
        ),
        (
            "dotdot",
            "../../secret/secret.obj".into(),
            base.join("robot/model/../../secret/secret.obj"),
            secret_obj.clone(),
        ),
        ("file_uri", file_uri, secret_obj.clone(), secret_obj.clone()),
        // The parent-folder search (pybullet's): `<ancestor>/secret/secret.obj`.
        (
            "package_parent",
            "package://secret/secret.obj".into(),
            base.join("secret/secret.obj"),
            secret_obj.clone(),
        ),
    ];
    for (name, mesh, resolved, real) in &cases {
        let urdf_path = base.join(format!("robot/model/{name}.urdf"));
        write(&urdf_path, urdf(&[mesh]));
        let (out, out_dir) = simulate(&base, &urdf_path, name, &[]);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {stderr}");
        for needle in [
            urdf_path.display().to_string(),
            "link `base`".into(),
            "visual #0".into(),
            format!("mesh `{mesh}`"),
            resolved.display().to_string(),
            real.display().to_string(),
            "--allow-mesh-path".into(),
        ] {
            assert!(
                stderr.contains(&needle),
                "{name}: no {needle:?} in {stderr}"
            );
        }
        assert_eq!(stderr.trim_end().lines().count(), 1, "{name}: {stderr}");
        assert!(!stderr.contains(SECRET), "{name}: {stderr}");
        assert!(!text(&out.stdout).contains(SECRET), "{name}");
        // Nothing written at all (no output, no `.part`), so no byte of the secret.
        assert!(files_under(&out_dir).is_empty(), "{name}: {:?}", {
            files_under(&out_dir)
                .into_iter()
                .map(|(p, _)| p)
                .collect::<Vec<_>>()
        });

        // inspect: a problem (exit 1), the mesh listed with its paths.
        let out = tumble(&["inspect", urdf_path.to_str().unwrap()], &base, None);
        let stdout = text(&out.stdout);
        assert_eq!(out.status.code(), Some(1), "{name}: {stdout}");
        assert!(stdout.contains("meshes (1, 1 refused)"), "{name}: {stdout}");
        let line = stdout
            .lines()
            .find(|l| l.contains("REFUSED"))
            .unwrap_or_else(|| panic!("{name}: {stdout}"));
        assert!(line.contains(&format!("`{mesh}`")), "{line}");
        assert!(line.contains(&resolved.display().to_string()), "{line}");
        assert!(line.contains(&real.display().to_string()), "{line}");
        // The real path is named apart only when it differs from the resolved one.
        assert_eq!(line.contains("(real path "), resolved != real, "{line}");
        assert!(stdout.contains("1 link(s) with problems"), "{stdout}");
        let out = tumble(
            &["inspect", urdf_path.to_str().unwrap(), "--json"],
            &base,
            None,
        );
        assert_eq!(out.status.code(), Some(1), "{name}");
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let m = &report["meshes"][0];
        assert_eq!(m["status"], "refused", "{name}: {m}");
        assert_eq!(m["uri"], mesh.as_str());
        assert_eq!(m["link"], "base");
        assert_eq!(m["path"], resolved.display().to_string());
        assert_eq!(m["real_path"], real.display().to_string());
        assert!(
            m["detail"]
                .as_str()
                .unwrap()
                .contains("outside the folders meshes are read from"),
            "{m}"
        );
        assert_eq!(report["ok"], false);
    }

    // All four at once: the first is named, the others counted.
    let all = base.join("robot/model/all.urdf");
    let meshes: Vec<&str> = cases.iter().map(|c| c.1.as_str()).collect();
    write(&all, urdf(&meshes));
    let (out, out_dir) = simulate(&base, &all, "all", &[]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("(and 4 more meshes"), "{stderr}");
    assert!(files_under(&out_dir).is_empty());
    assert!(holding(&base.join("out"), SECRET).is_empty());

    // A scene naming the URDF: the same refusal, from every command that loads it.
    let scene = base.join("scenes/all.toml");
    write(
        &scene,
        format!(
            "[sim]\nduration = 0.01\n[[model]]\nurdf = {:?}\n",
            all.display().to_string()
        ),
    );
    let scene_arg = scene.to_str().unwrap();
    let trade_out = base.join("out/trade");
    for args in [
        vec!["simulate", scene_arg, "--out", "out/scene/run"],
        vec![
            "trade",
            scene_arg,
            "--out",
            trade_out.to_str().unwrap(),
            "--dt",
            "0.005",
            "--repeats",
            "1",
        ],
        vec![
            "bench",
            "--scene",
            scene_arg,
            "--steps",
            "1",
            "--repeats",
            "1",
        ],
        vec![
            "stability",
            "--scene",
            scene_arg,
            "--out",
            "out/stability",
            "--dt",
            "0.005",
        ],
    ] {
        let out = tumble(&args, &base, None);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains("mesh `passwd.obj`"), "{args:?}: {stderr}");
    }
    assert!(holding(&base.join("out"), SECRET).is_empty());
    assert!(holding(&base.join("out"), "TUMBLE_").is_empty());
}

/// `--allow-mesh-path DIR`, the scene's `allow_mesh_paths`, the scene's own folder, a package
/// path and `ROS_PACKAGE_PATH` each allow a mesh outside the URDF's folder; it is then read and
/// embedded as the file it is.
#[test]
fn allowed_folders_admit_a_mesh_outside_the_urdf_folder() {
    let (_tmp, base) = fixture();
    let urdf_path = base.join("robot/model/outside.urdf");
    write(&urdf_path, urdf(&["../../secret/valid.obj"]));
    let rrd_holds_mesh = |out_dir: &Path| {
        let found = holding(out_dir, OUTSIDE_MESH);
        assert!(
            found
                .iter()
                .any(|p| p.extension().is_some_and(|e| e == "rrd")),
            "{found:?}"
        );
    };

    // Refused without a flag.
    let (out, _) = simulate(&base, &urdf_path, "none", &[]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));

    // --allow-mesh-path, relative to the working directory.
    let (out, out_dir) = simulate(&base, &urdf_path, "flag", &["--allow-mesh-path", "secret"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(
        !text(&out.stderr).contains("valid.obj"),
        "{}",
        text(&out.stderr)
    );
    rrd_holds_mesh(&out_dir);
    // A folder whose name only starts like the mesh's is no help.
    std::fs::create_dir_all(base.join("secre")).unwrap();
    let (out, _) = simulate(&base, &urdf_path, "prefix", &["--allow-mesh-path", "secre"]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));

    // inspect with the flag: read, no problem.
    let out = tumble(
        &[
            "inspect",
            urdf_path.to_str().unwrap(),
            "--allow-mesh-path",
            "secret",
            "--json",
        ],
        &base,
        None,
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let m = &report["meshes"][0];
    assert_eq!(m["status"], "allowed", "{m}");
    assert_eq!(
        m["real_path"],
        base.join("secret/valid.obj").display().to_string()
    );
    assert_eq!(
        m["detail"],
        format!("inside allowed folder {}", base.join("secret").display())
    );

    // The scene key, relative to the scene's folder.
    let scene = base.join("scenes/allowed.toml");
    write(
        &scene,
        format!(
            "[sim]\nduration = 0.01\n[[model]]\nurdf = {:?}\nallow_mesh_paths = [\"../secret\"]\n",
            urdf_path.display().to_string()
        ),
    );
    let (out, out_dir) = simulate(&base, &scene, "key", &[]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    rrd_holds_mesh(&out_dir);
    // Without the key the same scene is refused; the flag works on scenes too.
    let bare = base.join("scenes/bare.toml");
    write(
        &bare,
        format!(
            "[sim]\nduration = 0.01\n[[model]]\nurdf = {:?}\n",
            urdf_path.display().to_string()
        ),
    );
    let (out, _) = simulate(&base, &bare, "bare", &[]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    let (out, out_dir) = simulate(&base, &bare, "bare_flag", &["--allow-mesh-path", "secret"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    rrd_holds_mesh(&out_dir);

    // The scene's own folder.
    let beside = base.join("secret/scene.toml");
    write(
        &beside,
        format!(
            "[sim]\nduration = 0.01\n[[model]]\nurdf = {:?}\n",
            urdf_path.display().to_string()
        ),
    );
    let (out, out_dir) = simulate(&base, &beside, "scene_folder", &[]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    rrd_holds_mesh(&out_dir);

    // A package path, and ROS_PACKAGE_PATH.
    let (out, out_dir) = simulate(&base, &urdf_path, "package", &["--package-path", "secret"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    rrd_holds_mesh(&out_dir);
    let stem = base.join("out/ros/run");
    let out = tumble(
        &[
            "simulate",
            urdf_path.to_str().unwrap(),
            "--duration",
            "0.01",
            "--out",
            stem.to_str().unwrap(),
        ],
        &base,
        Some(&base.join("secret")),
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    rrd_holds_mesh(&base.join("out/ros"));

    // Allowing a folder never lets a non-mesh through: the secret stays out.
    let secret_urdf = base.join("robot/model/secret_allowed.urdf");
    write(&secret_urdf, urdf(&["../../secret/secret.obj"]));
    let (out, out_dir) = simulate(
        &base,
        &secret_urdf,
        "allowed_secret",
        &["--allow-mesh-path", "secret"],
    );
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("empty mesh"), "{stderr}");
    assert!(!files_under(&out_dir).is_empty());
    assert!(holding(&out_dir, SECRET).is_empty());
}

/// Inside the URDF's folder: a symbolic link to a mesh inside it is read and embedded; a ROS
/// package holding the URDF (a `package.xml` above it) is the URDF's tree.
#[test]
fn links_and_packages_inside_the_model_still_work() {
    let (_tmp, base) = fixture();
    let urdf_path = base.join("robot/model/inside.urdf");
    write(&urdf_path, urdf(&["tri_link.obj", "meshes/tri.obj"]));
    let (out, out_dir) = simulate(&base, &urdf_path, "inside", &[]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(!text(&out.stderr).contains("mesh"), "{}", text(&out.stderr));
    let found = holding(&out_dir, INSIDE_MESH);
    assert!(
        found
            .iter()
            .any(|p| p.extension().is_some_and(|e| e == "rrd")),
        "{found:?}"
    );
    let out = tumble(&["inspect", urdf_path.to_str().unwrap()], &base, None);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("meshes (2, 0 refused)"), "{stdout}");
    assert!(
        stdout.contains(&format!(
            "`tri_link.obj` -> {} (real path {}): allowed, inside the URDF's folder {}",
            base.join("robot/model/tri_link.obj").display(),
            base.join("robot/model/meshes/tri.obj").display(),
            base.join("robot/model").display()
        )),
        "{stdout}"
    );

    assert!(
        stdout.contains(&format!(
            "`meshes/tri.obj` -> {}: allowed, inside the URDF's folder {}\n",
            base.join("robot/model/meshes/tri.obj").display(),
            base.join("robot/model").display()
        )),
        "{stdout}"
    );

    // `../meshes` from a folder named `urdf`: the description layout, allowed.
    write(&base.join("robot/meshes/up.obj"), obj(INSIDE_MESH));
    let meshes = ["../meshes/up.obj", "package://robot/meshes/up.obj"];
    let layout = base.join("robot/urdf/layout.urdf");
    write(&layout, urdf(&meshes));
    let out = tumble(&["inspect", layout.to_str().unwrap()], &base, None);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(
        stdout.contains(&format!(
            "inside the folder holding the URDF's urdf/ folder {}",
            base.join("robot").display()
        )),
        "{stdout}"
    );
    // ... but not two levels up.
    let two_up = base.join("robot/urdf/two_up.urdf");
    write(&two_up, urdf(&["../../secret/valid.obj"]));
    let out = tumble(&["inspect", two_up.to_str().unwrap()], &base, None);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stdout));

    // From any other folder `../meshes` is outside the URDF's folder, unless a ROS package
    // (a `package.xml` above the URDF) holds both.
    let up = base.join("robot/model/up.urdf");
    write(&up, urdf(&meshes));
    let out = tumble(&["inspect", up.to_str().unwrap()], &base, None);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stdout));
    assert!(text(&out.stdout).contains("meshes (2, 2 refused)"));
    write(
        &base.join("robot/package.xml"),
        "<package><name>robot</name></package>",
    );
    let out = tumble(&["inspect", up.to_str().unwrap()], &base, None);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(
        stdout.contains(&format!(
            "inside the URDF's package {}",
            base.join("robot").display()
        )),
        "{stdout}"
    );
    // The package holds the link to the secret too, and still not the secret.
    let symlink = base.join("robot/model/symlink_pkg.urdf");
    write(&symlink, urdf(&["passwd.obj"]));
    let (out, out_dir) = simulate(&base, &symlink, "symlink_pkg", &[]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "the URDF's package {}",
            base.join("robot").display()
        )),
        "{stderr}"
    );
    assert!(holding(&out_dir, SECRET).is_empty());
}

/// Files inside the URDF's folder whose content tumble's reader rejects (text named `.obj`,
/// `.stl`; a `.glb`, a format tumble does not read) are left out of every recording with a
/// warning: none of their bytes in any file written.
#[test]
fn rejected_mesh_content_is_never_embedded() {
    let (_tmp, base) = fixture();
    let urdf_path = base.join("robot/model/rejected.urdf");
    write(
        &urdf_path,
        urdf(&[
            "notmesh.obj",
            "notmesh.stl",
            "notmesh.glb",
            "meshes/tri.obj",
        ]),
    );
    let (out, out_dir) = simulate(&base, &urdf_path, "rejected", &[]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    for needle in ["notmesh.obj", "notmesh.stl", "notmesh.glb"] {
        assert!(stderr.contains(needle), "{needle}: {stderr}");
    }
    assert!(
        stderr.contains("left out of the Rerun recording"),
        "{stderr}"
    );
    let written = files_under(&out_dir);
    // mcap, rrd, ros2.mcap, the three Parquet tables (trajectories, bodies, joints: the last
    // written with no rows for a run without joints) and run.foxglove.json (the model has a
    // mesh: the Foxglove layout following it).
    assert_eq!(
        written.len(),
        7,
        "{:?}",
        written.iter().map(|w| &w.0).collect::<Vec<_>>()
    );
    assert!(
        holding(&out_dir, REJECTED).is_empty(),
        "{:?}",
        holding(&out_dir, REJECTED)
    );
    // The valid mesh beside them is embedded.
    assert!(!holding(&out_dir, INSIDE_MESH).is_empty());
}
