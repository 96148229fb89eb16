use probe_place::*;
use probe_scene::Scene;
use std::time::Instant;
fn main() {
    let t = Instant::now();
    let path = std::env::args().nth(1).unwrap_or_else(|| {
        probe_testdata::scene_path(probe_testdata::SPONZA)
            .display()
            .to_string()
    });
    let scene = Scene::open(&path).unwrap();
    println!(
        "load {:?} tris {} bounds {:?}",
        t.elapsed(),
        scene.triangles().len(),
        scene.bounds()
    );
    let ds = scene.materials().iter().filter(|m| m.double_sided).count();
    println!("materials {} double-sided {}", scene.materials().len(), ds);
    let texels: usize = std::env::args()
        .nth(2)
        .map(|s| s.parse().unwrap())
        .unwrap_or(20000);
    let spacing: f32 = std::env::args()
        .nth(3)
        .map(|s| s.parse().unwrap())
        .unwrap_or(2.0);
    let params = AtlasParams::for_texel_count(&scene, texels);
    let t = Instant::now();
    let free = BackfaceVote::new(&scene);
    let pool = free_space_grid(&free, spacing);
    println!("free grid {} points in {:?}", pool.len(), t.elapsed());
    let t = Instant::now();
    let un = Atlas::build_unfiltered(&scene, &params).unwrap();
    println!(
        "unfiltered {} texels (size {}) in {:?}",
        un.samples().len(),
        params.texel_size,
        t.elapsed()
    );
    let t = Instant::now();
    let atlas = Atlas::build(&scene, &params, &pool).unwrap();
    println!(
        "filtered {} texels, dropped {} in {:?}",
        atlas.samples().len(),
        atlas.unreachable_texels(),
        t.elapsed()
    );
    let t = Instant::now();
    let mut n = 0;
    for p in pool.iter().take(64) {
        n += atlas.probe_views(*p).len();
    }
    println!("64 probe views: {} views in {:?}", n, t.elapsed());
    let t = Instant::now();
    println!(
        "pool coverage {} in {:?}",
        atlas.coverage(&pool),
        t.elapsed()
    );
}
