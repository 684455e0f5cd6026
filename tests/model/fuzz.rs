//! Property tests of the readers of untrusted input ("fuzzing" with proptest): the URDF loader,
//! the scene parser and the STL, OBJ and Collada readers are fed random mutations of valid
//! files (byte flips, truncation, deleted and duplicated elements or lines, attribute and
//! value replacements by NaN, infinities, huge, negative and non-numeric values, random bytes
//! inserted) and pure random bytes.
//!
//! The property, per target: the reader (and what runs on its output: validation, inertia
//! policies, mass properties, the inspect report) never panics, never hangs, and every error
//! it returns has a message. A panic is caught (`catch_unwind`), reported with the input that
//! caused it (proptest shrinks it first) and fails the test.
//!
//! Cases per target: `TUMBLE_FUZZ_CASES` (default 1000, under a second in release); seed:
//! `TUMBLE_FUZZ_SEED` (default 0, so CI runs are repeatable). The long campaign recorded in the
//! docs/reliability.md ("Hostile input"):
//!
//! ```sh
//! for t in urdf scene stl obj; do
//!   TUMBLE_FUZZ_CASES=1000000 TUMBLE_FUZZ_SEED=1 cargo test --release --test model fuzz::fuzz_$t -- --nocapture; done
//! TUMBLE_FUZZ_CASES=200000 TUMBLE_FUZZ_SEED=1 cargo test --release --test model fuzz::fuzz_dae -- --nocapture
//! ```
//!
//! Each target prints `fuzz <target>: N executions (A accepted, R refused with a message), 0 panics,
//! slowest case S s`.

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use std::panic::AssertUnwindSafe;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};
use tumble::commands::inspect::{self, ReportOptions};
use tumble::model::geometry::mesh::TriangleMesh;
use tumble::model::geometry::mesh_io::{DaeOptions, UpAxis, dae, obj, stl};
use tumble::model::policy::{self, GeometrySource, InertiaPolicy, MassSettings, ModelMassSettings};
use tumble::model::urdf;
use tumble::scene::Scene;

use crate::common;

/// Hang detection only (not a speed test): the slowest single case must finish within this.
const HANG_LIMIT: Duration = Duration::from_secs(30);

fn cases() -> u32 {
    std::env::var("TUMBLE_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1000)
}

fn runner(target: &str) -> TestRunner {
    let seed: u64 = std::env::var("TUMBLE_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    // One stream per target, so that targets do not see the same random choices.
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    for (k, b) in target.bytes().enumerate() {
        bytes[8 + k % 24] ^= b;
    }
    let config = Config {
        cases: cases(),
        failure_persistence: None,
        max_shrink_iters: 2000,
        ..Config::default()
    };
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &bytes))
}

/// Runs `check` on every input `strategy` draws; fails on a panic, an empty error message or a
/// case slower than [`HANG_LIMIT`]; prints the number of executions.
fn fuzz<S: Strategy>(
    target: &str,
    strategy: S,
    check: impl Fn(S::Value) -> Result<Outcome, String>,
) {
    let executions = AtomicU64::new(0);
    let accepted = AtomicU64::new(0);
    let slowest = std::sync::Mutex::new(Duration::ZERO);
    let result = runner(target).run(&strategy, |input| {
        executions.fetch_add(1, Ordering::Relaxed);
        let started = Instant::now();
        let outcome = std::panic::catch_unwind(AssertUnwindSafe(|| check(input)));
        let took = started.elapsed();
        {
            let mut s = slowest.lock().unwrap();
            *s = (*s).max(took);
        }
        match outcome {
            Err(panic) => {
                let message = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                Err(TestCaseError::fail(format!("panicked: {message}")))
            }
            Ok(Err(problem)) => Err(TestCaseError::fail(problem)),
            Ok(Ok(_)) if took > HANG_LIMIT => Err(TestCaseError::fail(format!(
                "one case took {took:?} (hang?)"
            ))),
            Ok(Ok(outcome)) => {
                if outcome == Outcome::Accepted {
                    accepted.fetch_add(1, Ordering::Relaxed);
                }
                Ok(())
            }
        }
    });
    let slowest = *slowest.lock().unwrap();
    let n = executions.load(Ordering::Relaxed);
    let ok = accepted.load(Ordering::Relaxed);
    eprintln!(
        "fuzz {target}: {n} executions ({ok} accepted, {} refused with a message), {} panics, \
         slowest case {:.3} s",
        n - ok,
        if result.is_ok() { "0" } else { "some" },
        slowest.as_secs_f64()
    );
    if let Err(e) = result {
        panic!("fuzz {target}: {e}");
    }
}

/// What a reader did with one input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    /// Read it (and everything downstream ran).
    Accepted,
    /// Refused it with a message.
    Refused,
}

/// An error message must say something.
fn nonempty(target: &str, message: String) -> Result<Outcome, String> {
    if message.trim().is_empty() {
        Err(format!("{target}: an error with an empty message"))
    } else {
        Ok(Outcome::Refused)
    }
}

// ------------------------------------------------------------------------------ mutations

/// Values put in place of attribute values and TOML values.
const HOSTILE_VALUES: &[&str] = &[
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "infinity",
    "1e308",
    "-1e308",
    "1e999",
    "-1e999",
    "1e-320",
    "-1",
    "-0.0",
    "0",
    "1",
    "2",
    "18446744073709551616",
    "4294967295",
    "-9223372036854775809",
    "abc",
    "",
    " ",
    "1 2",
    "1 2 3",
    "1 2 3 4",
    "nan nan nan",
    "0 0 0",
    "-1 -1 -1",
    "1e308 1e308 1e308",
    "0x10",
    "1,2,3",
    "package://pkg/../../x.stl",
    "/dev/zero",
    "file:///dev/urandom",
    "../../../../../../etc/passwd",
    "\"",
    "&amp;",
    "&bogus;",
    "<",
    "[",
    "{}",
    "true",
    "\"text\"",
    "[1.0, 2.0]",
    "[nan, inf, -inf]",
];

/// A position as a fraction of a length (`x / 2^32`), mapped onto the current length when a
/// mutation is applied; shrinks towards the start.
#[derive(Debug, Clone, Copy)]
struct Index(u32);

impl Index {
    /// The position in `0..len` (`len` > 0).
    fn index(self, len: usize) -> usize {
        ((u64::from(self.0) * len as u64) >> 32) as usize
    }

    /// The fraction `f` in [0, 1).
    fn at(f: f64) -> Index {
        Index((f * 4294967296.0) as u32)
    }
}

fn index() -> impl Strategy<Value = Index> {
    any::<u32>().prop_map(Index)
}

/// One edit of a text or byte string.
#[derive(Debug, Clone)]
enum Mutation {
    /// Replace the byte at a position.
    Flip(Index, u8),
    /// Cut the text at a position.
    Truncate(Index),
    /// Delete the span between two `<` (or line starts), i.e. a run of elements or lines.
    Delete(Index, Index),
    /// Copy the span between two `<` (or line starts) to another such position.
    Duplicate(Index, Index, Index),
    /// Replace a quoted attribute value (`"..."`) or a TOML value (after `= `) by one of
    /// [`HOSTILE_VALUES`].
    Value(Index, Index),
    /// Insert random bytes at a position.
    Insert(Index, Vec<u8>),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        2 => (index(), any::<u8>()).prop_map(|(i, b)| Mutation::Flip(i, b)),
        1 => index().prop_map(Mutation::Truncate),
        2 => (index(), index()).prop_map(|(a, b)| Mutation::Delete(a, b)),
        2 => (index(), index(), index())
            .prop_map(|(a, b, c)| Mutation::Duplicate(a, b, c)),
        5 => (index(), index()).prop_map(|(a, b)| Mutation::Value(a, b)),
        1 => (index(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(i, b)| Mutation::Insert(i, b)),
    ]
}

/// Positions where a mutation may cut: before each `<`, and at each line start.
fn boundaries(bytes: &[u8]) -> Vec<usize> {
    let mut out = vec![0];
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'<' || (b == b'\n' && i + 1 < bytes.len()) {
            out.push(if b == b'<' { i } else { i + 1 });
        }
    }
    out.push(bytes.len());
    out
}

/// Byte ranges of values: inside `"..."`, or after `= ` up to the end of the line.
fn value_ranges(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'"' {
            if let Some(len) = bytes[i + 1..].iter().position(|&b| b == b'"') {
                out.push((i + 1, i + 1 + len));
                i += len + 2;
                continue;
            }
        } else if bytes[i] == b'=' && bytes.get(i + 1) == Some(&b' ') {
            let end = bytes[i..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(bytes.len(), |p| i + p);
            out.push((i + 2, end));
        }
        i += 1;
    }
    out
}

fn apply(seed: &[u8], mutations: &[Mutation]) -> Vec<u8> {
    let mut b = seed.to_vec();
    for m in mutations {
        match m {
            Mutation::Flip(i, x) if !b.is_empty() => {
                let i = i.index(b.len());
                b[i] = *x;
            }
            Mutation::Truncate(i) => b.truncate(i.index(b.len() + 1)),
            Mutation::Delete(x, y) => {
                let cuts = boundaries(&b);
                let (p, q) = (cuts[x.index(cuts.len())], cuts[y.index(cuts.len())]);
                b.drain(p.min(q)..p.max(q));
            }
            Mutation::Duplicate(x, y, z) => {
                let cuts = boundaries(&b);
                let (p, q) = (cuts[x.index(cuts.len())], cuts[y.index(cuts.len())]);
                let span = b[p.min(q)..p.max(q)].to_vec();
                let at = cuts[z.index(cuts.len())];
                b.splice(at..at, span);
            }
            Mutation::Value(x, v) => {
                let ranges = value_ranges(&b);
                if !ranges.is_empty() {
                    let (p, q) = ranges[x.index(ranges.len())];
                    let value = HOSTILE_VALUES[v.index(HOSTILE_VALUES.len())];
                    b.splice(p..q, value.bytes());
                }
            }
            Mutation::Insert(i, bytes) => {
                let at = i.index(b.len() + 1);
                b.splice(at..at, bytes.iter().copied());
            }
            Mutation::Flip(..) => {}
        }
    }
    b
}

/// A valid seed (six times in ten) or a hostile one (three in ten) with 1 to 4 mutations
/// applied, or (one time in ten) random bytes. Valid seeds keep a good share of the inputs
/// readable, so that what runs after the parser is exercised too.
fn mutated(valid: Vec<Vec<u8>>, hostile: Vec<Vec<u8>>) -> impl Strategy<Value = Vec<u8>> {
    let (n, h) = (valid.len(), hostile.len().max(1));
    let hostile = if hostile.is_empty() {
        valid.clone()
    } else {
        hostile
    };
    prop_oneof![
        6 => (0..n, prop::collection::vec(mutation(), 1..5))
            .prop_map(move |(k, m)| apply(&valid[k], &m)),
        3 => (0..h, prop::collection::vec(mutation(), 1..5))
            .prop_map(move |(k, m)| apply(&hostile[k], &m)),
        1 => prop::collection::vec(any::<u8>(), 0..512),
    ]
}

/// The files in `dir` (relative to the repository root) with one of `extensions`.
fn seed_files(dir: &str, extensions: &[&str]) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(common::root().join(dir))
        .unwrap_or_else(|e| panic!("{dir}: {e}"))
        .filter_map(|e| Some(e.ok()?.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| extensions.contains(&e))
        })
        .collect();
    files.sort();
    files
}

fn read_all(files: &[PathBuf]) -> Vec<Vec<u8>> {
    files.iter().map(|f| std::fs::read(f).unwrap()).collect()
}

// ------------------------------------------------------------------------------ targets

/// Everything downstream of a loaded model that reads its values: every inertia policy (mesh
/// files read from disk), validation, totals, the inspect report.
fn exercise_model(model: &tumble::model::Model) -> Result<Outcome, String> {
    let _ = model.check_simulable(false);
    let _ = model.total_mass_properties();
    let _ = inspect::render_text(model);
    let _ = inspect::report(model);
    for inertia in [InertiaPolicy::Geometry, InertiaPolicy::Auto] {
        let mut m = model.clone();
        let settings = ModelMassSettings {
            model: MassSettings {
                inertia: Some(inertia),
                density: Some(1000.0),
                geometry: Some(GeometrySource::Visual),
            },
            links: Default::default(),
        };
        match policy::apply(&mut m, &settings) {
            Ok(()) => {
                let options = ReportOptions {
                    settings,
                    compare: true,
                };
                let _ = inspect::report_with(&m, &options);
                let _ = inspect::render_text_with(&m, &options);
                let _ = m.check_simulable(true);
            }
            Err(e) => {
                nonempty("policy", e.to_string())?;
            }
        }
    }
    Ok(Outcome::Accepted)
}

#[test]
fn fuzz_urdf_loader() {
    let mut valid = read_all(&seed_files("models", &["urdf"]));
    for ok in [
        "mesh_relative_parent_ok.urdf",
        "mesh_scale_negative_mirrors.urdf",
        "mass_huge.urdf",
    ] {
        valid.push(std::fs::read(common::root().join("tests/hostile/urdf").join(ok)).unwrap());
    }
    let hostile = read_all(&seed_files("tests/hostile/urdf", &["urdf"]));
    // Loaded as if from the hostile corpus, so that its relative meshes (../mesh/...) resolve.
    let path = common::root().join("tests/hostile/urdf/fuzzed.urdf");
    fuzz("urdf", mutated(valid, hostile), |bytes| {
        let text = String::from_utf8_lossy(&bytes);
        match urdf::load_str(&text, &path, &Default::default()) {
            Ok(model) => exercise_model(&model),
            Err(e) => {
                let message = e.to_string();
                if !message.contains("fuzzed.urdf") {
                    return Err(format!("error does not name the file: {message}"));
                }
                nonempty("urdf", message)
            }
        }
    });
}

#[test]
fn fuzz_scene_parser() {
    let valid = read_all(&seed_files("models", &["toml"]));
    let hostile = read_all(&seed_files("tests/hostile/scene", &["toml"]));
    // Parsed as if in models/, so that `urdf = "box.urdf"` and the like load.
    let path = common::root().join("models/fuzzed.toml");
    fuzz("scene", mutated(valid, hostile), |bytes| {
        let text = String::from_utf8_lossy(&bytes);
        let scene = match Scene::parse(&text, &path) {
            Ok(scene) => scene,
            Err(e) => return nonempty("scene", format!("{e:#}")),
        };
        let _ = scene.steps();
        let _ = scene.metadata();
        match scene.build() {
            Ok(world) => {
                let _ = tumble::commands::simulate::step_warning(&scene, &world);
                Ok(Outcome::Accepted)
            }
            Err(e) => nonempty("scene build", format!("{e:#}")),
        }
    });
}

/// What runs on a mesh a reader returned: topology checks, scaling, mass properties.
fn exercise_mesh(mesh: &TriangleMesh) {
    let _ = mesh.check();
    let _ = mesh.mass_properties(1000.0);
    let _ = mesh
        .scaled(&nalgebra::Vector3::new(-1.0, 2.0, 1e-3))
        .mass_properties(1.0);
}

fn mesh_target(
    target: &str,
    valid: Vec<Vec<u8>>,
    hostile: Vec<Vec<u8>>,
    read: impl Fn(&[u8]) -> Result<TriangleMesh, String>,
) {
    fuzz(target, mutated(valid, hostile), |bytes| {
        match read(&bytes) {
            Ok(mesh) => {
                exercise_mesh(&mesh);
                Ok(Outcome::Accepted)
            }
            Err(e) => nonempty(target, e),
        }
    });
}

fn hostile_meshes(prefix: &str) -> Vec<Vec<u8>> {
    let files: Vec<PathBuf> = seed_files("tests/hostile/mesh", &["stl", "obj", "dae"])
        .into_iter()
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(prefix))
        })
        .collect();
    read_all(&files)
}

fn hostile_mesh(name: &str) -> Vec<u8> {
    std::fs::read(common::root().join("tests/hostile/mesh").join(name)).unwrap()
}

#[test]
fn fuzz_stl_reader() {
    let valid = vec![
        hostile_mesh("cube.stl"),
        b"solid cube\nfacet normal 0 0 -1\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 1 0\n\
          endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 1\nvertex 1 0 1\n\
          vertex 1 1 1\nendloop\nendfacet\nendsolid cube\n"
            .to_vec(),
    ];
    mesh_target("stl", valid, hostile_meshes("stl_"), stl::read_stl);
}

#[test]
fn fuzz_obj_reader() {
    let valid = vec![
        b"o tetra\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nvt 0 0\n\
          f 1/1/1 3/1/1 2/1/1\nf 1//1 2//1 4//1\nf -4 -1 -2\nf 2 3 4\ng second\nf 1 2 3 4\n"
            .to_vec(),
    ];
    mesh_target("obj", valid, hostile_meshes("obj_"), obj::read_obj);
}

#[test]
fn fuzz_dae_reader() {
    let valid = vec![
        hostile_mesh("dae_tetra_ok.dae"),
        hostile_mesh("dae_up_axis_bogus.dae"),
    ];
    mesh_target("dae", valid, hostile_meshes("dae_"), |bytes| {
        let rotated = dae::read_dae(
            bytes,
            &DaeOptions {
                up_axis: UpAxis::RotateToZUp,
            },
        );
        if let Ok(mesh) = rotated {
            exercise_mesh(&mesh);
        }
        dae::read_dae(bytes, &DaeOptions::default())
    });
}

/// The mutation engine itself: each kind of edit does what it says (so that the campaign
/// figures mean what docs/reliability.md says).
#[test]
fn mutations_edit_what_they_say() {
    let seed = b"<a x=\"1\">\n<b y=\"2\"/>\n</a>\n";
    let value = apply(seed, &[Mutation::Value(Index::at(0.0), Index::at(0.0))]);
    assert_eq!(value, b"<a x=\"nan\">\n<b y=\"2\"/>\n</a>\n");
    let cut = apply(seed, &[Mutation::Truncate(Index::at(0.0))]);
    assert!(cut.is_empty());
    let deleted = apply(seed, &[Mutation::Delete(Index::at(0.0), Index::at(0.99))]);
    assert!(deleted.len() < seed.len());
    let duplicated = apply(
        seed,
        &[Mutation::Duplicate(
            Index::at(0.0),
            Index::at(0.99),
            Index::at(0.0),
        )],
    );
    assert!(duplicated.len() > seed.len());
    let toml = apply(
        b"dt = 0.001\n",
        &[Mutation::Value(Index::at(0.0), Index::at(0.2))],
    );
    assert_ne!(toml, b"dt = 0.001\n");
    assert!(value_ranges(b"a = 1\nb = \"x\"\n").len() >= 2);
}
