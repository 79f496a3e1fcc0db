//! Figure 13 of seed 003 (the LUT's memory at 30³, 40³, 50³, 56³) for `thickness = "pairs"`:
//! a bottle of the seed's shape voxelized at each resolution, its surface voxels N, the table's
//! N² bytes (R8, square, as the seed's) beside the paper's numbers, what the GPU holds besides (a
//! word per grid voxel and per surface voxel), and the bake's wall time (all pairs cast in f64).
//!
//! cargo run --release --example pairs_memory [-- --no-bake]

use hadou::effects::thickness_pairs::{bake, surface_voxels, table_bytes, PairOptions};
use hadou::scene::procedural;

/// The paper's figure 13: (resolution, LUT bytes as printed).
const PAPER: [(u32, &str); 4] = [(30, "968 KB"), (40, "3.71 MB"), (50, "10.3 MB"), (56, "17.5 MB")];

fn main() {
    let bake_too = !std::env::args().any(|a| a == "--no-bake");
    let bottles = [
        (
            "translucency.toml bottle (r 0.3, h 1.6, wall 0.04, half full)",
            procedural::bottle(0.3, 1.6, 0.04, 0.5, 48),
        ),
        ("fatter bottle (r 0.5, h 1.6, wall 0.05, half full)", procedural::bottle(0.5, 1.6, 0.05, 0.5, 48)),
    ];
    // Lift the budget: this measures the sizes, it does not load them on a GPU.
    let options = PairOptions { memory_budget: u64::MAX, ..PairOptions::default() };
    for (name, mesh) in bottles {
        let mesh = mesh.unwrap();
        println!("{name}: {} triangles", mesh.triangle_count());
        println!("| res | surface voxels N | table N² bytes | paper (fig. 13) | + lookups (bytes) | bake s (wall) |");
        println!("|---|---|---|---|---|---|");
        for (res, paper) in PAPER {
            let v = surface_voxels(&mesh, res).unwrap();
            let n = v.count() as u64;
            let extra = 4 * (v.lookup.len() as u64 + n);
            let seconds = if bake_too {
                let start = std::time::Instant::now();
                bake(&mesh, res, &options, &|_, _| {}).unwrap();
                format!("{:.2}", start.elapsed().as_secs_f64())
            } else {
                "–".into()
            };
            let mib = table_bytes(n) as f64 / (1 << 20) as f64;
            println!("| {res} | {n} | {} ({mib:.2} MiB) | {paper} | {extra} | {seconds} |", table_bytes(n));
        }
    }
}
