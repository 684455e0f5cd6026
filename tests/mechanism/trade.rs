//! `tumble trade` and `tumble stability --scene` on articulated scenes: the orders of the
//! variational family measured from trade's own CSV, exact momenta of a floating chain, the
//! skip lines and refusals for integrators without a constrained form, and the stability rows.

use crate::common;

use common::{root, text, tumble};

/// The rows of a CSV file: header, then one map per line.
fn read_csv(path: &std::path::Path) -> (String, Vec<Vec<String>>) {
    let csv = std::fs::read_to_string(path).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

fn model(name: &str) -> String {
    root().join("models").join(name).display().to_string()
}

/// `log2(err(h) / err(h/2))` for consecutive step sizes of one integrator (rows in dt order,
/// halving).
fn orders(rows: &[Vec<String>], integrator: &str, column: usize) -> Vec<f64> {
    let errs: Vec<f64> = rows
        .iter()
        .filter(|r| r[0] == integrator)
        .map(|r| r[column].parse().unwrap())
        .collect();
    common::bodies::orders(&errs)
}

/// Asserts every measured order of each `(integrator, p)` in `columns` is `p` ± 0.35
/// (pre-asymptotic constants at the coarsest step, ~4 % of a doubling).
fn assert_orders(rows: &[Vec<String>], expected: &[(&str, f64)], columns: &[usize]) {
    for &(integrator, p) in expected {
        for &column in columns {
            for order in orders(rows, integrator, column) {
                assert!(
                    (order - p).abs() < 0.35,
                    "{integrator} column {column}: measured order {order}, expected {p}"
                );
            }
        }
    }
}

#[test]
fn trade_measures_orders_two_four_six_on_the_double_pendulum() {
    let dir = tempfile::tempdir().unwrap();
    let out = tumble(
        &[
            "trade",
            &model("double_pendulum.toml"),
            "--out",
            "t",
            "--dt",
            "0.01,0.005,0.0025",
            "--duration",
            "2",
            "--drift-horizon",
            "2",
            "--repeats",
            "1",
        ],
        dir.path(),
    );
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // The default list: every integrator without a constrained form is skipped, one line each.
    for skipped in ["moser-veselov", "euler", "semi-implicit", "rk4"] {
        assert!(
            stdout.lines().any(|l| l.starts_with(&format!(
                "skipped {skipped}: model `double_pendulum` is articulated"
            ))),
            "{stdout}"
        );
    }
    let t = dir.path().join("t");
    let (_, rows) = read_csv(&t.join("trade.csv"));
    let names: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(
        names.into_iter().collect::<Vec<_>>(),
        ["variational", "variational4", "variational6"]
    );
    assert_eq!(rows.len(), 9);
    // Columns: 3 pos_err, 4 rot_err. Measured orders (pos, rot) over 2 s of a chaotic swing:
    // variational 2.01, 2.00 / 2.01, 2.01; variational4 4.07, 4.02 / 4.05, 4.00;
    // variational6 6.30, 6.04 / 6.25, 6.10. Bounds: the order ± 0.35 (pre-asymptotic
    // constants at the coarsest step, ~4 % of a doubling).
    for (integrator, p) in [
        ("variational", 2.0),
        ("variational4", 4.0),
        ("variational6", 6.0),
    ] {
        for column in [3, 4] {
            for order in orders(&rows, integrator, column) {
                assert!(
                    (order - p).abs() < 0.35,
                    "{integrator} column {column}: measured order {order}, expected {p}"
                );
            }
        }
        // A fixed-base model conserves no angular momentum: NaN, never a made-up 0.
        assert!(
            rows.iter()
                .filter(|r| r[0] == integrator)
                .all(|r| r[6] == "NaN")
        );
    }
    // The reference resolves the smallest error measured (3.8e-10 m) with room to spare: its
    // own error estimate is 2.0e-13 m.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(t.join("trade.json")).unwrap()).unwrap();
    let own = json["reference"]["own_error_m"].as_f64().unwrap();
    let smallest = rows
        .iter()
        .map(|r| r[3].parse::<f64>().unwrap())
        .fold(f64::INFINITY, f64::min);
    assert!(
        own < smallest / 100.0,
        "reference {own} m vs smallest error {smallest} m"
    );
    assert_eq!(json["skipped"].as_array().unwrap().len(), 4);
    // The side-by-side recording carries each integrator's joints.
    let info = tumble(
        &["info", &t.join("trade.mcap").display().to_string()],
        dir.path(),
    );
    let info = text(&info.stdout);
    for topic in ["/variational/joints", "/variational4/mechanisms"] {
        assert!(info.contains(topic), "{info}");
    }
}

#[test]
fn trade_keeps_a_floating_chain_momentum_exact() {
    let dir = tempfile::tempdir().unwrap();
    let out = tumble(
        &[
            "trade",
            &model("chain3_free.toml"),
            "--out",
            "t",
            "--integrators",
            "variational,variational4",
            "--dt",
            "0.02,0.01",
            "--duration",
            "2",
            "--drift-horizon",
            "2",
            "--repeats",
            "1",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (_, rows) = read_csv(&dir.path().join("t/trade.csv"));
    assert_eq!(rows.len(), 4);
    for r in &rows {
        // The change of L about the chain's centre of mass is round-off at any step (measured
        // 1.8e-15 .. 4.5e-15 kg m²/s).
        let dl: f64 = r[6].parse().unwrap();
        assert!(dl < 1e-12, "{r:?}");
        // Energy is not exact, only bounded: a non-zero error proves the column is measured.
        let de: f64 = r[5].parse().unwrap();
        assert!(de > 0.0 && de < 1e-2, "{r:?}");
    }
}

#[test]
fn trade_refuses_a_named_integrator_without_a_constrained_form() {
    let dir = tempfile::tempdir().unwrap();
    let out = tumble(
        &[
            "trade",
            &model("double_pendulum.toml"),
            "--out",
            "t",
            "--integrators",
            "variational,rk4",
            "--dt",
            "0.01",
            "--duration",
            "1",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2));
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("model `double_pendulum` is articulated")
            && stderr.contains("`rk4`")
            && stderr.contains("`variational4`"),
        "{stderr}"
    );
    assert!(!dir.path().join("t/trade.csv").exists());
    assert!(!dir.path().join("t/trade.mcap").exists());
}

#[test]
fn stability_maps_an_articulated_scene_along_dt() {
    let dir = tempfile::tempdir().unwrap();
    let out = tumble(
        &[
            "stability",
            "--scene",
            &model("double_pendulum.toml"),
            "--out",
            "s",
            "--dt",
            "0.001,0.002,0.064",
            "--duration",
            "4",
        ],
        dir.path(),
    );
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        stdout.contains("skipped rk4: model `double_pendulum` is articulated"),
        "{stdout}"
    );
    let (header, rows) = read_csv(&dir.path().join("s/stability_scene.csv"));
    assert_eq!(
        header,
        "integrator,dt,steps,steps_done,newton_iters_max,substeps,substep_factor_max,energy_err_max,residual_m_max,residual_rad_max,status"
    );
    assert_eq!(rows.len(), 9);
    let row = |integrator: &str, dt: &str| {
        rows.iter()
            .find(|r| r[0] == integrator && r[1] == dt)
            .unwrap_or_else(|| panic!("{integrator} {dt}: {rows:?}"))
    };
    let err = |r: &Vec<String>| r[7].parse::<f64>().unwrap();
    for integrator in ["variational", "variational4", "variational6"] {
        let fine = row(integrator, "0.001");
        assert_eq!(fine[10], "ok", "{fine:?}");
        assert_eq!(fine[3], "4000");
        // Joint gap at round-off of the Newton tolerance (1e-12 x the 0.5 m length scale):
        // measured 5.0e-13 m; axis misalignment 5e-16 rad.
        assert!(fine[8].parse::<f64>().unwrap() < 2e-12, "{fine:?}");
        assert!(fine[9].parse::<f64>().unwrap() < 1e-13, "{fine:?}");
        // 64 ms is past every scheme's reach on this swing (measured: diverged for all three).
        let coarse = row(integrator, "0.064");
        assert_ne!(coarse[10], "ok", "{coarse:?}");
    }
    // The energy error follows the order: doubling dt multiplies it by ~2^p (measured over
    // 4 s: 4.0 for variational, 16.1 for variational4, 61 for variational6).
    let ratio = |i: &str| err(row(i, "0.002")) / err(row(i, "0.001"));
    assert!(
        (3.0..5.5).contains(&ratio("variational")),
        "{}",
        ratio("variational")
    );
    assert!(
        (10.0..24.0).contains(&ratio("variational4")),
        "{}",
        ratio("variational4")
    );
    assert!(ratio("variational6") > 30.0, "{}", ratio("variational6"));
    assert!(
        stdout.contains(
            "variational: ok (energy error <= 0.01, no substeps, no failure) up to dt = 0.002 s"
        ),
        "{stdout}"
    );

    // Named integrators without a constrained form: one error, nothing written.
    let out = tumble(
        &[
            "stability",
            "--scene",
            &model("double_pendulum.toml"),
            "--out",
            "s2",
            "--integrators",
            "euler",
            "--dt",
            "0.001",
            "--duration",
            "1",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("`euler` cannot step"),
        "{}",
        text(&out.stderr)
    );
    assert!(!dir.path().join("s2").exists());
}

/// `stability --scene` on the double pendulum driven by a servo and a motor, its joints damped:
/// the energy column is the residual of the energy balance `E − E_0 − (W − D)` (issue 47:
/// it called the servo's work and the damping's dissipation "energy error"), so it is the
/// scheme's own error and falls at order 2 as dt halves. Measured: the servo and motor do
/// 8.93 J of work and damping takes 2.80 J, while the residual is 4.96e-6 of the energy scale
/// at dt = 2 ms and 1.24e-6 at 1 ms (ratio 4.00); the raw energy change, the column before,
/// was 1.45 of it (ratio 1).
#[test]
fn stability_judges_a_driven_damped_scene_by_its_energy_balance() {
    let dir = tempfile::tempdir().unwrap();
    let scene = format!(
        "[sim]\ndt = 0.001\nduration = 2.0\n\
         [[model]]\nurdf = {:?}\nbodies = \"articulated\"\nbase = \"fixed\"\n\
         [[model.actuator]]\njoint = \"shoulder\"\nkind = \"position\"\n\
         target = {{ sine = {{ amplitude = 0.5, frequency_hz = 0.5, phase = 0.0, offset = 0.2 }} }}\n\
         kp = 50.0\nkd = 2.0\n\
         [[model.actuator]]\njoint = \"elbow\"\nkind = \"motor\"\n\
         effort = {{ sine = {{ amplitude = 1.0, frequency_hz = 1.0, phase = 0.0, offset = 0.0 }} }}\n",
        dir.path().join("damped.urdf")
    );
    // The bundled pendulum with URDF damping 0.3 N m s/rad on the elbow.
    let urdf = std::fs::read_to_string(model("double_pendulum.urdf")).unwrap();
    let at = urdf.find("<joint name=\"elbow\"").unwrap();
    let close = at + urdf[at..].find("</joint>").unwrap();
    let damped = format!(
        "{}<dynamics damping=\"0.3\"/>\n  {}",
        &urdf[..close],
        &urdf[close..]
    );
    std::fs::write(dir.path().join("damped.urdf"), damped).unwrap();
    std::fs::write(dir.path().join("driven.toml"), scene).unwrap();
    let sim = tumble(
        &["simulate", "driven.toml", "--format", "parquet"],
        dir.path(),
    );
    let sim_out = text(&sim.stdout);
    assert!(sim.status.success(), "{}", text(&sim.stderr));
    eprintln!("{sim_out}");
    // The inputs really exchange energy: damping takes some out (the line's `dissipated`).
    assert!(!sim_out.contains("dissipated 0.000000e0 J"), "{sim_out}");
    let out = tumble(
        &[
            "stability",
            "--scene",
            "driven.toml",
            "--out",
            "s",
            "--integrators",
            "variational",
            "--dt",
            "0.001,0.002",
            "--duration",
            "2",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (_, rows) = read_csv(&dir.path().join("s/stability_scene.csv"));
    let err = |dt: &str| {
        let r = rows.iter().find(|r| r[1] == dt).unwrap();
        assert_eq!(r[10], "ok", "{r:?}");
        r[7].parse::<f64>().unwrap()
    };
    let (fine, coarse) = (err("0.001"), err("0.002"));
    eprintln!("energy balance residual: {fine:e} at 1 ms, {coarse:e} at 2 ms");
    // Order 2: the ratio is 4 up to the next order's term (measured 4.00).
    assert!((3.5..4.5).contains(&(coarse / fine)), "{fine:e} {coarse:e}");
    // The scheme's error, small against the energy exchanged (measured 1.24e-6; the raw
    // change is 1.45).
    assert!(fine < 1e-4, "{fine:e}");
}

/// The double pendulum driven: a position servo tracking a sine on the shoulder and a sine
/// motor on the elbow (`[[model.actuator]]`). Trade's columns measure orders 2, 4, 6 with the
/// time-varying inputs (the symmetric step efforts keep the compositions' orders), and the
/// energy column, the residual of the energy balance `E(t) − E(0) − (W − D)`, falls at the
/// same orders.
#[test]
fn trade_measures_orders_two_four_six_on_a_driven_double_pendulum() {
    let dir = tempfile::tempdir().unwrap();
    let scene = format!(
        "[sim]\ndt = 0.01\nduration = 2.0\n\
         [[model]]\nurdf = {:?}\nbodies = \"articulated\"\nbase = \"fixed\"\n\
         [[model.actuator]]\njoint = \"shoulder\"\nkind = \"position\"\n\
         target = {{ sine = {{ amplitude = 0.5, frequency_hz = 0.5, phase = 0.0, offset = 0.2 }} }}\n\
         kp = 50.0\nkd = 2.0\n\
         [[model.actuator]]\njoint = \"elbow\"\nkind = \"motor\"\n\
         effort = {{ sine = {{ amplitude = 1.0, frequency_hz = 1.0, phase = 0.0, offset = 0.0 }} }}\n",
        model("double_pendulum.urdf")
    );
    std::fs::write(dir.path().join("driven.toml"), scene).unwrap();
    let out = tumble(
        &[
            "trade",
            "driven.toml",
            "--out",
            "t",
            "--dt",
            "0.02,0.01,0.005",
            "--drift-horizon",
            "2",
            "--repeats",
            "1",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    // The side-by-side recording carries every run's drives.
    let info = tumble(&["info", "t/trade.mcap"], dir.path());
    let info = text(&info.stdout);
    for kind in ["variational", "variational4", "variational6"] {
        assert!(
            info.contains(&format!(
                "joint {kind}/shoulder continuous, driven: position"
            )),
            "{info}"
        );
    }
    let (_, rows) = read_csv(&dir.path().join("t/trade.csv"));
    // Columns 3 pos_err, 4 rot_err, 5 energy_err (the balance's residual). Measured (pos,
    // rot, energy): variational 2.00, 2.00, 2.00 / 2.00, 2.00, 2.00; variational4 4.02, 3.99,
    // 3.99 / 4.01, 4.00, 4.00; variational6 6.02, 6.01, 6.00 / 6.01, 6.01, 6.00. Bounds:
    // the order ± 0.35 (as for the passive pendulum above).
    let family = [
        ("variational", 2.0),
        ("variational4", 4.0),
        ("variational6", 6.0),
    ];
    assert_orders(&rows, &family, &[3, 4, 5]);
}

/// A free box pushed by a sine force and twisted by a sine torque (`[[model.load]]`): trade
/// measures every scheme against the numerical reference (no closed form under loads), the
/// explicit schemes included, at their orders; the angular momentum column is NaN (the
/// torque changes it: nothing is conserved to measure).
#[test]
fn trade_measures_every_scheme_under_a_load() {
    let dir = tempfile::tempdir().unwrap();
    let scene = format!(
        "[sim]\ndt = 0.01\nduration = 1.0\ngravity = [0.0, 0.0, -9.81]\n\
         [[model]]\nurdf = {:?}\nangvel = [0.3, 2.0, 0.1]\n\
         [[model.load]]\nlink = \"box\"\nframe = \"link\"\n\
         force = [{{ sine = {{ amplitude = 3.0, frequency_hz = 1.0, phase = 0.0, offset = 0.0 }} }}, 0.0, 0.5]\n\
         torque = [0.0, {{ sine = {{ amplitude = 0.2, frequency_hz = 2.0, phase = 0.0, offset = 0.0 }} }}, 0.0]\n",
        model("box.urdf")
    );
    std::fs::write(dir.path().join("pushed.toml"), scene).unwrap();
    let out = tumble(
        &[
            "trade",
            "pushed.toml",
            "--out",
            "t",
            "--dt",
            "0.02,0.01",
            "--drift-horizon",
            "1",
            "--repeats",
            "1",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (_, rows) = read_csv(&dir.path().join("t/trade.csv"));
    let names: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(names.len(), 7, "every scheme measured: {names:?}");
    // Orders of pos_err (column 3: the load moves the centre) from 20 to 10 ms (at 5 ms
    // variational6 reaches round-off, 1e-13 m). Measured: euler 1.00, semi-implicit 1.00,
    // moser-veselov 2.00, variational 2.00, variational4 3.97, rk4 4.02, variational6 6.01.
    let schemes = [
        ("euler", 1.0),
        ("semi-implicit", 1.0),
        ("variational", 2.0),
        ("moser-veselov", 2.0),
        ("variational4", 4.0),
        ("rk4", 4.0),
        ("variational6", 6.0),
    ];
    assert_orders(&rows, &schemes, &[3]);
    for (integrator, _) in schemes {
        assert!(
            rows.iter()
                .filter(|r| r[0] == integrator)
                .all(|r| r[6] == "NaN")
        );
    }
}
