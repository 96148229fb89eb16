//! Scenes for radiance-probe work: glTF 2.0 loading, built-in procedural scenes, materials,
//! lights, cameras, and fast BVH ray casting.
//!
//! This crate is the shared home of geometry for probe placement, indexing, capture and
//! tracing. A [`Scene`] is immutable once built and `Send + Sync`; it holds world-space
//! [`Triangle`]s (instances flattened), [`Material`]s reduced to constants (plus alpha-mask
//! textures), punctual [`Light`]s, [`Camera`]s, and an [obvhs](https://docs.rs/obvhs) compressed
//! wide BVH (CWBVH, built in parallel) for [`Scene::closest_hit`] and [`Scene::occluded`].
//!
//! ```
//! use probe_scene::{Ray, Scene};
//! use glam::Vec3;
//!
//! let scene = Scene::open("builtin:cornell")?;
//! assert_eq!(scene.triangles().len(), 32);
//!
//! // Straight down from just under the light: the ray hits the floor at y = 0.
//! let ray = Ray::new(Vec3::new(0.278, 0.5, 0.28), -Vec3::Y);
//! let hit = scene.closest_hit(&ray, f32::INFINITY).expect("the floor");
//! assert!((hit.position.y - 0.0).abs() < 1e-5 && (hit.t - 0.5).abs() < 1e-5);
//! assert!(hit.front_face && hit.geometric_normal.y > 0.99);
//! assert_eq!(scene.materials()[hit.material as usize].name, "white");
//!
//! // A shadow ray from the floor to the light is not blocked; one under the tall block is.
//! let floor = Vec3::new(0.1, 0.0, 0.45);
//! let light = Vec3::new(0.278, 0.548, 0.28);
//! let shadow = Ray::from_surface(floor, Vec3::Y, light - floor);
//! assert!(!scene.occluded(&shadow, (light - floor).length() - 1e-3));
//! let under_block = Vec3::new(0.37, 0.0, 0.35);
//! let shadow = Ray::from_surface(under_block, Vec3::Y, light - under_block);
//! assert!(scene.occluded(&shadow, (light - under_block).length() - 1e-3));
//! # Ok::<(), probe_scene::LoadError>(())
//! ```
//!
//! # Conventions
//! - Units are metres, `+Y` is up, right-handed (as glTF). Colours are linear RGB.
//! - Triangles are wound counter-clockwise seen from their front: the geometric normal is
//!   `(p1 − p0) × (p2 − p0)`. Barycentrics `(b1, b2)` name `(1 − b1 − b2)·p0 + b1·p1 + b2·p2`.
//! - Rays start at `t = 0` (no `t_min`); move origins off surfaces with [`Ray::from_surface`].
//!   Hits are accepted for `0 ≤ t < t_max`, on both faces; [`Hit::front_face`] says which.
//! - Built-ins follow the normal conventions in [`builtin`]: room walls face into rooms
//!   (they are outward-facing slabs), boxes and pillars face outward, all single-sided.
//!
//! # Design choices
//! - **Textures are reduced to their mean** (base colour, emissive, metallic-roughness): probe
//!   work needs radiance at a coarse scale, and it keeps the crate free of a texture sampler.
//!   Alpha-mask textures are the exception: their alpha is kept at full resolution (one byte
//!   per texel) because cut-outs change visibility.
//! - **Loading is strict where guessing would change the scene**: a required extension it
//!   cannot honour, a missing buffer or needed image, non-finite positions and out-of-range
//!   indices are errors naming the item; what cannot change visibility or colour (optional
//!   extensions, points and lines, missing normals) becomes a [`LoadWarning`].
//! - **Ray casting is a thin layer over obvhs**: triangles are stored in BVH leaf order in
//!   obvhs's intersection layout, the alpha test runs only for triangles flagged as masked,
//!   and hit attributes are computed once per ray after traversal. On Sponza it runs at
//!   0.83–0.90× the raw obvhs closest-hit rate (see `BENCHMARKS.md`).
//! - **No leaks through edges**: obvhs's triangle test rejects barycentrics of `−0.0`, so a ray
//!   exactly through a shared edge or vertex (common for axis-aligned rays and grid-aligned
//!   meshes) could miss both triangles, and its slab test misses boxes whose face plane an
//!   axis-parallel ray lies in. This crate intersects with the same Möller–Trumbore arithmetic
//!   but a small barycentric tolerance, and pads the BVH's leaf boxes by a few ulps.
//!
//! # Features
//! - `gltf` (default): the glTF 2.0 loader, [`Scene::load`] and file paths in [`Scene::open`]
//!   (pulls in `gltf` and `image`). Without it, built-in scenes, [`Scene::from_triangles`],
//!   the BVH and [`Scene::content_hash`] work as before, and [`Scene::open`] refuses a path
//!   with [`LoadError::LoaderDisabled`].
//! - `parallel` (default): the BVH is built and [`Scene::closest_hits`] runs on rayon's
//!   thread pool. Without it both run on the calling thread; hits are the same.
//!
//! # Examples
//! `cargo run --release -p probe-scene --example scene_info -- SPEC` prints a scene's counts,
//! bounds, materials, lights, cameras, warnings and hash; `--example preview -- SPEC OUT.png`
//! renders a quick shaded preview from the default camera. `SPEC` is a glTF path or
//! `builtin:NAME`.

#![forbid(unsafe_code)]

pub mod builtin;
mod camera;
mod error;
mod geometry;
#[cfg(feature = "gltf")]
mod gltf_load;
mod light;
mod material;
pub mod memory;
mod scene;

pub use builtin::BUILTIN_SCENES;
pub use camera::Camera;
pub use error::{BuildError, LoadError, LoadWarning};
pub use geometry::{Aabb, Hit, Ray, Triangle};
pub use light::Light;
pub use material::{AlphaMode, AlphaTexture, Material, TextureWrap};
pub use scene::{MAX_COORDINATE, Scene, SceneSource};

/// Re-exported so that users need not match this crate's `glam` version by hand.
pub use glam;
