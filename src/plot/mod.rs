//! What every plot of tumble shares (`trade`, `stability`, the accuracy validation plot): the
//! font, drawing errors, and atomic writes (a plot appears under its final name only when it is
//! complete).
//!
//! Text needs a TrueType font, read at run time: `$TUMBLE_FONT` if set, else the first of the
//! usual system locations (DejaVu Sans, Liberation Sans, Arial, Helvetica).

pub mod accuracy;

use anyhow::anyhow;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The family name the font is registered under.
pub const FONT: &str = "sans-serif";

const FONT_CANDIDATES: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "/Library/Fonts/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// Registers the font once; an error says where fonts were looked for.
pub fn ensure_font() -> anyhow::Result<()> {
    static FONT_RESULT: OnceLock<Result<(), String>> = OnceLock::new();
    FONT_RESULT
        .get_or_init(|| {
            let env = std::env::var_os("TUMBLE_FONT").map(PathBuf::from);
            let candidates: Vec<PathBuf> = env
                .into_iter()
                .chain(FONT_CANDIDATES.iter().map(PathBuf::from))
                .collect();
            for path in &candidates {
                if let Ok(bytes) = std::fs::read(path) {
                    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                    if plotters::style::register_font(FONT, FontStyle::Normal, bytes).is_ok() {
                        return Ok(());
                    }
                }
            }
            Err(format!(
                "no TrueType font found for the plots (looked at {}); set TUMBLE_FONT to a .ttf file",
                candidates
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })
        .clone()
        .map_err(|e| anyhow!(e))
}

/// A drawing error as an [`anyhow::Error`].
pub fn draw_err<E: std::error::Error + Send + Sync + 'static>(
    e: DrawingAreaErrorKind<E>,
) -> anyhow::Error {
    anyhow!("drawing failed: {e}")
}

/// Draws into `<path>.part.<ext>` with `draw`, then publishes it onto `path`
/// ([`crate::fsutil`]: the part file is this run's own, created before the drawing library
/// opens it, never through a link).
pub fn atomically(
    path: &Path,
    draw: impl FnOnce(&Path) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let part = crate::fsutil::part_path(path);
    // Keep the real extension last so the backend picks the right encoder.
    let tmp = part.with_extension(format!(
        "part.{}",
        path.extension().and_then(|e| e.to_str()).unwrap_or("png")
    ));
    let result = crate::fsutil::create_part_named(path, &tmp)
        .and_then(|file| {
            drop(file);
            draw(&tmp)
        })
        .and_then(|()| crate::fsutil::publish(&[path]));
    if result.is_err() {
        crate::fsutil::discard(&[path]);
    }
    result
}
