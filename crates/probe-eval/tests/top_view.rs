//! Top views: size, probes at their projected pixels, and the cut through the colonnade roof.

use glam::Vec3;
use probe_eval::top_view::{TopViewError, TopViewOptions, render_top_view, write_top_view};
use probe_scene::Scene;

fn keep_dir() -> Option<std::path::PathBuf> {
    std::env::var_os("PROBE_CHART_KEEP").map(|dir| {
        std::fs::create_dir_all(&dir).unwrap();
        std::path::PathBuf::from(dir)
    })
}

fn rgb(image: &image::RgbImage, pixel: glam::Vec2) -> [u8; 3] {
    image.get_pixel(pixel.x as u32, pixel.y as u32).0
}

#[test]
fn cornell_probes_appear_at_their_pixels() {
    let scene = Scene::builtin("cornell").unwrap();
    let probes = vec![
        Vec3::new(0.1, 0.1, 0.1),
        Vec3::new(0.28, 0.27, 0.28),
        Vec3::new(0.45, 0.5, 0.45),
        Vec3::new(0.12, 0.4, 0.45),
    ];
    let options = TopViewOptions {
        width: 320,
        cut_height: Some(0.5),
        number_probes: true,
        caption: Some("cornell, cut at 0.5 m".to_owned()),
        ..TopViewOptions::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let path = keep_dir()
        .unwrap_or(dir.path().to_path_buf())
        .join("cornell_top.png");
    let layout = write_top_view(&scene, &probes, &options, &path).unwrap();
    let with = image::open(&path).unwrap().to_rgb8();
    assert_eq!(with.width(), 320);
    assert_eq!((with.width(), with.height()), (layout.width, layout.height));
    assert!(layout.height > layout.map_height, "no legend strip");
    // The box is about square: so is the map.
    assert!((layout.map_height as i32 - 320).abs() < 12, "{layout:?}");

    let (without, same_layout) = render_top_view(&scene, &[], &options).unwrap();
    // The region widens to include probes only when they lie outside the scene; these don't.
    assert_eq!(layout, same_layout);
    for (i, &p) in probes.iter().enumerate() {
        let pixel = layout.project(p);
        let (a, b) = (rgb(&with, pixel), rgb(&without, pixel));
        assert_ne!(a, b, "probe {i} at {pixel} is not drawn");
    }
    // Away from every probe the two pictures agree.
    let far = layout.project(Vec3::new(0.45, 0.0, 0.1));
    assert_eq!(rgb(&with, far), rgb(&without, far));
    // The probes are coloured by height: the lowest and the highest differ.
    let low = rgb(&with, layout.project(probes[0]));
    let high = rgb(&with, layout.project(probes[2]));
    assert_ne!(low, high);
}

#[test]
fn the_cut_removes_the_colonnade_roof() {
    let scene = Scene::builtin("colonnade").unwrap();
    let options = TopViewOptions {
        width: 300,
        legend: false,
        ..TopViewOptions::default()
    };
    let (roofed, layout) = render_top_view(&scene, &[], &options).unwrap();
    assert_eq!(roofed.height(), layout.map_height);
    let cut = TopViewOptions {
        cut_height: Some(6.0),
        ..options.clone()
    };
    let (open, cut_layout) = render_top_view(&scene, &[], &cut).unwrap();
    assert_eq!(layout, cut_layout);
    if let Some(dir) = keep_dir() {
        roofed.save(dir.join("colonnade_roof.png")).unwrap();
        open.save(dir.join("colonnade_cut.png")).unwrap();
    }
    // Under the roof (floor at x = −9, z = 4.5, clear of pillars and walls): the roof's colour
    // without the cut, the floor's with it.
    let under_roof = [
        Vec3::new(-9.0, 0.0, 4.5),
        Vec3::new(4.5, 0.0, -1.5),
        Vec3::new(-4.5, 0.0, 4.0),
    ];
    for p in under_roof {
        let pixel = layout.project(p);
        assert_ne!(
            rgb(&roofed, pixel),
            rgb(&open, pixel),
            "no change under the roof at {p}"
        );
    }
    // Where the roof is open (the skylight over the nave) both views see the same floor.
    let skylight = layout.project(Vec3::new(1.5, 0.0, 0.0));
    let (a, b) = (rgb(&roofed, skylight), rgb(&open, skylight));
    // Same surface, but the height shade depends on the top of the view: compare hue only.
    let hue = |c: [u8; 3]| (c[0] as f32 / c[2] as f32, c[1] as f32 / c[2] as f32);
    assert!(
        (hue(a).0 - hue(b).0).abs() < 0.05 && (hue(a).1 - hue(b).1).abs() < 0.05,
        "{a:?} {b:?}"
    );
    // The cut walls show as dark sections: the back wall at z = −6.15.
    let wall = layout.project(Vec3::new(0.0, 0.0, -6.15));
    let c = rgb(&open, wall);
    assert!(c.iter().all(|&v| v < 80), "wall section {c:?} is not dark");
}

#[test]
fn comparison_set_and_probes_outside_the_scene_widen_the_view() {
    let scene = Scene::builtin("colonnade").unwrap();
    let grid: Vec<Vec3> = probe_scene::builtin::grid_cell_centers(&scene.bounds(), [4, 1, 2]);
    let outside = vec![Vec3::new(20.0, 3.0, 0.0)];
    let options = TopViewOptions {
        width: 240,
        comparison: grid.clone(),
        antialias: false,
        ..TopViewOptions::default()
    };
    let (image, layout) = render_top_view(&scene, &outside, &options).unwrap();
    assert_eq!(image.width(), 240);
    assert!(layout.region_max.x > 20.0);
    let (plain, _) = render_top_view(
        &scene,
        &outside,
        &TopViewOptions {
            comparison: Vec::new(),
            ..options.clone()
        },
    )
    .unwrap();
    for &g in &grid {
        let pixel = layout.project(g);
        assert_eq!(rgb(&image, pixel), [220, 40, 200], "grid probe at {pixel}");
        assert_ne!(rgb(&plain, pixel), [220, 40, 200]);
    }
    let pixel = layout.project(outside[0]);
    assert_ne!(rgb(&image, pixel), [204, 214, 224]);
}

#[test]
fn bad_options_are_errors() {
    let scene = Scene::builtin("cornell").unwrap();
    let base = TopViewOptions {
        width: 64,
        ..TopViewOptions::default()
    };
    let probe = [Vec3::new(0.2, 0.2, 0.2)];
    let err = |options: &TopViewOptions, probes: &[Vec3]| {
        render_top_view(&scene, probes, options).unwrap_err()
    };
    assert!(matches!(
        err(
            &TopViewOptions {
                width: 0,
                ..base.clone()
            },
            &probe
        ),
        TopViewError::InvalidSize { width: 0, .. }
    ));
    let e = err(&base, &[Vec3::new(0.0, f32::NAN, 0.0)]);
    assert!(
        matches!(e, TopViewError::NonFiniteProbe { index: 0, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("probes probe 0"), "{e}");
    let e = err(
        &TopViewOptions {
            comparison: vec![Vec3::ZERO, Vec3::INFINITY],
            ..base.clone()
        },
        &probe,
    );
    assert!(e.to_string().contains("grid probe 1"), "{e}");
    assert!(matches!(
        err(
            &TopViewOptions {
                cut_height: Some(f32::NAN),
                ..base.clone()
            },
            &probe
        ),
        TopViewError::InvalidCutHeight { .. }
    ));
    assert!(matches!(
        err(
            &TopViewOptions {
                probe_radius: Some(0.0),
                ..base.clone()
            },
            &probe
        ),
        TopViewError::InvalidProbeRadius { .. }
    ));
    // A very long, narrow view: the height it implies is too large.
    let far = [Vec3::new(0.2, 0.2, 5000.0)];
    assert!(matches!(
        err(
            &TopViewOptions {
                width: 1000,
                ..base.clone()
            },
            &far
        ),
        TopViewError::InvalidSize { .. }
    ));
    // Writing into a missing folder: a write error naming the file, nothing left behind.
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing/top.png");
    let e = write_top_view(&scene, &probe, &base, &missing).unwrap_err();
    assert!(matches!(e, TopViewError::Write { .. }) && e.to_string().contains("top.png"));
}

#[test]
fn renders_are_deterministic() {
    let scene = Scene::builtin("colonnade").unwrap();
    let probes = vec![Vec3::new(-3.0, 2.0, 1.0), Vec3::new(4.0, 6.5, -2.0)];
    let options = TopViewOptions {
        width: 200,
        cut_height: Some(5.0),
        number_probes: true,
        ..TopViewOptions::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
    write_top_view(&scene, &probes, &options, &a).unwrap();
    write_top_view(&scene, &probes, &options, &b).unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

/// Sponza from above, cut at 12 m (above the gallery floor at 9.6 m): decodes at the given
/// width, shows the cut walls and columns as dark sections, and says how long it took.
/// About 10 s in the dev profile; run with
/// `cargo test --release -p probe-eval --test top_view -- --ignored --nocapture sponza`.
#[test]
#[ignore = "loads Sponza (262k triangles): run in release, see the comment"]
fn sponza_top_view_timing() {
    let start = std::time::Instant::now();
    let scene = Scene::load(probe_testdata::scene_path(probe_testdata::SPONZA)).unwrap();
    let loaded = start.elapsed();
    let bounds = scene.bounds();
    let probes: Vec<Vec3> = probe_scene::builtin::grid_cell_centers(&bounds, [6, 3, 4]);
    let dir = tempfile::tempdir().unwrap();
    let out = keep_dir().unwrap_or(dir.path().to_path_buf());
    for (name, cut) in [("sponza_top.png", None), ("sponza_cut.png", Some(12.0))] {
        let options = TopViewOptions {
            width: 1000,
            cut_height: cut,
            number_probes: true,
            caption: Some("Sponza, 6×3×4 grid".to_owned()),
            ..TopViewOptions::default()
        };
        let t = std::time::Instant::now();
        let layout = write_top_view(&scene, &probes, &options, &out.join(name)).unwrap();
        let took = t.elapsed();
        let image = image::open(out.join(name)).unwrap().to_rgb8();
        assert_eq!(image.width(), 1000);
        let map_pixels = (layout.width * layout.map_height) as f64;
        let dark = image
            .pixels()
            .take(map_pixels as usize)
            .filter(|p| p.0.iter().all(|&v| v < 70))
            .count() as f64
            / map_pixels;
        println!(
            "{name}: {}×{} px, 4 rays per pixel{}: {:.3} s (scene load {:.3} s); dark (section) share {:.1} %",
            layout.width,
            layout.height,
            if cut.is_some() {
                " plus section tests"
            } else {
                ""
            },
            took.as_secs_f64(),
            loaded.as_secs_f64(),
            dark * 100.0
        );
        if cut.is_some() {
            assert!(dark > 0.01, "no cut walls or columns visible");
        }
    }
}
