//! `probes render --component final` from the command line: the diffuse options (the
//! surfels' near-field correction among them) and the glossy blend reach the parts they set
//! (and only those), and a blend over too many probes
//! is refused in one line naming the flag; `--sectors` cuts a filtered glossy lobe.

mod support;

use std::path::Path;
use std::process::Output;
use support::{assert_refused_in_one_line, probes, stderr};

/// Renders the final image of `bake` with `extra` flags and `--split` into `dir/NAME.exr`;
/// returns the bytes of the diffuse and the specular part.
fn render_parts(bake: &Path, dir: &Path, name: &str, extra: &[&str]) -> (Vec<u8>, Vec<u8>) {
    let out = dir.join(format!("{name}.exr"));
    let mut args = vec![
        "render",
        bake.to_str().unwrap(),
        "--component",
        "final",
        "--width",
        "32",
        "--height",
        "24",
        "--emitter-samples",
        "1",
        "--split",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let output = probes(&args);
    assert!(output.status.success(), "{name}: {}", stderr(&output));
    let part = |part: &str| std::fs::read(dir.join(format!("{name}.{part}.exr"))).unwrap();
    (part("diffuse"), part("specular"))
}

/// `probes render BAKE --tracer TRACER` of the glossy component at 32×24 into `out`, with
/// `extra` flags.
fn render_glossy(bake: &Path, tracer: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        bake.to_str().unwrap(),
        "--tracer",
        tracer,
        "--width",
        "32",
        "--height",
        "24",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    probes(&args)
}

/// A small bake of the built-in Cornell box (8 grid probes at 16²) in `dir/bake`.
fn small_cornell_bake(dir: &Path) -> std::path::PathBuf {
    small_cornell_bake_with(dir, "bake", &[])
}

/// [`small_cornell_bake`] in `dir/name` with `extra` flags.
fn small_cornell_bake_with(dir: &Path, name: &str, extra: &[&str]) -> std::path::PathBuf {
    let bake = dir.join(name);
    let mut args = vec![
        "bake",
        "builtin:cornell",
        "--probes",
        "grid:2x2x2",
        "--res",
        "16",
        "--spp",
        "2",
        "--out",
        bake.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let output = probes(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    bake
}

#[test]
fn diffuse_options_and_glossy_blend_reach_the_final_image() {
    let root = tempfile::tempdir().unwrap();
    let bake = small_cornell_bake(root.path());

    let (diffuse, specular) = render_parts(&bake, root.path(), "default", &[]);
    let (no_visibility, specular_same) = render_parts(
        &bake,
        root.path(),
        "no-visibility",
        &["--diffuse-options", "visibility=off"],
    );
    assert!(
        diffuse != no_visibility,
        "--diffuse-options did not change the final image's diffuse part"
    );
    assert!(
        specular == specular_same,
        "--diffuse-options changed the specular part"
    );
    // The bake holds surfels (`BakeSettings::surfel_resolution`), so turning the near-field
    // correction off changes the diffuse part, and only it.
    let (plain, specular_same) = render_parts(
        &bake,
        root.path(),
        "no-parallax",
        &["--diffuse-options", "parallax=off"],
    );
    assert!(
        diffuse != plain,
        "parallax=off did not change the final image's diffuse part"
    );
    assert!(
        specular == specular_same,
        "parallax=off changed the specular part"
    );
    let (diffuse_same, one_probe) =
        render_parts(&bake, root.path(), "one-probe", &["--glossy-blend", "0"]);
    assert!(
        specular != one_probe,
        "--glossy-blend 0 did not change the filtered specular part"
    );
    assert!(
        diffuse == diffuse_same,
        "--glossy-blend changed the diffuse part"
    );

    let out = root.path().join("refused.exr");
    let output = probes(&[
        "render",
        bake.to_str().unwrap(),
        "--component",
        "final",
        "--width",
        "8",
        "--height",
        "8",
        "--glossy-blend",
        "9",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    let message = stderr(&output);
    assert!(message.contains("glossy_blend"), "{message}");
    assert_eq!(message.trim().lines().count(), 1, "{message}");
    assert!(!out.exists(), "a refused render wrote {}", out.display());
}

/// `--sectors` cuts a filtered lobe into narrower cones: it changes a filtered glossy render
/// and the final image's filtered specular, and is refused in one line without `--filtered`,
/// with stochastic specular rays, or outside 1 to 8.
#[test]
fn sectors_change_a_filtered_render_and_bad_ones_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let bake = small_cornell_bake(root.path());
    let render = |name: &str, extra: &[&str]| {
        let out = root.path().join(format!("{name}.exr"));
        let mut args = vec![
            "render",
            bake.to_str().unwrap(),
            "--width",
            "24",
            "--height",
            "16",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        (probes(&args), out)
    };
    // A refused render: a one-line error naming `needle`, and no file written.
    let assert_refused = |name: &str, extra: &[&str], needle: &str| {
        let (output, out) = render(name, extra);
        assert_refused_in_one_line(&output, needle);
        assert!(!out.exists(), "a refused render wrote {}", out.display());
    };
    let filtered = ["--filtered", "--roughness", "0.3"];
    let (one, one_path) = render("one", &filtered);
    assert!(one.status.success(), "{}", stderr(&one));
    let (two, two_path) = render("two", &[&filtered[..], &["--sectors", "2"]].concat());
    assert!(two.status.success(), "{}", stderr(&two));
    assert!(
        std::fs::read(&one_path).unwrap() != std::fs::read(&two_path).unwrap(),
        "--sectors 2 did not change the filtered render"
    );
    // The final image's filtered specular takes them too; stochastic specular refuses them.
    let final_image = ["--component", "final"];
    let (one, one_path) = render("final-one", &final_image);
    assert!(one.status.success(), "{}", stderr(&one));
    let (two, two_path) = render(
        "final-two",
        &[&final_image[..], &["--sectors", "2"]].concat(),
    );
    assert!(two.status.success(), "{}", stderr(&two));
    assert!(
        std::fs::read(&one_path).unwrap() != std::fs::read(&two_path).unwrap(),
        "--sectors 2 did not change the final image's filtered specular"
    );
    for (name, extra) in [
        ("unfiltered", vec!["--sectors", "2"]),
        ("too-many", [&filtered[..], &["--sectors", "9"]].concat()),
        (
            "final-stochastic",
            [
                &final_image[..],
                &["--specular", "stochastic", "--sectors", "2"],
            ]
            .concat(),
        ),
        (
            "final-too-many",
            [&final_image[..], &["--sectors", "9"]].concat(),
        ),
    ] {
        assert_refused(name, &extra, "sectors");
    }
    // Interleaved sub-lobes: one ray per pixel, a render of its own; refused without
    // --filtered and 2 or 4 sectors, and for the final image.
    let (shared, shared_path) = render(
        "interleaved",
        &[&filtered[..], &["--sectors", "2", "--interleave", "--json"]].concat(),
    );
    assert!(shared.status.success(), "{}", stderr(&shared));
    let summary: serde_json::Value = serde_json::from_slice(&shared.stdout).unwrap();
    assert_eq!(summary["interleaved"], true, "{summary}");
    assert!(
        std::fs::read(&shared_path).unwrap() != std::fs::read(&two_path).unwrap(),
        "--interleave did not change the render"
    );
    for (name, extra) in [
        (
            "interleave-unfiltered",
            vec!["--sectors", "2", "--interleave"],
        ),
        (
            "interleave-three",
            [&filtered[..], &["--sectors", "3", "--interleave"]].concat(),
        ),
        (
            "interleave-final",
            [&final_image[..], &["--sectors", "2", "--interleave"]].concat(),
        ),
    ] {
        assert_refused(name, &extra, "--interleave");
    }
}

/// `--tracer shaded` answers every ray from the BVH (the hit shaded with direct light and the
/// irradiance probes; no light-field probe read: no fetches, nothing UNKNOWN), and is refused
/// with `--filtered` in one line naming the flag.
#[test]
fn the_shaded_tracer_answers_every_ray_from_the_bvh() {
    let root = tempfile::tempdir().unwrap();
    let bake = small_cornell_bake(root.path());
    let out = root.path().join("shaded.exr");
    let output = render_glossy(&bake, "shaded", &out, &[]);
    let log = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(log.contains("unknown 0.00 %"), "{log}");
    assert!(log.contains("0.0 texel fetches"), "{log}");
    assert!(out.exists());
    let refused = render_glossy(
        &bake,
        "shaded",
        &root.path().join("refused.exr"),
        &["--filtered", "--roughness", "0.3"],
    );
    assert_refused_in_one_line(&refused, "--filtered");
}

/// `--tracer split` renders the glossy component from a second bake of the reflected light at
/// the bake's positions, lit at each BVH hit by shadow rays: an image of its own (neither the
/// hybrid's nor the shaded hits'), the same bytes again for the same bake, and the final
/// image refuses it in one line naming the tracer.
#[test]
fn the_split_tracer_renders_the_glossy_component_only() {
    let root = tempfile::tempdir().unwrap();
    let bake = small_cornell_bake(root.path());
    let render = |name: &str, tracer: &str, extra: &[&str]| {
        let out = root.path().join(format!("{name}.exr"));
        (render_glossy(&bake, tracer, &out, extra), out)
    };
    let mut images = Vec::new();
    for (name, tracer) in [
        ("split", "split"),
        ("split-again", "split"),
        ("hybrid", "hybrid"),
        ("shaded", "shaded"),
    ] {
        let (output, out) = render(name, tracer, &[]);
        assert!(output.status.success(), "{name}: {}", stderr(&output));
        images.push(std::fs::read(out).unwrap());
    }
    assert_eq!(images[0], images[1], "the split is not deterministic");
    assert_ne!(
        images[0], images[2],
        "the split rendered the hybrid's image"
    );
    assert_ne!(
        images[0], images[3],
        "the split rendered the shaded hits' image"
    );
    let (refused, _) = render("split-final", "split", &["--component", "final"]);
    assert_refused_in_one_line(&refused, "split");
}

/// A bake of the reflected light alone (`probes bake --radiance indirect`) is what the split
/// bakes for itself from a bake of the outgoing radiance: the split renders it to the same
/// bytes with no second bake (the render says so), and every other image of it (another
/// tracer, the final image) is refused in one line naming it, not rendered as if it held all
/// the light.
#[test]
fn a_bake_of_reflected_light_is_read_by_the_split_alone() {
    let root = tempfile::tempdir().unwrap();
    let outgoing = small_cornell_bake(root.path());
    let indirect = small_cornell_bake_with(root.path(), "indirect", &["--radiance", "indirect"]);
    let mut images = Vec::new();
    for (name, bake, made) in [
        ("from-outgoing", &outgoing, "baked for this render"),
        ("from-indirect", &indirect, "the bake given"),
    ] {
        let out = root.path().join(format!("{name}.exr"));
        let rendered = render_glossy(bake, "split", &out, &["--json"]);
        assert!(rendered.status.success(), "{name}: {}", stderr(&rendered));
        let report: serde_json::Value = serde_json::from_slice(&rendered.stdout).unwrap();
        assert_eq!(report["reflected_light"], made, "{name}");
        images.push(std::fs::read(out).unwrap());
    }
    assert_eq!(
        images[0], images[1],
        "the split read a bake of the reflected light otherwise than the one it makes"
    );
    for (tracer, extra) in [
        ("hybrid", &[][..]),
        ("hiz", &[][..]),
        ("split", &["--component", "final"][..]),
    ] {
        let refused = render_glossy(&indirect, tracer, &root.path().join("refused.exr"), extra);
        assert_refused_in_one_line(&refused, "reflect");
    }
}
