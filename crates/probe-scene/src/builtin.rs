//! Built-in procedural scenes, built without files by [`Scene::builtin`](crate::Scene::builtin).
//!
//! All sizes are in metres, `+Y` is up. Conventions shared by all built-ins:
//! - **Solids are closed and face outward**: walls, floors and ceilings are slabs with
//!   thickness (closed boxes), so the faces that bound a room face *into* the room; blocks,
//!   boxes, stairs and pillars are closed and face outward. The exception is `cornell`, whose
//!   walls are single quads facing into the box and whose blocks stand open at the bottom, as
//!   in the Cornell data.
//! - **All materials are single-sided** (`double_sided = false`) and opaque.
//! - Light comes from emissive quads (materials with non-zero `emissive`, listed under each
//!   scene), except `colonnade`, lit by a directional sun.
//! - Each scene has exactly one camera, named `"default"`, which is also its
//!   [`default_camera`](crate::Scene::default_camera).
//!
//! | name | what it is | triangles |
//! |---|---|---|
//! | `cornell` | the Cornell box from the Cornell measurements | 32 |
//! | `colonnade` | a hall with two rows of pillars, stairs and a gallery, sun through openings | 1,740 |
//! | `boxes` | a room with small closed boxes exactly at a 4×2×4 grid's cell centres | 458 |
//! | `leak-closed` | a lit room beside a dark one, a complete 0.2 m wall between | 86 |
//! | `leak-gap` | the same with a 0.8 m full-height gap at one end of the wall | 86 |

use crate::camera::Camera;
use crate::geometry::{Aabb, Triangle};
use crate::light::Light;
use crate::material::Material;
use glam::{Vec2, Vec3};

/// The names [`Scene::builtin`](crate::Scene::builtin) accepts.
pub const BUILTIN_SCENES: &[&str] = &["cornell", "colonnade", "boxes", "leak-closed", "leak-gap"];

/// The grid of the `boxes` scene: `grid:4x2x4` (x, y, z cells) over the scene's bounds. One
/// closed box is centred exactly on each cell centre (see [`grid_cell_centers`]), so that a
/// regular grid of this resolution puts every probe inside a box (seed 003, Fig. 8.2).
pub const BOXES_GRID: [u32; 3] = [4, 2, 4];

/// The edge length of the `boxes` scene's cubes (0.3 m).
pub const BOXES_BOX_SIZE: f32 = 0.3;

/// The interior (air) of the lit room of `leak-closed` and `leak-gap`, which holds the light.
pub const LEAK_LIT_ROOM: Aabb = Aabb::new(Vec3::new(-4.1, 0.0, -2.0), Vec3::new(-0.1, 3.0, 2.0));

/// The interior (air) of the dark room of `leak-closed` and `leak-gap`: no light of its own.
pub const LEAK_DARK_ROOM: Aabb = Aabb::new(Vec3::new(0.1, 0.0, -2.0), Vec3::new(4.1, 3.0, 2.0));

/// The opening in `leak-gap`'s dividing wall (`x ∈ [−0.1, 0.1]`): full height, `z ∈ [1.2, 2]`.
pub const LEAK_GAP: Aabb = Aabb::new(Vec3::new(-0.1, 0.0, 1.2), Vec3::new(0.1, 3.0, 2.0));

/// The cell centres of a regular `dims` grid over `bounds`, x fastest then y then z:
/// `min + (i + ½) · size / dims` per axis. This is the convention the `boxes` scene follows.
pub fn grid_cell_centers(bounds: &Aabb, dims: [u32; 3]) -> Vec<Vec3> {
    let size = bounds.size();
    let cell = size / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    let mut centers = Vec::with_capacity((dims[0] * dims[1] * dims[2]) as usize);
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let index = Vec3::new(x as f32, y as f32, z as f32) + 0.5;
                centers.push(bounds.min + index * cell);
            }
        }
    }
    centers
}

/// The parts of a built-in scene.
pub(crate) struct BuiltinParts {
    pub triangles: Vec<Triangle>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    pub cameras: Vec<Camera>,
}

/// Builds the named scene; `None` for an unknown name.
pub(crate) fn build(name: &str) -> Option<(&'static str, BuiltinParts)> {
    let name = *BUILTIN_SCENES.iter().find(|n| **n == name)?;
    let parts = match name {
        "cornell" => cornell(),
        "colonnade" => colonnade(),
        "boxes" => boxes(),
        "leak-closed" => leak(false),
        _ => leak(true),
    };
    Some((name, parts))
}

/// Accumulates triangles and materials.
struct Builder {
    triangles: Vec<Triangle>,
    materials: Vec<Material>,
}

impl Builder {
    fn new() -> Builder {
        Builder {
            triangles: Vec::new(),
            materials: Vec::new(),
        }
    }

    fn material(&mut self, material: Material) -> u32 {
        self.materials.push(material);
        (self.materials.len() - 1) as u32
    }

    /// A planar quad with corners in order around its edge, wound so that its normal points
    /// to the side of `facing`.
    fn quad(&mut self, corners: [Vec3; 4], facing: Vec3, material: u32) {
        let [a, b, c, d] = corners;
        let normal = (b - a).cross(c - a);
        let (corners, uvs) = if normal.dot(facing) >= 0.0 {
            ([a, b, c, d], [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y])
        } else {
            ([a, d, c, b], [Vec2::ZERO, Vec2::Y, Vec2::ONE, Vec2::X])
        };
        let n = (corners[1] - corners[0])
            .cross(corners[2] - corners[0])
            .normalize_or_zero();
        for [i, j, k] in [[0, 1, 2], [0, 2, 3]] {
            self.triangles.push(Triangle {
                positions: [corners[i], corners[j], corners[k]],
                normals: [n; 3],
                uvs: [uvs[i], uvs[j], uvs[k]],
                material,
            });
        }
    }

    /// A closed axis-aligned box facing outward (12 triangles).
    fn cuboid(&mut self, min: Vec3, max: Vec3, material: u32) {
        let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let (x0, y0, z0, x1, y1, z1) = (min.x, min.y, min.z, max.x, max.y, max.z);
        self.quad(
            [c(x0, y0, z0), c(x0, y1, z0), c(x0, y1, z1), c(x0, y0, z1)],
            -Vec3::X,
            material,
        );
        self.quad(
            [c(x1, y0, z0), c(x1, y1, z0), c(x1, y1, z1), c(x1, y0, z1)],
            Vec3::X,
            material,
        );
        self.quad(
            [c(x0, y0, z0), c(x1, y0, z0), c(x1, y0, z1), c(x0, y0, z1)],
            -Vec3::Y,
            material,
        );
        self.quad(
            [c(x0, y1, z0), c(x1, y1, z0), c(x1, y1, z1), c(x0, y1, z1)],
            Vec3::Y,
            material,
        );
        self.quad(
            [c(x0, y0, z0), c(x1, y0, z0), c(x1, y1, z0), c(x0, y1, z0)],
            -Vec3::Z,
            material,
        );
        self.quad(
            [c(x0, y0, z1), c(x1, y0, z1), c(x1, y1, z1), c(x0, y1, z1)],
            Vec3::Z,
            material,
        );
    }

    /// A closed vertical cylinder facing outward: `segments` side quads with smooth normals
    /// and two flat caps (`4 · segments` triangles).
    fn cylinder(&mut self, base: Vec3, radius: f32, height: f32, segments: u32, material: u32) {
        let top = base + Vec3::Y * height;
        // `i % segments` makes the last segment end exactly where the first begins.
        let rim = |i: u32| {
            let angle = std::f32::consts::TAU * (i % segments) as f32 / segments as f32;
            Vec3::new(angle.cos(), 0.0, angle.sin())
        };
        for i in 0..segments {
            let (d0, d1) = (rim(i), rim(i + 1));
            let (b0, b1) = (base + d0 * radius, base + d1 * radius);
            let (t0, t1) = (top + d0 * radius, top + d1 * radius);
            let u0 = i as f32 / segments as f32;
            let u1 = (i + 1) as f32 / segments as f32;
            // Outward winding: (b0, t0, t1) has normal (t0 − b0) × (t1 − b0), pointing out.
            self.triangles.push(Triangle {
                positions: [b0, t0, t1],
                normals: [d0, d0, d1],
                uvs: [Vec2::new(u0, 1.0), Vec2::new(u0, 0.0), Vec2::new(u1, 0.0)],
                material,
            });
            self.triangles.push(Triangle {
                positions: [b0, t1, b1],
                normals: [d0, d1, d1],
                uvs: [Vec2::new(u0, 1.0), Vec2::new(u1, 0.0), Vec2::new(u1, 1.0)],
                material,
            });
            self.triangles.push(Triangle {
                positions: [top, t1, t0],
                normals: [Vec3::Y; 3],
                uvs: [Vec2::splat(0.5); 3],
                material,
            });
            self.triangles.push(Triangle {
                positions: [base, b0, b1],
                normals: [-Vec3::Y; 3],
                uvs: [Vec2::splat(0.5); 3],
                material,
            });
        }
    }

    fn finish(self, lights: Vec<Light>, camera: Camera) -> BuiltinParts {
        BuiltinParts {
            triangles: self.triangles,
            materials: self.materials,
            lights,
            cameras: vec![Camera {
                name: "default".to_owned(),
                ..camera
            }],
        }
    }
}

/// `cornell`: the Cornell box from the Cornell University Program of Computer Graphics
/// measurements (<https://www.graphics.cornell.edu/online/box/data.html>), converted from
/// millimetres to metres: about 0.556 × 0.549 × 0.559 m, floor at `y = 0`, the open side
/// towards `−Z`.
///
/// - Walls (floor, ceiling, back, left, right) are single quads facing into the box; the red
///   wall is at `x ≈ 0.55`, the green one at `x = 0` (red appears on the left from the camera).
///   The two blocks use the measured vertices, face outward and are open at the bottom.
/// - Albedos: white `(0.725, 0.71, 0.68)`, red `(0.63, 0.065, 0.05)`, green
///   `(0.14, 0.45, 0.091)`.
/// - The light is the measured 0.13 × 0.105 m quad, lowered 0.5 mm below the ceiling so they
///   do not coincide, facing down, with emitted radiance `(17, 12, 4)` (as in PBRT's scene).
/// - Camera: the measured one, at `(0.278, 0.273, −0.8)` looking along `+Z`, up `+Y`, vertical
///   field of view `2·atan(12.5 / 35) ≈ 39.3°` (35 mm lens, 25 mm film).
fn cornell() -> BuiltinParts {
    let mut b = Builder::new();
    let white = b.material(Material::diffuse("white", Vec3::new(0.725, 0.71, 0.68)));
    let red = b.material(Material::diffuse("red", Vec3::new(0.63, 0.065, 0.05)));
    let green = b.material(Material::diffuse("green", Vec3::new(0.14, 0.45, 0.091)));
    let light = b.material(Material {
        base_color: Vec3::splat(0.78),
        ..Material::emitter("light", Vec3::new(17.0, 12.0, 4.0))
    });
    let mm = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * 0.001;
    // Floor, ceiling, back wall, right (green) wall, left (red) wall.
    b.quad(
        [
            mm(552.8, 0.0, 0.0),
            mm(0.0, 0.0, 0.0),
            mm(0.0, 0.0, 559.2),
            mm(549.6, 0.0, 559.2),
        ],
        Vec3::Y,
        white,
    );
    b.quad(
        [
            mm(556.0, 548.8, 0.0),
            mm(556.0, 548.8, 559.2),
            mm(0.0, 548.8, 559.2),
            mm(0.0, 548.8, 0.0),
        ],
        -Vec3::Y,
        white,
    );
    b.quad(
        [
            mm(549.6, 0.0, 559.2),
            mm(0.0, 0.0, 559.2),
            mm(0.0, 548.8, 559.2),
            mm(556.0, 548.8, 559.2),
        ],
        -Vec3::Z,
        white,
    );
    b.quad(
        [
            mm(0.0, 0.0, 559.2),
            mm(0.0, 0.0, 0.0),
            mm(0.0, 548.8, 0.0),
            mm(0.0, 548.8, 559.2),
        ],
        Vec3::X,
        green,
    );
    b.quad(
        [
            mm(552.8, 0.0, 0.0),
            mm(549.6, 0.0, 559.2),
            mm(556.0, 548.8, 559.2),
            mm(556.0, 548.8, 0.0),
        ],
        -Vec3::X,
        red,
    );
    b.quad(
        [
            mm(343.0, 548.3, 227.0),
            mm(343.0, 548.3, 332.0),
            mm(213.0, 548.3, 332.0),
            mm(213.0, 548.3, 227.0),
        ],
        -Vec3::Y,
        light,
    );
    let short_block = [
        [
            mm(130.0, 165.0, 65.0),
            mm(82.0, 165.0, 225.0),
            mm(240.0, 165.0, 272.0),
            mm(290.0, 165.0, 114.0),
        ],
        [
            mm(290.0, 0.0, 114.0),
            mm(290.0, 165.0, 114.0),
            mm(240.0, 165.0, 272.0),
            mm(240.0, 0.0, 272.0),
        ],
        [
            mm(130.0, 0.0, 65.0),
            mm(130.0, 165.0, 65.0),
            mm(290.0, 165.0, 114.0),
            mm(290.0, 0.0, 114.0),
        ],
        [
            mm(82.0, 0.0, 225.0),
            mm(82.0, 165.0, 225.0),
            mm(130.0, 165.0, 65.0),
            mm(130.0, 0.0, 65.0),
        ],
        [
            mm(240.0, 0.0, 272.0),
            mm(240.0, 165.0, 272.0),
            mm(82.0, 165.0, 225.0),
            mm(82.0, 0.0, 225.0),
        ],
    ];
    let tall_block = [
        [
            mm(423.0, 330.0, 247.0),
            mm(265.0, 330.0, 296.0),
            mm(314.0, 330.0, 456.0),
            mm(472.0, 330.0, 406.0),
        ],
        [
            mm(423.0, 0.0, 247.0),
            mm(423.0, 330.0, 247.0),
            mm(472.0, 330.0, 406.0),
            mm(472.0, 0.0, 406.0),
        ],
        [
            mm(472.0, 0.0, 406.0),
            mm(472.0, 330.0, 406.0),
            mm(314.0, 330.0, 456.0),
            mm(314.0, 0.0, 456.0),
        ],
        [
            mm(314.0, 0.0, 456.0),
            mm(314.0, 330.0, 456.0),
            mm(265.0, 330.0, 296.0),
            mm(265.0, 0.0, 296.0),
        ],
        [
            mm(265.0, 0.0, 296.0),
            mm(265.0, 330.0, 296.0),
            mm(423.0, 330.0, 247.0),
            mm(423.0, 0.0, 247.0),
        ],
    ];
    for block in [short_block, tall_block] {
        let top = block[0];
        let center = (top[0] + top[1] + top[2] + top[3]) * 0.25 * Vec3::new(1.0, 0.5, 1.0);
        for face in block {
            let face_center = (face[0] + face[1] + face[2] + face[3]) * 0.25;
            b.quad(face, face_center - center, white);
        }
    }
    let camera = Camera::look_at(
        mm(278.0, 273.0, -800.0),
        mm(278.0, 273.0, 0.0),
        Vec3::Y,
        2.0 * (12.5f32 / 35.0).atan(),
    );
    b.finish(Vec::new(), camera)
}

/// `colonnade`: a 24 × 12 m hall, 8 m high, standing in for the temple of seed 000.
///
/// - Floor slab top at `y = 0`; walls 0.3 m thick around `x ∈ [−12, 12]`, `z ∈ [−6, 6]`.
///   The front wall (`z = 6`) has three doorways 2.4 m wide and 4 m high centred at
///   `x = −6, 0, 6`.
/// - Roof slab `y ∈ [8, 8.3]` with a 12 × 2.4 m skylight over the nave
///   (`x ∈ [−6, 6]`, `z ∈ [−1.2, 1.2]`).
/// - Two rows of seven pillars (radius 0.4 m, 24 segments, closed) at `z = ±2.6`,
///   `x = −9, −6, …, 9`, from the floor to the roof.
/// - A gallery along the back wall: slab `z ∈ [−6, −3.4]`, top at `y = 4`, with a 1 m parapet
///   along its edge, open at `x ∈ [10, 12]` where a flight of 16 solid steps (0.25 m rise,
///   0.425 m run, 2 m wide) climbs from `z = 3.4` at the floor to the gallery.
/// - Lit only by a sun: a directional light travelling along `(0.3, −1, −0.35)` normalised,
///   colour `(1, 0.96, 0.9)`, illuminance 20 (relative units, as probe-capture's default
///   daylight: a white surface facing it reflects about 20/π), entering through the skylight and the doorways.
///   Supply a sky if you want one; the scene has no emissive surfaces.
/// - Camera: in the front-left corner at `(−10.5, 1.7, 5)` looking diagonally at
///   `(6, 3.5, −3)`, across the pillars towards the gallery and stairs, 60°.
fn colonnade() -> BuiltinParts {
    let mut b = Builder::new();
    let stone = b.material(Material::diffuse("floor stone", Vec3::new(0.55, 0.5, 0.45)));
    let plaster = b.material(Material::diffuse(
        "wall plaster",
        Vec3::new(0.75, 0.72, 0.65),
    ));
    let marble = b.material(Material {
        roughness: 0.4,
        ..Material::diffuse("pillar marble", Vec3::new(0.8, 0.78, 0.74))
    });
    let wood = b.material(Material::diffuse(
        "gallery wood",
        Vec3::new(0.5, 0.35, 0.22),
    ));
    let roof = b.material(Material::diffuse("roof", Vec3::new(0.6, 0.58, 0.55)));
    let v = Vec3::new;
    // Floor.
    b.cuboid(v(-12.3, -0.3, -6.3), v(12.3, 0.0, 6.3), stone);
    // End walls span the full depth; back and front walls fit between them.
    b.cuboid(v(-12.3, 0.0, -6.3), v(-12.0, 8.0, 6.3), plaster);
    b.cuboid(v(12.0, 0.0, -6.3), v(12.3, 8.0, 6.3), plaster);
    b.cuboid(v(-12.0, 0.0, -6.3), v(12.0, 8.0, -6.0), plaster);
    for (x0, x1) in [(-12.0, -7.2), (-4.8, -1.2), (1.2, 4.8), (7.2, 12.0)] {
        b.cuboid(v(x0, 0.0, 6.0), v(x1, 8.0, 6.3), plaster);
    }
    for (x0, x1) in [(-7.2, -4.8), (-1.2, 1.2), (4.8, 7.2)] {
        b.cuboid(v(x0, 4.0, 6.0), v(x1, 8.0, 6.3), plaster);
    }
    // Roof around the skylight.
    b.cuboid(v(-12.3, 8.0, -6.3), v(12.3, 8.3, -1.2), roof);
    b.cuboid(v(-12.3, 8.0, 1.2), v(12.3, 8.3, 6.3), roof);
    b.cuboid(v(-12.3, 8.0, -1.2), v(-6.0, 8.3, 1.2), roof);
    b.cuboid(v(6.0, 8.0, -1.2), v(12.3, 8.3, 1.2), roof);
    // Pillars.
    for z in [-2.6, 2.6] {
        for i in -3..=3 {
            b.cylinder(v(3.0 * i as f32, 0.0, z), 0.4, 8.0, 24, marble);
        }
    }
    // Gallery, parapet and stairs.
    b.cuboid(v(-12.0, 3.75, -6.0), v(12.0, 4.0, -3.4), wood);
    b.cuboid(v(-12.0, 4.0, -3.4), v(10.0, 5.0, -3.25), plaster);
    let (rise, run) = (0.25, 0.425);
    for k in 0..16 {
        let z1 = 3.4 - k as f32 * run;
        b.cuboid(
            v(10.0, 0.0, z1 - run),
            v(12.0, (k + 1) as f32 * rise, z1),
            stone,
        );
    }
    let sun = Light::Directional {
        name: "sun".to_owned(),
        direction: v(0.3, -1.0, -0.35).normalize(),
        color: v(1.0, 0.96, 0.9),
        illuminance: 20.0,
        range: None,
    };
    let camera = Camera::look_at(
        v(-10.5, 1.7, 5.0),
        v(6.0, 3.5, -3.0),
        Vec3::Y,
        60f32.to_radians(),
    );
    b.finish(vec![sun], camera)
}

/// `boxes`: seed 003's failure case (§8.3, Fig. 8.2), a closed room in which a regular grid
/// puts every probe inside a small box.
///
/// - Room interior `x, z ∈ [−4, 4]`, `y ∈ [0, 3]`, enclosed by 0.2 m slabs, so the scene's
///   bounds are `[−4.2, −0.2, −4.2] .. [4.2, 3.2, 4.2]`.
/// - 32 closed cubes of edge [`BOXES_BOX_SIZE`] (0.3 m), facing outward, centred exactly on
///   the cell centres of the [`BOXES_GRID`] (`grid:4x2x4`) over those bounds
///   ([`grid_cell_centers`]): `x, z ∈ {−3.15, −1.05, 1.05, 3.15}`, `y ∈ {0.65, 2.35}`.
/// - Light: a 1 × 1 m emissive quad 1 cm under the ceiling centre, facing down, radiance 10.
/// - Camera: `(−3.7, 1.6, 3.7)` looking at `(0, 1, 0)`, 60°.
fn boxes() -> BuiltinParts {
    let mut b = Builder::new();
    let wall = b.material(Material::diffuse("wall", Vec3::splat(0.8)));
    let floor = b.material(Material::diffuse("floor", Vec3::splat(0.5)));
    let boxes = b.material(Material::diffuse("box", Vec3::new(0.7, 0.45, 0.2)));
    let light = b.material(Material::emitter("light", Vec3::splat(10.0)));
    let v = Vec3::new;
    let (inner, t) = (4.0, 0.2);
    let outer = inner + t;
    b.cuboid(v(-outer, -t, -outer), v(outer, 0.0, outer), floor);
    b.cuboid(v(-outer, 3.0, -outer), v(outer, 3.0 + t, outer), wall);
    b.cuboid(v(-outer, 0.0, -outer), v(-inner, 3.0, outer), wall);
    b.cuboid(v(inner, 0.0, -outer), v(outer, 3.0, outer), wall);
    b.cuboid(v(-inner, 0.0, -outer), v(inner, 3.0, -inner), wall);
    b.cuboid(v(-inner, 0.0, inner), v(inner, 3.0, outer), wall);
    let bounds = Aabb::new(v(-outer, -t, -outer), v(outer, 3.0 + t, outer));
    let half = Vec3::splat(0.5 * BOXES_BOX_SIZE);
    for center in grid_cell_centers(&bounds, BOXES_GRID) {
        b.cuboid(center - half, center + half, boxes);
    }
    b.quad(
        [
            v(-0.5, 2.99, -0.5),
            v(0.5, 2.99, -0.5),
            v(0.5, 2.99, 0.5),
            v(-0.5, 2.99, 0.5),
        ],
        -Vec3::Y,
        light,
    );
    let camera = Camera::look_at(
        v(-3.7, 1.6, 3.7),
        v(0.0, 1.0, 0.0),
        Vec3::Y,
        60f32.to_radians(),
    );
    b.finish(Vec::new(), camera)
}

/// `leak-closed` and `leak-gap`: seed 001's leak test (§5.1): a lit room beside a dark one.
///
/// - Two rooms 4 × 3 × 4 m ([`LEAK_LIT_ROOM`] at `x < 0`, [`LEAK_DARK_ROOM`] at `x > 0`)
///   enclosed by 0.2 m slabs; the dividing wall is the slab `x ∈ [−0.1, 0.1]`.
/// - `leak-closed`: the dividing wall is complete, so no ray from the lit room reaches the dark
///   room. `leak-gap`: the wall stops at `z = 1.2`, leaving a full-height 0.8 m gap
///   ([`LEAK_GAP`]) at the `+Z` end.
/// - Light: a 1 × 1 m emissive quad 1 cm under the lit room's ceiling, centred at
///   `(−2.1, 2.99, 0)`, facing down, radiance 10. The dark room has no light.
/// - Camera: in the dark room at `(3.8, 1.6, −1.7)` looking at `(0.1, 1.2, 1.0)`, towards the
///   dividing wall (and the gap), 60°.
fn leak(gap: bool) -> BuiltinParts {
    let mut b = Builder::new();
    let wall = b.material(Material::diffuse("wall", Vec3::splat(0.8)));
    let floor = b.material(Material::diffuse("floor", Vec3::splat(0.5)));
    let divider = b.material(Material::diffuse(
        "dividing wall",
        Vec3::new(0.7, 0.7, 0.75),
    ));
    let light = b.material(Material::emitter("light", Vec3::splat(10.0)));
    let v = Vec3::new;
    let (lit, dark) = (LEAK_LIT_ROOM, LEAK_DARK_ROOM);
    let t = 0.2;
    let (x0, x1) = (lit.min.x - t, dark.max.x + t);
    let (z0, z1) = (lit.min.z, lit.max.z);
    let height = lit.max.y;
    b.cuboid(v(x0, -t, z0 - t), v(x1, 0.0, z1 + t), floor);
    b.cuboid(v(x0, height, z0 - t), v(x1, height + t, z1 + t), wall);
    b.cuboid(v(x0, 0.0, z0 - t), v(lit.min.x, height, z1 + t), wall);
    b.cuboid(v(dark.max.x, 0.0, z0 - t), v(x1, height, z1 + t), wall);
    b.cuboid(v(lit.min.x, 0.0, z0 - t), v(dark.max.x, height, z0), wall);
    b.cuboid(v(lit.min.x, 0.0, z1), v(dark.max.x, height, z1 + t), wall);
    let divider_end = if gap { LEAK_GAP.min.z } else { z1 };
    b.cuboid(
        v(lit.max.x, 0.0, z0),
        v(dark.min.x, height, divider_end),
        divider,
    );
    let (cx, cy) = (0.5 * (lit.min.x + lit.max.x), height - 0.01);
    b.quad(
        [
            v(cx - 0.5, cy, -0.5),
            v(cx + 0.5, cy, -0.5),
            v(cx + 0.5, cy, 0.5),
            v(cx - 0.5, cy, 0.5),
        ],
        -Vec3::Y,
        light,
    );
    let camera = Camera::look_at(
        v(3.8, 1.6, -1.7),
        v(0.1, 1.2, 1.0),
        Vec3::Y,
        60f32.to_radians(),
    );
    b.finish(Vec::new(), camera)
}
