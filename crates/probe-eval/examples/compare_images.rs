//! Compares renders with a reference: tone-mapped MSE and FLIP of each, and one PNG with the
//! reference and every render side by side (all at the reference's exposure), each render's
//! FLIP map below it.
//!
//! ```text
//! cargo run --release -p probe-eval --example compare_images -- REFERENCE.exr OUT.png LABEL=RENDER.exr...
//! ```
//!
//! Prints a Markdown table. The reference's own noise is what `probes reference` reports with
//! it (state it beside these figures).

use probe_capture::Image;
use probe_eval::metrics::{flip, flip_map_rgb8, tonemapped_mse};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [reference_path, out, renders @ ..] = &args[..] else {
        return Err("usage: compare_images REFERENCE.exr OUT.png LABEL=RENDER.exr...".into());
    };
    let reference = Image::load_exr(reference_path)?;
    let exposure = reference.auto_exposure();
    let (w, h) = (reference.width as usize, reference.height as usize);
    let columns = 1 + renders.len();
    let mut canvas = vec![0u8; columns * w * 2 * h * 3];
    let mut put = |column: usize, row: usize, rgb: &[u8]| {
        for y in 0..h {
            for x in 0..w {
                let at = ((row * h + y) * columns * w + column * w + x) * 3;
                canvas[at..at + 3].copy_from_slice(&rgb[(y * w + x) * 3..(y * w + x) * 3 + 3]);
            }
        }
    };
    put(0, 0, &reference.to_rgb8(exposure));
    println!("| render | tone-mapped MSE | FLIP |");
    println!("|---|---:|---:|");
    for (column, spec) in renders.iter().enumerate() {
        let (label, path) = spec
            .split_once('=')
            .ok_or_else(|| format!("{spec}: give LABEL=PATH"))?;
        let image = Image::load_exr(path)?;
        let mse = tonemapped_mse(&image, &reference);
        let (map, mean) = flip(&image, &reference)?;
        println!("| {label} | {mse:.3e} | {mean:.4} |");
        put(column + 1, 0, &image.to_rgb8(exposure));
        put(
            column + 1,
            1,
            &flip_map_rgb8(image.width, image.height, &map),
        );
    }
    image::save_buffer(
        out,
        &canvas,
        (columns * w) as u32,
        (2 * h) as u32,
        image::ColorType::Rgb8,
    )?;
    Ok(())
}
