//! `tumble survey DIR...`: loads every URDF under each folder and tabulates which files load and
//! how many links have missing, zero, invalid, light or valid inertial data ([`crate::survey`]).
//! Exit 0 when the survey ran (files that fail are part of the report), 2 when a root does not
//! exist.

use crate::survey::{self, FileReport, LinkClass, Summary};
use anyhow::bail;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct SurveyArgs {
    /// Folders (searched recursively for *.urdf) or URDF files; one table row per argument.
    #[arg(required = true)]
    pub roots: Vec<PathBuf>,
    /// Folder searched first for `package://` meshes (repeatable).
    #[arg(long = "package-path")]
    pub package_paths: Vec<PathBuf>,
    /// Print `{"summaries": [...], "files": [...]}` as JSON instead of tables.
    #[arg(long)]
    pub json: bool,
    /// List every file that failed to load, with its error.
    #[arg(long)]
    pub failures: bool,
}

pub fn run(args: &SurveyArgs) -> anyhow::Result<()> {
    let mut summaries = Vec::new();
    let mut all_files: Vec<FileReport> = Vec::new();
    for root in &args.roots {
        if !root.exists() {
            bail!("{}: no such file or folder", root.display());
        }
        let files: Vec<FileReport> = survey::urdf_files(root)
            .iter()
            .map(|p| survey::survey_file(p, &args.package_paths))
            .collect();
        summaries.push(survey::summarize(root, &files));
        all_files.extend(files);
    }
    if args.json {
        println!(
            "{}",
            serde_json::json!({"summaries": summaries, "files": all_files})
        );
        return Ok(());
    }
    print_table(&summaries);
    if args.failures {
        for f in all_files.iter().filter(|f| f.error.is_some()) {
            println!("{}", f.error.as_deref().unwrap_or_default());
        }
    }
    Ok(())
}

fn print_table(summaries: &[Summary]) {
    let classes = LinkClass::ALL.map(LinkClass::name).join(" | ");
    println!(
        "| root | files | loaded | failed | links | {classes} | of which triangle | repaired by auto | still invalid |"
    );
    println!(
        "|---|---|---|---|---|{}---|---|---|",
        "---|".repeat(LinkClass::ALL.len())
    );
    for s in summaries {
        let counts: Vec<String> = LinkClass::ALL
            .iter()
            .map(|c| s.by_class.get(c).copied().unwrap_or(0).to_string())
            .collect();
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            s.root.display(),
            s.files,
            s.loaded,
            s.failed,
            s.links,
            counts.join(" | "),
            s.triangle_violations,
            s.repaired,
            s.still_invalid
        );
    }
}
