//! Tests that need no GPU: every shader passes naga's validation, and every `#[repr(C)]` struct
//! shared with WGSL has the layout WGSL gives it.

use std::mem::{offset_of, size_of};

use naga::valid::{Capabilities, ValidationFlags, Validator};

use super::{DIFFUSE_WGSL, TRACE_WGSL};
use crate::packed::{DiffuseParams, TraceParams};
use crate::ray::{RayRecord, ShadingPoint, TraceRay};

fn parse(name: &str, source: &str) -> naga::Module {
    naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)))
}

#[test]
fn shaders_pass_naga_validation() {
    for (name, source) in [("trace", TRACE_WGSL), ("diffuse", DIFFUSE_WGSL)] {
        let module = parse(name, source);
        Validator::new(ValidationFlags::all(), Capabilities::default())
            .validate(&module)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)));
        let entry = if name == "trace" {
            "trace_main"
        } else {
            "diffuse_main"
        };
        assert!(
            module.entry_points.iter().any(|e| e.name == entry),
            "{name} lacks `{entry}`"
        );
    }
}

/// Size and member offsets of the WGSL struct `name`.
fn wgsl_struct(module: &naga::Module, name: &str) -> (u32, Vec<(String, u32)>) {
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).expect("layout");
    for (handle, ty) in module.types.iter() {
        if ty.name.as_deref() == Some(name)
            && let naga::TypeInner::Struct { members, span } = &ty.inner
        {
            assert_eq!(*span, layouter[handle].size);
            let offsets = members
                .iter()
                .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                .collect();
            return (*span, offsets);
        }
    }
    panic!("no struct `{name}` in the shader");
}

fn check(module: &naga::Module, name: &str, size: usize, fields: &[(&str, usize)]) {
    let (wgsl_size, members) = wgsl_struct(module, name);
    assert_eq!(wgsl_size as usize, size, "size of {name}");
    for (field, offset) in fields {
        let found = members
            .iter()
            .find(|(m, _)| m == field)
            .unwrap_or_else(|| panic!("{name} has no member `{field}`"));
        assert_eq!(found.1 as usize, *offset, "offset of {name}.{field}");
    }
}

#[test]
fn shared_structs_match_the_wgsl_layout() {
    let trace = parse("trace", TRACE_WGSL);
    check(
        &trace,
        "TraceRay",
        size_of::<TraceRay>(),
        &[
            ("origin", offset_of!(TraceRay, origin)),
            ("t_min", offset_of!(TraceRay, t_min)),
            ("direction", offset_of!(TraceRay, direction)),
            ("t_max", offset_of!(TraceRay, t_max)),
        ],
    );
    check(
        &trace,
        "RayRecord",
        size_of::<RayRecord>(),
        &[
            ("position", offset_of!(RayRecord, position)),
            ("t", offset_of!(RayRecord, t)),
            ("normal", offset_of!(RayRecord, normal)),
            ("status", offset_of!(RayRecord, status)),
            ("radiance", offset_of!(RayRecord, radiance)),
            ("probe", offset_of!(RayRecord, probe)),
            ("probes_tried", offset_of!(RayRecord, probes_tried)),
            ("texel_fetches", offset_of!(RayRecord, texel_fetches)),
        ],
    );
    check(
        &trace,
        "GridParams",
        size_of::<probe_index::GridParams>(),
        &[
            ("origin", offset_of!(probe_index::GridParams, origin)),
            ("count_x", offset_of!(probe_index::GridParams, count_x)),
            ("spacing", offset_of!(probe_index::GridParams, spacing)),
            ("count_y", offset_of!(probe_index::GridParams, count_y)),
            ("count_z", offset_of!(probe_index::GridParams, count_z)),
        ],
    );
    check(
        &trace,
        "SvoHeader",
        size_of::<probe_index::SvoHeader>(),
        &[
            ("origin", offset_of!(probe_index::SvoHeader, origin)),
            ("size", offset_of!(probe_index::SvoHeader, size)),
            ("depth", offset_of!(probe_index::SvoHeader, depth)),
            (
                "packed_bits",
                offset_of!(probe_index::SvoHeader, packed_bits),
            ),
        ],
    );
    check(
        &trace,
        "TraceParams",
        size_of::<TraceParams>(),
        &[
            ("resolution", offset_of!(TraceParams, resolution)),
            ("ray_count", offset_of!(TraceParams, ray_count)),
            ("threads_per_row", offset_of!(TraceParams, threads_per_row)),
            ("method", offset_of!(TraceParams, method)),
            ("top_level", offset_of!(TraceParams, top_level)),
            ("coarse_level", offset_of!(TraceParams, coarse_level)),
            ("max_probes", offset_of!(TraceParams, max_probes)),
            ("selector", offset_of!(TraceParams, selector)),
            (
                "back_face_rejection",
                offset_of!(TraceParams, back_face_rejection),
            ),
            ("level_count", offset_of!(TraceParams, level_count)),
            ("max_steps", offset_of!(TraceParams, max_steps)),
            ("sky_distance", offset_of!(TraceParams, sky_distance)),
            ("thickness_scale", offset_of!(TraceParams, thickness_scale)),
            (
                "nearest_candidates",
                offset_of!(TraceParams, nearest_candidates),
            ),
            ("nearest_table", offset_of!(TraceParams, nearest_table)),
            ("level_offsets", offset_of!(TraceParams, level_offsets)),
            ("grid", offset_of!(TraceParams, grid)),
            ("svo", offset_of!(TraceParams, svo)),
            ("svo_nodes", offset_of!(TraceParams, svo_nodes)),
            ("svo_leaves", offset_of!(TraceParams, svo_leaves)),
            ("svo_blocks", offset_of!(TraceParams, svo_blocks)),
            ("kd_nodes", offset_of!(TraceParams, kd_nodes)),
            ("kd_count", offset_of!(TraceParams, kd_count)),
            ("neighbour_table", offset_of!(TraceParams, neighbour_table)),
            (
                "neighbour_resolution",
                offset_of!(TraceParams, neighbour_resolution),
            ),
            ("glossy_levels", offset_of!(TraceParams, glossy_levels)),
            ("glossy_tan", offset_of!(TraceParams, glossy_tan)),
            ("glossy_angle", offset_of!(TraceParams, glossy_angle)),
            (
                "glossy_base_angle",
                offset_of!(TraceParams, glossy_base_angle),
            ),
            ("glossy_blend", offset_of!(TraceParams, glossy_blend)),
            ("glossy_offsets", offset_of!(TraceParams, glossy_offsets)),
            ("bounds_min", offset_of!(TraceParams, bounds_min)),
            ("bounds_max", offset_of!(TraceParams, bounds_max)),
            ("sky_map", offset_of!(TraceParams, sky_map)),
        ],
    );
    let diffuse = parse("diffuse", DIFFUSE_WGSL);
    check(
        &diffuse,
        "ShadingPoint",
        size_of::<ShadingPoint>(),
        &[
            ("position", offset_of!(ShadingPoint, position)),
            ("normal", offset_of!(ShadingPoint, normal)),
        ],
    );
    check(
        &diffuse,
        "DiffuseParams",
        size_of::<DiffuseParams>(),
        &[
            ("point_count", offset_of!(DiffuseParams, point_count)),
            (
                "threads_per_row",
                offset_of!(DiffuseParams, threads_per_row),
            ),
            ("probe_count", offset_of!(DiffuseParams, probe_count)),
            ("interpolation", offset_of!(DiffuseParams, interpolation)),
            (
                "irradiance_resolution",
                offset_of!(DiffuseParams, irradiance_resolution),
            ),
            (
                "moments_resolution",
                offset_of!(DiffuseParams, moments_resolution),
            ),
            ("visibility", offset_of!(DiffuseParams, visibility)),
            ("max_walk_steps", offset_of!(DiffuseParams, max_walk_steps)),
            ("normal_bias", offset_of!(DiffuseParams, normal_bias)),
            ("hull", offset_of!(DiffuseParams, hull)),
            ("hull_count", offset_of!(DiffuseParams, hull_count)),
            (
                "visibility_exponent",
                offset_of!(DiffuseParams, visibility_exponent),
            ),
            ("grid", offset_of!(DiffuseParams, grid)),
            ("tets", offset_of!(DiffuseParams, tets)),
            ("tet_count", offset_of!(DiffuseParams, tet_count)),
            ("vertex_tets", offset_of!(DiffuseParams, vertex_tets)),
            ("kd_nodes", offset_of!(DiffuseParams, kd_nodes)),
            ("kd_count", offset_of!(DiffuseParams, kd_count)),
            ("min_weight", offset_of!(DiffuseParams, min_weight)),
            ("backface", offset_of!(DiffuseParams, backface)),
            ("max_hull_steps", offset_of!(DiffuseParams, max_hull_steps)),
        ],
    );
}

/// The value of the WGSL `u32` constant `name`.
fn wgsl_u32_constant(module: &naga::Module, name: &str) -> u32 {
    let constant = module
        .constants
        .iter()
        .map(|(_, c)| c)
        .find(|c| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no WGSL constant `{name}`"));
    match module.global_expressions[constant.init] {
        naga::Expression::Literal(naga::Literal::U32(v)) => v,
        ref other => panic!("`{name}` is {other:?}, not a u32 literal"),
    }
}

/// The packed diffuse layout's constants are the shader's.
#[test]
fn diffuse_constants_match_the_wgsl() {
    use crate::packed::{HULL_FACE, HULL_WORDS, MAX_HULL_FAN, TET_WORDS};
    let diffuse = parse("diffuse", DIFFUSE_WGSL);
    for (name, value) in [
        ("TET_WORDS", TET_WORDS as u32),
        ("HULL_WORDS", HULL_WORDS as u32),
        ("HULL_FACE", HULL_FACE),
        ("MAX_HULL_FAN", MAX_HULL_FAN),
    ] {
        assert_eq!(wgsl_u32_constant(&diffuse, name), value, "{name}");
    }
}

#[test]
fn an_opengl_fallback_is_named_and_other_backends_are_not() {
    let info = |backend| wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, backend);
    let note = super::backend_note(&info(wgpu::Backend::Gl)).expect("GL is named");
    assert!(note.contains("mesa-vulkan-drivers"), "{note}");
    assert_eq!(super::backend_note(&info(wgpu::Backend::Vulkan)), None);
}
