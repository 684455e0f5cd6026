//! Issue 32's corpus, at test time: every URDF of example-robot-data and of pybullet_data (the
//! pip packages of the test venv, never committed), articulated, fixed and floating base, 1 s at
//! dt = 1 ms, through this build's binary. `scripts/robot_corpus.py` runs them (two at a time)
//! and judges each run, the same script that writes docs/robot_corpus.md, so the table and the
//! test cannot disagree; the tests read its per-run lines (`--raw`) and assert that none fails.
//!
//! The full 1 s is kept: the 2328 runs and the 2000-odd reruns that follow the refusals' keys
//! took 40 s on 2 cores (the 1000 generated objects of `random_urdfs` are refused before any
//! step; the largest robots run 1000 steps in < 0.2 s).
//!
//! The script judges the energy from the run's two ends (the summary lines). The second test
//! looks at every step of the runs where nothing did work (no damping, friction or stop acted),
//! through the library: the variational step's energy error must stay bounded all along, not
//! only come back at t = 1 s.

use crate::common;

use std::collections::BTreeMap;
use std::process::Command;
use std::sync::{Arc, Mutex, OnceLock};
use tumble::scene::Scene;

/// The keys a refusal of a file Pinocchio loads may name as what runs it anyway: the model's
/// mass properties from its geometry, the inertia check relaxed, the other base.
const KEYS: [&str; 4] = [
    "inertia = \"geometry\"",
    "allow_non_physical_inertia",
    "base = \"floating\"",
    "base = \"fixed\"",
];

/// One run of the corpus: a line of `robot_corpus.py --raw`.
struct Row {
    corpus: String,
    file: String,
    base: String,
    /// `runs`, `refused` or `fails`.
    kind: String,
    /// The table's cell text: the energy figure of a run, the reason of a refusal.
    text: String,
    /// Whether Pinocchio loads the file (the corpus).
    pinocchio: bool,
    /// tumble's first error line (refusals).
    error: String,
    path: String,
    package_path: String,
    /// The "moving" runs' initial joint rates (a TOML inline table); empty for the others.
    joint_velocities: String,
}

/// The corpus, run once per test binary (both tests read it).
fn corpus() -> &'static [Row] {
    static ROWS: OnceLock<Vec<Row>> = OnceLock::new();
    ROWS.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let raw = dir.path().join("raw.tsv");
        let out = Command::new(common::python())
            .arg(common::root().join("scripts/robot_corpus.py"))
            .arg("--raw")
            .arg(&raw)
            .arg(common::exe())
            .output()
            .expect("cannot run scripts/robot_corpus.py");
        assert!(
            out.status.success(),
            "robot_corpus.py failed:\n{}",
            common::text(&out.stderr)
        );
        assert!(common::text(&out.stdout).contains("| corpus | files | base |"));
        std::fs::read_to_string(&raw)
            .unwrap()
            .lines()
            .map(|line| {
                let f: Vec<&str> = line.split('\t').collect();
                assert_eq!(f.len(), 10, "{line}");
                Row {
                    corpus: f[0].into(),
                    file: f[1].into(),
                    base: f[2].into(),
                    kind: f[3].into(),
                    text: f[4].into(),
                    pinocchio: f[5] == "1",
                    error: f[6].into(),
                    path: f[7].into(),
                    package_path: f[8].into(),
                    joint_velocities: f[9].into(),
                }
            })
            .collect()
    })
}

#[test]
fn every_corpus_urdf_runs_or_is_refused_with_its_reason() {
    let rows = corpus();
    // (corpus, base, kind) -> runs, over the files Pinocchio loads.
    let mut counts: BTreeMap<(&str, &str, &str), usize> = BTreeMap::new();
    for r in rows {
        let what = format!("{} {} {}", r.corpus, r.file, r.base);
        assert!(
            r.kind == "runs" || r.kind == "refused",
            "{what}: {} {}",
            r.kind,
            r.text
        );
        if r.kind == "refused" {
            // One line, naming the file.
            let name = r.file.rsplit('/').next().unwrap();
            assert!(
                r.error.starts_with("error: ") && r.error.contains(name),
                "{what}: {}",
                r.error
            );
            if r.pinocchio {
                // The files Pinocchio loads are refused for a defect a key accepts (the
                // others are malformed: a 4-number rpy, `$(optenv ...)`, no link at all).
                assert!(
                    KEYS.iter().any(|k| r.error.contains(k)),
                    "{what}: no key named: {}",
                    r.error
                );
                // The script followed the keys: they run the file, or end at a refusal.
                let ran = r.text.contains("**With**") && r.text.ends_with(": runs");
                if !ran {
                    assert!(r.text.contains("**Its keys end at**"), "{what}: {}", r.text);
                    *counts
                        .entry((r.corpus.as_str(), r.base.as_str(), "keys end"))
                        .or_default() += 1;
                }
            }
        }
        if r.pinocchio {
            *counts
                .entry((r.corpus.as_str(), r.base.as_str(), r.kind.as_str()))
                .or_default() += 1;
        }
    }
    eprintln!("{counts:?}");
    // 69 + 1095 files x 2 bases (example-robot-data 6.0.0, pybullet 3.2.7).
    assert!(rows.len() >= 2 * 1164, "{}", rows.len());
    let runs = |corpus: &str, base: &str| counts.get(&(corpus, base, "runs")).copied();
    // Measured: example-robot-data 59 fixed, 61 floating; pybullet_data 28 and 56 (the rest
    // refused: docs/robot_corpus.md).
    assert!(
        runs("example-robot-data", "fixed") >= Some(59),
        "{counts:?}"
    );
    assert!(
        runs("example-robot-data", "floating") >= Some(61),
        "{counts:?}"
    );
    assert!(runs("pybullet_data", "fixed") >= Some(28), "{counts:?}");
    assert!(runs("pybullet_data", "floating") >= Some(56), "{counts:?}");
    // The floating runs set moving (every joint at ±0.5 rad/s): measured 59 and 22 (every
    // floating run with a moving joint).
    assert!(
        runs("example-robot-data", "moving") >= Some(59),
        "{counts:?}"
    );
    assert!(runs("pybullet_data", "moving") >= Some(22), "{counts:?}");
    // The refusals whose keys end at another refusal, measured 3 per corpus and base: iCub
    // and iCub reduced (r_upper_leg's collision mesh is open) and romeo_laas_small (`body`'s
    // negative moment; its meshes are absolute paths of another machine); pybullet's
    // plane_implicit and samurai (open meshes: scenery, not solids) and random_urdfs/168 (an
    // empty mesh). Every other refusal runs with the keys it names (example-robot-data 6 and 4,
    // pybullet_data 1057 and 1029).
    for corpus in ["example-robot-data", "pybullet_data"] {
        for base in ["fixed", "floating"] {
            let ended = counts.get(&(corpus, base, "keys end")).copied();
            assert!(ended <= Some(3), "{corpus} {base}: {counts:?}");
        }
    }
}

/// The largest energy error over every step of a run and the largest kinetic energy reached.
#[derive(Default)]
struct Excursion {
    e0: Option<f64>,
    de_max: f64,
    kinetic_max: f64,
}

/// A sink following the total energy frame by frame (the frames' bodies, as the summary's).
struct EnergySink(Arc<Mutex<Excursion>>);

impl tumble::record::Sink for EnergySink {
    fn write(&mut self, frame: &tumble::record::Frame<'_>) -> anyhow::Result<()> {
        let kinetic: f64 = frame.bodies.iter().map(|b| b.kinetic_energy).sum();
        let potential: f64 = frame.bodies.iter().map(|b| b.potential_energy).sum();
        let mut x = self.0.lock().unwrap();
        let e0 = *x.e0.get_or_insert(kinetic + potential);
        x.de_max = x.de_max.max((kinetic + potential - e0).abs());
        x.kinetic_max = x.kinetic_max.max(kinetic);
        Ok(())
    }

    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        Ok(())
    }
}

/// Every run where nothing did work (the script's `dE/E0` or `dE/(m g 1 m)` figure: no balance
/// line), again through the library with every step recorded: the energy's largest excursion
/// from its start stays within 1e-3 of the largest kinetic energy reached (the energy the
/// motion exchanges, whatever the potential's zero), or 1e-9 J for a model that does not move.
#[test]
fn corpus_runs_without_work_keep_their_energy_bounded_at_every_step() {
    let dir = tempfile::tempdir().unwrap();
    let (mut checked, mut worst, mut worst_what) = (0, 0.0_f64, String::new());
    for r in corpus() {
        if r.kind != "runs" || !r.text.starts_with("dE") {
            continue;
        }
        // A moving run is the floating base with its joints' rates (gravity is the default,
        // as in the script's scene).
        let (base, extra) = match r.base.as_str() {
            "moving" => (
                "floating",
                format!("joint_velocities = {}\n", r.joint_velocities),
            ),
            base => (base, String::new()),
        };
        let text = format!(
            "[sim]\ndt = 0.001\nduration = 1.0\nlog_every = 1\n[[model]]\nurdf = {:?}\n\
             bodies = \"articulated\"\nbase = {:?}\npackage_paths = [{:?}]\n\
             allow_mesh_paths = [\"/\"]\n{extra}",
            r.path, base, r.package_path
        );
        let what = format!("{} {} {}", r.corpus, r.file, r.base);
        let scene = Scene::parse(&text, &dir.path().join("corpus.toml")).unwrap();
        let world = scene.build().unwrap_or_else(|e| panic!("{what}: {e:#}"));
        let excursion = Arc::new(Mutex::new(Excursion::default()));
        let s = common::run_scene_parts(
            &scene,
            &world,
            1,
            &scene.run_settings(),
            vec![Box::new(EnergySink(excursion.clone()))],
        );
        assert_eq!(s.stats.newton_failures, 0, "{what}");
        assert_eq!(s.energy_flow, Default::default(), "{what}: work was done");
        let x = excursion.lock().unwrap();
        let bound = 1e-3 * x.kinetic_max + 1e-9;
        assert!(
            x.de_max <= bound,
            "{what}: |E(t) - E(0)| up to {:.3e} J, largest kinetic energy {:.3e} J",
            x.de_max,
            x.kinetic_max
        );
        if x.de_max / bound > worst {
            worst = x.de_max / bound;
            worst_what = format!(
                "{what}: {:.2e} J of T_max {:.2e} J",
                x.de_max, x.kinetic_max
            );
        }
        checked += 1;
    }
    eprintln!(
        "{checked} runs checked at every step; closest to the bound: {worst:.2} ({worst_what})"
    );
    // Measured: 170 runs (141 fixed or floating at rest, 29 floating with their joints moving
    // and no stop touched); the largest excursion
    // 7.3e-5 of T_max (ur3_robot, fixed base: 1.22e-3 J of 16.8 J), 0.07 of the bound. Both
    // tests together: 8.6 s in release on 2 cores.
    assert!(checked >= 165, "{checked}");
}
