//! Models for the tests: files written and copied, URDFs loaded, links and poses checked.
#![allow(dead_code)]

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};
use tumble::model::{Link, Model};
use tumble::scene::Scene;

/// Writes `bytes` to `path`, creating its folders.
pub fn write(path: &Path, bytes: impl AsRef<[u8]>) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, bytes).unwrap();
}

/// Copies `models/<name>.urdf` into `dir` for each of `names`.
pub fn copy_models(dir: &Path, names: &[&str]) {
    for name in names {
        std::fs::copy(
            super::root().join(format!("models/{name}.urdf")),
            dir.join(format!("{name}.urdf")),
        )
        .unwrap();
    }
}

/// `tests/data/<folder>/<name>`.
pub fn data(folder: &str, name: &str) -> PathBuf {
    super::root().join("tests/data").join(folder).join(name)
}

/// The URDF at `path` loaded with the default settings; panics with the error's message.
pub fn load_urdf(path: &Path) -> Model {
    tumble::model::urdf::load(path, &Default::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// The link `name` of `model`.
pub fn link<'a>(model: &'a Model, name: &str) -> &'a Link {
    &model.links[model.link_index(name).expect(name)]
}

/// A scene text whose paths resolve in `models/`.
pub fn models_scene(text: &str) -> Scene {
    Scene::parse(text, &super::root().join("models/test_scene.toml")).expect("scene parses")
}

/// Asserts that `pose` has `translation` (each coordinate) and `rotation` (the angle between
/// them) both strictly within `tol`.
pub fn assert_pose(
    pose: &Isometry3<f64>,
    translation: Vector3<f64>,
    rotation: UnitQuaternion<f64>,
    tol: f64,
) {
    let dt = (pose.translation.vector - translation).amax();
    let dr = pose.rotation.angle_to(&rotation);
    assert!(
        dt < tol && dr < tol,
        "{pose} vs {translation} {rotation}: {dt:e} m, {dr:e} rad (bound {tol:e})"
    );
}

/// `|a - b| / |b|`.
pub fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}
