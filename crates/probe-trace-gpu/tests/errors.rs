//! Bad input gets an error naming the parameter, element or structure, never a panic.

mod support;

use glam::Vec3;
use probe_index::{NearestProbe, ProbeGrid, Tetrahedralization, VoronoiNeighbours};
use probe_trace_gpu::{
    CpuTracer, FieldOptions, LightField, ProbeSelection, TraceError, TraceOptions, TraceRay,
    Tracer, UploadError,
};
use support::Bake;

/// An `n×n` field of `probes` probes in a row, analytically.
fn field(n: u32, probes: usize) -> Bake {
    Bake::flat(
        n,
        (0..probes)
            .map(|i| Vec3::new(0.1 * i as f32, 0.0, 0.0))
            .collect(),
    )
}

fn grid_of_8() -> ProbeGrid {
    ProbeGrid::new(Vec3::ZERO, Vec3::ONE, [2, 2, 2]).unwrap()
}

fn upload(field: &LightField<'_>, selection: &ProbeSelection<'_>) -> Result<(), UploadError> {
    CpuTracer::new()
        .upload(field, selection, &FieldOptions::default())
        .map(drop)
}

#[test]
fn upload_errors_name_what_is_wrong() {
    let f = field(16, 8);
    let grid = ProbeSelection::Grid(grid_of_8());
    assert!(upload(&f.field(), &grid).is_ok());

    for bad in [0, 4, 12, 8192] {
        let mut g = field(bad.min(16), 8);
        g.resolution = bad;
        let e = upload(&g.field(), &grid).unwrap_err();
        assert!(
            matches!(e, UploadError::Resolution { parameter: "resolution", value, .. } if value == bad),
            "{e}"
        );
    }

    // Geometry bounds must be finite boxes.
    for (bounds, parameter) in [
        ([Vec3::ONE, Vec3::ZERO], "geometry_bounds"),
        (
            [Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ONE],
            "geometry_bounds[0]",
        ),
        (
            [Vec3::ZERO, Vec3::splat(f32::INFINITY)],
            "geometry_bounds[1]",
        ),
    ] {
        let boxed = LightField {
            geometry_bounds: Some(bounds),
            ..f.field()
        };
        let e = upload(&boxed, &grid).unwrap_err();
        assert!(
            matches!(e, UploadError::BadParameter { parameter: p, .. } if p == parameter),
            "{e}"
        );
        assert!(e.to_string().contains(parameter), "{e}");
    }

    let short = LightField {
        radial_distance: &f.distance[1..],
        ..f.field()
    };
    let e = upload(&short, &grid).unwrap_err();
    assert_eq!(
        e,
        UploadError::LengthMismatch {
            parameter: "radial_distance",
            expected: 8 * 18 * 18,
            actual: 8 * 18 * 18 - 1
        }
    );
    assert!(e.to_string().contains("radial_distance"));

    let mut g = field(16, 8);
    g.distance[77] = f32::NAN;
    let e = upload(&g.field(), &grid).unwrap_err();
    assert_eq!(
        e,
        UploadError::NonFinite {
            parameter: "radial_distance",
            index: 77
        }
    );
    let mut g = field(16, 8);
    g.distance[5] = -1.0;
    assert!(matches!(
        upload(&g.field(), &grid),
        Err(UploadError::NegativeDistance { index: 5, .. })
    ));
    let mut g = field(16, 8);
    g.normals[9] = Vec3::new(f32::INFINITY, 0.0, 0.0);
    assert!(matches!(
        upload(&g.field(), &grid),
        Err(UploadError::NonFinite {
            parameter: "normals",
            index: 9
        })
    ));
    let mut g = field(16, 8);
    g.positions[3] = Vec3::NAN;
    assert!(matches!(
        upload(&g.field(), &grid),
        Err(UploadError::NonFinite {
            parameter: "positions",
            index: 3
        })
    ));

    let sky = LightField {
        sky_distance: 0.0,
        geometry_bounds: None,
        ..f.field()
    };
    assert!(matches!(
        upload(&sky, &grid),
        Err(UploadError::BadParameter {
            parameter: "sky_distance",
            ..
        })
    ));
    let e = CpuTracer::new()
        .upload(
            &f.field(),
            &grid,
            &FieldOptions {
                thickness_scale: f32::NAN,
                ..FieldOptions::default()
            },
        )
        .unwrap_err();
    assert!(matches!(
        e,
        UploadError::BadParameter {
            parameter: "thickness_scale",
            ..
        }
    ));

    let empty = field(16, 0);
    assert_eq!(upload(&empty.field(), &grid), Err(UploadError::NoProbes));
}

#[test]
fn selection_must_fit_the_probes() {
    let f = field(16, 8);
    let big = ProbeGrid::new(Vec3::ZERO, Vec3::ONE, [3, 2, 2]).unwrap();
    let e = upload(&f.field(), &ProbeSelection::Grid(big)).unwrap_err();
    assert_eq!(
        e,
        UploadError::ProbeCountMismatch {
            selection: "grid",
            expected: 8,
            actual: 12
        }
    );

    // Neighbour maps of 9 probes for a field of 8.
    let mut nine = grid_of_8().positions();
    nine.push(Vec3::splat(0.5));
    let tets = Tetrahedralization::build(&nine).unwrap();
    let neighbours = VoronoiNeighbours::bake(&tets, 4).unwrap();
    let nearest = NearestProbe::new(&nine);
    let e = upload(
        &f.field(),
        &ProbeSelection::Voronoi {
            nearest: &nearest,
            neighbours: &neighbours,
        },
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            UploadError::ProbeCountMismatch {
                expected: 8,
                actual: 9,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn trace_errors_name_the_ray_or_option() {
    let f = field(16, 8);
    let mut tracer = CpuTracer::new();
    let ok = [TraceRay::new(Vec3::splat(0.5), Vec3::X)];
    let field = tracer
        .upload(
            &f.field(),
            &ProbeSelection::Grid(grid_of_8()),
            &FieldOptions::default(),
        )
        .unwrap();
    assert!(tracer.trace(&field, &ok, &TraceOptions::default()).is_ok());
    assert!(
        tracer
            .trace(&field, &[], &TraceOptions::default())
            .unwrap()
            .results
            .is_empty()
    );
    let cases = [
        (
            TraceRay::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X),
            "origin",
        ),
        (TraceRay::new(Vec3::ZERO, Vec3::ZERO), "zero"),
        (
            TraceRay::new(Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0)),
            "direction",
        ),
        (TraceRay::with_range(Vec3::ZERO, Vec3::X, 2.0, 1.0), "range"),
        (
            TraceRay::with_range(Vec3::ZERO, Vec3::X, -1.0, 1.0),
            "range",
        ),
    ];
    for (bad, word) in cases {
        let rays = [ok[0], ok[0], bad];
        let e = tracer
            .trace(&field, &rays, &TraceOptions::default())
            .unwrap_err();
        assert!(
            matches!(
                e,
                TraceError::BadInput {
                    item: "ray",
                    index: 2,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains(word), "{e}");
    }
    for (options, name) in [
        (
            TraceOptions {
                max_probes: 65,
                ..TraceOptions::default()
            },
            "max_probes",
        ),
        (
            TraceOptions {
                coarse_downsample: 12,
                ..TraceOptions::default()
            },
            "coarse_downsample",
        ),
    ] {
        let e = tracer.trace(&field, &ok, &options).unwrap_err();
        assert!(
            matches!(e, TraceError::BadOption { option, .. } if option == name),
            "{e}"
        );
    }
}
