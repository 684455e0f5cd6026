"""Every URDF of example-robot-data and of pybullet_data (both installed in the test venv by
scripts/test.sh) simulated articulated, fixed and floating base (and floating with every joint
set moving), 1 s at dt = 1 ms, through the
release binary: prints the Markdown of docs/robot_corpus.md (model x base: runs / refused with its
reason / fails, with the run's energy figure).

Usage: target/pyenv/bin/python scripts/robot_corpus.py [--jobs N] [--raw FILE] [TUMBLE] > docs/robot_corpus.md

Each file is first loaded by Pinocchio (`pinocchio.buildModelFromUrdf`, the issue's "that Pinocchio
loads"); the ones it refuses are listed with urdfdom's reason, still run, and not counted in the
totals. `--jobs` tumble processes (default 2) run at a time, each on one thread.

A run "runs" when it exits 0, no Newton solve failed, and its energy behaves as the variational
scheme promises (docs/forces.md, "What is conserved"; docs/mechanisms.md, "Energy" of the limits):
- nothing did work (no damping, friction or limit stop acted; no `energy balance` line): the
  energy error is bounded, no drift (O(h^2)): |E(1 s) - E(0)| / |E(0)| <= REL_TOL = 1e-3 (`dE/E0`
  in the table; measured at most 9.7e-5, ur3_robot fixed); a model starting at E = 0 (its centre
  of mass at z = 0) has its change judged against its weight times 1 m (`dE/(m g 1 m)`).
- something did work (URDF damping or friction, a limit stop: the `energy balance` line): the
  balance `change = input work - dissipated` closes, what it leaves open at most BAL_TOL = 1e-2 of
  the energy's scale (|E(0)|, |E(1 s)| and the balance's terms; `open` in the table), and the
  dissipation is not negative beyond that. Damping closes to O(h^2), a stop's ledger only to O(h)
  (its impulse acts at the start of the step): measured at most 1.0e-3 (pybullet's vision60, fixed
  base, its legs' stops; 4.4e-4 at dt = 0.5 ms, 2.0e-4 at 0.25 ms: first order, as documented).
  The scale, not the balance's largest term: a stop touched at rest makes every term round-off.

A refusal (of a file Pinocchio loads) is followed: the keys its message names (a link's or the
model's geometry, allow_non_physical_inertia, the other base, a lock) are set in a scene and the
file run again, a depth-first search over the keys each new refusal names, until it runs (the
cell says with which keys) or a refusal names no key left (the cell quotes it: "its keys end at").

`--raw FILE` also writes one tab-separated line per run: corpus, file, base, runs|refused|fails,
the table's text, 1|0 (Pinocchio loads the file), tumble's first error line (refusals), the
file's absolute path, its --package-path: what tests/mechanism/corpus.rs checks.
"""

import concurrent.futures
import json
import os
import re
import subprocess
import sys
import sysconfig
import tempfile

import pinocchio
import pybullet_data

REL_TOL = 1e-3  # |dE/E0| without work done: O(h^2)
BAL_TOL = 1e-2  # the balance left open, of the energy scale: O(h) with stops

args = sys.argv[1:]
jobs, raw = 2, None
while args and args[0].startswith("--"):
    flag = args.pop(0)
    if flag == "--jobs":
        jobs = int(args.pop(0))
    elif flag == "--raw":
        raw = args.pop(0)
    else:
        sys.exit(f"unknown flag {flag}")
tumble = args[0] if args else "target/release/tumble"

share = os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share")
CORPORA = [
    # (name, folder searched for *.urdf, --package-path)
    ("example-robot-data", os.path.join(share, "example-robot-data", "robots"), share),
    ("pybullet_data", pybullet_data.getDataPath(), pybullet_data.getDataPath()),
]


def urdfs(folder):
    return sorted(
        os.path.relpath(os.path.join(d, f), folder)
        for d, _, fs in os.walk(folder)
        for f in fs
        if f.endswith(".urdf")
    )


def pinocchio_refusal(path):
    """None when Pinocchio loads `path`, else its reason: urdfdom's first error line (it writes
    them on file descriptor 2, below Python), else the exception's text."""
    with tempfile.TemporaryFile(mode="w+") as err:
        saved = os.dup(2)
        os.dup2(err.fileno(), 2)
        try:
            pinocchio.buildModelFromUrdf(path)
            failure = None
        except Exception as e:  # noqa: BLE001 (any refusal is the answer)
            failure = str(e)
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        if failure is None:
            return None
        err.seek(0)
        lines = [l.strip() for l in err.read().splitlines() if l.strip().startswith("Error:")]
        return (lines[0].removeprefix("Error:").strip() if lines else failure)[:200]


NUM = r"([-+0-9.eE]+|NaN|inf|-inf)"


def total_mass(stem):
    """The bodies' total mass, kg, from the run's Parquet bodies table (0 without one)."""
    try:
        import pyarrow.parquet as pq
        return float(sum(pq.read_table(stem + ".bodies.parquet", columns=["mass"]).column("mass").to_pylist()))
    except Exception:  # noqa: BLE001 (no table: no mass)
        return 0.0


def energy(out, mass):
    """(figure text, behaves) from the summary lines: the energy's relative change without work
    done, else what the energy balance leaves open, both relative to the energy's scale (its
    start and end values and the balance's terms: a balance whose terms are all round-off, as
    a limit stop touched at rest, is no reason to fail)."""
    line = re.search(r"energy " + NUM + r" J -> " + NUM + r" J \((relative|absolute) change " + NUM, out)
    if not line:
        return "no energy line", False
    e0, e1 = float(line.group(1)), float(line.group(2))
    bal = re.search(r"energy balance: change " + NUM + r" J = input work " + NUM + r" J - dissipated "
                    + NUM + r" J.*not closed " + NUM + r" J", out)
    if bal:
        change, work, dissipated, open_ = (float(bal.group(i)) for i in (1, 2, 3, 4))
        scale = max(abs(e0), abs(e1), abs(change), abs(work), abs(dissipated))
        frac = abs(open_) / scale if scale > 0 else 0.0
        # Dissipation is >= 0 up to round-off: a negative one would be energy made.
        return f"open {frac:.1e}", frac <= BAL_TOL and dissipated >= -BAL_TOL * scale
    if e0 == 0.0:
        # Starting at zero energy (the centre of mass at z = 0, at rest) there is no relative
        # change: the change is judged against the model's weight times 1 m.
        scale = mass * 9.81
        r = (e1 - e0) / scale if scale > 0 else float("inf")
        return f"dE/(m g 1 m) {r:.1e}", abs(r) <= REL_TOL
    r = (e1 - e0) / abs(e0)
    return f"dE/E0 {r:.1e}", abs(r) <= REL_TOL


def keys_offered(err):
    """The keys a refusal names as what runs the file anyway, as (kind, value), in the order
    tried: the file's own values kept first (the opt-in), then a link's geometry, the base, the
    whole model's geometry, a lock."""
    keys = []
    # The opt-in accepts a body's moments that break the triangle inequality, not zero or
    # negative ones ("not positive definite"), and a part's negative ones ("semi-definite").
    opt_in = "triangle" in err or "semi-definite" in err
    if "allow_non_physical_inertia = true" in err and opt_in and "not positive definite" not in err:
        keys.append(("allow", "true"))
    # `links = { a = { inertia = "geometry" }, b = { ... } }`: all its links at once.
    for table in re.findall(r"`links = \{ (.*?) \}`", err):
        names = re.findall(r"([^ ,]+) = \{ inertia = \"geometry\" \}", table)
        if names:
            keys.append(("link", ",".join(names)))
    keys += [("link", m) for m in re.findall(r"Give `([^`]+)` mass \(an <inertial>, or links\.", err)]
    if '(`--base floating`)' in err:
        keys.append(("base", "floating"))
    if 'use base = "fixed"' in err:
        keys.append(("base", "fixed"))
    if "(`--inertia geometry`)" in err:
        keys.append(("inertia", "geometry"))
    keys += [("lock", m) for m in re.findall(r"or lock `([^`]+)`", err)]
    return keys


def scene_text(path, pkg, base, keys):
    model = {"base": base, "inertia": None, "allow": None}
    links, locks = [], []
    for kind, value in keys:
        if kind == "link":
            links += value.split(",")
        elif kind == "lock":
            locks.append(value)
        else:
            model[kind] = value
    text = (f"[sim]\ndt = 0.001\nduration = 1.0\n[[model]]\nurdf = {json.dumps(path)}\n"
            f"package_paths = [{json.dumps(pkg)}]\nallow_mesh_paths = [\"/\"]\nbodies = \"articulated\"\n"
            f"base = \"{model['base']}\"\n")
    if model["inertia"]:
        text += "inertia = \"geometry\"\n"
    if model["allow"]:
        text += "allow_non_physical_inertia = true\n"
    if links:
        text += "links = { " + ", ".join(f'{json.dumps(l)} = {{ inertia = "geometry" }}' for l in links) + " }\n"
    if locks:
        text += f"locked_joints = {json.dumps(locks)}\n"
    return text


def key_text(keys):
    names = {"allow": lambda v: "allow_non_physical_inertia = true", "base": lambda v: f'base = "{v}"',
             "inertia": lambda v: 'inertia = "geometry"', "link": lambda v: ", ".join(f'links.{l}.inertia = "geometry"' for l in v.split(",")),
             "lock": lambda v: f'locked_joints = ["{v}"]'}
    return ", ".join(f"`{names[k](v)}`" for k, v in keys)


def follow(job, err):
    """Follows a refusal's keys (a depth-first search over the keys each refusal names, at most
    40 runs): (the keys that run the file, None) or (None, the refusal at the end of the
    longest chain of keys: one that names no key left to try)."""
    corpus, folder, pkg, rel, base, tmp = job
    path = os.path.join(folder, rel)
    stem = os.path.join(tmp, f"follow-{corpus}-{rel.replace('/', '_')}-{base}")
    budget = [40]
    last = [err]
    deepest = [0]

    def search(keys, err):
        for key in keys_offered(err):
            if key in keys or budget[0] == 0:
                continue
            budget[0] -= 1
            tried = keys + [key]
            with open(stem + ".toml", "w") as f:
                f.write(scene_text(path, pkg, base, tried))
            p = subprocess.run([tumble, "simulate", stem + ".toml", "--threads", "1", "--format", "parquet",
                                "--out", stem, "--force"], capture_output=True, text=True, timeout=300)
            out = p.stdout + p.stderr
            figure, behaves = energy(out, total_mass(stem))
            if p.returncode == 0 and " 0 non-converged" in out and behaves:
                return tried
            if p.returncode == 0:
                newton = next((l for l in out.splitlines() if l.startswith("Newton:")), "")
                if len(tried) > deepest[0]:
                    deepest[0] = len(tried)
                    last[0] = f"with {key_text(tried)} it exits 0 but fails: {figure}; {newton}"
                continue
            e = next((l for l in out.splitlines() if l.startswith("error")), out.strip()[-200:])
            if len(tried) > deepest[0]:
                deepest[0] = len(tried)
                e = e.replace(stem + ".toml", "").replace(path, "").replace(folder + "/", "")
                last[0] = f"with {key_text(tried)}: {e}"
            found = search(tried, e)
            if found:
                return found
        return None

    found = search([], err)
    for suffix in (".toml", ".trajectories.parquet", ".bodies.parquet", ".joints.parquet"):
        if os.path.exists(stem + suffix):
            os.remove(stem + suffix)
    return (found, None) if found else (None, last[0])


def run(job):
    corpus, folder, pkg, rel, base, tmp = job
    path = os.path.join(folder, rel)
    stem = os.path.join(tmp, f"{corpus}-{rel.replace('/', '_')}-{base}")
    cmd = [tumble, "simulate", path, "--articulated", "--base", base, "--duration", "1", "--dt", "0.001",
           "--allow-mesh-path", "/", "--package-path", pkg, "--threads", "1",
           "--format", "parquet", "--out", stem, "--force"]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        out, code = p.stdout + p.stderr, p.returncode
    except subprocess.TimeoutExpired:
        out, code = "timeout after 300 s", -1
    newton = next((l for l in out.splitlines() if l.startswith("Newton:")), "")
    figure, behaves = energy(out, total_mass(stem))
    for suffix in (".trajectories.parquet", ".bodies.parquet", ".joints.parquet"):
        if os.path.exists(stem + suffix):
            os.remove(stem + suffix)
    err = next((l for l in out.splitlines() if l.startswith("error")), "")
    if code == 0 and " 0 non-converged" in newton and behaves:
        return "runs", figure, ""
    if code == 2:
        # The message without the paths (the file is the row's), its first 260 characters.
        reason = (err or out.strip()[:200]).replace(path, "").replace(folder + "/", "")
        reason = reason.removeprefix("error: ").removeprefix(": ")[:260].replace("|", "/")
        if (corpus, rel) in not_pinocchio:
            return "refused", reason, err
        keys, last = follow(job, err)
        if keys:
            return "refused", f"{reason}. **With** {key_text(keys)}: runs", err
        last = last.replace("error: : ", "").replace("error: ", "").replace("model[0]: : ", "").replace("model[0]: ", "")[:400].replace("|", "/")
        return "refused", f"{reason}. **Its keys end at**: {last}", err
    if code == 0 and " 0 non-converged" in newton:
        return "fails", f"energy: {figure}", err
    last = (newton or (out.strip().splitlines()[-1] if out.strip() else ""))[:160]
    return "fails", f"({code}): {last}".replace("|", "/"), err


MOVING_RATE = 0.5  # rad/s (a prismatic joint: m/s / 10), alternating in sign joint by joint


def moving_rates(path, pkg):
    """The initial rates of the "moving" run: every revolute, continuous and prismatic joint that
    is not a mimic follower, +-MOVING_RATE alternating (prismatic joints a tenth of it, m/s), as
    a TOML inline table; None when the model has no such joint."""
    p = subprocess.run([tumble, "inspect", path, "--json", "--package-path", pkg, "--allow-mesh-path", "/"],
                       capture_output=True, text=True, timeout=300)
    try:
        joints = json.loads(p.stdout)["joints"]
    except (ValueError, KeyError):
        return None
    rates = {}
    for j in joints:
        if j["type"] in ("revolute", "continuous", "prismatic") and not j.get("mimic"):
            v = MOVING_RATE * (1 if len(rates) % 2 == 0 else -1)
            rates[j["name"]] = v / 10 if j["type"] == "prismatic" else v
    return rates or None


def toml_rates(rates):
    return "{ " + ", ".join(f"{json.dumps(k)} = {v!r}" for k, v in rates.items()) + " }"


def run_moving(job):
    """The floating base set moving: every joint at +-MOVING_RATE (`moving_rates`), in gravity,
    1 s at 1 ms: the joints' dynamics in free flight, where energy is conserved and the floating
    base's momenta too. A joint the articulated model merges or that does not move is dropped
    (its refusal names it) and the run repeated. Returns (kind, text, err, rates)."""
    corpus, folder, pkg, rel, _, tmp = job
    path = os.path.join(folder, rel)
    stem = os.path.join(tmp, f"{corpus}-{rel.replace('/', '_')}-moving")
    rates = moving_rates(path, pkg)
    if not rates:
        return None
    for _ in range(20):
        with open(stem + ".toml", "w") as f:
            f.write(f"[sim]\ndt = 0.001\nduration = 1.0\ngravity = [0.0, 0.0, -9.81]\n[[model]]\n"
                    f"urdf = {json.dumps(path)}\npackage_paths = [{json.dumps(pkg)}]\nallow_mesh_paths = [\"/\"]\n"
                    f"bodies = \"articulated\"\nbase = \"floating\"\njoint_velocities = {toml_rates(rates)}\n")
        p = subprocess.run([tumble, "simulate", stem + ".toml", "--threads", "1", "--format", "parquet",
                            "--out", stem, "--force"], capture_output=True, text=True, timeout=300)
        out = p.stdout + p.stderr
        err = next((l for l in out.splitlines() if l.startswith("error")), "")
        dropped = re.search(r"joint_velocities\.([^:]+): joint `", err)
        if p.returncode == 2 and dropped and dropped.group(1) in rates:
            del rates[dropped.group(1)]
            if not rates:
                return None
            continue
        break
    newton = next((l for l in out.splitlines() if l.startswith("Newton:")), "")
    figure, behaves = energy(out, total_mass(stem))
    for suffix in (".toml", ".trajectories.parquet", ".bodies.parquet", ".joints.parquet"):
        if os.path.exists(stem + suffix):
            os.remove(stem + suffix)
    if p.returncode == 0 and " 0 non-converged" in newton and behaves:
        return "runs", figure, "", rates
    last = (err or newton or (out.strip().splitlines()[-1] if out.strip() else ""))[:200]
    return "fails", f"({p.returncode}) {figure}: {last}".replace("|", "/"), err, rates


files = [(c, folder, pkg, rel) for c, folder, pkg in CORPORA for rel in urdfs(folder)]
not_pinocchio = {(c, rel): why for c, folder, _, rel in files
                 if (why := pinocchio_refusal(os.path.join(folder, rel))) is not None}
with tempfile.TemporaryDirectory() as tmp:
    work = [(c, folder, pkg, rel, base, tmp) for c, folder, pkg, rel in files for base in ("fixed", "floating")]
    with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as pool:
        results = dict(zip(((w[0], w[3], w[4]) for w in work), pool.map(run, work)))
        moving_work = [w for w in work if w[4] == "floating" and results[(w[0], w[3], "floating")][0] == "runs"]
        rates_of = {}
        for w, r in zip(moving_work, pool.map(run_moving, moving_work)):
            if r is not None:
                results[(w[0], w[3], "moving")] = r[:3]
                rates_of[(w[0], w[3])] = r[3]

if raw:
    with open(raw, "w") as f:
        where = {(c, rel): (os.path.join(folder, rel), pkg) for c, folder, pkg, rel in files}
        for (c, rel, base), (kind, text, err) in sorted(results.items()):
            pin = 0 if (c, rel) in not_pinocchio else 1
            path, pkg = where[(c, rel)]
            rates = toml_rates(rates_of[(c, rel)]) if base == "moving" else ""
            f.write(f"{c}\t{rel}\t{base}\t{kind}\t{text}\t{pin}\t{err}\t{path}\t{pkg}\t{rates}\n")


def cell(kind, text, _err):
    if kind == "runs":
        return f"runs ({text})"
    if kind == "refused":
        return f"refused: {text}"
    return f"**fails** {text}"


print("# Real robots: example-robot-data and pybullet_data, articulated, 1 s at dt = 1 ms\n")
print("Generated by `target/pyenv/bin/python scripts/robot_corpus.py > docs/robot_corpus.md` (after "
      "`bash scripts/test.sh` installed the venv; about 40 s on 2 cores, two runs at a time): every URDF of "
      "example-robot-data and of pybullet_data (recursively) simulated with `tumble simulate X.urdf --articulated "
      "--base fixed|floating --duration 1 --dt 0.001`, its meshes found through `--package-path` and "
      "`--allow-mesh-path /`; then every file whose floating run runs is run a third time, **floating, joints "
      "moving**: a scene with every revolute, continuous and prismatic joint (not a mimic follower) at an initial "
      "rate of +-0.5 rad/s alternating joint by joint (prismatic: +-0.05 m/s), in gravity, 1 s at 1 ms, so the "
      "joints' own dynamics (and their limits) act in free flight, not only a rigid fall. The test `corpus::every_corpus_urdf_runs_or_is_refused_with_its_reason` "
      "(tests/mechanism/corpus.rs) runs this script on the test binary at each `cargo test` (the same 1 s: 42 s "
      "with the test below) and asserts the table below: no file fails; "
      "`corpus::corpus_runs_without_work_keep_their_energy_bounded_at_every_step` reruns the runs where nothing "
      "did work through the library with every step recorded: the energy's largest excursion stays within 1e-3 "
      "of the largest kinetic energy reached (measured at most 7.3e-5, ur3_robot fixed), not only at 1 s.\n")
print("**runs**: exit 0, no Newton failure, and the energy behaves as the variational scheme promises "
      "(docs/forces.md, \"What is conserved\"). Without anything doing work the energy error is bounded, no "
      f"drift (O(h^2)): `dE/E0` is (E(1 s) - E(0)) / |E(0)|, at most {REL_TOL:g} (E counts gravity's potential "
      "from z = 0, the root at the origin). When damping, friction or a limit stop acted, the energy balance "
      "(`change = input work - dissipated`, docs/forces.md) must close: `open` is what it leaves open as a "
      f"fraction of the energy's scale (|E(0)|, |E(1 s)|, the balance's terms), at most {BAL_TOL:g}, with no "
      "negative dissipation beyond it (damping closes to O(h^2), a limit stop's ledger to O(h), "
      "docs/mechanisms.md); starting at E = 0 (the centre of mass at z = 0) the change is judged against the "
      "model's weight times 1 m (`dE/(m g 1 m)`). **refused**: exit 2 with tumble's message, which names the file, "
      "the link or joint and the defect, and the key that runs it anyway (paths cut here: the row names the file). "
      "Each refusal of a file Pinocchio loads is then followed: the keys it names are set in a scene and the file "
      "run again, over the keys each new refusal names, until it runs (\"**With** keys: runs\", the same checks) "
      "or a refusal names no key left (\"**Its keys end at**\": that refusal). **fails**: anything else.\n")
print("Totals (file x base):\n")
print("| corpus | files | base | runs | refused | of them run with their keys | fails |\n|---|---|---|---|---|---|---|")
for c, _, _ in CORPORA:
    n = sum(1 for f in files if f[0] == c and (c, f[3]) not in not_pinocchio)
    for base in ("fixed", "floating", "moving"):
        k = [kind for (cc, rel, b), (kind, _, _) in results.items()
             if cc == c and b == base and (c, rel) not in not_pinocchio]
        keyed = sum(1 for (cc, rel, b), (kind, text, _) in results.items()
                    if cc == c and b == base and (c, rel) not in not_pinocchio and "**With**" in text)
        print(f"| {c} | {n} | {base} | {k.count('runs')} | {k.count('refused')} | {keyed} | {k.count('fails')} |")
print("\nThe files Pinocchio does not load are left out of the totals (listed below, with their rows).\n")
for c, _, _ in CORPORA:
    print(f"## {c}\n")
    print("| URDF | fixed base | floating base | floating, joints moving |\n|---|---|---|---|")
    # pybullet_data's random_urdfs/NNN/NNN.urdf (1000 generated objects) take one row when their
    # cells are the same but for the file's own number (then checked here, file by file).
    groups = {}
    for cc, folder, _, rel in files:
        if cc != c:
            continue
        note = " (not loaded by Pinocchio)" if (c, rel) in not_pinocchio else ""
        moving = results.get((c, rel, "moving"))
        cells = (f"{cell(*results[(c, rel, 'fixed')])} | {cell(*results[(c, rel, 'floating')])} | "
                 + (cell(*moving) if moving else "-"))
        m = re.fullmatch(r"random_urdfs/(\d+)/(\d+)\.urdf", rel)
        if m and m.group(1) == m.group(2) and not note:
            groups.setdefault(cells.replace(m.group(1), "NNN"), []).append(rel)
            continue
        print(f"| `{rel}`{note} | {cells} |")
    for cells, rels in groups.items():
        print(f"| `random_urdfs/NNN/NNN.urdf`, {len(rels)} files (`{rels[0]}` to `{rels[-1]}`) | {cells} |")
    print()
print("""## What the corpus found (issue 32)

No run fails (Newton, panic, timeout, energy). What it found, and what changed:

- **Refusals without a way out.** A model with no moving joint at `base = "fixed"` (pybullet's cubes, spheres,
  mugs, the xarm's single links) said "nothing would move" and stopped there; it now names `base = "floating"`
  (it falls as one rigid body). A model whose every link has mass 0 (pybullet's static objects: planes, tables,
  trays) said "nothing to simulate"; it now names `inertia = "geometry"`. A part's negative principal moment
  named only `allow_non_physical_inertia`, which runs the file only when the body the part is merged into comes
  out positive definite (tiago's antennas on its base: yes; romeo_laas_small's `body`, -0.021 kg m^2: no); it
  now also names `links.X.inertia = "geometry"`. Test: `robot::pybullet_static_objects_are_refused_with_the_key_that_runs_them`.
- **Meshes refused as non-manifold after welding.** An OBJ or DAE whose surface touches itself, each sheet with
  its own vertices (pybullet's V-HACD laikago chassis: hulls sharing an edge and a face; 28 of the 1000
  `random_urdfs` objects), became non-manifold once welding by position joined the sheets, so
  `inertia = "geometry"`, the key their zero inertias name, ended there. The file's own indexing closes them and is
  kept now (`mesh_io::weld_indexed`; stacked copies of a solid still refused). Tests:
  `mesh::an_obj_touching_itself_keeps_its_own_indexing_stacked_copies_do_not`,
  `robot::laikago_runs_with_its_mass_from_its_vhacd_meshes`.
- **A stop's energy at the first step.** The moving runs found the energy balance open on pybullet's
  pr2_gripper (17 % of the energy), spirit40 and vision60: a joint starting on its bound and moving into it
  (pr2's fingers at their lower limit 0, set closing) is stopped at the first step, and the stop's ledger took
  the rate before the impact from the previous step, which the first step does not have, so the lost kinetic
  energy was charged to no one. The rate before the first step is now the initial state's (from the bodies'
  velocities, exact there); the three close to 1e-8 or better. Test:
  `limits::a_slider_starting_on_its_limit_moving_into_it_is_charged_its_kinetic_energy`.
- **Energy.** The tightest balance is vision60's at a fixed base (its legs fold into their stops: 5.04 J
  dissipated, 5.5e-3 J open, 1.0e-3 of the energy, halving with the step: the stops' O(h) ledger). Test:
  `robot::vision60_closes_its_energy_balance_through_its_stops`.

Open (refused, each refusal naming its defect, but no key runs them without new data): iCub and iCub reduced
(zero inertias, and `r_upper_leg`'s collision mesh, which would give one, is open), romeo_laas_small (`body`'s
negative moment; its meshes are absolute paths of another machine, `file:///usr/Romeo/...`), pybullet's
plane_implicit and samurai (open meshes: scenery, not solids) and random_urdfs/168 (an empty mesh). Outside the
totals: husky.urdf's parse error (Pinocchio refuses it too) quotes urdf-rs's detail, which names the `xyz` or the
`rpy` attribute from one run to the next (urdf-rs's order), after tumble's own, stable, location.
""")
print("## Not loaded by Pinocchio\n")
print("`pinocchio.buildModelFromUrdf` refuses these (urdfdom's first error); tumble still runs them (rows above), "
      "outside the totals.\n")
for (c, rel), why in sorted(not_pinocchio.items()):
    print(f"- {c} `{rel}`: not loaded by Pinocchio '{why}'")
