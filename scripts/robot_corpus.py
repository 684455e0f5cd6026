"""Every URDF of example-robot-data and of pybullet_data (both installed in the test venv by
scripts/test.sh) simulated articulated, fixed and floating base, 1 s at dt = 1 ms, through the
release binary: prints the Markdown of docs/robot_corpus.md (model x base: runs / refused with its
reason / fails, with the run's energy figure).

Usage: target/pyenv/bin/python scripts/robot_corpus.py [--jobs N] [--raw FILE] [TUMBLE] > docs/robot_corpus.md

Each file is first loaded by Pinocchio (`pinocchio.buildModelFromUrdf`, the issue's "that Pinocchio
loads"); the ones it refuses are listed with urdfdom's reason, still run, and not counted in the
totals. The runs go through a pool of `--jobs` processes (default 2), each tumble on one thread.

A run "runs" when it exits 0, no Newton solve failed, and its energy behaves as the variational
scheme promises (docs/forces.md, "What is conserved"):
- nothing did work (no damping, friction, limit stop or drive acted; no `energy balance` line):
  the energy error is bounded, no drift: |E(1 s) - E(0)| / |E(0)| <= 1e-3 (`dE/E0` in the table);
  the measured ones are all below 1e-5, the bound leaves room for the O(h^2) oscillation.
- something did work (URDF damping, friction, limit stops: the `energy balance` line): the balance
  change = input work - dissipated closes to the scheme's O(h^2) error: what does not close is at
  most 1e-2 of the balance's largest term (`open` in the table). Dissipation is >= 0 by
  construction, so a closed balance without input is an energy that does not increase.
"""

import concurrent.futures
import os
import re
import subprocess
import sys
import sysconfig
import tempfile

import pinocchio
import pybullet_data

REL_TOL = 1e-3  # |dE/E0| without work done

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


def energy(out):
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
        return f"open {frac:.1e}", frac <= REL_TOL and dissipated >= -REL_TOL * scale
    if e0 == 0.0:
        return f"dE {e1 - e0:.1e} J", abs(e1 - e0) <= 1e-9
    r = (e1 - e0) / abs(e0)
    return f"dE/E0 {r:.1e}", abs(r) <= REL_TOL


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
    for suffix in (".trajectories.parquet", ".bodies.parquet", ".joints.parquet"):
        if os.path.exists(stem + suffix):
            os.remove(stem + suffix)
    newton = next((l for l in out.splitlines() if l.startswith("Newton:")), "")
    figure, behaves = energy(out)
    if code == 0 and " 0 non-converged" in newton and behaves:
        return "runs", figure
    if code == 2:
        err = next((l for l in out.splitlines() if l.startswith("error")), out.strip()[:200])
        # The message without the paths (the file is the row's), its first 260 characters.
        reason = err.replace(path, "").replace(folder + "/", "")
        reason = reason.removeprefix("error: ").removeprefix(": ")[:260].replace("|", "/")
        return "refused", reason
    if code == 0 and " 0 non-converged" in newton:
        return "fails", f"energy: {figure}"
    last = (newton or (out.strip().splitlines()[-1] if out.strip() else ""))[:160]
    return "fails", f"({code}): {last}".replace("|", "/")


files = [(c, folder, pkg, rel) for c, folder, pkg in CORPORA for rel in urdfs(folder)]
not_pinocchio = {(c, rel): why for c, folder, _, rel in files
                 if (why := pinocchio_refusal(os.path.join(folder, rel))) is not None}
with tempfile.TemporaryDirectory() as tmp:
    work = [(c, folder, pkg, rel, base, tmp) for c, folder, pkg, rel in files for base in ("fixed", "floating")]
    with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as pool:
        results = dict(zip(((w[0], w[3], w[4]) for w in work), pool.map(run, work)))

if raw:
    with open(raw, "w") as f:
        for (c, rel, base), (kind, text) in sorted(results.items()):
            f.write(f"{c}\t{rel}\t{base}\t{kind}\t{text}\n")


def cell(kind, text):
    if kind == "runs":
        return f"runs ({text})"
    if kind == "refused":
        return f"refused: {text}"
    return f"**fails** {text}"


print("# Real robots: example-robot-data and pybullet_data, articulated, 1 s at dt = 1 ms\n")
print("Generated by `target/pyenv/bin/python scripts/robot_corpus.py > docs/robot_corpus.md` (after "
      "`bash scripts/test.sh` installed the venv; about 10 min on 2 cores): every URDF of example-robot-data and of "
      "pybullet_data simulated with `tumble simulate X.urdf --articulated --base fixed|floating --duration 1 --dt 0.001`, "
      "its meshes found through `--package-path` and `--allow-mesh-path /`. The test "
      "`corpus::every_corpus_urdf_runs_or_is_refused_with_its_reason` (tests/mechanism/corpus.rs) runs the same "
      "files for 0.1 s at each `cargo test`.\n")
print("**runs**: exit 0, no Newton failure, and the energy behaves as the variational scheme promises "
      "(docs/forces.md, \"What is conserved\"). Without anything doing work the energy error is bounded, no "
      f"drift: `dE/E0` is (E(1 s) - E(0)) / |E(0)|, at most {REL_TOL:g} (E counts gravity's potential from z = 0, "
      "the root at the origin). When damping, friction or a limit stop acted, the energy balance "
      "(`change = input work - dissipated`, dissipated >= 0) must close to the scheme's O(h^2) error: `open` is "
      f"what does not close as a fraction of the balance's largest term, at most {REL_TOL:g}. **refused**: exit 2 "
      "with tumble's message (it names the link or joint, the defect, and the key that runs it anyway). "
      "**fails**: anything else.\n")
print("Totals (file x base):\n")
print("| corpus | files | base | runs | refused | fails |\n|---|---|---|---|---|---|")
for c, _, _ in CORPORA:
    n = sum(1 for f in files if f[0] == c and (c, f[3]) not in not_pinocchio)
    for base in ("fixed", "floating"):
        k = [kind for (cc, rel, b), (kind, _) in results.items()
             if cc == c and b == base and (c, rel) not in not_pinocchio]
        print(f"| {c} | {n} | {base} | {k.count('runs')} | {k.count('refused')} | {k.count('fails')} |")
print("\nThe files Pinocchio does not load are left out of the totals (listed below, with their rows).\n")
for c, _, _ in CORPORA:
    print(f"## {c}\n")
    print("| URDF | fixed base | floating base |\n|---|---|---|")
    for cc, folder, _, rel in files:
        if cc != c:
            continue
        note = " (not loaded by Pinocchio)" if (c, rel) in not_pinocchio else ""
        print(f"| `{rel}`{note} | {cell(*results[(c, rel, 'fixed')])} | {cell(*results[(c, rel, 'floating')])} |")
    print()
print("## Not loaded by Pinocchio\n")
print("`pinocchio.buildModelFromUrdf` refuses these (urdfdom's first error); tumble still runs them (rows above), "
      "outside the totals.\n")
for (c, rel), why in sorted(not_pinocchio.items()):
    print(f"- {c} `{rel}`: not loaded by Pinocchio '{why}'")
