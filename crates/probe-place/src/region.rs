//! Regions of interest: where viewers go. A [`Region`] is a union of axis-aligned boxes;
//! [`pipeline::place`](crate::pipeline::place) puts probes only inside it, and coverage counts
//! only the surfaces a point inside it can see (the atlas's reference points are the free
//! points of the region, so texels no viewer inside could see are not asked for).
//!
//! Unity's probe volumes, DDGI volumes and Godot's LightmapGI bounds play the same part.
//!
//! ```
//! use probe_place::region::Region;
//!
//! let region = Region::parse_boxes(["0,0,0:1,1,1", "1,0,0:3,1,1"])?;
//! assert!(region.contains(glam::Vec3::new(2.0, 0.5, 0.5)));
//! assert!(!region.contains(glam::Vec3::new(2.0, 1.5, 0.5)));
//! assert_eq!(region.bounds().max.x, 3.0);
//! # Ok::<(), probe_place::region::RegionError>(())
//! ```

use crate::atlas::FreeSpace;
use glam::Vec3;
use probe_scene::Aabb;
use serde_json::{Value, json};

/// Why a region was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RegionError {
    /// A box could not be read. Fix: write it as `x0,y0,z0:x1,y1,z1` (two corners in metres,
    /// six finite numbers).
    #[error("region box {text:?}: {reason} (expected x0,y0,z0:x1,y1,z1, two corners in metres)")]
    Parse {
        /// The text given.
        text: String,
        /// What is wrong with it.
        reason: String,
    },
    /// No box was given. Fix: give at least one box, or no region at all for the whole scene.
    #[error(
        "the region has no box: give at least one x0,y0,z0:x1,y1,z1, or none for the whole scene"
    )]
    Empty,
    /// A box's first corner is not below its second on every axis (an inverted or flat box).
    /// Fix: give the smaller coordinates first, and a positive extent on every axis.
    #[error(
        "region box {index} ({min:?} to {max:?}) is inverted or flat on the {axis} axis: give the smaller corner first and a positive extent"
    )]
    Inverted {
        /// The box's index in the region (0-based).
        index: usize,
        /// Its first corner.
        min: [f32; 3],
        /// Its second corner.
        max: [f32; 3],
        /// The first axis on which it fails.
        axis: char,
    },
    /// A box has a coordinate that is not finite. Fix: give finite numbers.
    #[error("region box {index} has a coordinate that is not finite")]
    NotFinite {
        /// The box's index.
        index: usize,
    },
    /// A box lies entirely outside the scene. Fix: check the scene's bounds (`probes
    /// scene-info` prints them) and the axis order (x, y, z; y is up in glTF).
    #[error(
        "region box {index} ({min:?} to {max:?}) lies outside the scene's bounds ({scene_min:?} to {scene_max:?}): check the coordinates against `probes scene-info`"
    )]
    OutsideScene {
        /// The box's index.
        index: usize,
        /// Its first corner.
        min: [f32; 3],
        /// Its second corner.
        max: [f32; 3],
        /// The scene's first corner.
        scene_min: [f32; 3],
        /// The scene's second corner.
        scene_max: [f32; 3],
    },
    /// No free point was found inside the region: it lies inside solid geometry or is too
    /// thin for the free-space test's sampling. Fix: move or enlarge the region into the
    /// space where viewers stand.
    #[error(
        "no free space inside the region ({points} points tested at {spacing} m): move or enlarge it into the space where viewers stand"
    )]
    NoFreeSpace {
        /// Points tested.
        points: usize,
        /// Their spacing in metres.
        spacing: f32,
    },
}

/// A union of axis-aligned boxes (metres, world space) where viewers go.
#[derive(Clone, Debug, PartialEq)]
pub struct Region {
    boxes: Vec<Aabb>,
}

impl Region {
    /// A region of `boxes`.
    ///
    /// # Errors
    /// [`RegionError::Empty`] for no box, [`RegionError::NotFinite`] and
    /// [`RegionError::Inverted`] for a bad box.
    pub fn new(boxes: Vec<Aabb>) -> Result<Region, RegionError> {
        if boxes.is_empty() {
            return Err(RegionError::Empty);
        }
        for (index, b) in boxes.iter().enumerate() {
            if !(b.min.is_finite() && b.max.is_finite()) {
                return Err(RegionError::NotFinite { index });
            }
            if let Some(axis) = (0..3).find(|&a| b.min[a] >= b.max[a]) {
                return Err(RegionError::Inverted {
                    index,
                    min: b.min.to_array(),
                    max: b.max.to_array(),
                    axis: ['x', 'y', 'z'][axis],
                });
            }
        }
        Ok(Region { boxes })
    }

    /// Reads one box, `x0,y0,z0:x1,y1,z1` (the command line's `--region`). Whitespace around
    /// the numbers is allowed.
    ///
    /// # Errors
    /// [`RegionError::Parse`] naming the text.
    pub fn parse_box(text: &str) -> Result<Aabb, RegionError> {
        let fail = |reason: &str| RegionError::Parse {
            text: text.to_owned(),
            reason: reason.to_owned(),
        };
        let corners: Vec<&str> = text.split(':').collect();
        let [a, b] = corners.as_slice() else {
            return Err(fail("expected two corners separated by ':'"));
        };
        let corner = |part: &str| -> Result<Vec3, RegionError> {
            let numbers: Vec<f32> = part
                .split(',')
                .map(|n| n.trim().parse::<f32>())
                .collect::<Result<_, _>>()
                .map_err(|e| fail(&format!("{part:?} is not three numbers ({e})")))?;
            match numbers.as_slice() {
                [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => {
                    Ok(Vec3::new(*x, *y, *z))
                }
                [_, _, _] => Err(fail("a coordinate is not finite")),
                _ => Err(fail(&format!(
                    "{part:?} has {} numbers, not 3",
                    numbers.len()
                ))),
            }
        };
        Ok(Aabb::new(corner(a)?, corner(b)?))
    }

    /// A region of the boxes in `texts`, each as [`Region::parse_box`] reads it.
    ///
    /// # Errors
    /// As [`Region::parse_box`] and [`Region::new`].
    pub fn parse_boxes<S: AsRef<str>>(
        texts: impl IntoIterator<Item = S>,
    ) -> Result<Region, RegionError> {
        let boxes = texts
            .into_iter()
            .map(|t| Region::parse_box(t.as_ref()))
            .collect::<Result<Vec<_>, _>>()?;
        Region::new(boxes)
    }

    /// The boxes.
    pub fn boxes(&self) -> &[Aabb] {
        &self.boxes
    }

    /// Whether `point` lies in some box (boundaries included).
    pub fn contains(&self, point: Vec3) -> bool {
        self.boxes.iter().any(|b| b.contains(point))
    }

    /// The smallest box containing every box of the region.
    pub fn bounds(&self) -> Aabb {
        self.boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b))
    }

    /// The region cut to `scene` bounds: each box intersected with them.
    ///
    /// # Errors
    /// [`RegionError::OutsideScene`] for a box that does not overlap the bounds.
    pub fn within(&self, scene: Aabb) -> Result<Region, RegionError> {
        let boxes = self
            .boxes
            .iter()
            .enumerate()
            .map(|(index, b)| {
                let cut = Aabb::new(b.min.max(scene.min), b.max.min(scene.max));
                if (0..3).any(|a| cut.min[a] >= cut.max[a]) {
                    Err(RegionError::OutsideScene {
                        index,
                        min: b.min.to_array(),
                        max: b.max.to_array(),
                        scene_min: scene.min.to_array(),
                        scene_max: scene.max.to_array(),
                    })
                } else {
                    Ok(cut)
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Region { boxes })
    }

    /// The boxes as `probes/1` records them: `[[x0,y0,z0],[x1,y1,z1]]` per box.
    pub fn to_json(&self) -> Value {
        Value::Array(
            self.boxes
                .iter()
                .map(|b| {
                    json!([
                        b.min.to_array().map(crate::probes::json_f32),
                        b.max.to_array().map(crate::probes::json_f32)
                    ])
                })
                .collect(),
        )
    }

    /// The boxes as the command line writes them (`x0,y0,z0:x1,y1,z1`, one per box).
    pub fn to_args(&self) -> Vec<String> {
        self.boxes
            .iter()
            .map(|b| {
                format!(
                    "{},{},{}:{},{},{}",
                    b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
                )
            })
            .collect()
    }
}

/// A free-space test restricted to a region: a point is free when it lies in the region and
/// `inner` finds it free. Its bounds are the region's (cut to `inner`'s), so grids of
/// reference points and optimiser moves stay inside. Without a region it is `inner` itself.
pub struct RegionFreeSpace<'f> {
    inner: &'f dyn FreeSpace,
    region: Option<&'f Region>,
    bounds: Aabb,
}

impl<'f> RegionFreeSpace<'f> {
    /// `inner` restricted to `region` (unrestricted for `None`).
    pub fn new(inner: &'f dyn FreeSpace, region: Option<&'f Region>) -> RegionFreeSpace<'f> {
        let outer = inner.bounds();
        let bounds = region.map_or(outer, |region| {
            let r = region.bounds();
            Aabb::new(r.min.max(outer.min), r.max.min(outer.max))
        });
        RegionFreeSpace {
            inner,
            region,
            bounds,
        }
    }

    /// The region, if there is one.
    pub fn region(&self) -> Option<&Region> {
        self.region
    }
}

impl FreeSpace for RegionFreeSpace<'_> {
    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn inside_geometry(&self, point: Vec3) -> bool {
        self.inner.inside_geometry(point)
    }

    fn is_free(&self, point: Vec3) -> bool {
        self.region.is_none_or(|r| r.contains(point)) && self.inner.is_free(point)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_refuses() {
        let b = Region::parse_box(" -1, 0,2 : 3,4.5,5").unwrap();
        assert_eq!(b.min, Vec3::new(-1.0, 0.0, 2.0));
        assert_eq!(b.max, Vec3::new(3.0, 4.5, 5.0));
        for bad in [
            "1,2,3",
            "1,2:3,4,5",
            "a,b,c:1,2,3",
            "1,2,3:4,5,6:7,8,9",
            "1,2,inf:3,4,5",
        ] {
            assert!(
                matches!(Region::parse_box(bad), Err(RegionError::Parse { .. })),
                "{bad}"
            );
        }
        assert_eq!(Region::new(Vec::new()), Err(RegionError::Empty));
        let inverted = Region::parse_boxes(["0,0,0:1,1,1", "0,2,0:1,1,1"]);
        assert!(matches!(
            inverted,
            Err(RegionError::Inverted {
                index: 1,
                axis: 'y',
                ..
            })
        ));
        let flat = Region::parse_boxes(["0,0,0:1,0,1"]);
        assert!(matches!(flat, Err(RegionError::Inverted { axis: 'y', .. })));
    }

    #[test]
    fn cut_to_the_scene() {
        let region = Region::parse_boxes(["-5,0,0:1,1,1"]).unwrap();
        let scene = Aabb::new(Vec3::ZERO, Vec3::splat(2.0));
        let cut = region.within(scene).unwrap();
        assert_eq!(cut.boxes()[0].min, Vec3::ZERO);
        assert_eq!(cut.boxes()[0].max, Vec3::ONE);
        let outside = Region::parse_boxes(["0,0,0:1,1,1", "5,5,5:6,6,6"]).unwrap();
        assert!(matches!(
            outside.within(scene),
            Err(RegionError::OutsideScene { index: 1, .. })
        ));
        // Touching the bounds only is outside too.
        let touching = Region::parse_boxes(["2,0,0:3,1,1"]).unwrap();
        assert!(touching.within(scene).is_err());
    }

    #[test]
    fn union_membership() {
        let region = Region::parse_boxes(["0,0,0:1,1,1", "2,0,0:3,1,1"]).unwrap();
        assert!(region.contains(Vec3::new(0.5, 0.5, 0.5)));
        assert!(region.contains(Vec3::new(2.5, 0.5, 0.5)));
        assert!(!region.contains(Vec3::new(1.5, 0.5, 0.5)));
        assert_eq!(region.to_args()[1], "2,0,0:3,1,1");
        assert_eq!(Region::parse_boxes(region.to_args()).unwrap(), region);
    }
}
