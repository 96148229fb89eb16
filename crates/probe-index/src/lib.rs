//! probe index (work in progress)

mod delaunay;
mod geometry;
mod error;
mod predicates;
mod rng;

pub use delaunay::{HullFace, Location, NO_NEIGHBOUR, TetRecord, Tetrahedralization};
pub use geometry::{RayHit, SceneGeometry, triangle_overlaps_box};
pub use error::{
    DelaunayError, EdgeCastError, GridError, IndexError, NeighbourError, QueryError, SvoError,
    ValidationError,
};
