//! Scene loading time against scene size: TOML text generated in memory and timed through
//! `parse_scene` (parse, validation, name resolution, mesh building). Loading must grow linearly
//! with the number of instances, materials and metaball balls (issue 14, finding 7).
//!
//! cargo run --release --example load_bench [N ...]
//!
//! Each N (default 100000) is run for four scenes: N instances sharing one material, N instances
//! each with its own material, N explicit balls in one metaball group, and N meshes (planes).

use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

const HEAD: &str = "[camera]\nposition = [0, 2, 8]\nlook_at = [0, 0, 0]\n\n";

/// N instances of one cube; with `own_material`, each names a material of its own.
fn instances(n: usize, own_material: bool) -> String {
    let mut s = String::from(HEAD);
    s.push_str("[[mesh]]\nname = \"box\"\nkind = \"cube\"\n\n");
    if !own_material {
        s.push_str("[[material]]\nname = \"grey\"\n\n");
    }
    for i in 0..n {
        if own_material {
            let _ = writeln!(s, "[[material]]\nname = \"m{i}\"\nalbedo = [0.5, 0.5, 0.5]\n");
        }
        let material = if own_material { format!("m{i}") } else { "grey".into() };
        let (x, z) = ((i % 1000) as f64, (i / 1000) as f64);
        let _ = writeln!(
            s,
            "[[instance]]\nmesh = \"box\"\nmaterial = \"{material}\"\ntransform = [{{ translate = [{x}, 0, {z}] }}]\n"
        );
    }
    s
}

/// One metaball group with N balls written out in `balls`.
fn balls(n: usize) -> String {
    let mut s = String::from(HEAD);
    s.push_str("[[metaballs]]\nname = \"swarm\"\nballs = [\n");
    for i in 0..n {
        let (x, y) = ((i % 1000) as f64 * 0.1, (i / 1000) as f64 * 0.1);
        let _ = writeln!(s, "  {{ centre = [{x}, {y}, 0], radius = 0.2 }},");
    }
    s.push_str("]\n");
    s
}

/// N plane meshes, each drawn by one instance.
fn meshes(n: usize) -> String {
    let mut s = String::from(HEAD);
    for i in 0..n {
        let _ = writeln!(s, "[[mesh]]\nname = \"p{i}\"\nkind = \"plane\"\n");
        let _ = writeln!(s, "[[instance]]\nmesh = \"p{i}\"\n");
    }
    s
}

fn time(label: &str, n: usize, text: &str) {
    let start = Instant::now();
    let scene = hadou::scene::parse_scene(text, Path::new("bench.toml")).expect("generated scene is valid");
    let seconds = start.elapsed().as_secs_f64();
    let objects = scene.instances.len() + scene.metaballs().iter().map(|g| g.balls.len()).sum::<usize>();
    println!(
        "{label:<28} N = {n:>7}  {:>6.1} MiB  {seconds:>8.3} s  ({objects} objects)",
        text.len() as f64 / 1048576.0
    );
}

fn main() {
    let sizes: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let sizes = if sizes.is_empty() { vec![100_000] } else { sizes };
    for n in sizes {
        time("instances, one material", n, &instances(n, false));
        time("instances, own materials", n, &instances(n, true));
        time("metaball balls", n, &balls(n));
        time("meshes", n, &meshes(n));
    }
}
