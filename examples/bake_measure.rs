//! Figure 13 of seed 003 as a table: the bottle baked at 30³, 40³, 50³, 56³ — surface voxels, LUT
//! bytes, bake seconds, and the LUT's error on light paths against the exact inside fraction.
//!
//! cargo run --release --example bake_measure

use glam::DVec3;
use hadou::effects::raycast::MeshBvh;
use hadou::effects::thickness_lut::{bake, BakeOptions};
use hadou::scene::procedural;
use hadou::testing::Rng;

fn options() -> BakeOptions {
    BakeOptions { threads: 2, ..BakeOptions::default() }
}

// ---------------------------------------------------------------------------------------------
// Measurements (not a timed test).

/// CPU seconds (user + system) this process has used so far, from /proc/self/stat (Linux); 0
/// elsewhere.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // Fields after the command name (which is in parentheses and may hold spaces).
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
    // utime and stime are fields 14 and 15 of the whole line: 11 and 12 after the name.
    (ticks(11) + ticks(12)) / 100.0
}

/// Figure 13 of the seed: the bottle at 30³, 40³, 50³, 56³ (release build, 2 threads): surface
/// voxels, LUT bytes, bake seconds (wall, and CPU over both threads, which a loaded machine does
/// not inflate), and the LUT's error on light paths: for random lines through the object, the
/// segment from the light's first entry to its last exit (the TSM segment), exact inside fraction
/// against the LUT's f(i, j) for the surface voxels of its two ends, and the thickness difference
/// in voxels.
fn main() {
    let bottles = [
        (
            "translucency.toml bottle (r 0.3, h 1.6, wall 0.04)",
            procedural::bottle(0.3, 1.6, 0.04, 0.5, 48).unwrap(),
        ),
        ("default bottle (r 0.5, h 1.6, wall 0.05)", procedural::bottle(0.5, 1.6, 0.05, 0.5, 48).unwrap()),
    ];
    for (name, mesh) in bottles {
        println!("{name}: {} triangles", mesh.triangle_count());
        println!(
            "| res | surface voxels | LUT bytes | texture | bake s wall / CPU (2 threads) | exact-path pairs \
             | p95 / max |Δf| | p95 / max |Δd| (voxels) |"
        );
        let bvh = MeshBvh::new(&mesh).unwrap();
        let (lo, hi) = mesh.bounds();
        let (centre, radius) = ((lo + hi) * 0.5, (hi - lo).length() * 0.5);
        for res in [30, 40, 50, 56] {
            let (start, cpu) = (std::time::Instant::now(), cpu_seconds());
            let (lut, stats) = bake(&mesh, res, &options(), &|_, _| {}).unwrap();
            let (seconds, cpu) = (start.elapsed().as_secs_f64(), cpu_seconds() - cpu);
            let mut rng = Rng(12345);
            let (mut df, mut dd, mut ndf, mut ndd) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
            while df.len() < 20000 {
                let z = 2.0 * rng.next() - 1.0;
                let phi = std::f64::consts::TAU * rng.next();
                let u = DVec3::new((1.0 - z * z).sqrt() * phi.cos(), z, (1.0 - z * z).sqrt() * phi.sin());
                let side = u.any_orthonormal_vector();
                let up = u.cross(side);
                let (s, t) = (rng.next().sqrt() * radius, std::f64::consts::TAU * rng.next());
                let origin = centre + (side * t.cos() + up * t.sin()) * s - u * 2.0 * radius;
                let crossings = bvh.crossings(origin, u);
                let (Some(first), Some(last)) = (crossings.first(), crossings.last()) else { continue };
                if last.t - first.t < 1e-9 {
                    continue;
                }
                let (a, b) = (origin + u * last.t, origin + u * first.t);
                let exact = bvh.inside_fraction(a, b);
                let record = |i: u32, j: u32, df: &mut Vec<f64>, dd: &mut Vec<f64>| {
                    let f = lut.fraction(i, j);
                    df.push((f - exact).abs());
                    let d = f * lut.centre(i).distance(lut.centre(j)) - exact * a.distance(b);
                    dd.push(d.abs() / lut.voxel_size);
                };
                record(lut.surface_voxel_at(a).unwrap(), lut.surface_voxel_at(b).unwrap(), &mut df, &mut dd);
                // Variant: the LUT's fraction times the length of the actual segment a → b.
                let f = lut.fraction(lut.surface_voxel_at(a).unwrap(), lut.surface_voxel_at(b).unwrap());
                ndf.push((f - exact).abs());
                ndd.push((f - exact).abs() * a.distance(b) / lut.voxel_size);
            }
            let pct = |v: &mut Vec<f64>, p: f64| {
                v.sort_by(f64::total_cmp);
                v[((v.len() - 1) as f64 * p) as usize]
            };
            println!(
                "| {res} | {} | {} | {}×{} | {seconds:.2} / {cpu:.2} | {} of {} | {:.4} / {:.4} | {:.2} / {:.2} |",
                lut.surface_count(),
                lut.bytes(),
                lut.width,
                lut.height,
                stats.exact_pairs,
                stats.pairs,
                pct(&mut df, 0.95),
                pct(&mut df, 1.0),
                pct(&mut dd, 0.95),
                pct(&mut dd, 1.0),
            );
            println!(
                "|    | d = f(i, j)·|b − a| instead of f(i, j)·|c_j − c_i| | | | | | {:.4} / {:.4} | {:.2} / {:.2} |",
                pct(&mut ndf, 0.95),
                pct(&mut ndf, 1.0),
                pct(&mut ndd, 0.95),
                pct(&mut ndd, 1.0),
            );
        }
    }
}
