//! `thickness = "pairs"`, the seed's own LUT (seed 003 §3.2; crates/hadou/src/effects/thickness_pairs.rs):
//! the bake against the exact f64 pair thickness, the GPU pass against its f64 twin on lavapipe
//! (validation and sync validation on), and the refusal of a table past the limits.
//!
//! # The GPU-vs-twin tolerance
//!
//! The TSM render of the same scene gives per pixel the light-map distance tsm = z(P) − z(entry)
//! the pairs mode starts from (same maps, same texel search), so the twin's entry is
//! a = P − l·tsm and d_twin = `exact_pair_thickness(M⁻¹a, M⁻¹P)` = tsm·min(d*(i, j)/|c_j − c_i|, 1),
//! with d*(i, j) the exact f64 pair thickness cast on the mesh (not the stored byte). The GPU reads
//! q(i, j)/255·D with |q/255·D − d*| ≤ ½·D/255 (`QUANTIZATION_BOUND`·D), and min(·, 1) is
//! 1-Lipschitz, so |d_gpu − d_twin| ≤ tsm·(½·D/255)/|c_j − c_i| for i ≠ j (0 for i = j or an end
//! without a surface voxel: both take the whole path), plus f32 rounding: P and M⁻¹ to ~2⁻²³
//! relative, the division and the products to a few ulps — 1e-5·tsm covers them. The one thing
//! f32 can change discontinuously is which voxel an end falls in (a point within ~1e-6 voxel of a
//! voxel face): a different (i, j), a jump. Those ties are excluded and capped at 1 % of the
//! pixels (they are ~1e-5 of them: two ends, six faces, 1e-6 voxel each).

mod common;

use glam::DVec3;
use hadou::effects::raycast::MeshBvh;
use hadou::effects::thickness_pairs::{self, exact_pair, PairOptions, QUANTIZATION_BOUND};
use hadou::scene::{Scene, ThicknessMode};
use hadou::testing::Comparison;
use hadou::{Aov, FrameRequest};
use hadou_cli::report::translucency::{self as report, with_thickness};

/// Every pair's stored thickness is within the quantization bound of the exact f64 thickness
/// (cast again here, on a sample of the pairs), symmetric, and the cavity of a cavity cube is
/// subtracted: a pair straight through it is shorter than its segment by about the cavity's
/// diameter.
#[test]
fn stored_pairs_are_the_exact_thickness_within_the_quantization_bound() {
    let mesh = hadou::scene::procedural::cavity_cube(1.4, 0.4, 48, 24).unwrap();
    let (t, stats) = thickness_pairs::bake(&mesh, 12, &PairOptions::default(), &|_, _| {}).unwrap();
    let bvh = MeshBvh::new(&mesh).unwrap();
    let n = t.surface_voxels() as u32;
    assert_eq!(t.bytes(), n as u64 * n as u64, "the seed's square N×N bytes");
    let bound = QUANTIZATION_BOUND * t.max_thickness;
    let mut checked = 0;
    for i in (0..n).step_by(7) {
        for j in (0..n).step_by(5) {
            let exact = exact_pair(&t.voxels, &bvh, i, j);
            let stored = t.stored(i, j);
            assert!((stored - exact).abs() <= bound * (1.0 + 1e-9), "pair ({i}, {j}): {stored} vs {exact}");
            assert_eq!(stored, t.stored(j, i));
            checked += 1;
        }
    }
    println!(
        "cavity cube at 12³: {n} surface voxels, {} bytes, {} pairs in {:.2} s, {checked} checked, D {:.3}",
        t.bytes(),
        stats.pairs,
        stats.pair_seconds,
        t.max_thickness
    );
    let (a, b) = (DVec3::new(0.01, 0.02, -0.69), DVec3::new(0.01, 0.02, 0.69));
    let (i, j) = t.voxels.pair_of(a, b).unwrap();
    let length = (t.voxels.centroid(j) - t.voxels.centroid(i)).length();
    let through = t.stored(i, j);
    assert!((length - through - 0.8).abs() < 2.0 * t.voxels.voxel_size, "{through} of {length}");
}

/// Renders `scene` (validation on, clean) and reads back the thickness and depth AOVs.
fn render(scene: &Scene, size: u32) -> (Vec<f32>, Vec<f32>) {
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let mut request = FrameRequest::new(size, size);
    request.color = false;
    request.aovs = vec![Aov::Depth, Aov::Thickness];
    let frame = rt.render(&request).unwrap();
    common::assert_clean(&rt);
    let get = |aov| frame.aov(aov).unwrap().data.clone();
    (get(Aov::Thickness), get(Aov::Depth))
}

const SCENE: &str = r#"
    [render]
    background = [0, 0, 0]
    [camera]
    position = [0, 0, 6]
    look_at = [0, 0, 0]
    fov_y_deg = 25
    [[light]]
    kind = "directional"
    direction = LIGHT
    intensity = 3
    [[mesh]]
    name = "hollow"
    MESH
    [[material]]
    name = "jade"
    kind = "translucent"
    albedo = [0.55, 0.85, 0.65]
    sigma = [3.0, 1.2, 2.2]
    voxel_res = 14
    thickness = "pairs"
    [[instance]]
    mesh = "hollow"
    material = "jade"
    transform = [{ scale = [1.1, 0.9, 1.25] }, { rotate = { angle_deg = 20, axis = [0.2, 0.3, 1] } }]
"#;

/// The pass against its twin on shapes with a cavity, back-lit through it and under a grazing
/// light (the light nearly in the plane of the faces the camera sees), within the tolerance of
/// the module documentation; and the cavity is subtracted where the light crosses it.
#[test]
fn gpu_pairs_match_the_f64_twin_through_cavities_and_at_grazing_light() {
    let ball = "kind = \"hollow_ball\"\nradius = 0.75\ncavity_radius = 0.18\nsegments = 48\nrings = 24";
    let cube = "kind = \"cavity_cube\"\nsize = 1.4\ncavity_radius = 0.45\nsegments = 48\nrings = 24";
    let bottle = "kind = \"bottle\"\nradius = 0.3\nheight = 1.4\nwall = 0.04\nfill = 0.5\nsegments = 48";
    for (label, mesh, light) in [
        ("hollow ball, back-lit", ball, "[0, 0, 1]"),
        ("cavity cube, grazing", cube, "[1, 0.08, 0.12]"),
        ("bottle, back-lit", bottle, "[0.2, -0.1, 1]"),
    ] {
        pairs_case(label, mesh, light);
    }
}

fn pairs_case(label: &str, mesh: &str, light: &str) {
    let size = 160;
    let scene = common::parse(&SCENE.replace("MESH", mesh).replace("LIGHT", light));
    let (pairs_d, depth) = render(&scene, size);
    let tsm_scene = with_thickness(scene.clone(), ThicknessMode::Tsm);
    let (tsm_d, _) = render(&tsm_scene, size);
    let set = report::sample_set(&scene, (size, size), &pairs_d, &depth).unwrap();
    println!("{}", set.assert_usable((size * size / 40) as usize));
    let m = scene.instances[0].transform;
    let mesh = &scene.meshes[0].mesh;
    let (table, _) = thickness_pairs::bake(mesh, 14, &PairOptions::default(), &|_, _| {}).unwrap();
    let bvh = MeshBvh::new(mesh).unwrap();
    let l = scene.lights[0].direction.normalize();
    let hw = report::world_voxel(&scene, 0).unwrap();
    let to_object = |p: DVec3| m.inverse.transform_point3(p);
    let mut cmp = Comparison::new(format!("{label}: |GPU − twin| / tolerance"));
    let (mut through, mut saved) = (0usize, 0.0);
    for s in &set.samples {
        let tsm = tsm_d[s.pixel] as f64;
        let (a, b) = (to_object(s.point - l * tsm), to_object(s.point));
        let twin = thickness_pairs::exact_pair_thickness(&table.voxels, &bvh, &m, a, b).unwrap();
        let quantization = match table.voxels.pair_of(a, b) {
            Some((i, j)) if i != j => {
                let length = (table.voxels.centroid(j) - table.voxels.centroid(i)).length();
                tsm * QUANTIZATION_BOUND * table.max_thickness / length
            }
            _ => 0.0,
        };
        // 1e-6 absolute: a silhouette pixel's tsm of ~0, where the relative terms vanish but the
        // f32 light-map distance itself is rounded.
        let tolerance = quantization + 1e-5 * tsm + 1e-6;
        let diff = (s.gpu - twin).abs();
        // A NaN is not > 1: compared (and failing), never excluded.
        if diff / tolerance > 1.0 {
            cmp.exclude();
        } else {
            cmp.error(
                format_args!("pixel {}: GPU {}, twin {twin}, tsm {tsm}", s.pixel, s.gpu),
                diff / tolerance,
            );
        }
        // TSM counts the cavity; the pairs subtract it where the path crosses more than 2 voxels
        // of it.
        if s.tsm - s.exact > 2.0 * hw {
            through += 1;
            saved += (tsm - s.gpu) / hw;
        }
    }
    let mean_saved = saved / through.max(1) as f64;
    println!(
        "{label}: {} pixels, {} surface voxels, {} table bytes; {through} through a cavity, the pairs \
         {mean_saved:.2} voxels under TSM there on average",
        set.samples.len(),
        table.surface_voxels(),
        table.bytes()
    );
    cmp.assert_within(1.0, set.samples.len() / 2);
    cmp.assert_excluded_at_most(0.01);
    if through > 100 {
        assert!(mean_saved > 1.0, "{label}: the cavity is not subtracted ({mean_saved} voxels)");
    }
}

/// A table past the memory budget is refused when the scene loads, naming the material, the
/// surface voxels and the bytes, before any pair is cast.
#[test]
fn a_table_past_the_budget_is_refused_naming_the_material() {
    let text = SCENE
        .replace("MESH", "kind = \"sphere\"")
        .replace("LIGHT", "[0, 0, 1]")
        .replace("voxel_res = 14", "voxel_res = 64");
    let scene = common::parse(&text);
    // N in (8192, 16384]: within the image side, past the 64 MiB budget.
    let n = thickness_pairs::surface_voxels(&scene.meshes[0].mesh, 64).unwrap().count();
    assert!((8193..=16384).contains(&n), "{n} surface voxels");
    let mut rt = common::runtime();
    let start = std::time::Instant::now();
    // The tables are baked when the passes are first built (at the first frame).
    let e = rt
        .load_scene(scene)
        .and_then(|_| rt.render(&FrameRequest::new(64, 64)).map(|_| ()))
        .expect_err("refused")
        .to_string();
    println!("{e} ({:.1} s)", start.elapsed().as_secs_f64());
    for says in ["material \"jade\"", "surface voxels", "memory budget", "voxel_res"] {
        assert!(e.contains(says), "{says}: {e}");
    }
    rt.finish();
}

/// A pairs instance spawned at run time (its mesh has no table yet) is drawn with TSM while the
/// table bakes in the background (crates/hadou/src/renderer/bakes.rs, the same jobs as the fields'); once it
/// is in use (one copy into the table image, waited for once), the frame is bit for bit the scene
/// loaded with that instance.
#[test]
fn a_pairs_instance_spawned_at_run_time_bakes_in_the_background() {
    let head = r#"
        [camera]
        position = [0, 1.2, 6]
        look_at = [0, 0, 0]
        [[light]]
        direction = [0.2, -0.3, -1]
        intensity = 3
        [[mesh]]
        name = "block"
        kind = "cube"
        size = 1.2
        [[mesh]]
        name = "ring"
        kind = "torus"
        [[material]]
        name = "jade"
        kind = "translucent"
        albedo = [0.55, 0.85, 0.65]
        sigma = [3.0, 1.2, 2.2]
        voxel_res = 14
        thickness = "pairs"
        [[instance]]
        mesh = "block"
        material = "jade"
        transform = [{ translate = [-1.2, 0, 0] }]
    "#;
    let ring = "[[instance]]\nmesh = \"ring\"\nmaterial = \"jade\"\ntransform = [{ rotate = { angle_deg = 70, axis = [1, 0, 0] } }, { translate = [1.2, 0, 0] }]\n";
    let file = common::parse(&format!("{head}{ring}"));
    let mut request = FrameRequest::new(64, 48);
    request.aovs = vec![Aov::Hdr, Aov::Thickness];
    let mut live = common::runtime();
    live.load_scene(common::parse(head)).unwrap();
    live.render(&request).unwrap();
    let r = live.renderer();
    r.spawn_instance("ring", "jade", file.instances[1].transform.matrix).unwrap();
    let progress = r.bakes_in_progress();
    assert_eq!(progress.len(), 1, "{progress:?}");
    assert_eq!((progress[0].mesh.as_str(), progress[0].voxel_res), ("ring", 14));
    let early = live.render(&request).unwrap();
    assert!(early.aov(Aov::Thickness).unwrap().data.iter().all(|v| !v.is_nan()));
    live.renderer().wait_for_bakes().unwrap();
    assert!(live.renderer().bakes_in_progress().is_empty());
    let got = live.render(&request).unwrap();
    let mut rt = common::runtime();
    rt.load_scene(file).unwrap();
    let want = rt.render(&request).unwrap();
    for aov in &request.aovs {
        assert!(common::same_bits(got.aov(*aov).unwrap(), want.aov(*aov).unwrap()), "{} differs", aov.name());
    }
    common::assert_clean(&live);
    common::assert_clean(&rt);
}

/// `hadou bake` on a scene with a `thickness = "pairs"` material bakes its pair table into the
/// cache (then a hit), and `--out` writes it in the cache's format.
#[test]
fn hadou_bake_bakes_pair_tables() {
    use common::cli::{output_within, s, scratch, text, RUN_LIMIT};
    let dir = scratch("pairs-bake");
    let scene = dir.join("pairs.toml");
    let text_scene = SCENE.replace("MESH", "kind = \"cavity_cube\"").replace("LIGHT", "[0, 0, 1]");
    std::fs::write(&scene, text_scene.replace("voxel_res = 14", "voxel_res = 10")).unwrap();
    let run = |args: &[&str]| {
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_hadou"));
        cmd.args(args).env("HADOU_CACHE_DIR", dir.join("cache"));
        output_within(&mut cmd, RUN_LIMIT)
    };
    let out = dir.join("table.hpair");
    let first = run(&["bake", s(&scene), "--out", s(&out)]);
    assert!(first.status.success(), "{}", text(&first));
    assert!(
        text(&first).contains("pair table") && text(&first).contains("baked, cached"),
        "{}",
        text(&first)
    );
    let second = run(&["bake", s(&scene)]);
    assert!(text(&second).contains("cache hit"), "{}", text(&second));
    let mesh = common::parse(&std::fs::read_to_string(&scene).unwrap()).meshes[0].mesh.clone();
    let table = hadou::effects::pair_cache::decode(&std::fs::read(&out).unwrap(), &mesh, 10).unwrap();
    assert!(table.surface_voxels() > 0);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A wobbling mesh cannot be drawn with a pair table (baked from the loaded shape): refused at the
/// instance's `material`, as for `"lut"`.
#[test]
fn a_wobbling_mesh_with_a_pair_table_is_refused() {
    let text = SCENE.replace("MESH", "kind = \"sphere\"\nwobble = 0.05").replace("LIGHT", "[0, 0, 1]");
    let e = hadou::scene::parse_scene(&text, std::path::Path::new("inline.toml")).unwrap_err().to_string();
    assert!(e.contains("material \"jade\" reads a thickness table") && e.contains("wobbles"), "{e}");
}
