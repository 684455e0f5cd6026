//! Bad contact input (issue 31), through the `tumble` binary: each is one error (exit status 2)
//! naming the scene file and the key — and for geometry the URDF, the link and the element —
//! with no panic and nothing written ([`super::hostile::refused_with`]).

use super::hostile::refused_with;

fn refused(scene: &str, expected: &[&str]) {
    refused_with(scene, &[], expected);
}

const PENDULUM: &str = "[sim]\nduration = 0.01\n[[model]]\nurdf = \"double_pendulum.urdf\"\n";

/// A one-link model `probe` whose link `body` has `geometry` (the inside of `<collision>` or
/// `<visual>` elements).
fn probe(elements: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<robot name="probe">
  <link name="body">
    <inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>
    {elements}
  </link>
</robot>
"#
    )
}

const PROBE: &str = "[sim]\nduration = 0.01\n[ground]\n[[model]]\nurdf = \"probe.urdf\"\n";

fn refused_probe(model_keys: &str, urdf: &str, files: &[(&str, &[u8])], expected: &[&str]) {
    let mut all: Vec<(&str, &[u8])> = vec![("probe.urdf", urdf.as_bytes())];
    all.extend_from_slice(files);
    refused_with(&format!("{PROBE}{model_keys}"), &all, expected);
}

#[test]
fn bad_ground_values_are_refused() {
    for (table, expected) in [
        (
            "friction = -0.5",
            &[
                "bad.toml: ground.friction must be a finite number >= 0",
                "got -0.5",
            ][..],
        ),
        (
            "friction = nan",
            &["ground.friction must be a finite number >= 0"],
        ),
        (
            "friction = inf",
            &["ground.friction must be a finite number >= 0"],
        ),
        (
            "restitution = 1.5",
            &[
                "bad.toml: ground.restitution must be a number between 0 and 1",
                "got 1.5",
            ],
        ),
        (
            "restitution = -0.1",
            &["ground.restitution must be a number between 0 and 1"],
        ),
        (
            "normal = [0, 0, 0]",
            &["bad.toml: ground.normal has zero length"],
        ),
        (
            "normal = [0, 0, nan]",
            &["ground.normal must hold three finite numbers"],
        ),
        (
            "normal = [0, 0, 1]\npoint = [nan, 0, 0]",
            &["ground.point must hold three finite numbers"],
        ),
        (
            "height = 0.0\nnormal = [0, 0, 1]",
            &["ground: give either `height`", "not both"],
        ),
        (
            "height = 0.0\npoint = [0, 0, 0]",
            &["ground.point goes with `normal`"],
        ),
        ("height = nan", &["ground.height must be a finite number"]),
        ("heigth = 0.0", &["unknown field `heigth`", "height"]),
    ] {
        refused(&format!("[ground]\n{table}\n{PENDULUM}"), expected);
    }
    refused(
        &format!(
            "[ground]\nheight = 0\n{}",
            PENDULUM.replace("[sim]\n", "[sim]\ngravity = [0, 0, 0]\n")
        ),
        &[
            "ground.height is measured along −gravity, and sim.gravity is zero",
            "`normal`",
        ],
    );
}

#[test]
fn bad_model_contact_keys_are_refused() {
    for (keys, expected) in [
        (
            "collisions = \"mesh\"",
            &[
                "bad.toml: model[0].collisions: unknown value \"mesh\"",
                "\"none\", \"urdf\", \"visual\"",
            ][..],
        ),
        (
            "collisions = \"urdf\"\nfriction = -1",
            &["model[0].friction must be a finite number >= 0"],
        ),
        (
            "collisions = \"urdf\"\nfriction = inf",
            &["model[0].friction must be a finite number >= 0"],
        ),
        (
            "collisions = \"urdf\"\nrestitution = 2",
            &["model[0].restitution must be a number between 0 and 1"],
        ),
        (
            "collisions = \"urdf\"\nrestitution = nan",
            &["model[0].restitution must be a number between 0 and 1"],
        ),
        (
            "friction = 0.5",
            &[
                "model[0].friction applies to a model that collides",
                "collisions = \"urdf\"",
            ],
        ),
        (
            "self_collision = true",
            &["model[0].self_collision applies to a model that collides"],
        ),
    ] {
        refused(&format!("{PENDULUM}{keys}\n"), expected);
    }
}

/// A user asking for collisions must not silently get none.
#[test]
fn collisions_on_models_without_the_geometry_are_refused() {
    refused(
        &format!("{PENDULUM}collisions = \"urdf\"\n"),
        &[
            "bad.toml: model[0]: collisions = \"urdf\": model `double_pendulum`",
            "double_pendulum.urdf",
            "no link has <collision> geometry",
        ],
    );
    refused_probe(
        "collisions = \"visual\"\nbodies = \"rigid\"\n",
        &probe("<collision><geometry><sphere radius=\"0.1\"/></geometry></collision>"),
        &[],
        &[
            "model[0]: collisions = \"visual\": model `probe`",
            "no link has <visual> geometry",
            "collisions = \"urdf\" for its <collision> geometry",
        ],
    );
    // Geometry only on a massless link: with bodies = "links" no body carries it.
    let urdf = probe("").replace(
        "</robot>",
        "<link name=\"tag\"><collision><geometry><sphere radius=\"0.1\"/></geometry></collision></link>\n\
         <joint name=\"j\" type=\"fixed\"><parent link=\"body\"/><child link=\"tag\"/></joint>\n</robot>",
    );
    refused_probe(
        "collisions = \"urdf\"\n",
        &urdf,
        &[],
        &[
            "model[0]: collisions = \"urdf\": model `probe`",
            "probe.urdf",
            "no body carries <collision> geometry",
            "`tag` (no mass: with bodies = \"links\" it is no body)",
        ],
    );
}

#[test]
fn collision_geometry_without_size_is_refused() {
    for (elements, expected) in [
        (
            "<collision><geometry><box size=\"0.1 0 0.1\"/></geometry></collision>",
            "link `body`, collision #0: box size along y must be positive and finite (got 0)",
        ),
        (
            "<collision name=\"ball\"><geometry><sphere radius=\"-0.1\"/></geometry></collision>",
            "link `body`, collision `ball`: sphere radius must be positive and finite",
        ),
        (
            "<collision><geometry><sphere radius=\"0.1\"/></geometry></collision>\n\
             <collision><geometry><cylinder radius=\"0.1\" length=\"0\"/></geometry></collision>",
            "link `body`, collision #1: cylinder length must be positive and finite",
        ),
    ] {
        refused_probe(
            "collisions = \"urdf\"\n",
            &probe(elements),
            &[],
            &[
                "model[0]: collisions = \"urdf\": model `probe`",
                "probe.urdf",
                expected,
            ],
        );
    }
    refused_probe(
        "collisions = \"visual\"\n",
        &probe("<visual><geometry><box size=\"0.1 0.1 -0.1\"/></geometry></visual>"),
        &[],
        &[
            "collisions = \"visual\"",
            "link `body`, visual #0: box size along z must be positive and finite",
        ],
    );
}

/// Meshes that make no convex hull: too few points, all in a plane, not found, not a mesh.
#[test]
fn collision_meshes_without_a_hull_are_refused() {
    let mesh = |file: &str| {
        probe(&format!(
            "<collision><geometry><mesh filename=\"{file}\"/></geometry></collision>"
        ))
    };
    let triangle = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    refused_probe(
        "collisions = \"urdf\"\n",
        &mesh("triangle.obj"),
        &[("triangle.obj", triangle)],
        &[
            "link `body`, collision #0",
            "mesh `triangle.obj`",
            "3 vertices: a convex hull needs at least 4 points not in one plane",
        ],
    );
    let square = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\nf 1 3 2\nf 1 4 3\n";
    refused_probe(
        "collisions = \"urdf\"\n",
        &mesh("flat.obj"),
        &[("flat.obj", square)],
        &[
            "link `body`, collision #0",
            "its convex hull",
            "all 4 vertices lie in one plane",
        ],
    );
    // A tetrahedron flattened by its scale.
    let tetra = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";
    refused_probe(
        "collisions = \"urdf\"\n",
        &probe(
            "<collision><geometry><mesh filename=\"tetra.obj\" scale=\"1 1 0\"/></geometry></collision>",
        ),
        &[("tetra.obj", tetra)],
        &["mesh `tetra.obj`: scale [1, 1, 0] must be finite and non-zero"],
    );
    refused_probe(
        "collisions = \"urdf\"\n",
        &mesh("missing.stl"),
        &[],
        &["link `body`, collision #0", "mesh `missing.stl` not found"],
    );
    refused_probe(
        "collisions = \"urdf\"\n",
        &mesh("junk.obj"),
        &[("junk.obj", b"this is no mesh\n")],
        &["link `body`, collision #0", "mesh `junk.obj`", "junk.obj"],
    );
}

/// A collision mesh outside the folders meshes are read from is refused by the existing rule
/// (never read), collisions or not.
#[test]
fn collision_meshes_outside_the_allowed_folders_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let outside = dir.path().join("outside.obj");
    std::fs::write(
        &outside,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n",
    )
    .unwrap();
    let urdf = probe(&format!(
        "<collision><geometry><mesh filename=\"file://{}\"/></geometry></collision>",
        outside.display()
    ));
    refused_probe(
        "collisions = \"urdf\"\n",
        &urdf,
        &[],
        &[
            "model[0]",
            "probe.urdf",
            "link `body`: collision #0",
            "outside.obj: refused: outside the folders meshes are read from",
        ],
    );
}

/// `trade`, `stability --scene` and `bench --scene` step the integrators directly, without the
/// contact phase: on a scene with contact each is refused, naming the scene and the verb, exit 2.
#[test]
fn sweeps_refuse_scenes_with_contact() {
    let scene = crate::common::scene("contact_box.toml");
    let dir = tempfile::tempdir().unwrap();
    for (args, verb) in [
        (vec!["trade", scene.as_str()], "trade"),
        (
            vec!["stability", "--scene", scene.as_str()],
            "stability --scene",
        ),
        (vec!["bench", "--scene", scene.as_str()], "bench --scene"),
    ] {
        let out = crate::common::tumble(&args, dir.path());
        let err = crate::common::text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{verb}: {err}");
        assert!(
            err.contains("contact_box.toml")
                && err.contains(&format!("{verb} does not support contact")),
            "{verb}: {err}"
        );
    }
}
