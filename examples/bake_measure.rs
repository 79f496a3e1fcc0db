//! Figure 13 of seed 003 as a table: the bottle baked at 30³, 40³, 50³, 56³ — surface voxels, LUT
//! bytes, bake seconds, and the LUT's error on light paths against the exact inside fraction
//! (`hadou::report::lut_paths`, shared with the library's tests).
//!
//! cargo run --release --example bake_measure

use hadou::effects::raycast::MeshBvh;
use hadou::effects::thickness_lut::{bake, BakeOptions};
use hadou::report::lut_paths::{at, cpu_seconds, path_errors};
use hadou::scene::procedural;

/// Random light paths per resolution.
const PATHS: usize = 20000;

/// Per bottle and resolution (release build, 2 threads): surface voxels, LUT bytes, bake seconds
/// (wall, and CPU over both threads, which a loaded machine does not inflate), pairs baked by the
/// exact path, and p95 / max of |Δf| and of |Δd| in voxels, for the seed's centre-to-centre
/// thickness and (second line) the LUT's fraction times the actual segment's length.
fn main() {
    let bottles = [
        (
            "translucency.toml bottle (r 0.3, h 1.6, wall 0.04)",
            procedural::bottle(0.3, 1.6, 0.04, 0.5, 48).unwrap(),
        ),
        ("default bottle (r 0.5, h 1.6, wall 0.05)", procedural::bottle(0.5, 1.6, 0.05, 0.5, 48).unwrap()),
    ];
    let options = BakeOptions { threads: 2, ..BakeOptions::default() };
    for (name, mesh) in bottles {
        println!("{name}: {} triangles", mesh.triangle_count());
        println!(
            "| res | surface voxels | LUT bytes | texture | bake s wall / CPU (2 threads) | exact-path pairs \
             | p95 / max |Δf| | p95 / max |Δd| (voxels) |"
        );
        let bvh = MeshBvh::new(&mesh).unwrap();
        for res in [30, 40, 50, 56] {
            let (start, cpu) = (std::time::Instant::now(), cpu_seconds());
            let (lut, stats) = bake(&mesh, res, &options, &|_, _| {}).unwrap();
            let (seconds, cpu) = (start.elapsed().as_secs_f64(), cpu_seconds() - cpu);
            let e = path_errors(&bvh, &lut, PATHS, 12345);
            println!(
                "| {res} | {} | {} | {}×{} | {seconds:.2} / {cpu:.2} | {} of {} | {:.4} / {:.4} | {:.2} / {:.2} |",
                lut.surface_count(),
                lut.bytes(),
                lut.width,
                lut.height,
                stats.exact_pairs,
                stats.pairs,
                at(&e.centre_df, 0.95),
                at(&e.centre_df, 1.0),
                at(&e.centre_dd, 0.95),
                at(&e.centre_dd, 1.0),
            );
            println!(
                "|    | d = f(i, j)·|b − a| instead of f(i, j)·|c_j − c_i| | | | | | {:.4} / {:.4} | {:.2} / {:.2} |",
                at(&e.path_df, 0.95),
                at(&e.path_df, 1.0),
                at(&e.path_dd, 0.95),
                at(&e.path_dd, 1.0),
            );
        }
    }
}
