//! The triangles a scene's recordings draw, bounded per scene.
//!
//! The MCAP `/scene` topic and the Rerun recording carry every recorded link frame's visual
//! geometry, so a mesh is written once per link that uses it and per copy of its model: 1 000
//! copies of a robot whose visuals hold 100 000 triangles are 10^8 triangles to encode, even
//! though each file is read once. [`check_recorded`] counts them before any recording is
//! created and refuses more than [`MAX_SCENE_TRIANGLES`] (the same cap as the meshes read for
//! the models' mass properties, [`crate::model::geometry::mesh_io::TriangleBudget`]).
//!
//! Each distinct file is counted once, cheaply where the format allows
//! ([`mesh_io::count_triangles`]: a binary STL from its header, ASCII STL and OBJ in one pass
//! over the text, DAE by reading it); a file that cannot be read counts 0 here (the recorder
//! leaves it out with a warning), one over the per-mesh cap is an error naming it.

use crate::budget::grouped;
use crate::model::Geometry;
use crate::model::geometry::mesh::MeshError;
use crate::model::geometry::mesh_io::{self, MAX_SCENE_TRIANGLES};
use crate::world::World;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The mesh file drawing most triangles: its path, its triangles and how many times it is
/// drawn.
pub type Heaviest = Option<(PathBuf, u64, u64)>;

/// Triangles of the visual meshes of every recorded frame of `world` (a mesh counted once per
/// frame and visual that uses it), and the mesh file contributing most. `count` gives a file's
/// triangles.
pub fn recorded_triangles(
    world: &World,
    mut count: impl FnMut(&Path) -> Result<u64, MeshError>,
) -> Result<(u64, Heaviest), MeshError> {
    let mut per_file: HashMap<&Path, (u64, u64)> = HashMap::new();
    let mut total = 0u64;
    for frame in &world.layout.frames {
        for visual in frame.visuals.iter() {
            let Geometry::Mesh {
                path: Some(path), ..
            } = &visual.geometry
            else {
                continue;
            };
            let entry = match per_file.get_mut(path.as_path()) {
                Some(entry) => entry,
                None => {
                    let n = match count(path) {
                        Ok(n) => n,
                        Err(e @ MeshError::TooManyTriangles { .. }) => return Err(e),
                        // Unreadable: the recorder leaves it out with a warning.
                        Err(_) => 0,
                    };
                    per_file.entry(path.as_path()).or_insert((n, 0))
                }
            };
            entry.1 += 1;
            total = total.saturating_add(entry.0);
        }
    }
    let worst = per_file
        .into_iter()
        .max_by_key(|(_, (n, uses))| n.saturating_mul(*uses))
        .map(|(path, (n, uses))| (path.to_path_buf(), n, uses));
    Ok((total, worst))
}

/// Refuses (naming `scene_file`, the total, the cap and the file contributing most) a world
/// whose recordings would draw more than [`MAX_SCENE_TRIANGLES`] mesh triangles; see the
/// module documentation.
pub fn check_recorded(world: &World, scene_file: &Path) -> anyhow::Result<()> {
    check_recorded_with(world, scene_file, mesh_io::count_triangles)
}

/// [`check_recorded`] with the files' counts from `count`.
pub fn check_recorded_with(
    world: &World,
    scene_file: &Path,
    count: impl FnMut(&Path) -> Result<u64, MeshError>,
) -> anyhow::Result<()> {
    let (total, worst) = recorded_triangles(world, count)
        .map_err(|e| anyhow::anyhow!("{}: a visual mesh: {e}", scene_file.display()))?;
    if total <= MAX_SCENE_TRIANGLES {
        return Ok(());
    }
    let (path, n, uses) = worst.unwrap_or_default();
    anyhow::bail!(
        "{}: the recordings would draw {} mesh triangles, over the cap of {} per scene \
         (every recorded link draws its visual meshes, in every copy of its model; the most: \
         {}, {} triangles drawn {} times). Use fewer copies or simpler visual meshes, or record \
         no geometry (--format parquet)",
        scene_file.display(),
        grouped(total),
        grouped(MAX_SCENE_TRIANGLES),
        path.display(),
        grouped(n),
        grouped(uses)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Visual;
    use crate::record::FrameLayout;
    use nalgebra::{Isometry3, Vector3};
    use std::sync::Arc;

    fn mesh(path: &str) -> Visual {
        Visual {
            name: None,
            link_from_visual: Isometry3::identity(),
            geometry: Geometry::Mesh {
                uri: path.into(),
                path: Some(PathBuf::from(path)),
                scale: Vector3::repeat(1.0),
            },
            rgba: None,
        }
    }

    /// `copies` frames each drawing `a.stl` twice and `b.stl` once (plus a box and an
    /// unresolved mesh, which draw no file's triangles).
    fn world(copies: usize) -> World {
        let visuals: Arc<[Visual]> = Arc::from(vec![
            mesh("a.stl"),
            mesh("a.stl"),
            mesh("b.stl"),
            Visual {
                geometry: Geometry::Box {
                    size: Vector3::repeat(1.0),
                },
                ..mesh("box")
            },
            Visual {
                geometry: Geometry::Mesh {
                    uri: "package://gone/x.stl".into(),
                    path: None,
                    scale: Vector3::repeat(1.0),
                },
                ..mesh("gone")
            },
        ]);
        let mut world = World::default();
        for i in 0..copies {
            world.layout.frames.push(FrameLayout {
                frame_id: format!("m_{i}/l"),
                model: format!("m_{i}"),
                link: "l".into(),
                visuals: visuals.clone(),
            });
        }
        world
    }

    /// a.stl: 1 000 000 triangles, b.stl: 1 triangle, c.stl unreadable.
    fn count(path: &Path) -> Result<u64, MeshError> {
        match path.to_str() {
            Some("a.stl") => Ok(1_000_000),
            Some("b.stl") => Ok(1),
            _ => Err(MeshError::Empty),
        }
    }

    /// Every use counts, in every copy; each file is counted once.
    #[test]
    fn every_use_in_every_copy_counts_and_each_file_is_read_once() {
        let mut calls = 0;
        let (total, worst) = recorded_triangles(&world(3), |p| {
            calls += 1;
            count(p)
        })
        .unwrap();
        assert_eq!(calls, 2);
        // 3 copies x (2 x 1e6 + 1).
        assert_eq!(total, 6_000_003);
        assert_eq!(worst, Some((PathBuf::from("a.stl"), 1_000_000, 6)));
    }

    /// 4 copies draw 8 000 004 triangles and pass, 6 draw 12 000 006 and do not. The cap is
    /// inclusive: with b.stl empty, 5 copies draw exactly 10 000 000 and pass; with b.stl's
    /// one triangle, 10 000 005 do not.
    #[test]
    fn the_cap_per_scene() {
        let scene = Path::new("s.toml");
        assert!(check_recorded_with(&world(4), scene, count).is_ok());
        let e = check_recorded_with(&world(6), scene, count)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("s.toml: the recordings would draw 12,000,006 mesh triangles, over the cap of 10,000,000 per scene"), "{e}");
        assert!(
            e.contains("a.stl, 1,000,000 triangles drawn 12 times"),
            "{e}"
        );
        // Exactly at the cap: 10 x 1e6 from a.stl alone.
        let at_cap = |p: &Path| match p.to_str() {
            Some("a.stl") => Ok(1_000_000),
            _ => Ok(0),
        };
        assert!(check_recorded_with(&world(5), scene, at_cap).is_ok());
        let over = |p: &Path| match p.to_str() {
            Some("a.stl") => Ok(1_000_000),
            _ => Ok(1),
        };
        assert!(check_recorded_with(&world(5), scene, over).is_err());
    }

    /// A mesh over the per-mesh cap is an error naming it; an unreadable one counts 0.
    #[test]
    fn a_mesh_over_its_own_cap_is_named() {
        let too_many = |_: &Path| {
            Err(MeshError::TooManyTriangles {
                path: PathBuf::from("big.stl"),
                format: "STL",
                count: "10,000,000 triangles (binary STL header)".into(),
            })
        };
        let e = check_recorded_with(&world(1), Path::new("s.toml"), too_many)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml: a visual mesh: big.stl: STL mesh with 10,000,000"),
            "{e}"
        );
        let unreadable = |_: &Path| Err(MeshError::Empty);
        assert!(check_recorded_with(&world(1000), Path::new("s.toml"), unreadable).is_ok());
    }
}
