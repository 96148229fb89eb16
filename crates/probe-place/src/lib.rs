//! `probe_place`: automatic placement of radiance probes in a 3-D scene.
//!
//! Engines place light-field probes by hand or in wasteful regular grids. This crate makes
//! probe positions from the scene's geometry ([`probe_scene::Scene`]) and returns them as a
//! [`ProbeSet`], saved as `probes/1` JSON.
//!
//! # Candidates
//!
//! - [`RegularGrid`]: the baseline, probes at the cell centres of a division of the scene's
//!   bounds (`grid:4x2x4` in [`ProbeSet::from_spec`]); [`classify_grid`] is the fair
//!   baseline, DDGI-style classification (probes inside geometry switched off) and relocation
//!   (probes moved at most 45 % of a cell towards free space).
//! - [`inside_geometry`]: the "is this probe inside geometry" test placement reports use.
//!
//! ```
//! use probe_place::{ClassifyParams, ProbeSet, RegularGrid, classify_grid, inside_geometry};
//! use probe_scene::Scene;
//!
//! // `boxes` hides a closed box at every cell centre of a 4×2×4 grid (seed 003, Fig. 8.2).
//! let scene = Scene::open("builtin:boxes")?;
//! let grid = ProbeSet::from_spec("grid:4x2x4", &scene)?;
//! assert_eq!(grid.len(), 32);
//! assert!(grid.positions.iter().all(|&p| inside_geometry(&scene, p)));
//!
//! // DDGI relocation moves every probe out of its box, within 45 % of its cell.
//! let relocated = classify_grid(
//!     &scene,
//!     &RegularGrid::over_scene(&scene, [4, 2, 4])?,
//!     &ClassifyParams::default(),
//! )?;
//! assert_eq!(relocated.positions.len(), 32);
//! assert!(relocated.positions.iter().all(|&p| !inside_geometry(&scene, p)));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod candidate_error;
mod grid;
mod probes;

pub use candidate_error::{CandidateError, Expected};
pub use grid::{
    ClassifiedGrid, ClassifyParams, INSIDE_BACKFACE_SHARE, INSIDE_TEST_RAYS, MAX_GRID_DIM,
    MAX_GRID_PROBES, MAX_RELOCATION_FRACTION, RegularGrid, classify_grid, inside_geometry,
};
pub use probes::{PROBE_SET_FORMAT, ProbeSet, ProbeSetError};
