//! `tumble survey DIR...`: loads every URDF under each folder and tabulates which files load and
//! how many links have missing, zero, invalid, light or valid inertial data ([`crate::survey`]).
//! Exit 0 when the survey ran (files that fail are part of the report), 2 when a root does not
//! exist. Each oddity a file loaded with (docs/urdf.md) is a `warning:` line on stderr and an
//! entry of that file's `warnings` in the JSON; `--strict` makes such files fail instead. Each mesh
//! refused because it is outside the folders meshes are read from ([`crate::model::confine`];
//! `--allow-mesh-path` widens them) is a `warning:` line too, and an entry of the file's
//! `refused_meshes`.

use crate::survey::{self, FileReport, LinkClass, Summary};
use anyhow::bail;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct SurveyArgs {
    /// Folders (searched recursively for *.urdf) or URDF files; one table row per argument.
    #[arg(required = true)]
    pub roots: Vec<PathBuf>,
    /// Folder searched first for `package://` meshes (repeatable).
    #[arg(long = "package-path")]
    pub package_paths: Vec<PathBuf>,
    /// Also read mesh files from DIR (repeatable). By default a mesh is read only when its real
    /// path (links resolved) is inside the URDF's folder (its parent for a folder named urdf, or
    /// the ROS package holding it), a package path or ROS_PACKAGE_PATH; any other is refused
    /// (listed on stderr and in the file's `refused_meshes`).
    #[arg(long = "allow-mesh-path", value_name = "DIR")]
    pub allow_mesh_paths: Vec<PathBuf>,
    /// Print `{"summaries": [...], "files": [...]}` as JSON instead of tables.
    #[arg(long)]
    pub json: bool,
    /// List every file that failed to load, with its error.
    #[arg(long)]
    pub failures: bool,
    /// Refuse the oddities urdfdom loads (docs/urdf.md): such files count as failed.
    #[arg(long)]
    pub strict: bool,
}

/// Runs the survey and prints it. A reader that goes away early (`tumble survey ... | head`)
/// ends the output quietly: a broken pipe is not an error here.
pub fn run(args: &SurveyArgs) -> anyhow::Result<()> {
    match print_survey(args) {
        Err(e) if is_broken_pipe(&e) => Ok(()),
        other => other,
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.downcast_ref::<std::io::Error>()
        .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}

fn print_survey(args: &SurveyArgs) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    let mut summaries = Vec::new();
    let mut all_files: Vec<FileReport> = Vec::new();
    let access = crate::model::confine::MeshAccess {
        allowed: args
            .allow_mesh_paths
            .iter()
            .map(std::path::absolute)
            .collect::<std::io::Result<_>>()?,
        scene_folder: None,
    };
    for root in &args.roots {
        if !root.exists() {
            bail!("{}: no such file or folder", root.display());
        }
        let files: Vec<FileReport> = survey::urdf_files(root)
            .iter()
            .map(|p| {
                survey::survey_file_with(
                    p,
                    &args.package_paths,
                    crate::model::urdf::Strictness::from_strict(args.strict),
                    &access,
                )
            })
            .collect();
        for warning in files
            .iter()
            .flat_map(|f| f.warnings.iter().chain(&f.refused_meshes))
        {
            eprintln!("warning: {warning}");
        }
        summaries.push(survey::summarize(root, &files));
        all_files.extend(files);
    }
    if args.json {
        writeln!(
            out,
            "{}",
            serde_json::json!({"summaries": summaries, "files": all_files})
        )?;
        return Ok(());
    }
    print_table(&mut out, &summaries)?;
    if args.failures {
        for f in all_files.iter().filter(|f| f.error.is_some()) {
            writeln!(out, "{}", f.error.as_deref().unwrap_or_default())?;
        }
    }
    Ok(())
}

fn print_table(out: &mut impl Write, summaries: &[Summary]) -> std::io::Result<()> {
    let classes = LinkClass::ALL.map(LinkClass::name).join(" | ");
    writeln!(
        out,
        "| root | files | loaded | failed | links | {classes} | of which triangle | repaired by auto | still invalid | warnings |"
    )?;
    writeln!(
        out,
        "|---|---|---|---|---|{}---|---|---|---|",
        "---|".repeat(LinkClass::ALL.len())
    )?;
    for s in summaries {
        let counts: Vec<String> = LinkClass::ALL
            .iter()
            .map(|c| s.by_class.get(c).copied().unwrap_or(0).to_string())
            .collect();
        writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            s.root.display(),
            s.files,
            s.loaded,
            s.failed,
            s.links,
            counts.join(" | "),
            s.triangle_violations,
            s.repaired,
            s.still_invalid,
            s.warnings
        )?;
    }
    Ok(())
}
