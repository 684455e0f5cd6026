//! The recording formats ([`Format`]; a set of them, [`FormatSet`], is `simulate --format`), the
//! files each writes ([`OutputFile`]), and the one place their sinks are opened ([`open_file`],
//! [`open`]), used by `simulate`, the dataset's per-run recordings and `trade`.

use super::mcap::{McapOptions, McapSink};
use super::parquet::{BodiesSink, ContactsSink, JointsSink, TrajectorySink};
use super::rerun::{RerunOptions, RerunSink};
use super::ros2::Ros2Sink;
use super::{RecordingLayout, Sink};
use std::path::{Path, PathBuf};

/// A recording format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Format {
    /// `STEM.mcap`: Foxglove's protobuf schemas ([`super::mcap`]).
    Mcap,
    /// `STEM.rrd`: a Rerun recording ([`super::rerun`]).
    Rrd,
    /// `STEM.ros2.mcap`, a ROS 2 recording ([`super::ros2`]).
    Ros2,
    /// `STEM.trajectories.parquet` and `STEM.bodies.parquet`, the dataset's tables for one run,
    /// `STEM.joints.parquet`, the articulated models' joints, and for runs that can have
    /// contacts `STEM.contacts.parquet` ([`super::parquet`]).
    Parquet,
}

impl Format {
    /// Every format, in the order their files are opened and listed.
    pub const ALL: [Format; 4] = [Format::Mcap, Format::Rrd, Format::Ros2, Format::Parquet];

    /// The name `--format` takes.
    pub fn name(self) -> &'static str {
        match self {
            Format::Mcap => "mcap",
            Format::Rrd => "rrd",
            Format::Ros2 => "ros2",
            Format::Parquet => "parquet",
        }
    }

    /// The files the format writes for every run, in order ([`Self::files_of`] adds those
    /// that depend on the layout).
    pub fn files(self) -> &'static [OutputFile] {
        match self {
            Format::Mcap => &[OutputFile::Mcap],
            Format::Rrd => &[OutputFile::Rrd],
            Format::Ros2 => &[OutputFile::Ros2],
            Format::Parquet => &[
                OutputFile::Trajectories,
                OutputFile::Bodies,
                OutputFile::Joints,
            ],
        }
    }

    /// The files the format writes for a run of `layout`, in order: [`Self::files`], and for
    /// Parquet the contacts table when the run can have contacts
    /// ([`RecordingLayout::contacts`]).
    pub fn files_of(self, layout: &RecordingLayout) -> Vec<OutputFile> {
        let mut files = self.files().to_vec();
        if self == Format::Parquet && layout.contacts {
            files.push(OutputFile::Contacts);
        }
        files
    }
}

/// One file of a recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum OutputFile {
    Mcap,
    Rrd,
    Ros2,
    /// The trajectories table ([`TrajectorySink`]).
    Trajectories,
    /// The bodies table ([`BodiesSink`]).
    Bodies,
    /// The joints table ([`JointsSink`]).
    Joints,
    /// The contacts table ([`ContactsSink`]), for runs that can have contacts.
    Contacts,
}

impl OutputFile {
    /// What follows the stem in the file's name (after a `.`).
    pub fn extension(self) -> &'static str {
        match self {
            OutputFile::Mcap => "mcap",
            OutputFile::Rrd => "rrd",
            OutputFile::Ros2 => super::ros2::EXTENSION,
            OutputFile::Trajectories => super::parquet::TRAJECTORIES_EXTENSION,
            OutputFile::Bodies => super::parquet::BODIES_EXTENSION,
            OutputFile::Joints => super::parquet::JOINTS_EXTENSION,
            OutputFile::Contacts => super::parquet::CONTACTS_EXTENSION,
        }
    }

    /// The name of the thread encoding the file when its sink is pipelined
    /// ([`super::pipelined::Pipelined`]).
    pub fn thread_name(self) -> &'static str {
        match self {
            OutputFile::Mcap => "tumble-mcap",
            OutputFile::Rrd => "tumble-rrd",
            OutputFile::Ros2 => "tumble-ros2",
            OutputFile::Trajectories => "tumble-parquet",
            OutputFile::Bodies => "tumble-bodies",
            OutputFile::Joints => "tumble-joints",
            OutputFile::Contacts => "tumble-contacts",
        }
    }

    /// The file at `stem`: `stem` with `.` and [`Self::extension`] appended.
    pub fn path(self, stem: &Path) -> PathBuf {
        with_extension(stem, self.extension())
    }
}

/// `stem` with `.ext` appended (a stem may itself contain dots).
pub fn with_extension(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// A set of formats (`simulate --format mcap,rrd,parquet,ros2`), iterated in [`Format::ALL`]
/// order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FormatSet(u8);

impl Default for FormatSet {
    /// `mcap,rrd`.
    fn default() -> Self {
        Self::of(&[Format::Mcap, Format::Rrd])
    }
}

impl FormatSet {
    /// No format.
    pub const EMPTY: FormatSet = FormatSet(0);

    fn bit(format: Format) -> u8 {
        1 << format as u8
    }

    /// The set of `formats`.
    pub fn of(formats: &[Format]) -> Self {
        let mut set = Self::EMPTY;
        for &format in formats {
            set.insert(format);
        }
        set
    }

    pub fn insert(&mut self, format: Format) {
        self.0 |= Self::bit(format);
    }

    pub fn contains(self, format: Format) -> bool {
        self.0 & Self::bit(format) != 0
    }

    /// The formats of the set, in [`Format::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = Format> {
        Format::ALL.into_iter().filter(move |&f| self.contains(f))
    }

    /// Every file of the set's formats under `stem` written for every run, in order
    /// ([`Self::paths_of`] adds those that depend on the layout).
    pub fn paths(self, stem: &Path) -> Vec<PathBuf> {
        self.iter()
            .flat_map(|format| format.files())
            .map(|file| file.path(stem))
            .collect()
    }

    /// Every file of the set's formats under `stem` for a run of `layout`, in order
    /// ([`Format::files_of`]).
    pub fn paths_of(self, stem: &Path, layout: &RecordingLayout) -> Vec<PathBuf> {
        self.iter()
            .flat_map(|format| format.files_of(layout))
            .map(|file| file.path(stem))
            .collect()
    }

    /// `mcap,rrd,parquet,ros2`: a comma-separated list, at least one.
    pub fn parse(s: &str) -> Result<Self, String> {
        let mut set = Self::EMPTY;
        for name in s.split(',').map(str::trim) {
            match Format::ALL.into_iter().find(|f| f.name() == name) {
                Some(format) => set.insert(format),
                None => {
                    return Err(format!(
                        "unknown format {name:?} (expected a comma-separated list of mcap, rrd, parquet, ros2)"
                    ));
                }
            }
        }
        Ok(set)
    }
}

impl std::str::FromStr for FormatSet {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::parse(s)
    }
}

/// How the sinks write their files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SinkOptions {
    pub mcap: McapOptions,
    pub rerun: RerunOptions,
    /// Print the MCAP sink's warnings (meshes left out of `/scene`) on stderr, as `simulate`
    /// does (the Rerun sink prints its own).
    pub print_mcap_warnings: bool,
}

/// Opens the sink writing `file` at `path` (under `<path>.part` until
/// [`super::finish_all`] publishes it): the one place recording files are created.
pub fn open_file(
    file: OutputFile,
    path: &Path,
    layout: &RecordingLayout,
    options: &SinkOptions,
) -> anyhow::Result<Box<dyn Sink + Send>> {
    Ok(match file {
        OutputFile::Mcap => {
            let sink = McapSink::create_with(path, layout, &options.mcap)?;
            if options.print_mcap_warnings {
                for warning in sink.warnings() {
                    eprintln!("warning: {warning}");
                }
            }
            Box::new(sink)
        }
        OutputFile::Rrd => Box::new(RerunSink::create(path, layout, &options.rerun)?),
        OutputFile::Ros2 => Box::new(Ros2Sink::create(path, layout)?),
        OutputFile::Trajectories => Box::new(TrajectorySink::create(path, layout)?),
        OutputFile::Bodies => Box::new(BodiesSink::new(path, layout)?),
        OutputFile::Joints => Box::new(JointsSink::create(path, layout)?),
        OutputFile::Contacts => Box::new(ContactsSink::create(path, layout)?),
    })
}

/// The files of `format` for a run of `layout` under `stem` ([`Format::files_of`]), each with
/// its path and its sink opened ([`open_file`]) when the iterator reaches it: a caller that
/// stops at the first error creates no file after it.
pub fn open<'a>(
    format: Format,
    stem: &'a Path,
    layout: &'a RecordingLayout,
    options: &'a SinkOptions,
) -> impl Iterator<Item = (OutputFile, PathBuf, anyhow::Result<Box<dyn Sink + Send>>)> + 'a {
    format.files_of(layout).into_iter().map(move |file| {
        let path = file.path(stem);
        let sink = open_file(file, &path, layout, options);
        (file, path, sink)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_lists_parse_as_sets_in_file_order() {
        let set = FormatSet::parse("ros2, mcap,mcap").unwrap();
        assert_eq!(set.iter().collect::<Vec<_>>(), [Format::Mcap, Format::Ros2]);
        assert_eq!(FormatSet::parse("mcap,rrd").unwrap(), FormatSet::default());
        assert_eq!(
            FormatSet::parse("mcap,json").unwrap_err(),
            "unknown format \"json\" (expected a comma-separated list of mcap, rrd, parquet, ros2)"
        );
        let all = FormatSet::parse("parquet,ros2,rrd,mcap").unwrap();
        let names: Vec<String> = all
            .paths(Path::new("out/a.b"))
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        assert_eq!(
            names,
            [
                "out/a.b.mcap",
                "out/a.b.rrd",
                "out/a.b.ros2.mcap",
                "out/a.b.trajectories.parquet",
                "out/a.b.bodies.parquet",
                "out/a.b.joints.parquet"
            ]
        );
        // A run that can have contacts adds the contacts table, after the joints table.
        let contacts = RecordingLayout {
            contacts: true,
            ..Default::default()
        };
        let names: Vec<String> = FormatSet::parse("parquet,mcap")
            .unwrap()
            .paths_of(Path::new("s"), &contacts)
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        assert_eq!(
            names,
            [
                "s.mcap",
                "s.trajectories.parquet",
                "s.bodies.parquet",
                "s.joints.parquet",
                "s.contacts.parquet"
            ]
        );
        assert_eq!(
            FormatSet::parse("parquet")
                .unwrap()
                .paths_of(Path::new("s"), &RecordingLayout::default()),
            FormatSet::parse("parquet").unwrap().paths(Path::new("s"))
        );
    }
}
