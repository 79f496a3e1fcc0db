//! Figure 13 of seed 003 as a table: the bottle baked at 30³, 40³, 50³, 56³ — field bytes, bake
//! seconds, and the field's error on light paths against the exact inside fraction
//! (`hadou_cli::report::lut_paths`, shared with the library's tests).
//!
//! cargo run --release --example bake_measure

use hadou::effects::raycast::MeshBvh;
use hadou::effects::thickness_lut::{bake, BakeOptions};
use hadou::scene::procedural;
use hadou_cli::report::lut_paths::{at, cpu_seconds, path_errors};

/// Random light paths per resolution.
const PATHS: usize = 20000;

/// Per bottle and resolution (release build, 2 threads): field bytes, bake seconds (wall, and CPU
/// over both threads, which a loaded machine does not inflate), the gap threshold τ, and p95 / max
/// of |Δf| and of |Δd| in voxels.
fn main() {
    let bottles = [
        (
            "translucency.toml bottle (r 0.3, h 1.6, wall 0.04)",
            procedural::bottle(0.3, 1.6, 0.04, 0.5, 48).unwrap(),
        ),
        ("default bottle (r 0.5, h 1.6, wall 0.05)", procedural::bottle(0.5, 1.6, 0.05, 0.5, 48).unwrap()),
    ];
    let options = BakeOptions { threads: 2 };
    for (name, mesh) in bottles {
        println!("{name}: {} triangles", mesh.triangle_count());
        println!("| res | field bytes | bake s wall / CPU (2 threads) | τ (voxels) | p95 / max |Δf| | p95 / max |Δd| (voxels) |");
        let bvh = MeshBvh::new(&mesh).unwrap();
        for res in [30, 40, 50, 56] {
            let (start, cpu) = (std::time::Instant::now(), cpu_seconds());
            let (lut, _) = bake(&mesh, res, &options, &|_, _| {}).unwrap();
            let (seconds, cpu) = (start.elapsed().as_secs_f64(), cpu_seconds() - cpu);
            let e = path_errors(&bvh, &lut, PATHS, 12345);
            println!(
                "| {res} | {} | {seconds:.2} / {cpu:.2} | {:.3} | {:.4} / {:.4} | {:.2} / {:.2} |",
                lut.bytes(),
                lut.gap_threshold() / lut.voxel_size,
                at(&e.df, 0.95),
                at(&e.df, 1.0),
                at(&e.dd, 0.95),
                at(&e.dd, 1.0),
            );
        }
    }
}
