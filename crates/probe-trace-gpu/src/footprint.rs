//! The bytes an uploaded field takes on the device, buffer by buffer, and the check of those
//! buffers against a device's limits: what a user runs before baking, and what
//! [`GpuTracer`](crate::GpuTracer) runs before creating any buffer.

use crate::error::UploadError;
use crate::input::{Interpolation, ProbeSelection};
use crate::packed::{HULL_WORDS, NEAREST_ROW, TET_WORDS, padded_len};

/// One storage buffer the GPU tracer creates for an uploaded field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceBuffer {
    /// The buffer's name, as [`UploadError::DeviceLimit`] gives it.
    pub name: &'static str,
    /// Its size in bytes.
    pub bytes: u64,
    /// What to lower when it does not fit (what its size grows with).
    pub lower: &'static str,
}

/// The storage buffers of an uploaded field and their sizes: exactly what
/// [`GpuTracer`](crate::GpuTracer) allocates for it. Each is bound whole, so each must fit
/// both `max_buffer_size` and `max_storage_buffer_binding_size` of the device
/// ([`DeviceFootprint::check`]).
///
/// ```
/// use probe_trace_gpu::DeviceFootprint;
///
/// // 16,384 probes at 128²: the geometry buffer alone is 16,384 × 130² × 16 bytes.
/// let footprint = DeviceFootprint::light_field(16_384, 128, None);
/// assert_eq!(footprint.buffer("geometry").unwrap().bytes, 16_384 * 130 * 130 * 16);
/// // WebGPU's default limits bind at most 128 MiB: refused, naming the buffer and the fix.
/// let error = footprint.check(&wgpu::Limits::default()).unwrap_err();
/// assert!(error.to_string().contains("max_storage_buffer_binding_size"));
/// // 64 probes at 128² fit.
/// assert!(DeviceFootprint::light_field(64, 128, None).check(&wgpu::Limits::default()).is_ok());
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceFootprint {
    buffers: Vec<DeviceBuffer>,
}

/// Bytes of one element of each light-field buffer (see `PackedField`).
const POSITION_BYTES: u64 = 16;
const GEOMETRY_TEXEL_BYTES: u64 = 16;
const PYRAMID_TEXEL_BYTES: u64 = 16;
const RADIANCE_TEXEL_BYTES: u64 = 12;
const WORD_BYTES: u64 = 4;

/// What to lower for buffers that hold texels of every probe.
const LOWER_PROBES_OR_RESOLUTION: &str =
    "upload fewer probes (split the set) or bake at a lower resolution";

impl DeviceFootprint {
    /// The buffers [`Tracer::upload`](crate::Tracer::upload) creates for `probes` probes
    /// at interior resolution `resolution` (a power of two from 8 to 4096; other values give
    /// the footprint the formula gives, which the upload then refuses) with `selection`
    /// (`None`: a regular grid, whose own data is a few words; an octree or Voronoi
    /// neighbour maps add theirs).
    pub fn light_field(
        probes: usize,
        resolution: u32,
        selection: Option<&ProbeSelection<'_>>,
    ) -> DeviceFootprint {
        Self::light_field_with_glossy(probes, resolution, 0, selection)
    }

    /// [`Self::light_field`] for a field uploaded with `glossy_levels` prefiltered glossy
    /// levels ([`crate::FieldOptions::glossy_levels`], clamped as there), which the radiance
    /// buffer holds after level 0.
    pub fn light_field_with_glossy(
        probes: usize,
        resolution: u32,
        glossy_levels: u32,
        selection: Option<&ProbeSelection<'_>>,
    ) -> DeviceFootprint {
        let p = probes as u64;
        let texels = p * padded_len(resolution) as u64;
        let glossy_texels = if resolution.is_power_of_two() {
            let levels = crate::packed::glossy_level_count(resolution, glossy_levels);
            p * crate::packed::glossy_texels_per_probe(resolution, levels) as u64
        } else {
            0
        };
        let levels = if resolution.is_power_of_two() {
            resolution.trailing_zeros() + 1
        } else {
            1
        };
        let pyramid_texels: u64 = (1..levels)
            .map(|level| p * u64::from(resolution >> level).pow(2))
            .sum();
        // Selection words (PackedSelection::new): the selection's own data, the k-d tree of
        // the positions (4 words per probe), the nearest-probe table (16 words per probe).
        let own = match selection {
            None | Some(ProbeSelection::Grid(_)) => 4 * p,
            Some(ProbeSelection::SparseVoxelOctree(svo)) => {
                svo.nodes().len() as u64
                    + 4 * svo.leaves().len() as u64
                    + svo.blocks().len() as u64
                    + 4 * p
            }
            Some(ProbeSelection::Voronoi {
                nearest,
                neighbours,
            }) => 4 * nearest.nodes().len() as u64 + neighbours.table().len() as u64,
        };
        let words = (own + u64::from(NEAREST_ROW) * p).max(1);
        DeviceFootprint {
            buffers: vec![
                DeviceBuffer {
                    name: "positions",
                    bytes: p * POSITION_BYTES,
                    lower: "upload fewer probes",
                },
                DeviceBuffer {
                    name: "geometry",
                    bytes: texels * GEOMETRY_TEXEL_BYTES,
                    lower: LOWER_PROBES_OR_RESOLUTION,
                },
                DeviceBuffer {
                    name: "pyramid",
                    bytes: (pyramid_texels * PYRAMID_TEXEL_BYTES).max(PYRAMID_TEXEL_BYTES),
                    lower: LOWER_PROBES_OR_RESOLUTION,
                },
                DeviceBuffer {
                    name: "radiance",
                    // The probes' maps, their glossy levels, then the sky map (N² texels).
                    bytes: (texels + glossy_texels + u64::from(resolution).pow(2))
                        * RADIANCE_TEXEL_BYTES,
                    lower: LOWER_PROBES_OR_RESOLUTION,
                },
                DeviceBuffer {
                    name: "selection",
                    bytes: words * WORD_BYTES,
                    lower: "upload fewer probes or a shallower octree",
                },
            ],
        }
    }

    /// The buffers [`Tracer::upload_irradiance`](crate::Tracer::upload_irradiance) creates
    /// for `probes` probes with irradiance maps of interior resolution `irradiance_resolution`
    /// and moment maps of `moments_resolution`, interpolated by `interpolation` (`None`: a
    /// regular grid), with `surfels_per_probe` surfels each
    /// ([`IrradianceField::surfels`](crate::IrradianceField::surfels); 0 for none).
    pub fn irradiance(
        probes: usize,
        irradiance_resolution: u32,
        moments_resolution: u32,
        interpolation: Option<&Interpolation<'_>>,
        surfels_per_probe: usize,
    ) -> DeviceFootprint {
        let p = probes as u64;
        // With surfels, each probe's surfel irradiance map follows the irradiance maps.
        let maps = if surfels_per_probe > 0 { 2 } else { 1 };
        let words = match interpolation {
            None | Some(Interpolation::Grid(_)) => 1,
            Some(Interpolation::Delaunay(tets)) => {
                (tets.tetrahedra().len() * TET_WORDS + tets.hull_faces().len() * HULL_WORDS) as u64
                    + 5 * p
            }
        };
        DeviceFootprint {
            buffers: vec![
                DeviceBuffer {
                    name: "irradiance positions",
                    bytes: p * POSITION_BYTES,
                    lower: "upload fewer probes",
                },
                DeviceBuffer {
                    name: "irradiance",
                    bytes: maps * p * padded_len(irradiance_resolution) as u64 * 12,
                    lower: "upload fewer probes or lower the irradiance resolution",
                },
                DeviceBuffer {
                    name: "surfels",
                    // One zero vec4 stands in for none.
                    bytes: if surfels_per_probe > 0 {
                        p * surfels_per_probe as u64 * crate::packed::SURFEL_VEC4S as u64 * 16
                    } else {
                        16
                    },
                    lower: "upload fewer probes or bake fewer surfels per probe",
                },
                DeviceBuffer {
                    name: "moments",
                    bytes: p * padded_len(moments_resolution) as u64 * 8,
                    lower: "upload fewer probes or lower the moments resolution",
                },
                DeviceBuffer {
                    name: "interpolation",
                    bytes: words.max(1) * WORD_BYTES,
                    lower: "upload fewer probes",
                },
            ],
        }
    }

    /// The buffers, in the order the tracer creates them.
    pub fn buffers(&self) -> &[DeviceBuffer] {
        &self.buffers
    }

    /// The buffer named `name`, if the field has one.
    pub fn buffer(&self, name: &str) -> Option<DeviceBuffer> {
        self.buffers.iter().copied().find(|b| b.name == name)
    }

    /// Bytes of all the buffers together.
    pub fn total_bytes(&self) -> u64 {
        self.buffers.iter().map(|b| b.bytes).sum()
    }

    /// The largest buffer.
    pub fn largest(&self) -> Option<DeviceBuffer> {
        self.buffers.iter().copied().max_by_key(|b| b.bytes)
    }

    /// Checks every buffer against the device's `max_buffer_size` and
    /// `max_storage_buffer_binding_size` (each buffer is one binding).
    ///
    /// # Errors
    /// [`UploadError::DeviceLimit`] for the first buffer over a limit, naming the buffer, its
    /// size, the limit and what to lower.
    pub fn check(&self, limits: &wgpu::Limits) -> Result<(), UploadError> {
        self.buffers
            .iter()
            .try_for_each(|b| check_buffer(b.name, b.bytes, b.lower, limits))
    }
}

/// Checks one buffer of `bytes` against the device's buffer and storage-binding limits.
pub(crate) fn check_buffer(
    name: &'static str,
    bytes: u64,
    lower: &'static str,
    limits: &wgpu::Limits,
) -> Result<(), UploadError> {
    let over = |limit_name: &'static str, limit: u64| UploadError::DeviceLimit {
        buffer: name,
        bytes,
        limit_name,
        limit,
        lower,
    };
    // The smaller limit first: it is the one to quote.
    let mut checks = [
        (
            "max_storage_buffer_binding_size",
            limits.max_storage_buffer_binding_size,
        ),
        ("max_buffer_size", limits.max_buffer_size),
    ];
    checks.sort_by_key(|c| c.1);
    for (limit_name, limit) in checks {
        if bytes > limit {
            return Err(over(limit_name, limit));
        }
    }
    Ok(())
}

/// `bytes` as `N bytes (X.Y MiB)`.
pub(crate) fn describe_bytes(bytes: u64) -> String {
    const MIB: f64 = 1024.0 * 1024.0;
    if bytes >= 1 << 30 {
        format!("{bytes} bytes ({:.2} GiB)", bytes as f64 / (MIB * 1024.0))
    } else {
        format!("{bytes} bytes ({:.1} MiB)", bytes as f64 / MIB)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::{FieldOptions, LightField};
    use crate::packed::{PackedField, PackedIrradiance, PackedSelection};
    use glam::{Vec2, Vec3};
    use probe_index::{
        NearestProbe, ProbeGrid, SparseVoxelOctree, SvoOptions, Tetrahedralization,
        VoronoiNeighbours,
    };

    fn positions(probes: usize) -> Vec<Vec3> {
        (0..probes)
            .map(|i| {
                Vec3::new(
                    (i % 3) as f32 * 0.15 + 0.1,
                    ((i / 3) % 3) as f32 * 0.15 + 0.1 + 0.003 * i as f32,
                    (i / 9) as f32 * 0.15 + 0.1,
                )
            })
            .collect()
    }

    /// The footprint is the byte size of what the tracer packs and uploads, for every
    /// selection and interpolation.
    #[test]
    fn footprints_are_the_packed_sizes() {
        let n = 16;
        let probes = 27;
        let positions = positions(probes);
        let len = padded_len(n) * probes;
        let distance = vec![1.0f32; len];
        let normals = vec![Vec3::Y; len];
        let radiance = vec![Vec3::ONE; len];
        let field = LightField {
            resolution: n,
            positions: &positions,
            radial_distance: &distance,
            normals: &normals,
            radiance: &radiance,
            distance_range: None,
            sky_distance: 100.0,
            geometry_bounds: None,
        };
        let packed = PackedField::new(&field, &FieldOptions::default()).unwrap();
        // Prefiltered glossy levels (asked for more than a 16² map has: clamped to 3).
        let glossy = PackedField::new(
            &field,
            &FieldOptions {
                glossy_levels: 9,
                ..FieldOptions::default()
            },
        )
        .unwrap();
        assert_eq!(glossy.glossy_levels, 3);
        assert_eq!(
            DeviceFootprint::light_field_with_glossy(probes, n, 9, None).buffers()[3].bytes,
            (glossy.radiance.len() * 4) as u64
        );
        let grid = ProbeGrid::new(Vec3::ZERO, Vec3::ONE, [3, 3, 3]).unwrap();
        let tets = Tetrahedralization::build(&positions).unwrap();
        let neighbours = VoronoiNeighbours::bake(&tets, 8).unwrap();
        let nearest = NearestProbe::new(&positions);
        let scene = probe_scene::Scene::builtin("cornell").unwrap();
        let svo = SparseVoxelOctree::build(
            &scene,
            &positions,
            &SvoOptions {
                max_depth: 4,
                ..SvoOptions::default()
            },
        )
        .unwrap();
        let selections = [
            ProbeSelection::Grid(grid),
            ProbeSelection::SparseVoxelOctree(&svo),
            ProbeSelection::Voronoi {
                nearest: &nearest,
                neighbours: &neighbours,
            },
        ];
        for selection in &selections {
            let footprint = DeviceFootprint::light_field(probes, n, Some(selection));
            let words = PackedSelection::new(selection, &positions).unwrap().words;
            let bytes = |v: usize, size: usize| (v * size) as u64;
            assert_eq!(
                footprint
                    .buffers()
                    .iter()
                    .map(|b| (b.name, b.bytes))
                    .collect::<Vec<_>>(),
                vec![
                    ("positions", bytes(packed.positions.len(), 16)),
                    ("geometry", bytes(packed.geometry.len(), 16)),
                    ("pyramid", bytes(packed.pyramid.len(), 16)),
                    ("radiance", bytes(packed.radiance.len(), 4)),
                    ("selection", bytes(words.len(), 4)),
                ],
                "{}",
                selection.name()
            );
        }
        assert_eq!(
            DeviceFootprint::light_field(probes, n, None),
            DeviceFootprint::light_field(probes, n, Some(&selections[0]))
        );

        let (r, m) = (6, 14);
        let irradiance = vec![Vec3::ONE; padded_len(r) * probes];
        let moments = vec![Vec2::ONE; padded_len(m) * probes];
        let surfels = vec![probe_octa::Surfel::default(); 4 * probes];
        for (interpolation, surfels) in [
            (Interpolation::Grid(grid), &surfels[..0]),
            (Interpolation::Delaunay(&tets), &surfels[..]),
        ] {
            let low = crate::input::IrradianceField {
                positions: &positions,
                irradiance_resolution: r,
                irradiance: &irradiance,
                moments_resolution: m,
                moments: &moments,
                surfels,
                inside_geometry: &[],
            };
            let packed = PackedIrradiance::new(&low, &interpolation).unwrap();
            let footprint = DeviceFootprint::irradiance(
                probes,
                r,
                m,
                Some(&interpolation),
                surfels.len() / probes,
            );
            assert_eq!(
                footprint
                    .buffers()
                    .iter()
                    .map(|b| b.bytes)
                    .collect::<Vec<_>>(),
                vec![
                    (packed.positions.len() * 16) as u64,
                    (packed.irradiance.len() * 4) as u64,
                    (packed.surfels.len() * 16) as u64,
                    (packed.moments.len() * 8) as u64,
                    (packed.words.len() * 4) as u64,
                ]
            );
        }
    }

    #[test]
    fn limits_name_the_buffer_the_size_and_the_fix() {
        let footprint = DeviceFootprint::light_field(64, 128, None);
        let geometry = footprint.buffer("geometry").unwrap().bytes;
        assert_eq!(geometry, 64 * 130 * 130 * 16);
        assert_eq!(footprint.largest().unwrap().name, "geometry");
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: geometry - 4,
            max_buffer_size: 1 << 40,
            ..wgpu::Limits::default()
        };
        let error = footprint.check(&limits).unwrap_err();
        assert_eq!(
            error,
            UploadError::DeviceLimit {
                buffer: "geometry",
                bytes: geometry,
                limit_name: "max_storage_buffer_binding_size",
                limit: geometry - 4,
                lower: LOWER_PROBES_OR_RESOLUTION,
            }
        );
        let message = error.to_string();
        assert!(
            message.contains("`geometry`")
                && message.contains("17305600 bytes")
                && message.contains("lower resolution"),
            "{message}"
        );
        // The smaller of the two limits is the one quoted.
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: 1 << 40,
            max_buffer_size: 1 << 20,
            ..wgpu::Limits::default()
        };
        assert!(matches!(
            footprint.check(&limits),
            Err(UploadError::DeviceLimit {
                buffer: "geometry",
                limit_name: "max_buffer_size",
                limit: 1_048_576,
                ..
            })
        ));
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: geometry,
            max_buffer_size: geometry,
            ..wgpu::Limits::default()
        };
        assert!(footprint.check(&limits).is_ok());
        assert_eq!(
            footprint.total_bytes(),
            footprint.buffers().iter().map(|b| b.bytes).sum::<u64>()
        );
    }
}
