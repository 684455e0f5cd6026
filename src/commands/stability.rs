//! `tumble stability [--out DIR] [--integrators a,b] [--quick]`: the stability map of
//! [`crate::stability`]; writes `DIR/stability.csv` and `DIR/stability.png` and prints, per
//! integrator, the limit of `h|Ω|` derived from the map beside the documented one
//! ([`crate::sim::limits::h_omega_limit`]).

use crate::commands::parse_integrators;
use crate::fsutil::write_atomic;
use crate::stability::{self, Grid};
use anyhow::Context;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug, Clone)]
pub struct StabilityArgs {
    /// Output folder.
    #[arg(long, default_value = "logs/stability")]
    pub out: PathBuf,
    /// Integrators to map, comma-separated (default: all).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub integrators: Vec<String>,
    /// A coarser grid (8 step sizes, 5 shapes) for a quick look; its derived limits are
    /// indicative only (the documented ones come from the full map).
    #[arg(long)]
    pub quick: bool,
    /// Replace stability.csv and stability.png if they exist.
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: &StabilityArgs) -> anyhow::Result<()> {
    let kinds = parse_integrators(&args.integrators)?;
    let csv = args.out.join("stability.csv");
    let png = args.out.join("stability.png");
    crate::fsutil::check_not_overwriting(&csv, args.force)?;
    crate::fsutil::check_not_overwriting(&png, args.force)?;
    let grid = if args.quick {
        Grid::quick()
    } else {
        Grid::full()
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let cells = grid.cells().len();
    println!(
        "stability map{}: {} integrators x {} cells ({} h|Ω| x {} shapes x {} spin axes), |Ω|max = 1 rad/s",
        if args.quick { " (quick grid)" } else { "" },
        kinds.len(),
        cells,
        grid.h_omegas.len(),
        grid.shapes.len(),
        grid.spin_axes.len()
    );
    let started = Instant::now();
    let rows = stability::sweep(&grid, &kinds, stability::default_threads());
    println!(
        "ran {} cells in {:.1} s",
        rows.len(),
        started.elapsed().as_secs_f64()
    );
    print!("{}", stability::output::summary(&rows, &kinds));
    if args.quick {
        println!(
            "(quick grid: fewer step sizes and shapes, so its derived limits are indicative only; \
             the documented ones come from the full map)"
        );
    }
    write_atomic(&csv, stability::output::csv(&rows).as_bytes())?;
    stability::plot::heat_map(&png, &grid, &rows, &kinds)?;
    println!("wrote");
    println!("  {}", csv.display());
    println!("  {}", png.display());
    Ok(())
}
