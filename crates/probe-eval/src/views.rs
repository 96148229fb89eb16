//! View sets: the viewpoints a probe set is judged from. A level is seen from everywhere a
//! viewer goes, not from one camera, so the evaluation samples `N` viewpoints in the free
//! space of the region of interest (or of the scene) and adds the scene's own cameras
//! ([`view_set`]); every accuracy figure is then a mean over the set, with its worst view
//! ([`crate::sweep`]).
//!
//! ```
//! use probe_eval::views::{ViewSetOptions, view_set};
//! use probe_scene::Scene;
//!
//! let scene = Scene::builtin("cornell")?;
//! let views = view_set(&scene, &ViewSetOptions { sampled: 3, seed: 1, ..ViewSetOptions::default() })?;
//! assert_eq!(views.len(), 4); // the scene's camera, then three sampled viewpoints
//! assert_eq!(views[1].name, "view-1-0");
//! // The scene's camera stands in front of the open box; the sampled ones inside it.
//! assert!(views[1..].iter().all(|v| scene.bounds().contains(v.position)));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use glam::Vec3;
use probe_place::atlas::{BackfaceVote, FreeSpace};
use probe_place::region::{Region, RegionFreeSpace};
use probe_scene::{Camera, Ray, Scene};

/// The most sampled viewpoints a set may ask for.
pub const MAX_SAMPLED_VIEWS: usize = 4096;

/// Why a view set could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ViewSetError {
    /// More sampled views than [`MAX_SAMPLED_VIEWS`]. Fix: ask for fewer.
    #[error("{asked} sampled views asked for, more than the limit of {limit}")]
    TooMany {
        /// Views asked for.
        asked: usize,
        /// [`MAX_SAMPLED_VIEWS`].
        limit: usize,
    },
    /// No free viewpoint was found after many tries. Fix: check the region lies in the space
    /// viewers stand in (`probes place --region ... --top-view` shows it).
    #[error(
        "no free viewpoint found in {tries} tries inside {where_}: give a region that lies in the space viewers stand in"
    )]
    NoFreeSpace {
        /// Points tried.
        tries: usize,
        /// "the region" or "the scene".
        where_: &'static str,
    },
    /// The region was refused. Fix: as the error says.
    #[error("region: {0}")]
    Region(#[from] probe_place::region::RegionError),
    /// A scene camera named in the set does not exist. Fix: use one `probes scene-info`
    /// lists, or `default`.
    #[error("the scene has no camera {name:?} (probes scene-info lists them)")]
    NoCamera {
        /// The name given.
        name: String,
    },
}

/// What a view set holds.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewSetOptions {
    /// The scene's cameras to include, by name (`default` for the scene's default camera);
    /// they come first, in this order.
    pub cameras: Vec<String>,
    /// Viewpoints to sample in free space.
    pub sampled: usize,
    /// Seed of the sampled viewpoints (another seed gives a held-out set).
    pub seed: u64,
    /// Where viewers go (`None`: the scene's free space).
    pub region: Option<Region>,
}

impl Default for ViewSetOptions {
    fn default() -> Self {
        ViewSetOptions {
            cameras: vec!["default".to_owned()],
            sampled: 0,
            seed: 0,
            region: None,
        }
    }
}

/// The names of the scene's own cameras (those of its file), or `default` when it has none.
pub fn scene_cameras(scene: &Scene) -> Vec<String> {
    let names: Vec<String> = scene.cameras().iter().map(|c| c.name.clone()).collect();
    if names.is_empty() {
        vec!["default".to_owned()]
    } else {
        names
    }
}

/// Draws in `[0, 1)` from a counter-based hash (SplitMix64): the same seed and index give the
/// same number on every machine.
fn unit(seed: u64, index: u64) -> f32 {
    let mut z = seed
        .wrapping_add(0x9e37_79b9_7f4a_7c15u64.wrapping_mul(index.wrapping_add(1)))
        .wrapping_add(0x632b_e59b_d9b4_e019);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 24) as f32
}

/// The scene cameras named in `options`, then `options.sampled` viewpoints drawn in the free
/// space of the region (or of the scene), named `view-SEED-K`.
///
/// Each sampled viewpoint is a uniform point of the region's boxes (of the scene's bounds
/// without a region) that the free-space test of probe-place finds free (a ray vote and a
/// clearance; without a region, points from which more than half of all directions escape
/// the scene are outdoors and skipped). Its direction is the best of 8 seeded candidates
/// (yaw uniform, pitch in −17°…+11°): the one whose 4×4 test rays see the most geometry,
/// each hit counting its distance up to half the scene's diagonal, so that a view does not
/// stare into a wall or the sky. Field of view and aspect are the scene's default camera's.
///
/// # Errors
/// [`ViewSetError`] for too many views, a bad region, a missing camera or no free point.
pub fn view_set(scene: &Scene, options: &ViewSetOptions) -> Result<Vec<Camera>, ViewSetError> {
    if options.sampled > MAX_SAMPLED_VIEWS {
        return Err(ViewSetError::TooMany {
            asked: options.sampled,
            limit: MAX_SAMPLED_VIEWS,
        });
    }
    let mut views = Vec::new();
    for name in &options.cameras {
        let camera = if name == "default" {
            scene.default_camera()
        } else {
            scene
                .camera(name)
                .cloned()
                .ok_or_else(|| ViewSetError::NoCamera { name: name.clone() })?
        };
        views.push(camera);
    }
    if options.sampled == 0 {
        return Ok(views);
    }
    let template = scene.default_camera();
    let region = match &options.region {
        Some(region) => Some(region.within(scene.bounds())?),
        None => None,
    };
    let vote = BackfaceVote::new(scene);
    let mut outdoors_limited = vote.clone();
    outdoors_limited.max_escaping_fraction = Some(0.5);
    let inner: &dyn FreeSpace = if region.is_some() {
        &vote
    } else {
        &outdoors_limited
    };
    let free = RegionFreeSpace::new(inner, region.as_ref());
    let boxes = region
        .as_ref()
        .map_or_else(|| vec![scene.bounds()], |r| r.boxes().to_vec());
    let volumes: Vec<f32> = boxes.iter().map(|b| b.size().element_product()).collect();
    let total: f32 = volumes.iter().sum();
    let diagonal = scene.bounds().size().length();
    let seed = options.seed;
    let max_tries = 2000 * options.sampled;
    let mut draw = 0u64;
    let mut next = || {
        draw += 1;
        unit(seed, draw)
    };
    let mut tries = 0;
    let mut k = 0;
    while k < options.sampled {
        if tries >= max_tries {
            return Err(ViewSetError::NoFreeSpace {
                tries,
                where_: if region.is_some() {
                    "the region"
                } else {
                    "the scene"
                },
            });
        }
        tries += 1;
        // A box by volume, then a uniform point in it.
        let mut pick = next() * total;
        let mut b = boxes[boxes.len() - 1];
        for (candidate, volume) in boxes.iter().zip(&volumes) {
            if pick < *volume {
                b = *candidate;
                break;
            }
            pick -= volume;
        }
        let position = b.min + Vec3::new(next(), next(), next()) * b.size();
        if !free.is_free(position) {
            continue;
        }
        let mut best: Option<(f32, Camera)> = None;
        for _ in 0..8 {
            let yaw = next() * std::f32::consts::TAU;
            let pitch = -0.3 + 0.5 * next();
            let forward = Vec3::new(
                yaw.cos() * pitch.cos(),
                pitch.sin(),
                yaw.sin() * pitch.cos(),
            );
            let camera = Camera {
                name: format!("view-{seed}-{k}"),
                aspect: template.aspect,
                ..Camera::look_at(position, position + forward, Vec3::Y, template.yfov)
            };
            let score = geometry_seen(scene, &camera, diagonal * 0.5);
            if best.as_ref().is_none_or(|(s, _)| score > *s) {
                best = Some((score, camera));
            }
        }
        if let Some((score, camera)) = best
            && score > 0.0
        {
            views.push(camera);
            k += 1;
        }
    }
    Ok(views)
}

/// The mean over 4×4 camera rays of the hit distance, each clamped to `cap` (misses 0).
fn geometry_seen(scene: &Scene, camera: &Camera, cap: f32) -> f32 {
    let (width, height) = (4u32, 4u32);
    let mut sum = 0.0;
    for y in 0..height {
        for x in 0..width {
            let ray: Ray = camera.ray(x, y, width, height, glam::Vec2::ZERO);
            if let Some(hit) = scene.closest_hit(&ray, f32::INFINITY) {
                sum += hit.t.min(cap);
            }
        }
    }
    sum / (width * height) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeded_sets_are_repeatable_and_differ_by_seed() {
        let scene = Scene::builtin("cornell").unwrap();
        let options = ViewSetOptions {
            cameras: Vec::new(),
            sampled: 4,
            seed: 3,
            region: None,
        };
        let a = view_set(&scene, &options).unwrap();
        let b = view_set(&scene, &options).unwrap();
        assert_eq!(a, b);
        let c = view_set(&scene, &ViewSetOptions { seed: 4, ..options }).unwrap();
        assert_ne!(a[0].position, c[0].position);
    }

    #[test]
    fn sampled_views_stay_in_the_region_and_bad_requests_fail() {
        let scene = Scene::builtin("cornell").unwrap();
        let region = Region::parse_boxes(["0.02,0.02,0.02:0.25,0.52,0.54"]).unwrap();
        let views = view_set(
            &scene,
            &ViewSetOptions {
                cameras: Vec::new(),
                sampled: 6,
                seed: 0,
                region: Some(region.clone()),
            },
        )
        .unwrap();
        assert!(views.iter().all(|v| region.contains(v.position)));
        let solid = Region::parse_boxes(["0.35,0.05,0.33:0.39,0.25,0.37"]).unwrap();
        let err = view_set(
            &scene,
            &ViewSetOptions {
                sampled: 1,
                region: Some(solid),
                ..ViewSetOptions::default()
            },
        )
        .unwrap_err();
        assert!(matches!(err, ViewSetError::NoFreeSpace { .. }), "{err}");
        let missing = view_set(
            &scene,
            &ViewSetOptions {
                cameras: vec!["nope".into()],
                ..ViewSetOptions::default()
            },
        )
        .unwrap_err();
        assert!(matches!(missing, ViewSetError::NoCamera { .. }));
    }
}
