//! The URDF oddities urdfdom loads (docs/urdf.md, `src/model/urdf/lenient.rs`): one test per
//! oddity with a small hand-written URDF, asserting the warning's exact text, the values the
//! model then has (the axis, scale, geometry, joint motion used), and the `--strict` refusal
//! with the message it gave before the leniency; then the warnings' way to the user through
//! `inspect`, `simulate`, `survey`, `trade`, `dataset` and the scene key `strict`.
//!
//! Tolerances: poses are one or two rotations of exactly representable inputs (agreement to a
//! few ulps, bound 1e-15); mesh mass properties are sums over 12 triangles of a unit cube with
//! integer coordinates (bound 1e-12 relative; measured: mass and centre of mass exact, inertia
//! 1.7e-16 relative), primitive boxes are closed forms evaluated the same way (measured 0).

use crate::common;
use crate::common::urdfs::{assert_pose, link};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::collections::HashMap;
use std::f64::consts::FRAC_PI_2;
use std::path::{Path, PathBuf};
use tumble::model::policy::{self, InertiaPolicy, MassSettings, ModelMassSettings};
use tumble::model::urdf::{self, Oddity, Strictness};
use tumble::model::{Geometry, Model};

/// Mass 2 kg, unit moments: a valid body.
const INERTIAL: &str = r#"<inertial><mass value="2"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>"#;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn load_at(path: &Path, joints: &[(&str, f64)], strictness: Strictness) -> Result<Model, String> {
    let joints: HashMap<String, f64> = joints.iter().map(|(k, v)| (k.to_string(), *v)).collect();
    let options = urdf::LoadOptions {
        joint_positions: joints,
        strictness,
        ..Default::default()
    };
    urdf::load(path, &options).map_err(|e| e.to_string())
}

fn lenient(path: &Path) -> Model {
    load_at(path, &[], Strictness::Lenient).unwrap_or_else(|e| panic!("{e}"))
}

fn strict_error(path: &Path) -> String {
    match load_at(path, &[], Strictness::Strict) {
        Ok(_) => panic!("{}: loaded under --strict", path.display()),
        Err(e) => e,
    }
}

/// The one warning of `model`, as displayed.
fn only_warning(model: &Model, oddity: Oddity) -> String {
    assert_eq!(model.warnings.len(), 1, "{:#?}", model.warnings);
    assert_eq!(model.warnings[0].oddity, oddity);
    model.warnings[0].to_string()
}

/// Mass properties from collision geometry at 1000 kg/m^3.
fn from_geometry(model: &mut Model) {
    let settings = ModelMassSettings {
        model: MassSettings {
            inertia: Some(InertiaPolicy::Geometry),
            density: Some(1000.0),
            geometry: None,
        },
        links: Default::default(),
    };
    policy::apply(model, &settings).unwrap_or_else(|e| panic!("{e}"));
}

// ---------------------------------------------------------------- one test per oddity

#[test]
fn an_xml_declaration_after_blank_lines_is_ignored_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "\n\n<?xml version=\"1.0\"?>\n<robot name=\"r\"><link name=\"base\">{INERTIAL}</link></robot>\n"
    );
    let path = write(dir.path(), "late.urdf", &text);
    let model = lenient(&path);
    assert_eq!(
        only_warning(&model, Oddity::XmlDeclaration),
        format!(
            "{}: line 3: the XML declaration comes after leading whitespace (XML allows it only \
             as the file's first bytes): ignored, as tinyxml2 (urdfdom's XML parser) ignores it",
            path.display()
        )
    );
    assert_eq!(model.links.len(), 1);
    assert_eq!(link(&model, "base").inertial.unwrap().mass, 2.0);
    // Today's refusal, under --strict.
    let e = strict_error(&path);
    assert!(
        e.contains("late.urdf: not well-formed XML: unexpected XML declaration at 3:1"),
        "{e}"
    );
}

#[test]
fn a_second_xml_declaration_is_ignored_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "<?xml version=\"1.0\"?>\n<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<robot name=\"r\"><link name=\"base\">{INERTIAL}</link></robot>"
    );
    let path = write(dir.path(), "twice.urdf", &text);
    let model = lenient(&path);
    assert_eq!(
        only_warning(&model, Oddity::XmlDeclaration),
        format!(
            "{}: line 2: a second XML declaration (XML allows one): ignored, as tinyxml2 \
             (urdfdom's XML parser) ignores it",
            path.display()
        )
    );
    assert_eq!(link(&model, "base").inertial.unwrap().mass, 2.0);
    let e = strict_error(&path);
    assert!(e.contains("unexpected XML declaration at 2:1"), "{e}");
}

#[test]
fn blanking_a_declaration_keeps_the_positions_of_later_xml_errors() {
    // `</robot>` closes `<link>` on the file's line 5: the error must say 5:1 (the declaration
    // is blanked in place, not cut out, so no line moves).
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "bad.urdf",
        "\n<?xml version=\"1.0\"?>\n<robot name=\"r\">\n<link name=\"a\">\n</robot>\n",
    );
    let e = load_at(&path, &[], Strictness::Lenient).unwrap_err();
    assert!(
        e.contains("not well-formed XML: expected 'link' tag, not 'robot' at 5:1"),
        "{e}"
    );
}

#[test]
fn unknown_geometry_leaves_only_that_collision_out() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        r#"<robot name="r">
  <link name="base">{INERTIAL}
    <visual><geometry><box size="1 2 3"/></geometry></visual>
    <collision><geometry><plane normal="0 0 1"/></geometry></collision>
    <collision><geometry><box size="0.1 0.2 0.3"/></geometry></collision>
  </link>
</robot>"#
    );
    let path = write(dir.path(), "plane.urdf", &text);
    let mut model = lenient(&path);
    assert_eq!(
        only_warning(&model, Oddity::UnknownGeometry),
        format!(
            "{}: link `base`: collision #0 (line 4): <plane> is not a URDF geometry (box, \
             cylinder, sphere, capsule, mesh): this collision is left out, as urdfdom leaves it \
             out",
            path.display()
        )
    );
    let base = link(&model, "base");
    assert_eq!(base.visuals.len(), 1);
    // The collision after the plane is kept (urdfdom would stop reading the link there).
    assert_eq!(base.collisions.len(), 1);
    match &base.collisions[0].geometry {
        Geometry::Box { size } => assert_eq!(*size, Vector3::new(0.1, 0.2, 0.3)),
        other => panic!("{other:?}"),
    }
    // Mass properties from the collision geometry are the kept box's alone:
    // m = 1000 * 0.1 * 0.2 * 0.3 = 6 kg, I_xx = m (b^2 + c^2) / 12 = 0.065 kg m^2 (measured
    // exact).
    from_geometry(&mut model);
    let mp = link(&model, "base").inertial.unwrap();
    let m = 1000.0 * 0.1 * 0.2 * 0.3;
    assert!((mp.mass - m).abs() <= 1e-12 * m, "{}", mp.mass);
    let ixx = m * (0.2f64.powi(2) + 0.3f64.powi(2)) / 12.0;
    assert!(
        (mp.inertia[(0, 0)] - ixx).abs() <= 1e-12 * ixx,
        "{}",
        mp.inertia
    );
    let e = strict_error(&path);
    assert!(
        e.contains(
            "plane.urdf: cannot parse URDF (link `base`: <collision> #0: unknown geometry <plane>)"
        ),
        "{e}"
    );
}

#[test]
fn error_locations_number_visuals_and_collisions_separately() {
    // Regression: the first <collision> after a <visual> was called "<collision> #1" in parse
    // errors while the link's problems and the warnings call it "collision #0".
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        r#"<robot name="r"><link name="base">{INERTIAL}<visual><geometry><box size="1 1 1"/></geometry></visual><visual><geometry><box size="1 1 1"/></geometry></visual><collision><geometry><cdf filename="x.cdf"/></geometry></collision></link></robot>"#
    );
    let path = write(dir.path(), "cdf.urdf", &text);
    let e = strict_error(&path);
    assert!(
        e.contains("(link `base`: <collision> #0: unknown geometry <cdf>)"),
        "{e}"
    );
}

#[test]
fn an_element_after_the_shape_in_geometry_is_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        r#"<robot name="r">
  <material name="grey"><color rgba="0.2 0.2 0.2 1"/></material>
  <link name="laser">{INERTIAL}
    <visual><geometry><box size="1 2 3"/><material name="grey"/></geometry></visual>
  </link>
</robot>"#
    );
    let path = write(dir.path(), "stray.urdf", &text);
    let model = lenient(&path);
    assert_eq!(
        only_warning(&model, Oddity::ExtraGeometryElement),
        format!(
            "{}: link `laser`: visual #0 (line 4): <geometry> holds <material> after its <box> \
             (URDF allows one shape there): <material> is ignored, as urdfdom reads only the \
             first element of <geometry>",
            path.display()
        )
    );
    let visual = &link(&model, "laser").visuals[0];
    match &visual.geometry {
        Geometry::Box { size } => assert_eq!(*size, Vector3::new(1.0, 2.0, 3.0)),
        other => panic!("{other:?}"),
    }
    // As in urdfdom, the misplaced <material> gives the visual no colour.
    assert_eq!(visual.rgba, None);
    let e = strict_error(&path);
    assert!(
        e.contains(
            "(link `laser`: <visual> #0: <geometry> holds <material> after its <box> (URDF \
             allows one shape there))"
        ),
        "{e}"
    );
    // A second shape is ambiguous: refused however the file is read.
    let two = write(
        dir.path(),
        "two.urdf",
        &text.replace(
            r#"<material name="grey"/></geometry>"#,
            r#"<sphere radius="1"/></geometry>"#,
        ),
    );
    let e = load_at(&two, &[], Strictness::Lenient).unwrap_err();
    assert!(
        e.contains("<geometry> holds <sphere> after its <box>"),
        "{e}"
    );
}

#[test]
fn identical_repeated_axes_use_the_first() {
    let dir = tempfile::tempdir().unwrap();
    let joint = |axes: &str| {
        format!(
            r#"<robot name="r">
  <link name="base">{INERTIAL}</link>
  <link name="arm">{INERTIAL}</link>
  <joint name="elbow" type="revolute">
    {axes}<origin xyz="0 0 1"/><parent link="base"/><child link="arm"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
</robot>"#
        )
    };
    // The same axis written two ways (numbers compare as numbers).
    let path = write(
        dir.path(),
        "axes.urdf",
        &joint(r#"<axis xyz="0 1 0"/><axis xyz="0.0 1.0 0"/>"#),
    );
    let model = load_at(&path, &[("elbow", FRAC_PI_2)], Strictness::Lenient).unwrap();
    assert_eq!(
        only_warning(&model, Oddity::RepeatedElement),
        format!(
            "{}: joint `elbow` (line 4): <axis> appears 2 times with the same content (URDF \
             allows one): the first is used, as urdfdom uses the first",
            path.display()
        )
    );
    // The arm turned by pi/2 about y at 1 m above the base: Translation(0, 0, 1) Ry(pi/2)
    // (measured 0 m and 0 rad apart).
    let expected = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 1.0),
        UnitQuaternion::from_axis_angle(&Vector3::y_axis(), FRAC_PI_2),
    );
    assert_pose(
        &link(&model, "arm").model_from_link,
        expected.translation.vector,
        expected.rotation,
        1e-15,
    );
    let e = strict_error(&path);
    assert!(
        e.contains(
            "axes.urdf: cannot parse URDF (joint `elbow`: <joint> has more than one <axis> (at \
             most one is allowed)): custom: duplicate field `axis`"
        ),
        "{e}"
    );
    // Copies that differ are ambiguous: refused in both modes, saying so.
    let differ = write(
        dir.path(),
        "differ.urdf",
        &joint(r#"<axis xyz="0 1 0"/><axis xyz="1 0 0"/>"#),
    );
    let e = load_at(&differ, &[], Strictness::Lenient).unwrap_err();
    assert!(
        e.contains(
            "joint `elbow`: <joint> has more than one <axis> (at most one is allowed; the copies \
             differ, so which one is meant is unclear)"
        ),
        "{e}"
    );
}

#[test]
fn a_uniform_four_number_mesh_scale_is_read_as_three() {
    let dir = tempfile::tempdir().unwrap();
    // The unit cube [0, 1]^3 (12 triangles), beside the URDF (meshes are read only inside
    // the URDF's folder: src/model/confine.rs).
    let cube = dir.path().join("cube.stl");
    std::fs::copy(common::root().join("tests/hostile/mesh/cube.stl"), &cube).unwrap();
    let text = format!(
        r#"<robot name="r"><link name="chassis">{INERTIAL}
  <collision><geometry><mesh filename="{}" scale="2 2 2 2"/></geometry></collision>
</link></robot>"#,
        cube.display()
    );
    let path = write(dir.path(), "scale.urdf", &text);
    let mut model = lenient(&path);
    assert_eq!(
        only_warning(&model, Oddity::MeshScale),
        format!(
            "{}: link `chassis`: collision #0 (line 2): mesh scale=\"2 2 2 2\" has 4 numbers, not \
             3; all are equal: read as the uniform scale \"2 2 2\" (urdfdom refuses the scale and \
             leaves this collision out, with the link's later visuals and collisions)",
            path.display()
        )
    );
    match &link(&model, "chassis").collisions[0].geometry {
        Geometry::Mesh { scale, .. } => assert_eq!(*scale, Vector3::new(2.0, 2.0, 2.0)),
        other => panic!("{other:?}"),
    }
    // The cube scaled by 2: side 2 m, m = 1000 * 8 = 8000 kg, com (1, 1, 1) m,
    // I = m (2^2 + 2^2) / 12 = 16000/3 kg m^2 on each axis (measured: mass and com exact,
    // inertia 1.7e-16 relative).
    from_geometry(&mut model);
    let mp = link(&model, "chassis").inertial.unwrap();
    assert!((mp.mass - 8000.0).abs() <= 1e-12 * 8000.0, "{}", mp.mass);
    assert!(
        (mp.com - Vector3::repeat(1.0)).amax() <= 1e-12,
        "{}",
        mp.com
    );
    let i = 16000.0 / 3.0;
    for k in 0..3 {
        assert!(
            (mp.inertia[(k, k)] - i).abs() <= 1e-12 * i,
            "{}",
            mp.inertia
        );
    }
    let e = strict_error(&path);
    assert!(
        e.contains("(link `chassis`: <collision> #0: <mesh> scale=\"2 2 2 2\" is not 3 numbers)"),
        "{e}"
    );
    // Unequal numbers have no one meaning: refused in both modes.
    let unequal = write(
        dir.path(),
        "unequal.urdf",
        &text.replace("2 2 2 2", "2 2 2 1"),
    );
    let e = load_at(&unequal, &[], Strictness::Lenient).unwrap_err();
    assert!(e.contains("scale=\"2 2 2 1\" is not 3 numbers"), "{e}");
}

#[test]
fn a_mimic_of_a_missing_joint_is_dropped_and_the_joint_moves_on_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        r#"<robot name="r">
  <link name="base">{INERTIAL}</link>
  <link name="finger">{INERTIAL}</link>
  <link name="thumb">{INERTIAL}</link>
  <joint name="grip" type="prismatic">
    <parent link="base"/><child link="finger"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="1" effort="1" velocity="1"/>
    <mimic joint="ghost" multiplier="2" offset="0.1"/>
  </joint>
  <joint name="pinch" type="prismatic">
    <parent link="base"/><child link="thumb"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="1" effort="1" velocity="1"/>
    <mimic joint="grip" multiplier="2" offset="0.1"/>
  </joint>
</robot>"#
    );
    let path = write(dir.path(), "mimic.urdf", &text);
    let model = load_at(&path, &[("grip", 0.25)], Strictness::Lenient).unwrap();
    assert_eq!(
        only_warning(&model, Oddity::MimicOfMissingJoint),
        format!(
            "{}: joint `grip` (line 5): mimics `ghost`, which does not exist: the mimic is \
             ignored and the joint moves on its own (at 0 unless `joints` sets it), as urdfdom \
             (which does not check mimic targets) and Pinocchio read it",
            path.display()
        )
    );
    // `grip` takes its own position (0.25 m), not 2 * 0 + 0.1 as the mimic would give...
    let finger = link(&model, "finger").model_from_link;
    assert_eq!(finger.translation.vector, Vector3::new(0.25, 0.0, 0.0));
    // ...and a valid mimic of it still follows it: 2 * 0.25 + 0.1 = 0.6 m along y (measured
    // exact).
    let thumb = link(&model, "thumb").model_from_link;
    assert!(
        (thumb.translation.vector - Vector3::new(0.0, 0.6, 0.0)).amax() <= 1e-15,
        "{thumb}"
    );
    // At the zero configuration the finger stays at 0 (no mimic offset).
    let at_zero = lenient(&path);
    assert_eq!(
        link(&at_zero, "finger").model_from_link.translation.vector,
        Vector3::zeros()
    );
    let e = strict_error(&path);
    assert!(
        e.ends_with("mimic.urdf: joint `grip` mimics `ghost`, which does not exist"),
        "{e}"
    );
}

#[test]
fn warnings_come_in_file_order() {
    // A mimic joint before the links, a collision before a visual: the rules run link by link
    // and kind by kind, the warnings are sorted by the line their element starts on.
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        r#"<robot name="r">
  <joint name="j" type="continuous"><parent link="a"/><child link="b"/><mimic joint="ghost"/></joint>
  <link name="a">{INERTIAL}
    <collision><geometry><plane/></geometry></collision>
    <visual><geometry><box size="1 1 1"/><material name="m"/></geometry></visual>
  </link>
  <link name="b">{INERTIAL}</link>
</robot>"#
    );
    let path = write(dir.path(), "order.urdf", &text);
    let model = lenient(&path);
    let got: Vec<(usize, Oddity)> = model.warnings.iter().map(|w| (w.line, w.oddity)).collect();
    assert_eq!(
        got,
        [
            (2, Oddity::MimicOfMissingJoint),
            (4, Oddity::UnknownGeometry),
            (5, Oddity::ExtraGeometryElement),
        ]
    );
}

#[test]
fn a_file_urdf_defines_fully_has_no_warnings() {
    let model = lenient(&common::root().join("models/arm.urdf"));
    assert!(model.warnings.is_empty(), "{:#?}", model.warnings);
}

// ---------------------------------------------------------------- to the user

/// A URDF with two oddities (a late XML declaration, a repeated axis) and two bodies.
fn odd_robot(dir: &Path) -> PathBuf {
    let text = format!(
        r#"
<?xml version="1.0"?>
<robot name="odd">
  <link name="base">{INERTIAL}</link>
  <link name="arm">{INERTIAL}</link>
  <joint name="elbow" type="continuous">
    <origin xyz="0 0 1"/><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><axis xyz="0 0 1"/>
  </joint>
</robot>
"#
    );
    write(dir, "odd.urdf", &text)
}

fn warning_lines(stderr: &str) -> Vec<&str> {
    stderr
        .lines()
        .filter(|l| l.starts_with("warning: "))
        .collect()
}

#[test]
fn inspect_prints_the_warnings_and_strict_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = odd_robot(dir.path());
    let file = urdf.display().to_string();
    let out = common::tumble(&["inspect", &file], dir.path());
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let lines = warning_lines(&stderr);
    assert_eq!(lines.len(), 2, "{stderr}");
    assert!(
        lines[0].starts_with(&format!("warning: {file}: line 2: ")),
        "{stderr}"
    );
    assert!(
        lines[1].starts_with(&format!("warning: {file}: joint `elbow` (line 6): <axis>")),
        "{stderr}"
    );

    let out = common::tumble(&["inspect", &file, "--json"], dir.path());
    assert_eq!(out.status.code(), Some(0));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let warnings: Vec<&str> = json["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    let expected: Vec<&str> = lines.iter().map(|l| &l["warning: ".len()..]).collect();
    assert_eq!(warnings, expected);
    assert_eq!(json["total_mass"], 4.0);

    let out = common::tumble(&["inspect", &file, "--strict"], dir.path());
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "error: {file}: not well-formed XML: unexpected XML declaration at 2:1"
        )),
        "{stderr}"
    );
    assert!(out.stdout.is_empty());
}

#[test]
fn simulate_prints_the_warnings_and_strict_refuses_writing_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = odd_robot(dir.path());
    let file = urdf.display().to_string();
    let out = common::tumble(
        &["simulate", &file, "--duration", "0.01", "--out", "run"],
        dir.path(),
    );
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert_eq!(warning_lines(&stderr).len(), 2, "{stderr}");
    assert!(dir.path().join("run.mcap").is_file());

    let out = common::tumble(
        &[
            "simulate",
            &file,
            "--duration",
            "0.01",
            "--out",
            "strict",
            "--strict",
        ],
        dir.path(),
    );
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("unexpected XML declaration at 2:1"),
        "{stderr}"
    );
    for name in [
        "strict.mcap",
        "strict.rrd",
        "strict.mcap.part",
        "strict.rrd.part",
    ] {
        assert!(!dir.path().join(name).exists(), "{name} written");
    }
}

#[test]
fn scene_models_warn_once_per_file_and_strict_is_a_model_key() {
    let dir = tempfile::tempdir().unwrap();
    odd_robot(dir.path());
    let scene = |strict: &str| {
        let models: String = (0..3)
            .map(|i| {
                format!(
                    "[[model]]\nurdf = \"odd.urdf\"\nname = \"m{i}\"\nposition = [{i}.0, 0.0, 0.0]\n{strict}\n"
                )
            })
            .collect();
        format!("[sim]\nduration = 0.01\n\n{models}")
    };
    write(dir.path(), "lenient.toml", &scene(""));
    let out = common::tumble(&["simulate", "lenient.toml", "--out", "l"], dir.path());
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    // Three models share the file: its two warnings once each.
    assert_eq!(warning_lines(&stderr).len(), 2, "{stderr}");

    // The library carries them too.
    let built = tumble::scene::Scene::load(&dir.path().join("lenient.toml"))
        .unwrap()
        .build()
        .unwrap();
    let oddities: Vec<Oddity> = built.warnings.iter().map(|w| w.oddity).collect();
    assert_eq!(oddities, [Oddity::XmlDeclaration, Oddity::RepeatedElement]);

    // `strict = true` on only the last model refuses it, naming the scene's model entry.
    let mut text = scene("");
    text.push_str("[[model]]\nurdf = \"odd.urdf\"\nname = \"m3\"\nstrict = true\n");
    write(dir.path(), "strict.toml", &text);
    let out = common::tumble(&["simulate", "strict.toml", "--out", "s"], dir.path());
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("strict.toml: model[3]:")
            && stderr.contains("unexpected XML declaration at 2:1"),
        "{stderr}"
    );
    assert!(!dir.path().join("s.mcap").exists());
    // And --strict on the command line sets it on every model.
    let out = common::tumble(
        &["simulate", "lenient.toml", "--out", "s", "--strict"],
        dir.path(),
    );
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("lenient.toml: model[0]:"), "{stderr}");
}

#[test]
fn survey_counts_warnings_per_file_and_strict_fails_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = odd_robot(dir.path());
    let file = urdf.display().to_string();
    write(
        dir.path(),
        "plain.urdf",
        &format!(r#"<robot name="p"><link name="base">{INERTIAL}</link></robot>"#),
    );
    let root = dir.path().display().to_string();
    let out = common::tumble(&["survey", &root, "--json"], dir.path());
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert_eq!(warning_lines(&stderr).len(), 2, "{stderr}");
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let summary = &json["summaries"][0];
    assert_eq!(summary["loaded"], 2);
    assert_eq!(summary["warnings"], 2);
    assert_eq!(summary["files_with_warnings"], 1);
    for f in json["files"].as_array().unwrap() {
        let n = f["warnings"].as_array().unwrap().len();
        if f["path"] == file.as_str() {
            assert_eq!(n, 2, "{f}");
            assert!(f["warnings"][0].as_str().unwrap().starts_with(&file));
        } else {
            assert_eq!(n, 0, "{f}");
        }
    }
    // The table carries the count in its last column.
    let out = common::tumble(&["survey", &root], dir.path());
    let table = common::text(&out.stdout);
    assert!(
        table.lines().next().unwrap().ends_with("| warnings |"),
        "{table}"
    );
    assert!(table.lines().nth(2).unwrap().ends_with("| 2 |"), "{table}");

    let out = common::tumble(&["survey", &root, "--json", "--strict"], dir.path());
    assert_eq!(out.status.code(), Some(0));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["summaries"][0]["loaded"], 1);
    assert_eq!(json["summaries"][0]["failed"], 1);
    assert_eq!(json["summaries"][0]["warnings"], 0);
    let failed = json["files"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["path"] == file.as_str())
        .unwrap();
    assert!(
        failed["error"]
            .as_str()
            .unwrap()
            .contains("unexpected XML declaration at 2:1"),
        "{failed}"
    );
}

#[test]
fn trade_and_dataset_take_strict_too() {
    let dir = tempfile::tempdir().unwrap();
    odd_robot(dir.path());
    write(
        dir.path(),
        "scene.toml",
        "[sim]\nduration = 0.01\n\n[[model]]\nurdf = \"odd.urdf\"\n",
    );
    let out = common::tumble(
        &[
            "trade",
            "scene.toml",
            "--out",
            "trade",
            "--dt",
            "0.01",
            "--strict",
        ],
        dir.path(),
    );
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("unexpected XML declaration at 2:1"),
        "{stderr}"
    );

    write(
        dir.path(),
        "spec.toml",
        "[dataset]\nruns = 2\nseed = 1\n\n[scene.sim]\nduration = 0.01\n\n[[scene.model]]\nurdf = \"odd.urdf\"\n",
    );
    let out = common::tumble(
        &[
            "dataset",
            "spec.toml",
            "--out",
            "ds",
            "--quiet",
            "--threads",
            "1",
        ],
        dir.path(),
    );
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert_eq!(warning_lines(&stderr).len(), 2, "{stderr}");
    let out = common::tumble(
        &[
            "dataset",
            "spec.toml",
            "--out",
            "ds2",
            "--quiet",
            "--strict",
        ],
        dir.path(),
    );
    let stderr = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("unexpected XML declaration at 2:1"),
        "{stderr}"
    );
    assert!(!dir.path().join("ds2/manifest.json").exists());
}
