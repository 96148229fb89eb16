//! The `Scene`: immutable geometry, materials, lights and cameras with a BVH for ray casting.

use crate::camera::Camera;
use crate::error::{BuildError, LoadError, LoadWarning};
use crate::geometry::{Aabb, Hit, Ray, Triangle};
use crate::light::Light;
use crate::material::{AlphaMode, Material};
use crate::memory::MemoryLimit;
use glam::{Vec2, Vec3, Vec3A};
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};
use obvhs::ray::RayHit;
use obvhs::rt_triangle::RtTriangle;
use sha2::{Digest, Sha256};
use std::fmt;
#[cfg(feature = "gltf")]
use std::path::Path;
use std::path::PathBuf;
use std::sync::OnceLock;

/// The most triangles a scene may hold (one bit of the BVH's triangle ids flags alpha masks).
pub(crate) const MAX_TRIANGLES: usize = (1 << 31) - 1;
/// The largest coordinate magnitude a vertex may have, in metres. Beyond it the BVH builder's
/// surface areas (products of two extents) overflow `f32` and its build goes wrong (found by
/// fuzzing: a vertex at 1.3e31 broke obvhs's wide-BVH conversion). 10^18 m is a hundred light
/// years; no scene's geometry is there.
pub const MAX_COORDINATE: f32 = 1.0e18;
/// The memory a loaded triangle takes, for the up-front check of a file's declared size: the
/// [`Triangle`] itself, its BVH share while the BVH is built, and the decoded vertices.
#[cfg(feature = "gltf")]
pub(crate) const BYTES_PER_TRIANGLE: u64 = size_of::<Triangle>() as u64 + 160;
/// Set in a BVH slot's id when the triangle's material is an alpha mask.
const MASKED: u32 = 1 << 31;

/// Where a scene came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SceneSource {
    /// A glTF file (the path as given to [`Scene::load`]).
    File(PathBuf),
    /// A built-in procedural scene (one of [`BUILTIN_SCENES`](crate::BUILTIN_SCENES)).
    Builtin(&'static str),
    /// Triangles passed to [`Scene::from_triangles`].
    Triangles,
}

impl fmt::Display for SceneSource {
    /// Files show as their path and built-ins as `builtin:NAME`: both are accepted by
    /// [`Scene::open`]. Triangle scenes show as `triangles`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneSource::File(path) => write!(f, "{}", path.display()),
            SceneSource::Builtin(name) => write!(f, "builtin:{name}"),
            SceneSource::Triangles => f.write_str("triangles"),
        }
    }
}

/// The BVH over a scene's triangles, with the triangles in leaf order for fast intersection.
struct Bvh {
    cwbvh: CwBvh,
    /// Triangles in BVH leaf order, in obvhs's intersection layout.
    leaf_triangles: Vec<RtTriangle>,
    /// Per leaf slot: the index into `Scene::triangles`, with [`MASKED`] set for alpha masks.
    leaf_ids: Vec<u32>,
}

/// A scene: world-space triangles (instances flattened), materials, lights, cameras and a
/// compressed wide BVH (obvhs CWBVH) for ray casting. Immutable once built; `Send + Sync`.
///
/// Build one with [`Scene::load`] (glTF 2.0), [`Scene::builtin`], [`Scene::open`] (either, by a
/// string) or [`Scene::from_triangles`].
pub struct Scene {
    name: String,
    source: SceneSource,
    triangles: Vec<Triangle>,
    materials: Vec<Material>,
    lights: Vec<Light>,
    cameras: Vec<Camera>,
    default_camera: Camera,
    bounds: Aabb,
    unique_triangle_count: usize,
    warnings: Vec<LoadWarning>,
    content_hash: OnceLock<[u8; 32]>,
    bvh: Bvh,
}

impl fmt::Debug for Scene {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Scene")
            .field("name", &self.name)
            .field("source", &self.source)
            .field("triangles", &self.triangles.len())
            .field("unique_triangles", &self.unique_triangle_count)
            .field("materials", &self.materials.len())
            .field("lights", &self.lights.len())
            .field("cameras", &self.cameras.len())
            .field("bounds", &self.bounds)
            .field("warnings", &self.warnings.len())
            .finish()
    }
}

impl Scene {
    /// Loads a glTF 2.0 file (`.gltf` with its buffers and images, or `.glb`).
    ///
    /// What is read: the default scene's node hierarchy (transforms; normals by the
    /// inverse-transpose; winding flipped under mirroring transforms), `EXT_mesh_gpu_instancing`,
    /// all triangle modes (strips and fans triangulated; points and lines skipped with a
    /// warning), materials reduced to constants (texture means) plus alpha masks,
    /// `KHR_lights_punctual` and perspective cameras, both placed by their nodes. What is
    /// ignored is listed in [`Scene::warnings`]; what cannot be honoured is a [`LoadError`].
    ///
    /// Images are read only when a material needs them (base colour, emissive and
    /// metallic-roughness textures, decoded as PNG or JPEG for their mean; alpha-mask textures
    /// kept); normal and occlusion maps and `MSFT_texture_dds` alternatives are never opened.
    /// A needed image that is missing is an error naming its URI
    /// ([`LoadError::MissingFile`]), not a silent fall-back to the material's factor, which
    /// would change the scene's colours or cut-outs.
    ///
    /// Needs the `gltf` feature (on by default).
    #[cfg(feature = "gltf")]
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, LoadError> {
        Scene::load_with_limit(path, MemoryLimit::machine())
    }

    /// [`Scene::load`] with a memory limit other than the machine's: a file whose accessor
    /// counts declare more triangles than `limit` holds is refused
    /// ([`LoadError::TooLarge`]) before any mesh is decoded.
    #[cfg(feature = "gltf")]
    pub fn load_with_limit(path: impl AsRef<Path>, limit: MemoryLimit) -> Result<Scene, LoadError> {
        let path = path.as_ref();
        let loaded = crate::gltf_load::load(path, limit)?;
        let name = path
            .file_stem()
            .map_or_else(|| "scene".to_owned(), |s| s.to_string_lossy().into_owned());
        Scene::build(
            name,
            SceneSource::File(path.to_owned()),
            loaded.triangles,
            loaded.materials,
            loaded.lights,
            loaded.cameras,
            Some(loaded.unique_triangle_count),
            loaded.warnings,
        )
        .map_err(|source| LoadError::Build {
            path: path.to_owned(),
            source,
        })
    }

    /// Builds one of the procedural scenes listed in [`BUILTIN_SCENES`](crate::BUILTIN_SCENES)
    /// (see the [`builtin`](crate::builtin) module for their layouts).
    pub fn builtin(name: &str) -> Result<Scene, LoadError> {
        let (name, parts) =
            crate::builtin::build(name).ok_or_else(|| LoadError::UnknownBuiltin {
                name: name.to_owned(),
            })?;
        Scene::build(
            name.to_owned(),
            SceneSource::Builtin(name),
            parts.triangles,
            parts.materials,
            parts.lights,
            parts.cameras,
            None,
            Vec::new(),
        )
        .map_err(|source| LoadError::Build {
            path: PathBuf::from(format!("builtin:{name}")),
            source,
        })
    }

    /// Opens `builtin:NAME` as [`Scene::builtin`] and anything else as a file path with
    /// [`Scene::load`]. Built without the `gltf` feature, a path is
    /// [`LoadError::LoaderDisabled`].
    pub fn open(spec: &str) -> Result<Scene, LoadError> {
        Scene::open_with_limit(spec, MemoryLimit::machine())
    }

    /// [`Scene::open`] with a memory limit for files ([`Scene::load_with_limit`]); built-in
    /// scenes are small and ignore it.
    pub fn open_with_limit(spec: &str, limit: MemoryLimit) -> Result<Scene, LoadError> {
        match spec.strip_prefix("builtin:") {
            Some(name) => Scene::builtin(name),
            #[cfg(feature = "gltf")]
            None => Scene::load_with_limit(spec, limit),
            #[cfg(not(feature = "gltf"))]
            None => {
                let _ = limit;
                Err(LoadError::LoaderDisabled {
                    path: PathBuf::from(spec),
                })
            }
        }
    }

    /// Builds a scene from world-space triangles. `material` indices refer to `materials`.
    /// Every triangle counts as unique. Light directions are normalised; everything else is
    /// kept as given after checking (see [`BuildError`]).
    pub fn from_triangles(
        name: impl Into<String>,
        triangles: Vec<Triangle>,
        materials: Vec<Material>,
        lights: Vec<Light>,
        cameras: Vec<Camera>,
    ) -> Result<Scene, BuildError> {
        Scene::build(
            name.into(),
            SceneSource::Triangles,
            triangles,
            materials,
            lights,
            cameras,
            None,
            Vec::new(),
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        name: String,
        source: SceneSource,
        triangles: Vec<Triangle>,
        materials: Vec<Material>,
        lights: Vec<Light>,
        cameras: Vec<Camera>,
        unique_triangle_count: Option<usize>,
        warnings: Vec<LoadWarning>,
    ) -> Result<Scene, BuildError> {
        check_triangles(&triangles, materials.len())?;
        check_materials(&materials)?;
        let lights = check_lights(lights)?;
        check_cameras(&cameras)?;
        let bounds = Aabb::from_points(triangles.iter().flat_map(|t| t.positions));
        let default_camera = cameras
            .first()
            .cloned()
            .unwrap_or_else(|| framing_camera(&bounds));
        let bvh = build_bvh(&triangles, &materials);
        Ok(Scene {
            name,
            source,
            unique_triangle_count: unique_triangle_count.unwrap_or(triangles.len()),
            triangles,
            materials,
            lights,
            cameras,
            default_camera,
            bounds,
            warnings,
            content_hash: OnceLock::new(),
            bvh,
        })
    }

    /// The scene's name: the file stem, the built-in's name, or the name given.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Where the scene came from; its `Display` form reopens it with [`Scene::open`].
    pub fn source(&self) -> &SceneSource {
        &self.source
    }

    /// All triangles in world space, instances flattened. [`Hit::triangle`] indexes this.
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    /// The materials; [`Triangle::material`] indexes this. A loaded file's materials keep
    /// the file's order; the glTF default material is appended when a primitive names none.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// The punctual lights, world space.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// The cameras, world space, in node order.
    pub fn cameras(&self) -> &[Camera] {
        &self.cameras
    }

    /// The first camera with this name.
    pub fn camera(&self, name: &str) -> Option<&Camera> {
        self.cameras.iter().find(|c| c.name == name)
    }

    /// The first camera; without cameras, a framing pose computed from the bounds: named
    /// `"default"`, vertical field of view 60°, looking along `−Z` at the bounds' centre from
    /// `center + (0, 0, r / sin 30°)` where `r` is half the bounds' diagonal (at least 1 m), so
    /// the bounding sphere fits the view. Built-ins document their own fixed pose.
    pub fn default_camera(&self) -> Camera {
        self.default_camera.clone()
    }

    /// The bounds of all triangles ([`Aabb::EMPTY`] for a scene without triangles).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The number of triangles before instancing: for a loaded file, the triangles of each
    /// mesh drawn counted once however often it is drawn; otherwise the triangle count.
    pub fn unique_triangle_count(&self) -> usize {
        self.unique_triangle_count
    }

    /// What the loader ignored or repaired (empty for built-ins and triangle scenes).
    pub fn warnings(&self) -> &[LoadWarning] {
        &self.warnings
    }

    /// SHA-256 of the geometry, materials and lights (names, cameras and the source are left
    /// out), computed on first use. The same scene gives the same hash on every run and
    /// machine. Byte order: the ASCII tag `probe-scene content v1`; the triangle count as u64;
    /// per triangle its 3 positions, 3 normals (xyz f32 each), 3 uvs (xy f32) and material
    /// (u32); the material count (u64); per material base colour (3 f32), metallic,
    /// roughness, emissive (3 f32), double-sided (u8), alpha mode (u8: 0 opaque, 1 mask,
    /// 2 blend) and for masks the cutoff (f32), constant alpha (f32), texture width and height
    /// (u32, 0 without texture), wrap modes (u8 each) and alpha bytes; the light count (u64);
    /// per light its kind (u8: 0 point, 1 spot, 2 directional), position (3 f32, zeros for
    /// directional), direction (3 f32, zeros for point), colour (3 f32), intensity or
    /// illuminance, inner and outer cone (f32, zeros unless spot) and range (f32, −1 for none).
    /// All numbers little-endian; floats by their IEEE-754 bits, with −0 written as +0.
    pub fn content_hash(&self) -> [u8; 32] {
        *self
            .content_hash
            .get_or_init(|| self.compute_content_hash())
    }

    fn compute_content_hash(&self) -> [u8; 32] {
        let mut hasher = Sha256::new();
        let mut bytes: Vec<u8> = Vec::with_capacity(1 << 16);
        bytes.extend_from_slice(b"probe-scene content v1");
        bytes.extend_from_slice(&(self.triangles.len() as u64).to_le_bytes());
        // `+ 0.0` turns −0 into +0, so that equal values hash equally.
        let push_f32 =
            |bytes: &mut Vec<u8>, v: f32| bytes.extend_from_slice(&(v + 0.0).to_le_bytes());
        let push_vec3 = |bytes: &mut Vec<u8>, v: Vec3| {
            for c in v.to_array() {
                bytes.extend_from_slice(&(c + 0.0).to_le_bytes());
            }
        };
        for triangle in &self.triangles {
            for p in triangle.positions.iter().chain(&triangle.normals) {
                push_vec3(&mut bytes, *p);
            }
            for uv in triangle.uvs {
                push_f32(&mut bytes, uv.x);
                push_f32(&mut bytes, uv.y);
            }
            bytes.extend_from_slice(&triangle.material.to_le_bytes());
            if bytes.len() >= 1 << 16 {
                hasher.update(&bytes);
                bytes.clear();
            }
        }
        bytes.extend_from_slice(&(self.materials.len() as u64).to_le_bytes());
        for material in &self.materials {
            push_vec3(&mut bytes, material.base_color);
            push_f32(&mut bytes, material.metallic);
            push_f32(&mut bytes, material.roughness);
            push_vec3(&mut bytes, material.emissive);
            bytes.push(u8::from(material.double_sided));
            match &material.alpha {
                AlphaMode::Opaque => bytes.push(0),
                AlphaMode::Blend => bytes.push(2),
                AlphaMode::Mask {
                    cutoff,
                    texture,
                    constant_alpha,
                } => {
                    bytes.push(1);
                    push_f32(&mut bytes, *cutoff);
                    push_f32(&mut bytes, *constant_alpha);
                    match texture {
                        Some(texture) => {
                            bytes.extend_from_slice(&texture.width().to_le_bytes());
                            bytes.extend_from_slice(&texture.height().to_le_bytes());
                            let (u, v) = texture.wrap();
                            bytes.push(u as u8);
                            bytes.push(v as u8);
                            hasher.update(&bytes);
                            bytes.clear();
                            hasher.update(texture.alpha());
                        }
                        None => bytes.extend_from_slice(&[0; 10]),
                    }
                }
            }
        }
        bytes.extend_from_slice(&(self.lights.len() as u64).to_le_bytes());
        for light in &self.lights {
            let (kind, position, direction, intensity, cones) = match light {
                Light::Point {
                    position,
                    intensity,
                    ..
                } => (0u8, *position, Vec3::ZERO, *intensity, [0.0, 0.0]),
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    inner_cone,
                    outer_cone,
                    ..
                } => (
                    1,
                    *position,
                    *direction,
                    *intensity,
                    [*inner_cone, *outer_cone],
                ),
                Light::Directional {
                    direction,
                    illuminance,
                    ..
                } => (2, Vec3::ZERO, *direction, *illuminance, [0.0, 0.0]),
            };
            bytes.push(kind);
            push_vec3(&mut bytes, position);
            push_vec3(&mut bytes, direction);
            push_vec3(&mut bytes, light.color());
            push_f32(&mut bytes, intensity);
            push_f32(&mut bytes, cones[0]);
            push_f32(&mut bytes, cones[1]);
            push_f32(&mut bytes, light.range().unwrap_or(-1.0));
        }
        hasher.update(&bytes);
        hasher.finalize().into()
    }

    /// The obvhs ray for `ray` over `[t_min, t_max)`, or `None` when nothing can be hit
    /// (no triangles, non-finite ray, `t_max ≤ t_min` or NaN).
    #[inline(always)]
    fn bvh_ray(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<obvhs::ray::Ray> {
        // `t_max > t_min` is false for NaN too.
        let positive = t_max > t_min;
        if self.bvh.leaf_triangles.is_empty()
            || !positive
            || !ray.origin.is_finite()
            || !ray.direction.is_finite()
        {
            return None;
        }
        // Adding +0 turns −0 components into +0: obvhs takes the octant from the direction's
        // comparison with zero but the slab signs from `safe_inverse`, which disagree on −0.
        let direction = Vec3A::from(ray.direction) + Vec3A::ZERO;
        Some(obvhs::ray::Ray {
            origin: Vec3A::from(ray.origin),
            direction,
            inv_direction: Vec3A::new(
                obvhs::ray::safe_inverse(direction.x),
                obvhs::ray::safe_inverse(direction.y),
                obvhs::ray::safe_inverse(direction.z),
            ),
            tmin: t_min,
            tmax: t_max,
        })
    }

    /// Intersects the triangle in leaf slot `slot`, honouring alpha masks; `f32::INFINITY`
    /// for a miss.
    #[inline(always)]
    fn intersect_slot(&self, ray: &obvhs::ray::Ray, slot: usize) -> f32 {
        let triangle = &self.bvh.leaf_triangles[slot];
        let t = intersect_triangle(triangle, ray);
        if t < ray.tmax {
            let id = self.bvh.leaf_ids[slot];
            if id & MASKED != 0
                && !self.alpha_passes(id & !MASKED, triangle.compute_barycentric(ray))
            {
                return f32::INFINITY;
            }
        }
        t
    }

    #[cold]
    fn alpha_passes(&self, triangle: u32, barycentrics: Vec2) -> bool {
        let triangle = &self.triangles[triangle as usize];
        self.materials[triangle.material as usize]
            .alpha
            .passes(triangle.uv(barycentrics))
    }

    /// The closest hit with `0 ≤ t < t_max` (pass `f32::INFINITY` for no limit), or `None`.
    ///
    /// Both faces are hit (no culling); alpha-mask cut-outs are skipped. Rays start at
    /// `t = 0`: offset origins on surfaces with [`Ray::from_surface`]. A ray with a
    /// non-finite origin or direction hits nothing.
    #[inline]
    pub fn closest_hit(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        self.closest_hit_between(ray, 0.0, t_max)
    }

    /// The closest hit with `t_min ≤ t < t_max`, or `None`: for a ray that starts exactly on a
    /// surface point rather than at an offset origin, with `t_min` past the rounding of that
    /// point off its own plane (a few ulps of the coordinates over the cosine between the ray
    /// and the plane). Its `t` is then measured from the surface point itself, which matters
    /// where the ray's solid angle does: an offset origin at large coordinates (256 ulps:
    /// 1.6 cm at 1 km) stands measurably closer to a light a few centimetres away.
    /// Otherwise as [`Scene::closest_hit`]; a negative or NaN `t_min` counts as 0.
    #[inline]
    pub fn closest_hit_between(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let t_min = t_min.max(0.0);
        let bvh_ray = self.bvh_ray(ray, t_min, t_max)?;
        let mut hit = RayHit::none();
        if !self
            .bvh
            .cwbvh
            .ray_traverse(bvh_ray, &mut hit, |r, slot| self.intersect_slot(r, slot))
        {
            return None;
        }
        let slot = hit.primitive_id as usize;
        let barycentrics = self.bvh.leaf_triangles[slot].compute_barycentric(&bvh_ray);
        let index = self.bvh.leaf_ids[slot] & !MASKED;
        let triangle = &self.triangles[index as usize];
        let geometric_normal = triangle.geometric_normal();
        Some(Hit {
            t: hit.t,
            position: triangle.point(barycentrics),
            triangle: index,
            barycentrics,
            geometric_normal,
            shading_normal: triangle.shading_normal(barycentrics),
            material: triangle.material,
            front_face: ray.direction.dot(geometric_normal) < 0.0,
        })
    }

    /// Whether anything lies on the ray with `0 ≤ t < t_max` (any hit; stops at the first).
    /// For a shadow ray towards a point at distance `d`, pass a `t_max` slightly below `d`.
    /// Alpha-mask cut-outs do not occlude.
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        match self.bvh_ray(ray, 0.0, t_max) {
            Some(bvh_ray) => !self
                .bvh
                .cwbvh
                .ray_traverse_miss(bvh_ray, |r, slot| self.intersect_slot(r, slot)),
            None => false,
        }
    }

    /// [`Scene::closest_hit`] for many rays, spread over rayon's thread pool with the
    /// `parallel` feature (on by default) and on the calling thread without it: element `i` is
    /// the hit of `rays[i]` either way.
    pub fn closest_hits(&self, rays: &[Ray], t_max: f32) -> Vec<Option<Hit>> {
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            rays.par_iter()
                .with_min_len(256)
                .map(|ray| self.closest_hit(ray, t_max))
                .collect()
        }
        #[cfg(not(feature = "parallel"))]
        {
            rays.iter()
                .map(|ray| self.closest_hit(ray, t_max))
                .collect()
        }
    }
}

/// Barycentric slack of [`intersect_triangle`]: points this far outside a triangle (relative to
/// its size) still hit it, so that rays through a shared edge hit at least one of the two
/// triangles despite rounding.
const EDGE_TOLERANCE: f32 = 1e-6;

/// Möller–Trumbore on obvhs's triangle layout (`e1 = v0 − v1`, `e2 = v2 − v0`,
/// `ng = e1 × e2`), returning `t` in `[tmin, tmax]` or `f32::INFINITY`.
///
/// obvhs's own `RtTriangle::intersect` tests the barycentrics' sign bits, which rejects
/// `−0.0`: a ray through a shared edge, or exactly through a vertex, can then miss both
/// triangles (rays along axes through grid-aligned meshes do). Here the barycentrics are
/// compared with a small negative tolerance instead; the arithmetic is otherwise the same.
#[inline(always)]
fn intersect_triangle(triangle: &RtTriangle, ray: &obvhs::ray::Ray) -> f32 {
    let c = triangle.v0 - ray.origin;
    let r = ray.direction.cross(c);
    let det = triangle.ng.dot(ray.direction);
    let inv_det = 1.0 / det;
    let u = r.dot(triangle.e2) * inv_det;
    let v = r.dot(triangle.e1) * inv_det;
    let w = 1.0 - u - v;
    if det != 0.0 && u >= -EDGE_TOLERANCE && v >= -EDGE_TOLERANCE && w >= -EDGE_TOLERANCE {
        let t = triangle.ng.dot(c) * inv_det;
        if t >= ray.tmin && t <= ray.tmax {
            return t;
        }
    }
    f32::INFINITY
}

fn build_bvh(triangles: &[Triangle], materials: &[Material]) -> Bvh {
    let rt: Vec<RtTriangle> = triangles
        .iter()
        .map(|t| {
            let [p0, p1, p2] = t.positions;
            RtTriangle::new(p0.into(), p1.into(), p2.into())
        })
        .collect();
    if rt.is_empty() {
        return Bvh {
            cwbvh: CwBvh::default(),
            leaf_triangles: Vec::new(),
            leaf_ids: Vec::new(),
        };
    }
    // Boxes padded by a few ulps: a ray lying exactly in a box's face plane with a zero
    // direction component (an axis-aligned ray along the edge of a mesh) would otherwise miss
    // the box through obvhs's slab test.
    let boxes: Vec<obvhs::aabb::Aabb> = rt
        .iter()
        .map(|t| {
            let aabb = t.aabb();
            let scale = aabb.min.abs().max(aabb.max.abs()).max_element();
            let pad = Vec3A::splat(scale * 4.0 * f32::EPSILON + f32::MIN_POSITIVE);
            obvhs::aabb::Aabb::new(aabb.min - pad, aabb.max + pad)
        })
        .collect();
    // obvhs's `medium_build` preset, spelled out to skip its debug-build validation pass.
    let mut bvh2 = PlocBuilder::with_capacity(rt.len()).build(
        PlocSearchDistance::Medium,
        &boxes,
        (0..rt.len() as u32).collect(),
        SortPrecision::U64,
        3,
    );
    ReinsertionOptimizer::default().run(&mut bvh2, 0.05, None);
    let cwbvh = bvh2_to_cwbvh(&bvh2, 3, true, false);
    let masked: Vec<bool> = materials
        .iter()
        .map(|m| matches!(m.alpha, AlphaMode::Mask { .. }))
        .collect();
    let leaf_triangles = cwbvh
        .primitive_indices
        .iter()
        .map(|&i| rt[i as usize])
        .collect();
    let leaf_ids = cwbvh
        .primitive_indices
        .iter()
        .map(|&i| {
            if masked[triangles[i as usize].material as usize] {
                i | MASKED
            } else {
                i
            }
        })
        .collect();
    Bvh {
        cwbvh,
        leaf_triangles,
        leaf_ids,
    }
}

fn framing_camera(bounds: &Aabb) -> Camera {
    let yfov = 60f32.to_radians();
    let center = bounds.center();
    let radius = (0.5 * bounds.size().length()).max(1.0);
    let position = center + Vec3::Z * (radius / (0.5 * yfov).sin());
    Camera {
        name: "default".to_owned(),
        ..Camera::look_at(position, center, Vec3::Y, yfov)
    }
}

fn check_triangles(triangles: &[Triangle], material_count: usize) -> Result<(), BuildError> {
    if triangles.len() > MAX_TRIANGLES {
        return Err(BuildError::TooManyTriangles {
            count: triangles.len(),
        });
    }
    for (index, t) in triangles.iter().enumerate() {
        let non_finite = |attribute| BuildError::NonFiniteVertex {
            triangle: index,
            attribute,
        };
        if !t.positions.iter().all(|p| p.is_finite()) {
            return Err(non_finite("position"));
        }
        if t.positions
            .iter()
            .any(|p| p.abs().max_element() > MAX_COORDINATE)
        {
            return Err(BuildError::PositionOutOfRange {
                triangle: index,
                limit: MAX_COORDINATE,
            });
        }
        if !t.normals.iter().all(|n| n.is_finite()) {
            return Err(non_finite("normal"));
        }
        if !t.uvs.iter().all(|uv| uv.is_finite()) {
            return Err(non_finite("uv"));
        }
        if t.material as usize >= material_count {
            return Err(BuildError::MaterialOutOfRange {
                triangle: index,
                material: t.material,
                material_count,
            });
        }
    }
    Ok(())
}

fn check_materials(materials: &[Material]) -> Result<(), BuildError> {
    for (index, m) in materials.iter().enumerate() {
        let invalid = |reason: &str| BuildError::InvalidMaterial {
            material: index,
            name: m.name.clone(),
            reason: reason.to_owned(),
        };
        let unit = |v: f32| (0.0..=1.0).contains(&v);
        if !(m.base_color.is_finite() && m.base_color.min_element() >= 0.0) {
            return Err(invalid("base_color must be finite and non-negative"));
        }
        if !(m.emissive.is_finite() && m.emissive.min_element() >= 0.0) {
            return Err(invalid("emissive must be finite and non-negative"));
        }
        if !unit(m.metallic) {
            return Err(invalid("metallic must lie in [0, 1]"));
        }
        if !unit(m.roughness) {
            return Err(invalid("roughness must lie in [0, 1]"));
        }
        if let AlphaMode::Mask {
            cutoff,
            constant_alpha,
            ..
        } = m.alpha
            && (!cutoff.is_finite() || !constant_alpha.is_finite())
        {
            return Err(invalid("alpha cutoff and constant alpha must be finite"));
        }
    }
    Ok(())
}

fn check_lights(mut lights: Vec<Light>) -> Result<Vec<Light>, BuildError> {
    for (index, light) in lights.iter_mut().enumerate() {
        let name = light.name().to_owned();
        let invalid = |reason: &str| BuildError::InvalidLight {
            light: index,
            name: name.clone(),
            reason: reason.to_owned(),
        };
        if !(light.color().is_finite() && light.color().min_element() >= 0.0) {
            return Err(invalid("color must be finite and non-negative"));
        }
        if light
            .range()
            .is_some_and(|range| range.is_nan() || range <= 0.0)
        {
            return Err(invalid("range must be positive"));
        }
        if light
            .position()
            .is_some_and(|position| !position.is_finite())
        {
            return Err(invalid("position must be finite"));
        }
        match light {
            Light::Point { intensity, .. } => {
                if !(intensity.is_finite() && *intensity >= 0.0) {
                    return Err(invalid("intensity must be finite and non-negative"));
                }
            }
            Light::Spot {
                direction,
                intensity,
                inner_cone,
                outer_cone,
                ..
            } => {
                if !(intensity.is_finite() && *intensity >= 0.0) {
                    return Err(invalid("intensity must be finite and non-negative"));
                }
                if !(0.0 <= *inner_cone
                    && inner_cone < outer_cone
                    && *outer_cone <= std::f32::consts::FRAC_PI_2 + 1e-6)
                {
                    return Err(invalid("cones must satisfy 0 ≤ inner < outer ≤ π/2"));
                }
                *direction = direction
                    .try_normalize()
                    .ok_or_else(|| invalid("direction must be finite and non-zero"))?;
            }
            Light::Directional {
                direction,
                illuminance,
                ..
            } => {
                if !(illuminance.is_finite() && *illuminance >= 0.0) {
                    return Err(invalid("illuminance must be finite and non-negative"));
                }
                *direction = direction
                    .try_normalize()
                    .ok_or_else(|| invalid("direction must be finite and non-zero"))?;
            }
        }
    }
    Ok(lights)
}

fn check_cameras(cameras: &[Camera]) -> Result<(), BuildError> {
    for (index, c) in cameras.iter().enumerate() {
        let invalid = |reason: &str| BuildError::InvalidCamera {
            camera: index,
            name: c.name.clone(),
            reason: reason.to_owned(),
        };
        if !c.position.is_finite() {
            return Err(invalid("position must be finite"));
        }
        let unit = |v: Vec3| v.is_finite() && (v.length() - 1.0).abs() < 1e-3;
        if !unit(c.forward) || !unit(c.up) || c.forward.dot(c.up).abs() > 1e-3 {
            return Err(invalid("forward and up must be orthogonal unit vectors"));
        }
        if !(c.yfov > 0.0 && c.yfov < std::f32::consts::PI) {
            return Err(invalid("yfov must lie in (0, π)"));
        }
    }
    Ok(())
}
