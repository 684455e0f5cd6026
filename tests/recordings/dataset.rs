//! `tumble dataset`: determinism across threads and shards, independence of each run's draws,
//! the distributions, the physics in the Parquet rows, resume after SIGINT and after corruption,
//! merge and its refusals, bad specs, and pandas reading the files.
//!
//! Every dataset here is tiny (tens of runs of ≤ 50 steps) so the whole file runs in seconds.

use crate::common;

use arrow_array::{
    Array, BooleanArray, Float64Array, Int64Array, RecordBatch, StringArray, UInt64Array,
};
use common::{root, run_py, text, tumble};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tumble::dataset::{DatasetSpec, Manifest, Options, generate, merge};
use tumble::scene::placement::distribution::Dist;
use tumble::scene::placement::rng::Rng;

/// A spec varying every key over the three bundled models, written to `dir/name`.
/// `dataset` holds extra `[dataset]` lines; `vary` replaces the `[vary]` entries when given.
fn write_spec(dir: &Path, name: &str, dataset: &str, vary: Option<&str>) -> PathBuf {
    let models = root().join("models");
    let m = |f: &str| models.join(f).display().to_string();
    let default_vary = format!(
        r#"model = {{ choice = ["{box}", "{th}", "{arm}"] }}
dt = {{ log_uniform = [5e-4, 2e-3] }}
integrator = {{ choice = ["variational", "variational4", "rk4"] }}
gravity = {{ normal = {{ mean = [0, 0, -9.81], std = [1, 1, 1] }} }}
position = {{ uniform = [[-1, -1, 0], [1, 1, 1]] }}
orientation = "uniform"
linvel = {{ uniform = [[-1, -1, 0], [1, 1, 3]] }}
angvel = {{ normal = {{ mean = [0, 0, 0], std = [3, 3, 3] }} }}"#,
        box = m("box.urdf"),
        th = m("t_handle.urdf"),
        arm = m("arm.urdf")
    );
    let spec = format!(
        "[dataset]\n{dataset}\n\n[scene.sim]\nduration = 0.03\ndt = 0.001\nlog_every = 5\n\n\
         [[scene.model]]\nurdf = \"{}\"\n\n[vary]\n{}\n",
        m("box.urdf"),
        vary.unwrap_or(&default_vary)
    );
    let path = dir.join(name);
    std::fs::write(&path, spec).unwrap();
    path
}

fn opts(out: &Path, threads: usize) -> Options {
    Options {
        out: out.to_path_buf(),
        threads: Some(threads),
        ..Default::default()
    }
}

/// Every file under `dir` (relative path → bytes).
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(base: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(base, &path, out);
            } else {
                let rel = path.strip_prefix(base).unwrap().display().to_string();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// Asserts two folders hold the same file names with the same bytes.
fn assert_same_files(a: &Path, b: &Path) {
    let (fa, fb) = (files(a), files(b));
    assert_eq!(
        fa.keys().collect::<Vec<_>>(),
        fb.keys().collect::<Vec<_>>(),
        "{} vs {}",
        a.display(),
        b.display()
    );
    for (name, bytes) in &fa {
        assert!(bytes == &fb[name], "{name} differs");
    }
}

/// The batches of one Parquet file, or of every `*.parquet` in a folder (in name order).
pub(crate) fn read(path: &Path) -> Vec<RecordBatch> {
    let paths: Vec<PathBuf> = if path.is_dir() {
        let mut v: Vec<_> = std::fs::read_dir(path)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "parquet"))
            .collect();
        v.sort();
        v
    } else {
        vec![path.to_path_buf()]
    };
    paths
        .iter()
        .flat_map(|p| {
            ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(p).unwrap())
                .unwrap()
                .build()
                .unwrap()
                .map(|b| b.unwrap())
                .collect::<Vec<_>>()
        })
        .collect()
}

pub(crate) fn f64s(batches: &[RecordBatch], name: &str) -> Vec<f64> {
    batches
        .iter()
        .flat_map(|b| {
            let a = b.column_by_name(name).unwrap();
            let a = a.as_any().downcast_ref::<Float64Array>().unwrap();
            a.iter().map(|x| x.unwrap_or(f64::NAN)).collect::<Vec<_>>()
        })
        .collect()
}

pub(crate) fn i64s(batches: &[RecordBatch], name: &str) -> Vec<i64> {
    batches
        .iter()
        .flat_map(|b| {
            let a = b.column_by_name(name).unwrap();
            a.as_any()
                .downcast_ref::<Int64Array>()
                .unwrap()
                .values()
                .to_vec()
        })
        .collect()
}

pub(crate) fn strs(batches: &[RecordBatch], name: &str) -> Vec<String> {
    batches
        .iter()
        .flat_map(|b| {
            let a = b.column_by_name(name).unwrap();
            let a = a.as_any().downcast_ref::<StringArray>().unwrap();
            a.iter()
                .map(|s| s.unwrap_or("null").to_string())
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Every row as text (floats by their bits), for exact comparisons of whole tables.
pub(crate) fn rows(batches: &[RecordBatch]) -> Vec<String> {
    let mut out = Vec::new();
    for b in batches {
        for r in 0..b.num_rows() {
            let cells: Vec<String> = b
                .columns()
                .iter()
                .map(|c| {
                    if c.is_null(r) {
                        "null".to_string()
                    } else if let Some(a) = c.as_any().downcast_ref::<Float64Array>() {
                        format!("{:x}", a.value(r).to_bits())
                    } else if let Some(a) = c.as_any().downcast_ref::<Int64Array>() {
                        a.value(r).to_string()
                    } else if let Some(a) = c.as_any().downcast_ref::<UInt64Array>() {
                        a.value(r).to_string()
                    } else if let Some(a) = c.as_any().downcast_ref::<StringArray>() {
                        a.value(r).to_string()
                    } else if let Some(a) = c.as_any().downcast_ref::<BooleanArray>() {
                        a.value(r).to_string()
                    } else {
                        panic!("unexpected column type {:?}", c.data_type())
                    }
                })
                .collect();
            out.push(cells.join(","));
        }
    }
    out
}

/// 1 and 2 threads write the same bytes: every Parquet file, every MCAP, RRD and ROS 2 MCAP
/// recording and the manifest (whose checksums cover them all).
#[test]
fn one_and_two_threads_write_identical_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let spec_path = write_spec(
        tmp.path(),
        "s.toml",
        "runs = 24\nseed = 5\nruns_per_file = 4\nrecord = [\"mcap\", \"rrd\", \"ros2\"]\nrecord_runs = 2",
        None,
    );
    let spec = DatasetSpec::load(&spec_path).unwrap();
    let (a, b) = (tmp.path().join("t1"), tmp.path().join("t2"));
    let s1 = generate(&spec, &opts(&a, 1)).unwrap();
    let s2 = generate(&spec, &opts(&b, 2)).unwrap();
    assert_eq!((s1.runs_done, s1.chunks_done), (24, 6));
    assert_eq!((s1.rows, s1.body_steps), (s2.rows, s2.body_steps));
    assert_same_files(&a, &b);
    let m = Manifest::load(&a).unwrap().unwrap();
    assert!(m.complete);
    assert_eq!(m.chunks_done.len(), 6);
    assert_eq!(m.runs_done(), 24);
    // The files are the ones listed, with the listed sizes.
    let listed: usize = m.chunks_done.iter().map(|c| c.files.len()).sum();
    assert_eq!(
        listed + 2,
        files(&a).len(),
        "+ manifest.json and bodies.parquet"
    );
    assert!(a.join("recordings/run-000001.mcap").is_file());
    assert!(a.join("recordings/run-000001.rrd").is_file());
    assert!(a.join("recordings/run-000001.ros2.mcap").is_file());
}

/// Shards 1/2 and 2/2 hold disjoint chunks whose union is the unsharded dataset byte for byte,
/// and `merge` joins them into a folder identical to the unsharded one, manifest included.
#[test]
fn shards_together_equal_the_unsharded_dataset_and_merge_joins_them() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = DatasetSpec::load(&write_spec(
        tmp.path(),
        "s.toml",
        "runs = 14\nseed = 9\nruns_per_file = 3",
        None,
    ))
    .unwrap();
    let full = tmp.path().join("full");
    generate(&spec, &opts(&full, 2)).unwrap();
    let mut union = BTreeMap::new();
    for k in 1..=2 {
        let dir = tmp.path().join(format!("shard{k}"));
        let mut o = opts(&dir, 1);
        o.shard = Some(format!("{k}/2").parse().unwrap());
        let s = generate(&spec, &o).unwrap();
        // 5 chunks: shard 1 has chunks 0, 2, 4 (3 + 3 + 2 runs), shard 2 has 1, 3 (3 + 3).
        assert_eq!(s.runs_done, if k == 1 { 8 } else { 6 });
        let m = Manifest::load(&dir).unwrap().unwrap();
        assert!(m.complete);
        for (name, bytes) in files(&dir) {
            if name != "manifest.json" {
                let before = union.insert(name.clone(), bytes.clone());
                assert!(
                    before.is_none() || name == "bodies.parquet",
                    "{name} in both shards"
                );
            }
        }
    }
    let mut expected = files(&full);
    expected.remove("manifest.json");
    assert_eq!(union, expected);

    let merged = tmp.path().join("merged");
    let s = merge(
        &[tmp.path().join("shard2"), tmp.path().join("shard1")],
        &merged,
        false,
    )
    .unwrap();
    assert_eq!((s.chunks, s.runs), (5, 14));
    assert_same_files(&merged, &full);
    // An existing dataset in --out is not replaced without --force.
    let shards = [tmp.path().join("shard1"), tmp.path().join("shard2")];
    let e = format!("{:#}", merge(&shards, &merged, false).unwrap_err());
    assert!(e.contains("pass --force"), "{e}");
    merge(&shards, &merged, true).unwrap();
    assert_same_files(&merged, &full);
}

/// `merge` refuses overlapping inputs, a missing shard (naming it), shards of a different
/// spec, a corrupted file, and an existing output; the CLI exits 2 with one error line.
#[test]
fn merge_refuses_overlap_missing_shards_other_specs_and_corruption() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let make = |name: &str, seed: u64, shard: Option<&str>| {
        let spec = DatasetSpec::load(&write_spec(
            t,
            &format!("{name}.toml"),
            &format!("runs = 6\nseed = {seed}\nruns_per_file = 2"),
            None,
        ))
        .unwrap();
        let dir = t.join(name);
        let mut o = opts(&dir, 1);
        o.shard = shard.map(|s| s.parse().unwrap());
        generate(&spec, &o).unwrap();
        dir
    };
    let s1 = make("s1", 3, Some("1/2"));
    let s2 = make("s2", 3, Some("2/2"));
    let other = make("other", 4, Some("2/2"));
    let full = make("full", 3, None);
    let err = |inputs: &[&Path]| {
        let inputs: Vec<PathBuf> = inputs.iter().map(|p| p.to_path_buf()).collect();
        format!("{:#}", merge(&inputs, &t.join("out"), false).unwrap_err())
    };
    let e = err(&[&s1]);
    assert!(
        e.contains("miss 1 of 3 chunks: 1") && e.contains("shard 2/2"),
        "{e}"
    );
    let e = err(&[&s1, &full]);
    assert!(e.contains("is in both") && e.contains("overlap"), "{e}");
    let e = err(&[&s1, &other]);
    assert!(
        e.contains("not shards of the same dataset") && e.contains("spec"),
        "{e}"
    );
    assert!(!t.join("out").exists(), "a refused merge writes nothing");

    // A flipped byte in a shard's file is found by its checksum.
    let victim = s2.join("trajectories/part-00001.parquet");
    let mut bytes = std::fs::read(&victim).unwrap();
    bytes[100] ^= 0x40;
    std::fs::write(&victim, bytes).unwrap();
    let e = err(&[&s1, &s2]);
    assert!(
        e.contains("part-00001.parquet") && e.contains("SHA-256"),
        "{e}"
    );

    // The CLI: exit 2, one error line.
    let out = tumble(&["dataset", "merge", "s1", "--out", "out2"], t);
    assert_eq!(out.status.code(), Some(2));
    let stderr = text(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with("error: ") && stderr.contains("shard 2/2"),
        "{stderr}"
    );
}

/// Run i's parameters and rows depend on (seed, i) alone: the first 10 runs of a 20-run dataset
/// chunked by 7 are those of a 10-run dataset chunked by 3, value for value.
#[test]
fn a_runs_values_do_not_depend_on_run_count_or_chunking() {
    let tmp = tempfile::tempdir().unwrap();
    let small = DatasetSpec::load(&write_spec(
        tmp.path(),
        "a.toml",
        "runs = 10\nseed = 77\nruns_per_file = 3",
        None,
    ))
    .unwrap();
    let large = DatasetSpec::load(&write_spec(
        tmp.path(),
        "b.toml",
        "runs = 20\nseed = 77\nruns_per_file = 7",
        None,
    ))
    .unwrap();
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    generate(&small, &opts(&a, 2)).unwrap();
    generate(&large, &opts(&b, 1)).unwrap();
    let runs_a = rows(&read(&a.join("runs")));
    let runs_b = rows(&read(&b.join("runs")));
    assert_eq!(runs_a.len(), 10);
    assert_eq!(runs_b.len(), 20);
    assert_eq!(runs_a[..], runs_b[..10]);
    let traj_a = rows(&read(&a.join("trajectories")));
    let traj_b = rows(&read(&b.join("trajectories")));
    let first_ten: Vec<_> = traj_b
        .iter()
        .filter(|r| r.split(',').next().unwrap().parse::<i64>().unwrap() < 10)
        .cloned()
        .collect();
    assert!(!traj_a.is_empty());
    assert_eq!(traj_a, first_ten);
    // A different seed draws different values.
    let p = tumble::dataset::sample::draw(&small, 0);
    let mut other = small.clone();
    other.seed = 78;
    assert_ne!(p, tumble::dataset::sample::draw(&other, 0));
}

/// The samplers against their definitions, n = 20 000 draws each; bounds are 5 standard errors
/// (a false failure has probability < 1e-6 per check), the measured value beside each.
#[test]
fn distributions_match_their_definitions() {
    let n = 20_000;
    let parse = |text: &str, dims| {
        let v: toml::Table = toml::from_str(&format!("k = {text}")).unwrap();
        Dist::parse("k", &v["k"], dims).unwrap()
    };
    let mut rng = Rng::new(2024);
    let sample = |d: &Dist, rng: &mut Rng| (0..n).map(|_| d.sample(rng)).collect::<Vec<_>>();
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
    let std = |x: &[f64]| {
        let m = mean(x);
        (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
    };
    let se = 1.0 / (n as f64).sqrt();

    // Uniform on [-1, 3): within bounds, mean 1 (std 4/√12 = 1.155, SE 0.0082).
    let u: Vec<f64> = sample(&parse("{ uniform = [-1, 3] }", 1), &mut rng)
        .iter()
        .map(|v| v[0])
        .collect();
    assert!(u.iter().all(|x| (-1.0..3.0).contains(x)));
    assert!((mean(&u) - 1.0).abs() < 5.0 * 1.155 * se, "{}", mean(&u)); // measured 0.0051
    // Log-uniform on [1e-4, 1e-2]: median = geometric mean 1e-3. The sample median's CDF value
    // has SE 0.5/√n, i.e. ln-space SE 0.5 ln(100)/√n = 0.0163.
    let mut l: Vec<f64> = sample(&parse("{ log_uniform = [1e-4, 1e-2] }", 1), &mut rng)
        .iter()
        .map(|v| v[0])
        .collect();
    assert!(l.iter().all(|x| (1e-4..=1e-2).contains(x)));
    l.sort_by(f64::total_cmp);
    let median = l[n / 2];
    let ln_err = (median / 1e-3).ln().abs();
    assert!(ln_err < 5.0 * 0.5 * 100f64.ln() * se, "{median}"); // measured 0.025
    // Normal N(2, 0.5²) per component: mean SE 0.5/√n, std SE 0.5/√(2n).
    let d = parse(
        "{ normal = { mean = [2, 2, 2], std = [0.5, 0.5, 0.5] } }",
        3,
    );
    let x = sample(&d, &mut rng);
    for k in 0..3 {
        let c: Vec<f64> = x.iter().map(|v| v[k]).collect();
        assert!((mean(&c) - 2.0).abs() < 5.0 * 0.5 * se, "{}", mean(&c)); // measured ≤ 0.0059
        assert!(
            (std(&c) - 0.5).abs() < 5.0 * 0.5 * se / 2f64.sqrt(), // measured ≤ 0.0031
            "{}",
            std(&c)
        );
    }
    // Choice: every value, each ≈ 1/3 (SE √(2/9/n) = 0.0033).
    let c = sample(&parse("{ choice = [1, 2, 3] }", 1), &mut rng);
    for v in [1.0, 2.0, 3.0] {
        let share = c.iter().filter(|x| x[0] == v).count() as f64 / n as f64;
        assert!(
            (share - 1.0 / 3.0).abs() < 5.0 * (2.0f64 / 9.0).sqrt() * se,
            "{share}"
        ); // measured ≤ 0.00018
    }
    // Uniform rotations (Shoemake): the rotated z axis is uniform on the sphere, so each of its
    // components has mean 0 and variance 1/3 (SE of the mean √(1/3/n) = 0.0041).
    let z: Vec<[f64; 3]> = (0..n)
        .map(|_| {
            let [qx, qy, qz, qw] = rng.unit_quaternion_xyzw();
            let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                qw, qx, qy, qz,
            ));
            (q * nalgebra::Vector3::z()).into()
        })
        .collect();
    for k in 0..3 {
        let c: Vec<f64> = z.iter().map(|v| v[k]).collect();
        assert!(
            mean(&c).abs() < 5.0 * (1.0f64 / 3.0).sqrt() * se,
            "{}",
            mean(&c)
        ); // measured ≤ 0.0047
        let var = c.iter().map(|v| v * v).sum::<f64>() / n as f64;
        // Var(z²) = 1/5 − 1/9 = 4/45, SE √(4/45/n) = 0.0021.
        assert!(
            (var - 1.0 / 3.0).abs() < 5.0 * (4.0f64 / 45.0).sqrt() * se,
            "{var}"
        ); // measured ≤ 0.0014
    }
}

/// The rows obey the physics: every centre of mass follows the exact parabola
/// `p(0) + v(0) t + g t²/2` (Störmer–Verlet and RK4 are exact for constant acceleration), and
/// each body's angular momentum about its centre of mass, `R J Rᵀ ω` from the rows and
/// `bodies.parquet`, is conserved (the variational family conserves it to round-off).
#[test]
fn rows_follow_the_parabola_and_conserve_angular_momentum() {
    let tmp = tempfile::tempdir().unwrap();
    let models = root().join("models");
    let vary = format!(
        r#"model = {{ choice = ["{}", "{}", "{}"] }}
dt = {{ log_uniform = [5e-4, 2e-3] }}
integrator = {{ choice = ["variational", "variational4"] }}
gravity = {{ uniform = [[-2, -2, -12], [2, 2, -8]] }}
position = {{ uniform = [[-1, -1, 0], [1, 1, 1]] }}
orientation = "uniform"
linvel = {{ uniform = [[-1, -1, 0], [1, 1, 3]] }}
angvel = {{ normal = {{ mean = [0, 0, 0], std = [4, 4, 4] }} }}"#,
        models.join("box.urdf").display(),
        models.join("t_handle.urdf").display(),
        models.join("arm.urdf").display()
    );
    let spec = DatasetSpec::load(&write_spec(
        tmp.path(),
        "p.toml",
        "runs = 12\nseed = 1\nruns_per_file = 6",
        Some(&vary),
    ))
    .unwrap();
    let dir = tmp.path().join("d");
    generate(&spec, &opts(&dir, 2)).unwrap();
    let traj = read(&dir.join("trajectories"));
    let runs = read(&dir.join("runs"));
    let bodies = read(&dir.join("bodies.parquet"));

    let run_ids = i64s(&runs, "run");
    let dt = f64s(&runs, "dt");
    let g: Vec<[f64; 3]> = (0..run_ids.len())
        .map(|i| {
            let c = |n: &str| f64s(&runs, n)[i];
            [c("gravity_x"), c("gravity_y"), c("gravity_z")]
        })
        .collect();
    let models_of_run = strs(&runs, "model");
    assert!(strs(&runs, "status").iter().all(|s| s == "ok"));
    let mut inertia = BTreeMap::new();
    let (bm, bb) = (strs(&bodies, "model"), strs(&bodies, "body"));
    for i in 0..bm.len() {
        let j = ["x", "y", "z"].map(|a| f64s(&bodies, &format!("principal_moment_{a}"))[i]);
        inertia.insert((bm[i].clone(), bb[i].clone()), j);
    }

    let run = i64s(&traj, "run");
    let step = i64s(&traj, "step");
    let body = strs(&traj, "body");
    let col = |n: &str| f64s(&traj, n);
    let (px, py, pz) = (col("position_x"), col("position_y"), col("position_z"));
    let (qx, qy, qz, qw) = (
        col("orientation_x"),
        col("orientation_y"),
        col("orientation_z"),
        col("orientation_w"),
    );
    let (vx, vy, vz) = (
        col("linear_velocity_x"),
        col("linear_velocity_y"),
        col("linear_velocity_z"),
    );
    let (wx, wy, wz) = (
        col("angular_velocity_x"),
        col("angular_velocity_y"),
        col("angular_velocity_z"),
    );
    let mut first: BTreeMap<(i64, String), usize> = BTreeMap::new();
    let (mut pos_err, mut l_err, mut checked) = (0.0f64, 0.0f64, 0);
    for i in 0..run.len() {
        let r = run[i] as usize;
        let i0 = *first.entry((run[i], body[i].clone())).or_insert(i);
        assert_eq!(step[i0], 0);
        let t = step[i] as f64 * dt[r];
        let p = [px[i], py[i], pz[i]];
        let p0 = [px[i0], py[i0], pz[i0]];
        let v0 = [vx[i0], vy[i0], vz[i0]];
        for k in 0..3 {
            pos_err = pos_err.max((p[k] - (p0[k] + v0[k] * t + 0.5 * g[r][k] * t * t)).abs());
        }
        let angmom = |i: usize| {
            let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                qw[i], qx[i], qy[i], qz[i],
            ));
            let j = inertia[&(models_of_run[r].clone(), body[i].clone())];
            let w_body = q.inverse() * nalgebra::Vector3::new(wx[i], wy[i], wz[i]);
            q * nalgebra::Vector3::new(j[0] * w_body.x, j[1] * w_body.y, j[2] * w_body.z)
        };
        let (l, l0) = (angmom(i), angmom(i0));
        l_err = l_err.max((l - l0).norm() / l0.norm());
        checked += 1;
    }
    assert!(checked > 100, "{checked} rows");
    // Round-off over ≤ 60 steps at positions ≈ 1 m: measured 7.8e-16 m.
    assert!(pos_err < 1e-12, "parabola error {pos_err:e} m");
    // Momentum is exact in the integrator; the rows add the pose composition and J⁻¹M: measured 2.5e-15.
    assert!(l_err < 1e-12, "angular momentum relative change {l_err:e}");
}

/// A generation stopped after 2 chunks (as SIGINT would stop it, in-process) leaves a
/// resumable folder; `--resume` completes it, identical to an uninterrupted run.
#[test]
fn a_stopped_dataset_resumes_to_the_same_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = DatasetSpec::load(&write_spec(
        tmp.path(),
        "s.toml",
        "runs = 20\nseed = 21\nruns_per_file = 2\nrecord = [\"mcap\"]\nrecord_runs = 5",
        None,
    ))
    .unwrap();
    let reference = tmp.path().join("ref");
    generate(&spec, &opts(&reference, 2)).unwrap();
    let dir = tmp.path().join("d");
    let mut o = opts(&dir, 2);
    o.stop_after_chunks = Some(2);
    let err = generate(&spec, &o).unwrap_err();
    let stop = err
        .downcast_ref::<tumble::interrupt::Interrupted>()
        .unwrap_or_else(|| panic!("{err:#}"));
    assert!(stop.finished.contains("--resume"), "{}", stop.finished);
    let m = Manifest::load(&dir).unwrap().unwrap();
    assert!(!m.complete);
    // 2 chunks asked; the other thread's chunk in flight is finished too.
    assert!(
        (2..=3).contains(&m.chunks_done.len()),
        "{}",
        m.chunks_done.len()
    );
    // Without --resume the folder is refused.
    let e = format!("{:#}", generate(&spec, &opts(&dir, 2)).unwrap_err());
    assert!(e.contains("--resume") && e.contains("--force"), "{e}");
    let mut o = opts(&dir, 1);
    o.resume = true;
    let s = generate(&spec, &o).unwrap();
    assert_eq!(s.runs_skipped + s.runs_done, 20);
    assert!(s.runs_skipped >= 4);
    assert_same_files(&dir, &reference);
}

/// The real signal: SIGINT to `tumble dataset` stops it at a chunk boundary, writes the
/// manifest and exits 130; `--resume` completes the folder identical to an uninterrupted run.
/// The signal is raised by the process itself after exactly 3 chunks
/// (`TUMBLE_TEST_SIGINT_AFTER_CHUNKS`, one worker thread), through the same handler as a Ctrl-C:
/// a signal sent from here at a moment picked by a timer raced the end of the run (the test
/// failed whenever the run finished first).
#[test]
fn sigint_stops_cleanly_and_resume_completes() {
    let tmp = tempfile::tempdir().unwrap();
    // 10 chunks of 20 runs, 100 steps each.
    let models = root().join("models");
    let spec_text = format!(
        "[dataset]\nruns = 200\nseed = 3\nruns_per_file = 20\n\n[scene.sim]\nduration = 0.1\n\
         log_every = 10\n\n[[scene.model]]\nurdf = \"{}\"\n\n[vary]\n\
         angvel = {{ normal = {{ mean = [0, 0, 0], std = [5, 5, 5] }} }}\n",
        models.join("box.urdf").display()
    );
    std::fs::write(tmp.path().join("s.toml"), spec_text).unwrap();
    let dir = tmp.path().join("d");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_tumble"))
        .args([
            "dataset",
            "s.toml",
            "--out",
            "d",
            "--threads",
            "1",
            "--quiet",
        ])
        .env("TUMBLE_TEST_SIGINT_AFTER_CHUNKS", "3")
        .current_dir(tmp.path())
        .output()
        .unwrap();
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(
        stderr.contains("stopped by SIGINT")
            && stderr.contains("dataset stopped with 60 of 200 runs complete")
            && stderr.contains("the chunks in flight were finished")
            && stderr.contains("--resume"),
        "{stderr}"
    );
    let m = Manifest::load(&dir).unwrap().unwrap();
    assert!(!m.complete);
    let done: Vec<u64> = m.chunks_done.iter().map(|c| c.chunk).collect();
    assert_eq!(done, [0, 1, 2]);
    // No unfinished file is left, and only the listed chunks' files exist.
    for (name, _) in files(&dir) {
        assert!(!name.ends_with(".part"), "{name} left behind");
        assert!(
            !name.contains("part-00003"),
            "{name}: chunk 3 was never started"
        );
    }
    let out = tumble(
        &["dataset", "s.toml", "--out", "d", "--resume", "-q"],
        tmp.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("resumed: 60 runs (3 chunks) were complete"),
        "{stdout}"
    );
    let reference = tmp.path().join("ref");
    let spec = DatasetSpec::load(&tmp.path().join("s.toml")).unwrap();
    generate(&spec, &opts(&reference, 2)).unwrap();
    assert_same_files(&dir, &reference);
}

/// `--resume` checks every listed file: a truncated trajectories file and a runs file with one
/// flipped byte are reported by name and recomputed; the result equals the original.
#[test]
fn resume_recomputes_truncated_and_corrupted_chunks() {
    let tmp = tempfile::tempdir().unwrap();
    write_spec(
        tmp.path(),
        "s.toml",
        "runs = 8\nseed = 8\nruns_per_file = 2",
        None,
    );
    let out = tumble(&["dataset", "s.toml", "--out", "d", "-q"], tmp.path());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let dir = tmp.path().join("d");
    let original = files(&dir);
    let truncated = dir.join("trajectories/part-00001.parquet");
    let len = std::fs::metadata(&truncated).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&truncated)
        .unwrap()
        .set_len(len / 2)
        .unwrap();
    let flipped = dir.join("runs/part-00002.parquet");
    let mut bytes = std::fs::read(&flipped).unwrap();
    bytes[50] ^= 1;
    std::fs::write(&flipped, bytes).unwrap();

    let out = tumble(
        &["dataset", "s.toml", "--out", "d", "--resume", "-q"],
        tmp.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("chunk 1: ") && stderr.contains("part-00001.parquet has"),
        "{stderr}"
    );
    assert!(
        stderr.contains("chunk 2: ") && stderr.contains("SHA-256"),
        "{stderr}"
    );
    assert!(
        text(&out.stdout).contains("2 chunks recomputed"),
        "{}",
        text(&out.stdout)
    );
    assert_eq!(files(&dir), original);
}

/// An existing dataset is never silently replaced: the same spec asks for --resume or --force,
/// another spec is refused even with --resume; --force starts over.
#[test]
fn existing_output_needs_resume_or_force() {
    let tmp = tempfile::tempdir().unwrap();
    write_spec(
        tmp.path(),
        "a.toml",
        "runs = 4\nseed = 1\nruns_per_file = 2",
        None,
    );
    write_spec(
        tmp.path(),
        "b.toml",
        "runs = 4\nseed = 2\nruns_per_file = 2",
        None,
    );
    let run = |args: &[&str]| tumble(args, tmp.path());
    assert!(
        run(&["dataset", "a.toml", "--out", "d", "-q"])
            .status
            .success()
    );
    let out = run(&["dataset", "a.toml", "--out", "d", "-q"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("pass --resume"),
        "{}",
        text(&out.stderr)
    );
    let out = run(&["dataset", "b.toml", "--out", "d", "--resume", "-q"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("different spec"),
        "{}",
        text(&out.stderr)
    );
    let out = run(&["dataset", "b.toml", "--out", "d", "--force", "-q"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let m = Manifest::load(&tmp.path().join("d")).unwrap().unwrap();
    assert_eq!(m.seed, 2);
    // A complete dataset resumed does no work.
    let out = run(&["dataset", "b.toml", "--out", "d", "--resume", "-q"]);
    assert!(
        text(&out.stdout).contains("runs=0 "),
        "{}",
        text(&out.stdout)
    );
}

/// Bad specs: one error line naming the file and the key, exit 2, nothing written.
#[test]
fn bad_specs_fail_with_one_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let box_urdf = root().join("models/box.urdf").display().to_string();
    let model = format!("[[scene.model]]\nurdf = \"{box_urdf}\"\n");
    let cases = [
        (
            format!(
                "[dataset]\nruns = 3\nseed = 1\n{model}[vary]\nspin = {{ uniform = [0, 1] }}\n"
            ),
            "vary.spin: unknown key",
        ),
        (
            format!(
                "[dataset]\nruns = 3\nseed = 1\n{model}[vary]\ndt = {{ normal = {{ mean = 0.001, std = 1e-4 }} }}\n"
            ),
            "vary.dt: every step size drawn must be positive",
        ),
        (
            format!(
                "[dataset]\nruns = 3\nseed = 1\n{model}[vary]\nintegrator = {{ choice = [\"verlet\"] }}\n"
            ),
            "vary.integrator.choice[0]: unknown integrator \"verlet\"",
        ),
        (
            format!(
                "[dataset]\nruns = 3\nseed = 1\n{model}[vary]\nposition = {{ uniform = [[0, 0], [1, 1]] }}\n"
            ),
            "vary.position.uniform[0]: expected an array of 3 numbers",
        ),
        (
            format!("[dataset]\nruns = 0\nseed = 1\n{model}"),
            "dataset.runs must be at least 1",
        ),
        (
            format!("[dataset]\nruns = 3\nseed = 1\nthreads = 2\n{model}"),
            "[dataset]: unknown field `threads`",
        ),
        (
            format!("[dataset]\nruns = 3\nseed = 1\n{model}{model}"),
            "exactly one [[scene.model]]",
        ),
        (
            format!("[dataset]\nruns = 3\nseed = 1\n[scene.sim]\ndt = -1.0\n{model}"),
            "sim.dt must be a positive finite number",
        ),
        (
            format!(
                "[dataset]\nruns = 3\nseed = 1\n{model}[vary]\nmodel = {{ choice = [\"nope.urdf\"] }}\n"
            ),
            "model choice 0 (nope.urdf)",
        ),
    ];
    for (i, (spec, needle)) in cases.iter().enumerate() {
        let name = format!("bad{i}.toml");
        std::fs::write(tmp.path().join(&name), spec).unwrap();
        let out = tumble(&["dataset", &name, "--out", "d", "-q"], tmp.path());
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{name}: {stderr}");
        assert!(
            stderr.starts_with(&format!("error: {name}")) && stderr.contains(needle),
            "{name}: expected {needle:?} in {stderr}"
        );
        assert!(!tmp.path().join("d").exists(), "{name}: wrote output");
    }
}

/// Both command lines of the issue parse, `--shard` is checked, and `--help` shows both.
#[test]
fn both_command_lines_parse() {
    use clap::Parser;
    use tumble::cli::{Cli, Command};
    use tumble::commands::dataset::DatasetCommand;
    let cli = Cli::try_parse_from([
        "tumble",
        "dataset",
        "s.toml",
        "--out",
        "d",
        "--threads",
        "2",
        "--shard",
        "2/3",
        "--resume",
    ])
    .unwrap();
    let Command::Dataset(args) = cli.command else {
        panic!("not dataset")
    };
    assert_eq!(args.spec.as_deref(), Some(Path::new("s.toml")));
    assert_eq!(args.shard.unwrap().to_string(), "2/3");
    assert_eq!(args.threads, Some(2));
    assert!(args.resume && args.command.is_none());
    let cli = Cli::try_parse_from(["tumble", "dataset", "merge", "a", "b", "--out", "m"]).unwrap();
    let Command::Dataset(args) = cli.command else {
        panic!("not dataset")
    };
    let Some(DatasetCommand::Merge(m)) = args.command else {
        panic!("not merge")
    };
    assert_eq!(m.inputs, [PathBuf::from("a"), PathBuf::from("b")]);
    assert_eq!(m.out, PathBuf::from("m"));
    for bad in [
        vec![
            "tumble", "dataset", "s.toml", "--out", "d", "--shard", "3/2",
        ],
        vec!["tumble", "dataset", "s.toml"],
        vec![
            "tumble",
            "dataset",
            "s.toml",
            "--out",
            "d",
            "--threads",
            "0",
        ],
        vec![
            "tumble", "dataset", "s.toml", "--out", "d", "--resume", "--force",
        ],
    ] {
        assert!(Cli::try_parse_from(&bad).is_err(), "{bad:?}");
    }
    let out = tumble(&["dataset", "--help"], &root());
    let help = text(&out.stdout);
    assert!(help.contains("merge") && help.contains("--shard") && help.contains("--resume"));
}

/// pandas (pyarrow engine) reads the folder: the documented columns and dtypes, every run,
/// row counts equal to the manifest's, and the closed-form parabola in the rows.
#[test]
fn pandas_reads_the_dataset() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = DatasetSpec::load(&write_spec(
        tmp.path(),
        "s.toml",
        "runs = 9\nseed = 12\nruns_per_file = 4",
        None,
    ))
    .unwrap();
    let dir = tmp.path().join("d");
    let s = generate(&spec, &opts(&dir, 2)).unwrap();
    let r = run_py("read_parquet.py", &[&dir]);
    let columns: Vec<&str> = r["trajectory_columns"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_str().unwrap())
        .collect();
    assert_eq!(
        columns,
        [
            "run",
            "step",
            "time",
            "time_secs",
            "body",
            "position_x",
            "position_y",
            "position_z",
            "orientation_x",
            "orientation_y",
            "orientation_z",
            "orientation_w",
            "linear_velocity_x",
            "linear_velocity_y",
            "linear_velocity_z",
            "angular_velocity_x",
            "angular_velocity_y",
            "angular_velocity_z"
        ]
    );
    let dtypes = &r["trajectory_dtypes"];
    for c in ["run", "step", "time"] {
        assert_eq!(dtypes[c], "int64", "{c}");
    }
    for c in &columns[5..] {
        assert_eq!(dtypes[*c], "float64", "{c}");
    }
    // pandas 2 reads strings as `object`, pandas 3 as `str`.
    assert!(["object", "str"].contains(&dtypes["body"].as_str().unwrap()));
    assert_eq!(r["runs_dtypes"]["seed"], "uint64");
    assert_eq!(r["trajectory_rows"], s.rows);
    assert_eq!(r["manifest_rows"], s.rows);
    assert_eq!(r["runs_rows"], 9);
    assert_eq!(r["run_ids"], serde_json::json!((0..9).collect::<Vec<_>>()));
    assert_eq!(r["runs_status"], serde_json::json!(["ok"]));
    assert_eq!(r["bodies_rows"], 6, "box 1 + T-handle 1 + arm 4");
    // Round-off over ≤ 60 steps (RK4 and Störmer–Verlet are exact for constant acceleration):
    // measured 8.9e-16 m.
    assert!(r["parabola_err_max"].as_f64().unwrap() < 1e-12, "{r}");
    assert_eq!(
        r["time_err_max"].as_f64().unwrap(),
        0.0,
        "time_secs = time · 1e-9 exactly"
    );
    // Whole-ns rounding of `time` when dt is not a whole number of ns: at most 0.5 ns.
    assert!(
        r["time_rounding_max"].as_f64().unwrap() <= 0.5e-9 + 1e-15,
        "{r}"
    );
    // Unit quaternions to a few ulp: measured 2.2e-16.
    assert!(r["quat_norm_err_max"].as_f64().unwrap() < 1e-14, "{r}");
}

/// 1e15 runs are refused before any work, with the estimate (issue 8), and nothing is written.
#[test]
fn absurd_datasets_are_refused_up_front() {
    let tmp = tempfile::tempdir().unwrap();
    write_spec(
        tmp.path(),
        "huge.toml",
        "runs = 1000000000000000\nseed = 1",
        None,
    );
    let out = tumble(&["dataset", "huge.toml", "--out", "ds", "-q"], tmp.path());
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    // 1e15 runs of ~30 steps: ~1e17 rows, exbibytes of Parquet and millennia of computing.
    assert!(err.contains("refusing") && err.contains("EiB"), "{err}");
    assert!(!tmp.path().join("ds").exists());
}
