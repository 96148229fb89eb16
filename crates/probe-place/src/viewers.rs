//! What viewers see: the surface points a set of cameras sees directly and in mirror
//! reflection ([`view_samples`]). As the texels of an atlas
//! ([`Atlas::from_samples`](crate::atlas::Atlas::from_samples)) they make surfaces weigh by
//! how much the view set sees them, and coverage of them is the cheap proxy of the view
//! set's glossy error that the error-driven sets minimise ([`pipeline::place`](crate::pipeline::place)
//! with [`PlaceOptions::viewers`](crate::pipeline::PlaceOptions::viewers)): a reflection ray
//! whose true hit no probe sees at a non-grazing angle is one a light-field probe cannot
//! answer.
//!
//! ```
//! use probe_place::viewers::view_samples;
//! use probe_scene::Scene;
//!
//! let scene = Scene::builtin("cornell")?;
//! let samples = view_samples(&scene, &[scene.default_camera()], 400);
//! // Each pixel gives its visible point and, when the mirror ray hits, the reflected one.
//! assert!(samples.len() > 400 && samples.len() <= 800);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::atlas::{
    Atlas, AtlasParams, BackfaceVote, FreeSpace, SurfaceSample, VoxelFreeSpace, free_space_grid,
};
use crate::par::*;
use crate::pipeline::{PlaceError, free_space_voxels};
use crate::region::{Region, RegionError, RegionFreeSpace};
use glam::{Vec2, Vec3};
use probe_scene::{Camera, Hit, Ray, Scene};

/// The points `cameras` see: for each camera, a grid of about `pixels_per_view` primary rays
/// (the camera's aspect, pixel centres) gives each visible point, and the mirror reflection
/// of each (about the geometric normal facing the viewer) gives the point seen in it when
/// the reflected ray hits. Each sample's normal is the geometric normal of the side the ray
/// arrived from. Cameras first to last, rows top to bottom; deterministic.
pub fn view_samples(
    scene: &Scene,
    cameras: &[Camera],
    pixels_per_view: usize,
) -> Vec<SurfaceSample> {
    view_samples_per_view(scene, cameras, pixels_per_view)
        .into_iter()
        .flatten()
        .collect()
}

/// [`view_samples`] with each camera's samples apart, in camera order (for
/// [`Atlas::from_view_samples`], whose texels remember their view).
pub fn view_samples_per_view(
    scene: &Scene,
    cameras: &[Camera],
    pixels_per_view: usize,
) -> Vec<Vec<SurfaceSample>> {
    let mut out = Vec::new();
    for camera in cameras {
        let aspect = camera.aspect.unwrap_or(1.0).max(1e-3);
        let height = ((pixels_per_view.max(1) as f32 / aspect).sqrt().round() as u32).max(1);
        let width = ((height as f32 * aspect).round() as u32).max(1);
        let rows: Vec<Vec<SurfaceSample>> = (0..height)
            .into_par_iter()
            .map(|y| {
                let mut row = Vec::new();
                for x in 0..width {
                    let ray = camera.ray(x, y, width, height, Vec2::ZERO);
                    let Some(hit) = scene.closest_hit(&ray, f32::INFINITY) else {
                        continue;
                    };
                    let normal = facing(&hit, ray.direction);
                    row.push(SurfaceSample {
                        position: hit.position,
                        normal,
                        triangle: hit.triangle,
                    });
                    let d = ray.direction.normalize();
                    let reflected = d - 2.0 * d.dot(normal) * normal;
                    let bounce = Ray::from_surface(hit.position, normal, reflected);
                    if let Some(seen) = scene.closest_hit(&bounce, f32::INFINITY) {
                        row.push(SurfaceSample {
                            position: seen.position,
                            normal: facing(&seen, bounce.direction),
                            triangle: seen.triangle,
                        });
                    }
                }
                row
            })
            .collect();
        out.push(rows.into_iter().flatten().collect());
    }
    out
}

/// The geometric normal of the side a ray of `direction` arrived from.
fn facing(hit: &Hit, direction: Vec3) -> Vec3 {
    if hit.geometric_normal.dot(direction) > 0.0 {
        -hit.geometric_normal
    } else {
        hit.geometric_normal
    }
}

/// The cheap proxy of a view set's glossy error, without a bake: the share of the points the
/// views see, directly and in reflection ([`view_samples`]), that no probe sees at a
/// non-grazing angle (the atlas's view-cosine rule). Points no free reference point (of the
/// region) sees are left out, as an atlas leaves them out.
pub struct ViewProxy<'a> {
    atlas: Atlas<'a>,
}

impl<'a> ViewProxy<'a> {
    /// The proxy of `cameras` (about `samples` points in all) in `scene`, reference points on
    /// a grid of 1/25 of the longest side of the region (of the scene without one) that the
    /// free-space test of placement (the ray vote and the voxels) finds free, so that it counts
    /// what an error-driven placement's atlas counts.
    ///
    /// # Errors
    /// [`PlaceError::Region`] for a bad region or one without free space,
    /// [`PlaceError::Atlas`] when the views see nothing reachable.
    pub fn new(
        scene: &'a Scene,
        region: Option<&Region>,
        cameras: &[Camera],
        samples: usize,
    ) -> Result<ViewProxy<'a>, PlaceError> {
        let region = match region {
            Some(r) => Some(r.within(scene.bounds())?),
            None => None,
        };
        let voxels = free_space_voxels(scene)?;
        let scene_free = (
            BackfaceVote::new(scene),
            VoxelFreeSpace::new(&voxels, scene.bounds()),
        );
        let region_free = RegionFreeSpace::new(&scene_free, region.as_ref());
        let free: &dyn FreeSpace = &region_free;
        let spacing = free.bounds().size().max_element() / 25.0;
        let pool = free_space_grid(free, spacing);
        if pool.is_empty() {
            return Err(RegionError::NoFreeSpace { points: 0, spacing }.into());
        }
        let per_view = (samples / (2 * cameras.len().max(1))).max(16);
        let atlas = Atlas::from_samples(
            scene,
            &AtlasParams::for_texel_count(scene, samples),
            view_samples(scene, cameras, per_view),
            &pool,
        )?;
        Ok(ViewProxy { atlas })
    }

    /// The proxy for `probes`: the share of the views' points they leave unseen, in `[0, 1]`.
    pub fn error(&self, probes: &[Vec3]) -> f64 {
        1.0 - self.atlas.coverage(probes)
    }

    /// The points the proxy counts.
    pub fn points(&self) -> usize {
        self.atlas.samples().len()
    }
}
