//! URDF loading: closed forms, validation rules, structural errors, mesh resolution, forward
//! kinematics, totals and the `inspect --json` report.
//!
//! Tolerances: inputs are written with 16-17 significant digits and the operations are a few
//! rotations and sums, so agreement is at the 1e-16..1e-15 level; bounds are set at 1e-12
//! (absolute, on quantities of order 1e-5..1) unless stated, with the measured value beside.

use crate::common;
use crate::common::urdfs::{assert_pose, link, load_urdf, write};
use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};
use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_6};
use std::path::{Path, PathBuf};
use tumble::commands::inspect::{self, InspectArgs};
use tumble::model::urdf::{self, ModelError};
use tumble::model::{Geometry, InertiaSource, MassProperties, package};

fn data(name: &str) -> PathBuf {
    common::urdfs::data("urdf", name)
}

fn assert_close_m(a: &Matrix3<f64>, b: &Matrix3<f64>, tol: f64) {
    assert!(
        (a - b).amax() <= tol,
        "\n{a}\nvs\n{b}\n(diff {})",
        (a - b).amax()
    );
}

fn assert_close_v(a: &Vector3<f64>, b: &Vector3<f64>, tol: f64) {
    assert!(
        (a - b).amax() <= tol,
        "{a} vs {b} (diff {})",
        (a - b).amax()
    );
}

// ---------------------------------------------------------------- closed forms

#[test]
fn rotated_inertial_frame_is_r_i_rt() {
    // rpy (pi/2, 0, pi/2): x -> y, y -> z, z -> x (see the file's comment).
    let model = load_urdf(&data("rotated_inertial.urdf"));
    let mp = link(&model, "body").inertial.expect("has inertial");
    assert_eq!(mp.mass, 5.0);
    assert_close_v(&mp.com, &Vector3::new(0.1, -0.2, 0.3), 0.0);
    #[rustfmt::skip]
    let expected = Matrix3::new(
        3.0, 0.0, 0.0,
        0.0, 1.0, 0.1,
        0.0, 0.1, 2.0,
    );
    // cos(pi/2) = 6.1e-17 enters twice: measured 4.7e-16, bound 1e-12.
    assert_close_m(&mp.inertia, &expected, 1e-12);
    assert!(link(&model, "body").problems.is_empty());
}

#[test]
fn arm_hand_inertia_in_link_frame() {
    // Box diag(5e-5, 1.7e-4, 2e-4) turned Rz(30 deg): hand computation in models/arm.urdf.
    let model = load_urdf(&common::root().join("models/arm.urdf"));
    let hand = link(&model, "hand").inertial.unwrap();
    let ixy = -3e-5 * 3f64.sqrt();
    #[rustfmt::skip]
    let expected = Matrix3::new(
        8e-5, ixy, 0.0,
        ixy, 1.4e-4, 0.0,
        0.0, 0.0, 2e-4,
    );
    // Measured 5.4e-20 on entries of 1e-4; bound 1e-17 (1e-13 relative).
    assert_close_m(&hand.inertia, &expected, 1e-17);
    assert_close_v(&hand.com, &Vector3::new(0.0, 0.0, 0.04), 0.0);
    // The forearm's cylinder, turned Ry(90 deg), lies along x.
    let forearm = link(&model, "forearm").inertial.unwrap();
    let across = 0.0652 / 12.0;
    let expected = Matrix3::from_diagonal(&Vector3::new(0.00045, across, across));
    // cos(pi/2) times 0.005: measured 1.1e-18; bound 1e-16.
    assert_close_m(&forearm.inertia, &expected, 1e-16);
}

#[test]
fn box_model_matches_closed_form() {
    let model = load_urdf(&common::root().join("models/box.urdf"));
    assert_eq!(model.name, "box");
    assert_eq!(model.links.len(), 1);
    let l = &model.links[0];
    let mp = l.inertial.unwrap();
    // Density 1000 kg/m^3 times 0.1 x 0.2 x 0.3 m.
    assert!((mp.mass - 1000.0 * 0.1 * 0.2 * 0.3).abs() < 1e-12);
    let (a, b, c) = (0.1f64, 0.2f64, 0.3f64);
    let expected = Vector3::new(b * b + c * c, a * a + c * c, a * a + b * b) * (mp.mass / 12.0);
    // Measured 3.5e-18 on entries of 0.05; bound 1e-15.
    assert_close_m(&mp.inertia, &Matrix3::from_diagonal(&expected), 1e-15);
    assert!(l.problems.is_empty(), "{:?}", l.problems);
    assert_eq!(l.visuals.len(), 1);
    let v = &l.visuals[0];
    assert!(matches!(v.geometry, Geometry::Box { size } if size == Vector3::new(a, b, c)));
    // Colour by reference to the robot-level material.
    assert_eq!(v.rgba, Some([1.0, 0.55, 0.1, 1.0]));
}

#[test]
fn t_handle_has_the_intermediate_axis_along_y() {
    let model = load_urdf(&common::root().join("models/t_handle.urdf"));
    let l = &model.links[0];
    let mp = l.inertial.unwrap();
    assert!(l.problems.is_empty(), "{:?}", l.problems);
    // Independent recomputation from the two visual cylinders, density 10000/pi.
    let rho = 10_000.0 / std::f64::consts::PI;
    let cylinders: Vec<(f64, f64, Vector3<f64>, usize)> = l
        .visuals
        .iter()
        .map(|v| match v.geometry {
            Geometry::Cylinder { radius, length } => {
                let axis = v.link_from_visual.rotation * Vector3::z();
                let k = axis.iamax();
                (radius, length, v.link_from_visual.translation.vector, k)
            }
            _ => panic!("t-handle visuals are cylinders"),
        })
        .collect();
    assert_eq!(cylinders.len(), 2);
    let masses: Vec<f64> = cylinders
        .iter()
        .map(|(r, len, _, _)| rho * std::f64::consts::PI * r * r * len)
        .collect();
    let total: f64 = masses.iter().sum();
    let com = cylinders
        .iter()
        .zip(&masses)
        .fold(Vector3::zeros(), |acc, ((_, _, c, _), m)| acc + c * *m)
        / total;
    let mut inertia = Matrix3::zeros();
    for ((r, len, c, axis), m) in cylinders.iter().zip(&masses) {
        let mut own = Vector3::repeat(m * (3.0 * r * r + len * len) / 12.0);
        own[*axis] = m * r * r / 2.0;
        let d = c - com;
        inertia += Matrix3::from_diagonal(&own)
            + (Matrix3::identity() * d.norm_squared() - d * d.transpose()) * *m;
    }
    // Mass and com: measured 0 on 0.1 kg and 0.01 m; bound 1e-15.
    assert!((mp.mass - total).abs() < 1e-15, "{} vs {total}", mp.mass);
    assert_close_v(&mp.com, &com, 1e-15);
    // Inertia entries ~5e-5: measured 1.4e-20; bound 1e-18 (2e-14 relative).
    assert_close_m(&mp.inertia, &inertia, 1e-18);

    let (moments, frame_from_principal) = mp.principal();
    assert!(moments[0] < moments[1] && moments[1] < moments[2]);
    // Distinct by more than 10 %: the flip is visible.
    assert!(moments[1] / moments[0] > 1.1 && moments[2] / moments[1] > 1.1);
    let intermediate = frame_from_principal * Vector3::y();
    assert!(
        (intermediate.y.abs() - 1.0).abs() < 1e-12,
        "intermediate axis {intermediate}"
    );
    assert_eq!(l.visuals.len(), 2);
    assert!(l.visuals.iter().all(|v| v.rgba.is_some()));
}

// ---------------------------------------------------------------- missing vs zero

#[test]
fn missing_inertial_is_not_an_explicit_zero() {
    let model = load_urdf(&data("missing_and_zero.urdf"));
    let frame = link(&model, "frame");
    assert_eq!(frame.source, InertiaSource::Missing);
    assert!(frame.inertial.is_none());
    assert!(frame.problems.is_empty(), "{:?}", frame.problems);

    let ghost = link(&model, "ghost");
    assert_eq!(ghost.source, InertiaSource::Urdf);
    assert_eq!(ghost.inertial.map(|m| m.mass), Some(0.0));
    assert_eq!(ghost.problems.len(), 1, "{:?}", ghost.problems);
    assert!(ghost.problems[0].contains("mass is zero"));
    assert!(!ghost.has_mass());

    let body = link(&model, "body");
    assert!(body.has_mass() && body.problems.is_empty());
    // Zero-mass and missing links are frames, not bodies: the model is simulable.
    model.check_simulable(false).expect("simulable");
    assert!(model.has_problems());
}

// ---------------------------------------------------------------- validation rules

#[test]
fn every_validation_rule_names_file_link_and_rule() {
    let cases = [
        ("negative_mass.urdf", "mass is negative"),
        ("nan_mass.urdf", "mass is not finite"),
        ("infinite_inertia.urdf", "inertia is not finite"),
        ("not_positive_definite.urdf", "not positive definite"),
        ("triangle.urdf", "triangle inequality"),
    ];
    for (file, rule) in cases {
        let path = data(file);
        let model = load_urdf(&path);
        let payload = link(&model, "payload");
        assert!(
            payload.problems.iter().any(|p| p.contains(rule)),
            "{file}: {rule} not in {:?}",
            payload.problems
        );
        assert!(link(&model, "base").problems.is_empty());
        let err = model.check_simulable(false).expect_err(file);
        assert!(matches!(err, ModelError::NotSimulable { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains(file), "{msg}");
        assert!(msg.contains("`payload`"), "{msg}");
        assert!(msg.contains(rule), "{msg}");
    }
}

#[test]
fn a_model_without_mass_is_not_simulable() {
    let xml = r#"<robot name="r"><link name="only"/></robot>"#;
    let model = urdf::load_str(xml, Path::new("frames_only.urdf"), &Default::default()).unwrap();
    let msg = model.check_simulable(false).unwrap_err().to_string();
    assert!(
        msg.contains("frames_only.urdf") && msg.contains("nothing to simulate"),
        "{msg}"
    );
    assert!(model.total_mass_properties().is_none());
}

// ---------------------------------------------------------------- structural errors

#[test]
fn structural_errors_name_file_and_culprit() {
    let cases: [(&str, &[&str]); 8] = [
        ("duplicate_link.urdf", &["`wheel`", "more than once"]),
        ("unknown_link.urdf", &["`axle`", "`wheel`", "child"]),
        (
            "two_roots.urdf",
            &["`base`", "`loose`", "more than one root"],
        ),
        ("cycle.urdf", &["`a`", "more than one joint"]),
        ("all_cycle.urdf", &["cycle", "`a`", "`b`"]),
        ("no_links.urdf", &["no links"]),
        ("bad_number.urdf", &["link `wheel`", "heavy"]),
        ("not_xml.urdf", &["not well-formed XML"]),
    ];
    for (file, needles) in cases {
        let err = urdf::load(&data(file), &Default::default()).expect_err(file);
        let msg = err.to_string();
        assert!(msg.contains(file), "{file}: {msg}");
        for needle in needles {
            assert!(msg.contains(needle), "{file}: `{needle}` not in: {msg}");
        }
    }
}

#[test]
fn unreadable_file_is_an_error_naming_it() {
    let err = urdf::load(Path::new("/nonexistent/robot.urdf"), &Default::default()).unwrap_err();
    assert!(matches!(err, ModelError::Read { .. }));
    assert!(err.to_string().contains("/nonexistent/robot.urdf"));
}

#[test]
fn texture_without_filename_is_accepted() {
    let model = load_urdf(&data("texture.urdf"));
    let v = &link(&model, "head").visuals[0];
    assert_eq!(v.rgba, Some([0.9, 0.8, 0.7, 1.0]));
    assert!(matches!(v.geometry, Geometry::Sphere { radius } if radius == 0.1));
}

// ---------------------------------------------------------------- package://

fn mesh_urdf(uri: &str) -> String {
    format!(
        r#"<robot name="r"><link name="base">
             <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
             <visual><geometry><mesh filename="{uri}" scale="1 1 -1"/></geometry></visual>
           </link></robot>"#
    )
}

#[test]
fn package_uris_with_hyphens_resolve_without_ros() {
    let tmp = tempfile::tempdir().unwrap();
    let ws = tmp.path().join("ws");
    let pkg = ws.join("example-robot-data");
    let mesh = pkg.join("robots/ur/meshes/base.stl");
    write(&mesh, "solid empty\nendsolid empty\n");
    let uri = "package://example-robot-data/robots/ur/meshes/base.stl";

    // (c) parent folders: the URDF sits inside the package.
    let inside = pkg.join("robots/ur/urdf/ur5.urdf");
    write(&inside, mesh_urdf(uri));
    let found = package::resolve_with(uri, &inside, &[], &[]).expect("via parent folders");
    assert_eq!(found.canonicalize().unwrap(), mesh.canonicalize().unwrap());
    let model = load_urdf(&inside);
    match &model.links[0].visuals[0].geometry {
        Geometry::Mesh {
            uri: u,
            path,
            scale,
        } => {
            assert_eq!(u, uri);
            assert!(path.is_some());
            assert_eq!(*scale, Vector3::new(1.0, 1.0, -1.0));
        }
        g => panic!("{g:?}"),
    }
    assert!(
        model.links[0].problems.is_empty(),
        "{:?}",
        model.links[0].problems
    );

    // (a) search paths: the URDF elsewhere; the folder holding the package, or the package
    // folder itself.
    let outside = tmp.path().join("elsewhere/robot.urdf");
    write(&outside, mesh_urdf(uri));
    assert_eq!(package::resolve_with(uri, &outside, &[], &[]), None);
    for search in [ws.clone(), pkg.clone()] {
        let found = package::resolve_with(uri, &outside, std::slice::from_ref(&search), &[])
            .unwrap_or_else(|| panic!("via {}", search.display()));
        assert_eq!(found.canonicalize().unwrap(), mesh.canonicalize().unwrap());
    }
    let model = urdf::load(
        &outside,
        &urdf::LoadOptions {
            package_paths: vec![ws.clone()],
            ..Default::default()
        },
    )
    .unwrap();
    assert!(model.links[0].problems.is_empty());

    // (b) ROS_PACKAGE_PATH-style entries.
    assert!(package::resolve_with(uri, &outside, &[], std::slice::from_ref(&ws)).is_some());

    // Unresolved: a problem on the link, not an error, no panic.
    let model = load_urdf(&outside);
    let problems = &model.links[0].problems;
    assert!(
        problems
            .iter()
            .any(|p| p.contains("not found") && p.contains(uri)),
        "{problems:?}"
    );
    assert!(matches!(
        &model.links[0].visuals[0].geometry,
        Geometry::Mesh { path: None, .. }
    ));
    // A missing mesh does not stop the simulation.
    model.check_simulable(false).unwrap();
}

#[test]
fn file_uris_and_relative_paths_resolve() {
    let tmp = tempfile::tempdir().unwrap();
    let urdf = tmp.path().join("robot/model.urdf");
    let mesh = tmp.path().join("robot/meshes/a b.obj");
    write(&urdf, "");
    write(&mesh, "");
    let abs = format!("file://{}", mesh.display()).replace(' ', "%20");
    assert_eq!(
        package::resolve_with(&abs, &urdf, &[], &[]),
        Some(mesh.clone())
    );
    let found = package::resolve_with("meshes/a b.obj", &urdf, &[], &[]).unwrap();
    assert_eq!(found.canonicalize().unwrap(), mesh.canonicalize().unwrap());
    assert_eq!(
        package::resolve_with("meshes/none.obj", &urdf, &[], &[]),
        None
    );
}

// ---------------------------------------------------------------- kinematics

#[test]
fn arm_forward_kinematics_matches_hand_computation() {
    let model = load_urdf(&common::root().join("models/arm.urdf"));
    let names: Vec<&str> = model.links.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["base", "upper_arm", "forearm", "hand", "tool0"]);
    assert_eq!(model.links[model.root].name, "base");
    let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2);
    let rx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), FRAC_PI_2);
    let id = UnitQuaternion::identity();
    let pose = |n: &str| link(&model, n).model_from_link;
    assert_pose(&pose("base"), Vector3::zeros(), id, 1e-12);
    assert_pose(&pose("upper_arm"), Vector3::new(0.0, 0.0, 0.1), id, 1e-12);
    assert_pose(&pose("forearm"), Vector3::new(0.0, 0.0, 0.4), rz, 1e-12);
    assert_pose(&pose("hand"), Vector3::new(0.0, 0.25, 0.4), rz * rx, 1e-12);
    assert_pose(
        &pose("tool0"),
        Vector3::new(0.08, 0.25, 0.4),
        rz * rx,
        1e-12,
    );
    assert_eq!(link(&model, "tool0").source, InertiaSource::Missing);
    for l in &model.links {
        assert!(l.problems.is_empty(), "{}: {:?}", l.name, l.problems);
    }
    model.check_simulable(false).unwrap();

    // Visual kinds: box, cylinder and sphere all present.
    let kinds: Vec<&str> = model
        .links
        .iter()
        .flat_map(|l| l.visuals.iter())
        .map(|v| match v.geometry {
            Geometry::Box { .. } => "box",
            Geometry::Cylinder { .. } => "cylinder",
            Geometry::Sphere { .. } => "sphere",
            _ => "other",
        })
        .collect();
    for k in ["box", "cylinder", "sphere"] {
        assert!(kinds.contains(&k), "{kinds:?}");
    }
}

#[test]
fn arm_forward_kinematics_at_a_bent_elbow() {
    // Elbow (axis y of its joint frame) at +90 deg: the forearm's x, Rz(90) Ry(90) x, points
    // down (0, 0, -1), so the hand sits 0.25 m below the elbow at z = 0.15.
    let q = HashMap::from([("elbow".to_string(), FRAC_PI_2)]);
    let model = urdf::load(
        &common::root().join("models/arm.urdf"),
        &urdf::LoadOptions {
            joint_positions: q,
            ..Default::default()
        },
    )
    .unwrap();
    let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2);
    let ry = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), FRAC_PI_2);
    let rx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), FRAC_PI_2);
    let hand = link(&model, "hand").model_from_link;
    assert_pose(&hand, Vector3::new(0.0, 0.0, 0.15), rz * ry * rx, 1e-12);
    // An unknown joint name is an error naming the file and joint.
    let q = HashMap::from([("knee".to_string(), 1.0)]);
    let msg = urdf::load(
        &common::root().join("models/arm.urdf"),
        &urdf::LoadOptions {
            joint_positions: q,
            ..Default::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(msg.contains("arm.urdf") && msg.contains("`knee`"), "{msg}");
}

// ---------------------------------------------------------------- totals

#[test]
fn two_link_total_matches_hand_computation() {
    let model = load_urdf(&data("two_links.urdf"));
    let total = model.total_mass_properties().unwrap();
    // By hand: a (1 kg at 0, diag(0.01, 0.02, 0.03)); b (3 kg at (1, 0.5, 0), diag(0.2, 0.1, 0.3)
    // in model axes). Two bodies about their common centre: sum of own inertias plus the
    // reduced mass mu = m_a m_b / M = 0.75 at separation r = (1, 0.5, 0):
    //   mu (|r|^2 E - r r^T) = 0.75 [[0.25, -0.5, 0], [-0.5, 1, 0], [0, 0, 1.25]].
    assert_eq!(total.mass, 4.0);
    assert_close_v(&total.com, &Vector3::new(0.75, 0.375, 0.0), 1e-15);
    #[rustfmt::skip]
    let expected = Matrix3::new(
        0.01 + 0.2 + 0.1875, -0.375, 0.0,
        -0.375, 0.02 + 0.1 + 0.75, 0.0,
        0.0, 0.0, 0.03 + 0.3 + 0.9375,
    );
    // Measured 0 (cos(pi/2) rounding cancels here); bound 1e-12 for other platforms' libm.
    assert_close_m(&total.inertia, &expected, 1e-12);
    // The massless sensor frame does not count, but is placed: b * (0, 0, 5).
    let sensor = link(&model, "sensor");
    assert_eq!(sensor.source, InertiaSource::Missing);
    assert_close_v(
        &sensor.model_from_link.translation.vector,
        &Vector3::new(1.0, 0.0, 5.0),
        1e-12,
    );
}

#[test]
fn total_is_invariant_under_moving_the_parts_together() {
    // Combining then moving equals moving then combining (rotation and translation).
    let model = load_urdf(&common::root().join("models/arm.urdf"));
    let total = model.total_mass_properties().unwrap();
    let world_from_model = Isometry3::from_parts(
        Translation3::new(3.0, -1.0, 2.0),
        UnitQuaternion::from_euler_angles(0.3, FRAC_PI_6, -1.2),
    );
    let moved: Vec<MassProperties> = model
        .links
        .iter()
        .filter(|l| l.has_mass())
        .map(|l| {
            l.inertial
                .unwrap()
                .transformed(&(world_from_model * l.model_from_link))
        })
        .collect();
    let a = MassProperties::combine(&moved).unwrap();
    let b = total.transformed(&world_from_model);
    assert!((a.mass - 4.8).abs() < 1e-15);
    // Coordinates ~3: measured 4.4e-16; bound 1e-13.
    assert_close_v(&a.com, &b.com, 1e-13);
    // Entries ~0.1: measured 9.7e-17; bound 1e-14.
    assert_close_m(&a.inertia, &b.inertia, 1e-14);
}

// ---------------------------------------------------------------- inspect

#[test]
fn inspect_json_structure() {
    let model = load_urdf(&data("missing_and_zero.urdf"));
    let r = inspect::report(&model);
    assert_eq!(r["model"], "missing_and_zero");
    assert_eq!(r["root"], "frame");
    assert_eq!(r["ok"], false);
    assert!(
        r["file"]
            .as_str()
            .unwrap()
            .ends_with("missing_and_zero.urdf")
    );
    let links = r["links"].as_array().unwrap();
    assert_eq!(links.len(), 3);
    for l in links {
        for key in [
            "name",
            "mass",
            "com",
            "inertia",
            "principal_moments",
            "source",
            "problems",
            "model_from_link",
        ] {
            assert!(l.get(key).is_some(), "link lacks {key}: {l}");
        }
        assert_eq!(l["com"].as_array().unwrap().len(), 3);
        let rows = l["inertia"].as_array().unwrap();
        assert_eq!(rows.len(), 3);
        assert!(rows.iter().all(|r| r.as_array().unwrap().len() == 3));
    }
    assert_eq!(links[0]["name"], "frame");
    assert_eq!(links[0]["source"], "missing");
    assert_eq!(links[0]["mass"], 0.0);
    assert_eq!(links[1]["source"], "urdf");
    assert!(
        links[1]["problems"][0]
            .as_str()
            .unwrap()
            .contains("mass is zero")
    );
    assert_eq!(links[2]["mass"], 2.0);
    assert_eq!(links[2]["com"], serde_json::json!([0.0, 0.0, 0.1]));
    assert_eq!(
        links[2]["principal_moments"],
        serde_json::json!([0.02, 0.02, 0.02])
    );
    assert_eq!(r["total_mass"], 2.0);
    assert_eq!(r["com"], serde_json::json!([0.0, 0.0, 0.1]));
    assert_eq!(r["inertia_about_com"][2][2], 0.02);

    // A NaN mass becomes null, not a broken document.
    let r = inspect::report(&load_urdf(&data("nan_mass.urdf")));
    assert!(r["links"][1]["mass"].is_null());
    serde_json::to_string(&r).unwrap();
}

#[test]
fn inspect_run_and_text() {
    use clap::Parser;
    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: InspectArgs,
    }
    let arm = common::root().join("models/arm.urdf");
    let cli = Cli::try_parse_from([
        "inspect",
        arm.to_str().unwrap(),
        "--json",
        "--package-path",
        "/a",
        "--package-path",
        "/b",
    ])
    .unwrap();
    assert!(cli.args.json);
    assert_eq!(
        cli.args.package_paths,
        [PathBuf::from("/a"), PathBuf::from("/b")]
    );
    assert!(inspect::run(&cli.args).unwrap());

    let zero = InspectArgs {
        model: data("missing_and_zero.urdf"),
        json: false,
        package_paths: vec![],
        allow_mesh_paths: vec![],
        mass: Default::default(),
        compare: false,
        strict: false,
    };
    assert!(!inspect::run(&zero).unwrap());
    let missing = InspectArgs {
        model: PathBuf::from("/nonexistent.urdf"),
        json: false,
        package_paths: vec![],
        allow_mesh_paths: vec![],
        mass: Default::default(),
        compare: false,
        strict: false,
    };
    let err = inspect::run(&missing).unwrap_err();
    assert!(format!("{err:#}").contains("/nonexistent.urdf"));

    let text = inspect::render_text(&load_urdf(&arm));
    for needle in [
        "link `hand`",
        "link `tool0` (no <inertial>",
        "principal moments",
        "total",
        "4.80000 kg",
        "no problems found",
    ] {
        assert!(text.contains(needle), "`{needle}` not in\n{text}");
    }
}

/// `<dynamics damping>` and `<limit effort>` are kept as written for every joint type (0 when
/// absent); `friction` is not read.
#[test]
fn joint_damping_and_effort_are_read_as_written() {
    let xml = r#"<robot name="r">
      <link name="a"/><link name="b"/><link name="c"/><link name="d"/>
      <joint name="hinge" type="revolute"><parent link="a"/><child link="b"/>
        <limit lower="-1" upper="1" effort="12.5" velocity="1"/>
        <dynamics damping="0.3" friction="7"/></joint>
      <joint name="spin" type="continuous"><parent link="b"/><child link="c"/>
        <limit effort="4" velocity="1"/></joint>
      <joint name="weld" type="fixed"><parent link="c"/><child link="d"/>
        <dynamics damping="2"/></joint>
    </robot>"#;
    let model = urdf::load_str(xml, Path::new("dyn.urdf"), &Default::default()).unwrap();
    let read: Vec<(&str, f64, f64)> = model
        .joints
        .iter()
        .map(|j| (j.name.as_str(), j.damping, j.effort_limit))
        .collect();
    assert_eq!(
        read,
        [("hinge", 0.3, 12.5), ("spin", 0.0, 4.0), ("weld", 2.0, 0.0)]
    ); // `<limit velocity>` as written, for `inspect` (0 without a `<limit>`).
    let velocity: Vec<f64> = model.joints.iter().map(|j| j.velocity_limit).collect();
    assert_eq!(velocity, [1.0, 1.0, 0.0]);
}
