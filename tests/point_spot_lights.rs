//! Point and spot lights (issue 26 item 2, `KHR_lights_punctual`'s other kinds): candela, the
//! inverse square, glTF's range window and spot cone, placed by the glTF node or a `[[light]]`
//! table or spawned at run time; the raster against its f64 twin (`effects::shading::Lighting::
//! raster_at`), pre-exposure under a 100,000 cd light next to a surface, the hard cases.
//!
//! # Tolerance of the per-pixel comparison (GPU HDR AOV vs the f64 twin × pre-exposure)
//!
//! The twin is evaluated at the f64 intersection of the pixel-centre ray with the plane (y = 0,
//! normal +y). The GPU shades the fragment at its interpolated position relative to the camera
//! (as the lights' positions are), which differs by the rasterizer's sub-pixel snapping of the
//! vertices (lavapipe: 8 sub-pixel bits, 1/256 pixel) and the f32 perspective-correct
//! interpolation (a few ulps of the corners' coordinates relative to the camera, ≤ 13 here: under
//! δₙ = 2⁻²⁰·|p − camera| in any direction, off the plane too): along the plane well below 1/32 of
//! the pixel's footprint, the distance δ used. So the GPU value is within
//! V = max |twin(p ± δ·x̂), twin(p ± δ·ẑ), twin(p ± δₙ·ŷ) − twin(p)| of the twin's at a point the
//! GPU may have shaded (off the plane it matters only where n·l ≈ 0: a light lying in the plane); V is computed per pixel, which makes the band wide exactly
//! where the shading is steep (the spot cone's edge: clamp(cos θ·scale + offset)² with scale up to
//! 1/(cos 15° − cos 25°) ≈ 17, and the range window's rim) and narrow elsewhere. On top: the f32
//! arithmetic of `light_arriving` (d² as a dot product, inversesqrt (2 ulp), the division (2.5
//! ulp), the cone's multiply-add, the products: under 32·2⁻²⁴ relative) and the RGBA16F store
//! (one ulp, 2⁻¹⁰ relative, 2⁻²⁴ absolute below 2⁻¹⁴: lavapipe's f32 → f16 store rounds toward
//! zero, measured — an ambient-only 0.016 is stored as 0.0159912, not the nearer 0.0160065).
//! Asserted: |gpu − twin| ≤ twin·(2⁻¹⁰ + 2⁻¹⁹) + V + 2⁻²⁴, twin = min(scene-linear twin ×
//! pre-exposure, 65504) (the shader's cap). The maximum ratio of error to bound is printed.

mod common;

use std::f64::consts::PI;
use std::path::Path;

use common::gltf_writer::{temp_dir, IndexWidth, Writer};
use glam::DVec3;
use hadou::effects::shading::{Lighting, LocalLight};
use hadou::effects::tonemap::{pre_exposure, tonemap_channel, tonemap_factor};
use hadou::passes::gpu_structs::GpuLight;
use hadou::scene::{Light, LightKind, Scene, LOCAL_LIGHT_MAX};
use hadou::{Aov, FrameRequest};
use serde_json::json;

const W: u32 = 96;
const H: u32 = 72;

/// A 10 × 10 plane at y = 0 (albedo 0.8, 0.7, 0.6), seen from above at an angle, lit by a point
/// light (8 cd, range 4) and a spot light (30 cd, cone 15°–25°, tilted), ambient 0.02.
const TOML: &str = r#"
[render]
ambient = [0.02, 0.02, 0.02]
[camera]
position = [0, 7, 6]
look_at = [0, 0, 0.3]
fov_y_deg = 55
[[mesh]]
name = "ground"
kind = "plane"
size = 10
[[material]]
name = "clay"
albedo = [0.8, 0.7, 0.6]
[[instance]]
mesh = "ground"
material = "clay"
[[light]]
kind = "point"
position = [-1.5, 0.8, 0.2]
color = [1.0, 0.8, 0.6]
intensity = 8
range = 4
[[light]]
kind = "spot"
position = [1.6, 2.0, 0.5]
direction = [0.2, -1, 0.1]
color = [0.6, 0.8, 1.0]
intensity = 30
inner_cone_deg = 15
outer_cone_deg = 25
"#;

fn parse(text: &str) -> Scene {
    hadou::scene::parse_scene(text, Path::new("lights.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// A camera first (3 lines), then `text`.
fn with_camera(text: &str) -> String {
    format!("[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n{text}")
}

fn parse_err(text: &str) -> String {
    hadou::scene::parse_scene(&with_camera(text), Path::new("lights.toml"))
        .map(|_| ())
        .unwrap_err()
        .to_string()
}

#[test]
fn twin_inverse_square_window_cone_and_hard_cases() {
    // 8 cd facing a white surface at 2: E = 8/4 lux, luminance E/π.
    let point =
        LocalLight { light: Light::point(DVec3::new(0.0, 2.0, 0.0), DVec3::ONE, 8.0), radiance: DVec3::ZERO };
    let point = LocalLight { radiance: point.light.radiance(), ..point };
    let (l, r) = point.arriving(DVec3::ZERO);
    assert_eq!(l, DVec3::Y);
    assert!((r.x - 2.0 / PI).abs() < 1e-15, "{r}");
    // Range: the spec's window clamp(1 − (d/range)⁴, 0, 1): 1 − 1/16 at half the range, 0 at it.
    let ranged = LocalLight { light: point.light.with_range(4.0), ..point };
    assert!((ranged.arriving(DVec3::ZERO).1.x - 2.0 / PI * (1.0 - 1.0 / 16.0)).abs() < 1e-15);
    assert_eq!(ranged.arriving(DVec3::new(0.0, -2.0, 0.0)).1, DVec3::ZERO);
    // d → 0: at the light itself l = 0 and the light is finite (capped); just off it, capped.
    for p in [DVec3::new(0.0, 2.0, 0.0), DVec3::new(1e-20, 2.0, 0.0), DVec3::new(0.0, 2.0 - 1e-9, 0.0)] {
        let (l, r) = point.arriving(p);
        assert!(l.is_finite() && r.is_finite() && r.max_element() <= LOCAL_LIGHT_MAX, "{p}: {l} {r}");
    }
    assert_eq!(point.arriving(point.light.position).0, DVec3::ZERO);
    // A surface at the light gets no light (n·l = 0), no NaN; huge albedo-free sums stay finite.
    let scene = parse(TOML);
    let lighting = Lighting::new(&scene);
    let at_light = lighting.raster_at(DVec3::ONE, scene.lights[0].position, DVec3::Y);
    assert!(at_light.is_finite(), "{at_light}");
    // Spot: full inside the inner cone, none outside the outer, the spec's ramp squared between.
    let spot = Light::spot(DVec3::ZERO, DVec3::NEG_Y, DVec3::ONE, 1.0, 0.2, 0.4);
    assert_eq!(spot.cone_attenuation(DVec3::NEG_Y), 1.0);
    let at = |a: f64| spot.cone_attenuation(DVec3::new(a.sin(), -a.cos(), 0.0));
    assert_eq!(at(0.41), 0.0);
    assert_eq!(at(0.19), 1.0);
    let mid = ((0.3f64.cos() - 0.4f64.cos()) / (0.2f64.cos() - 0.4f64.cos())).powi(2);
    assert!((at(0.3) - mid).abs() < 1e-14);
    // inner ≥ outer: the spec's guard (a ramp 0.001 wide in cos θ), finite, 0 outside, 1 inside.
    for (inner, outer) in [(0.4, 0.4), (0.5, 0.4)] {
        let hard = Light::spot(DVec3::ZERO, DVec3::NEG_Y, DVec3::ONE, 1.0, inner, outer);
        let (scale, offset) = hard.cone_scale_offset();
        assert_eq!(scale, 1000.0);
        assert!(offset.is_finite());
        let at = |a: f64| hard.cone_attenuation(DVec3::new(a.sin(), -a.cos(), 0.0));
        assert_eq!(at(0.41), 0.0);
        assert_eq!(at(0.3), 1.0);
    }
    // A directional light's GPU record is what it was before point lights (bit for bit).
    let sun = Light::directional(DVec3::new(1.0, -2.0, -1.0), DVec3::new(1.0, 0.9, 0.8), 3.0);
    let g = GpuLight::new(&sun, 0.25, DVec3::new(3.0, 1.0, 2.0));
    let want = sun.color * sun.intensity * 0.25;
    assert_eq!(g.radiance, [want.x as f32, want.y as f32, want.z as f32, 0.0]);
    assert_eq!(g.position, [0.0; 4]);
    let d = sun.direction;
    assert_eq!(g.direction, [d.x as f32, d.y as f32, d.z as f32, 0.0]);
}

#[test]
fn toml_point_and_spot_lights_and_their_errors() {
    let s = parse(TOML);
    assert_eq!(s.lights.len(), 2);
    let (p, sp) = (s.lights[0], s.lights[1]);
    assert_eq!(p.kind, LightKind::Point);
    assert_eq!((p.position, p.intensity, p.range), (DVec3::new(-1.5, 0.8, 0.2), 8.0, Some(4.0)));
    let LightKind::Spot { inner_cone, outer_cone } = sp.kind else { panic!("{sp:?}") };
    assert!(
        (inner_cone - 15f64.to_radians()).abs() < 1e-15 && (outer_cone - 25f64.to_radians()).abs() < 1e-15
    );
    assert!((sp.direction - DVec3::new(0.2, -1.0, 0.1).normalize()).length() < 1e-15);
    assert_eq!(sp.range, None, "no range: infinite");
    // Defaults of a spot: inner 0°, outer 45° (glTF's).
    let d = parse(&with_camera("[[light]]\nkind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\n"));
    assert_eq!(d.lights[0].kind, LightKind::Spot { inner_cone: 0.0, outer_cone: 45f64.to_radians() });
    // Errors at line:col, naming the field and what is expected.
    let cases = [
        (
            "[[light]]\nkind = \"point\"\nposition = [0, 1, 0]\nrange = 0\n",
            "lights.toml:7:9: light 1 `range`: expected a number in [1.0842e-19",
        ),
        (
            "[[light]]\nkind = \"point\"\nposition = [0, 1, 0]\nrange = -2\n",
            "lights.toml:7:9: light 1 `range`",
        ),
        (
            "[[light]]\nkind = \"point\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\n",
            "lights.toml:7:1: light 1: `direction` is not a field of a point light",
        ),
        ("[[light]]\nkind = \"point\"\n", "light 1: missing `position`"),
        (
            "[[light]]\ndirection = [0, -1, 0]\nposition = [0, 1, 0]\n",
            "lights.toml:6:1: light 1: `position` is not a field of a directional light",
        ),
        (
            "[[light]]\nkind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nouter_cone_deg = 0\n",
            "lights.toml:8:18: light 1 `outer_cone_deg`: expected a number in (0, 90]",
        ),
        (
            "[[light]]\nkind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\ninner_cone_deg = -1\n",
            "lights.toml:8:18: light 1 `inner_cone_deg`: expected a number in [0, 90]",
        ),
        ("[[light]]\nkind = \"spot\"\nposition = [0, 1, 0]\n", "light 1: missing `direction`"),
        (
            "[[light]]\nkind = \"point\"\nposition = [0, 1, 0]\ninner_cone_deg = 5\n",
            "`inner_cone_deg` is not a field of a point light",
        ),
        (
            "[[light]]\nkind = \"point\"\nposition = [0, 1e20, 0]\n",
            "light 1 `position`: expected an array of 3 numbers, each in [-2.8147e14",
        ),
        ("[[light]]\nkind = \"area\"\n", "light 1 `kind`: expected one of"),
    ];
    for (text, want) in cases {
        let e = parse_err(text);
        assert!(e.contains(want), "{text:?}: {e}");
    }
    // More than 8 lights of any kind: refused, naming the limit.
    let nine = "[[light]]\nkind = \"point\"\nposition = [0, 1, 0]\n".repeat(9);
    let e = parse_err(&nine);
    assert!(e.contains("too many [[light]] tables (expected at most 8 lights of any kind"), "{e}");
    // Inner ≥ outer is the spec's hard edge, not an error.
    parse(&with_camera(
        "[[light]]\nkind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\ninner_cone_deg = 30\nouter_cone_deg = 30\n",
    ));
}

/// The same scene as a glTF file: the plane, the point light on a node at its position, the spot
/// light on a node turned so its −z points straight down.
fn gltf_scene(dir: &Path) -> std::path::PathBuf {
    let mut w = Writer::default();
    let plane = hadou::scene::procedural::plane(10.0).unwrap();
    let m = w.material(json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.7, 0.6, 1.0] } }));
    let prim = w.primitive(&plane, IndexWidth::U16, true, Some(m));
    let mesh = w.mesh(vec![prim]);
    let ground = w.node(json!({ "mesh": mesh }));
    w.lights.push(json!({ "type": "point", "color": [1.0, 0.8, 0.6], "intensity": 8.0, "range": 4.0 }));
    w.lights.push(json!({
        "type": "spot", "color": [0.6, 0.8, 1.0], "intensity": 30.0,
        "spot": { "innerConeAngle": 15f64.to_radians(), "outerConeAngle": 25f64.to_radians() }
    }));
    w.uses("KHR_lights_punctual");
    let point = w.node(
        json!({ "translation": [-1.5, 0.8, 0.2], "extensions": { "KHR_lights_punctual": { "light": 0 } } }),
    );
    // −90° about x: −z → −y.
    let h = std::f64::consts::FRAC_PI_4;
    let spot = w.node(json!({
        "translation": [1.6, 2.0, 0.5], "rotation": [-h.sin(), 0.0, 0.0, h.cos()],
        "extensions": { "KHR_lights_punctual": { "light": 1 } }
    }));
    let half = -(7f64 / 6.0).atan() / 2.0;
    w.cameras.push(json!({ "type": "perspective", "perspective": { "yfov": 55f64.to_radians(), "znear": 0.1, "zfar": 100.0 } }));
    let cam = w.node(json!({ "camera": 0, "translation": [0.0, 7.0, 6.0], "rotation": [half.sin(), 0.0, 0.0, half.cos()] }));
    w.scene_roots = vec![ground, point, spot, cam];
    w.write_glb(dir, "lamps")
}

struct Shot {
    color: Vec<u8>,
    hdr: Vec<[f64; 3]>,
    depth: Vec<f32>,
}

fn shoot(scene: &Scene) -> Shot {
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let shot = shoot_with(&mut rt);
    rt.finish();
    shot
}

fn shoot_with(rt: &mut hadou::Runtime) -> Shot {
    let mut request = FrameRequest::new(W, H);
    request.aovs = vec![Aov::Hdr, Aov::Depth];
    let frame = rt.render(&request).unwrap();
    let hdr =
        frame.aov(Aov::Hdr).unwrap().data.chunks(4).map(|c| [c[0], c[1], c[2]].map(f64::from)).collect();
    let depth = frame.aov(Aov::Depth).unwrap().data.clone();
    Shot { color: frame.color.unwrap(), hdr, depth }
}

/// An upward square face: the plane y = `y` within `half` of (`cx`, `cz`), drawn by `instance`.
struct Face {
    y: f64,
    cx: f64,
    cz: f64,
    half: f64,
    instance: usize,
}

/// The ground plane of `TOML`.
const GROUND: Face = Face { y: 0.0, cx: 0.0, cz: 0.0, half: 5.0, instance: 0 };

/// Where the ray of pixel (x, y) meets the ground, if it does within it (margin `inset` from its
/// edges).
fn on_plane(scene: &Scene, x: u32, y: u32, inset: f64) -> Option<DVec3> {
    on_face(scene, &GROUND, x, y, inset)
}

fn on_face(scene: &Scene, f: &Face, x: u32, y: u32, inset: f64) -> Option<DVec3> {
    let (o, u) = scene.camera.pixel_ray(x, y, W, H);
    let t = (f.y - o.y) / u.y;
    let p = o + u * t;
    let inside = (p.x - f.cx).abs() <= f.half - inset && (p.z - f.cz).abs() <= f.half - inset;
    (t > 0.0 && inside).then_some(p)
}

/// Compares every plane pixel's HDR value with the twin × pre-exposure (module docs); returns the
/// pixels inside the spot's penumbra (steep cone) that were compared.
fn compare_with_twin(name: &str, scene: &Scene, shot: &Shot) -> usize {
    compare_face(name, scene, shot, &GROUND, (W * H / 2) as usize)
}

/// `compare_with_twin` on face `f`, over the pixels that show it (their distance AOV is the
/// face's), at least `min` of them.
fn compare_face(name: &str, scene: &Scene, shot: &Shot, f: &Face, min: usize) -> usize {
    let lighting = Lighting::new(scene);
    assert_eq!(lighting.local.len(), scene.lights.iter().filter(|l| l.is_local()).count());
    let p = pre_exposure(scene);
    let albedo = scene.materials[scene.instances[f.instance].material].albedo;
    let twin = |q: DVec3| (lighting.raster_at(albedo, q, DVec3::Y) * p).min(DVec3::splat(65504.0));
    let (mut compared, mut penumbra, mut worst) = (0usize, 0usize, 0.0f64);
    let spot = scene.lights.iter().find(|l| matches!(l.kind, LightKind::Spot { .. })).copied();
    for y in 0..H {
        for x in 0..W {
            let Some(q) = on_face(scene, f, x, y, 0.05) else { continue };
            let i = (y * W + x) as usize;
            assert!(shot.depth[i].is_finite(), "{name}: pixel ({x}, {y}) shows no surface");
            let dist = (q - scene.camera.position).length();
            if (shot.depth[i] as f64 - dist).abs() > 1e-3 * dist {
                continue; // another surface in front
            }
            // δ: 1/32 of the pixel's footprint on the plane.
            let step =
                |dx: u32, dy: u32| on_face(scene, f, x + dx, y + dy, -1.0).map_or(0.0, |n| (n - q).length());
            let delta = step(1, 0).max(step(0, 1)).max(1e-3) / 32.0;
            let t = twin(q);
            let mut v = DVec3::ZERO;
            for off in [DVec3::X, DVec3::NEG_X, DVec3::Z, DVec3::NEG_Z] {
                v = v.max((twin(q + off * delta) - t).abs());
            }
            // Off the plane: the f32 position relative to the camera (module docs).
            let off_plane = 2f64.powi(-20) * dist;
            for off in [DVec3::Y, DVec3::NEG_Y] {
                v = v.max((twin(q + off * off_plane) - t).abs());
            }
            let bound = t * (2f64.powi(-10) + 2f64.powi(-19)) + v + DVec3::splat(2f64.powi(-24));
            for k in 0..3 {
                let e = (shot.hdr[i][k] - t[k]).abs();
                worst = worst.max(e / bound[k]);
                assert!(
                    e <= bound[k],
                    "{name} ({x}, {y}) channel {k}: gpu {}, twin {}, bound {}",
                    shot.hdr[i][k],
                    t[k],
                    bound[k]
                );
            }
            compared += 1;
            if let Some(s) = spot {
                let c = s.cone_attenuation((q - s.position).normalize());
                penumbra += usize::from(c > 0.0 && c < 1.0);
            }
        }
    }
    println!(
        "{name}: {compared} plane pixels, {penumbra} in the spot's penumbra; max error / bound {worst:.3}"
    );
    assert!(compared >= min, "{name}: {compared}");
    penumbra
}

#[test]
fn point_and_spot_lights_over_a_plane_match_the_twin() {
    // TOML.
    let toml = parse(TOML);
    let shot = shoot(&toml);
    let penumbra = compare_with_twin("toml", &toml, &shot);
    assert!(penumbra > 40, "the cone's edge is in view: {penumbra}");
    // The tonemapped picture (linear exposure 1, p = 1) follows the HDR (≤ 1 code).
    assert_eq!(pre_exposure(&toml), 1.0);
    let factor = tonemap_factor(&toml, 1.0);
    for (i, c) in shot.hdr.iter().enumerate() {
        for (k, &v) in c.iter().enumerate() {
            let want = tonemap_channel(v, factor);
            assert!((shot.color[i * 4 + k] as f64 - want).abs() <= 1.0, "pixel {i}");
        }
    }
    // glTF: the same lights placed by their nodes, shown at the automatic exposure.
    let dir = temp_dir("point_spot");
    let path = gltf_scene(&dir);
    let imp = hadou::scene::gltf::import(&path, &Default::default()).unwrap();
    let summary = imp.ignored.summary();
    assert!(!summary.contains("point light") && !summary.contains("spot light"), "{summary}");
    let gltf = hadou::scene::load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(gltf.lights.len(), 2);
    let (p, s) = (gltf.lights[0], gltf.lights[1]);
    assert_eq!((p.kind, p.intensity, p.range), (LightKind::Point, 8.0, Some(4.0)), "candela as they are");
    assert!((p.position - DVec3::new(-1.5, 0.8, 0.2)).length() < 1e-6);
    assert!((s.position - DVec3::new(1.6, 2.0, 0.5)).length() < 1e-6);
    assert!((s.direction - DVec3::NEG_Y).length() < 1e-6, "{}", s.direction);
    let shot = shoot(&gltf);
    let penumbra = compare_with_twin("gltf", &gltf, &shot);
    assert!(penumbra > 40, "{penumbra}");
}

/// A light spawned at run time draws exactly what the same light from the file draws; the light
/// API keeps `LightId`s across kinds and refuses a ninth light naming the limit.
#[test]
fn spawned_point_and_spot_lights_draw_as_the_file_does() {
    let file = parse(TOML);
    let from_file = shoot(&file);
    let mut bare = file.clone();
    bare.lights.clear();
    let mut rt = common::runtime();
    rt.load_scene(bare).unwrap();
    let r = rt.renderer();
    let a = r.spawn_light(DVec3::NEG_Y, DVec3::ONE, 1.0).unwrap();
    let b = r.spawn_light_with(file.lights[1]).unwrap();
    r.set_light_with(a, file.lights[0]).unwrap();
    assert_eq!(r.light(a).unwrap(), file.lights[0]);
    assert_eq!(r.light_ids(), vec![a, b]);
    let spawned = shoot_with(&mut rt);
    assert_eq!(spawned.hdr, from_file.hdr, "bit for bit");
    assert_eq!(spawned.color, from_file.color);
    // Bad values are refused, state unchanged.
    let r = rt.renderer();
    let bad = [
        Light::point(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::ONE, 1.0),
        Light::point(DVec3::ZERO, DVec3::ONE, -1.0),
        Light::point(DVec3::ZERO, DVec3::ONE, 1.0).with_range(0.0),
        Light::spot(DVec3::ZERO, DVec3::NEG_Y, DVec3::ONE, 1.0, 0.1, 0.0),
    ];
    for l in bad {
        assert!(r.set_light_with(b, l).is_err(), "{l:?}");
    }
    assert_eq!(r.light(b).unwrap(), file.lights[1]);
    // set_light on a point light keeps its position.
    r.set_light(a, DVec3::X, DVec3::ONE, 2.0).unwrap();
    assert_eq!(r.light(a).unwrap().position, file.lights[0].position);
    for _ in 0..6 {
        r.spawn_light_with(Light::point(DVec3::Y, DVec3::ONE, 1.0)).unwrap();
    }
    let e = r.spawn_light_with(Light::point(DVec3::Y, DVec3::ONE, 1.0)).unwrap_err().to_string();
    assert!(e.contains("at most 8 lights of any kind"), "{e}");
    let _ = shoot_with(&mut rt);
    rt.finish();
}

/// A 100,000 cd point light 5 cm above the plane, and one lying on it (d → 0 at the surface):
/// finite HDR at most RGBA16F's largest, never refused; every plane pixel matches the twin ×
/// pre-exposure (capped at 65504 as the shader caps), and the pre-exposure keeps the plane's
/// typical (median) pixel a normal f16 (≥ 2⁻¹⁴), not lost in subnormals below the hot spot.
#[test]
fn a_100000_candela_point_light_near_a_surface_renders_finite() {
    for (height, exposure) in [(0.05, "1"), (0.05, "\"auto\""), (0.0, "\"auto\"")] {
        let text = TOML.replacen("[render]", &format!("[render]\nexposure = {exposure}"), 1).replacen(
            "position = [-1.5, 0.8, 0.2]\ncolor = [1.0, 0.8, 0.6]\nintensity = 8",
            &format!("position = [-1.5, {height}, 0.2]\ncolor = [1.0, 0.8, 0.6]\nintensity = 100000"),
            1,
        );
        let scene = parse(&text);
        let p = pre_exposure(&scene);
        let shot = shoot(&scene);
        let top = shot.hdr.iter().flatten().fold(0.0f64, |m, &v| m.max(v));
        assert!(
            shot.hdr.iter().flatten().all(|v| v.is_finite() && *v <= 65504.0),
            "height {height}: HDR not finite"
        );
        let name = format!("100,000 cd at {height}, exposure {exposure}");
        compare_with_twin(&name, &scene, &shot);
        let mut plane: Vec<f64> = (0..H)
            .flat_map(|y| (0..W).map(move |x| (x, y)))
            .filter(|&(x, y)| on_plane(&scene, x, y, 0.05).is_some())
            .map(|(x, y)| shot.hdr[(y * W + x) as usize][1])
            .collect();
        plane.sort_by(f64::total_cmp);
        let median = plane[plane.len() / 2];
        let codes: Vec<u8> = shot.color.chunks(4).map(|c| c[1]).collect();
        let white = codes.iter().filter(|&&c| c == 255).count();
        println!(
            "{name}: p = 2^{}, HDR up to {top:.1}, plane median {median:.3e}, {white} of {} pixels white",
            p.log2(),
            codes.len()
        );
        // Lying on the plane (height 0) the light reaches it at grazing incidence, n·l = 0: the
        // plane has only the spot and the ambient, while the pre-exposure still assumes a surface
        // facing the light at 1% of the scene's extent (conservative): the plane's median falls
        // below f16's normals, where its step 2⁻²⁴ is still ≤ 2⁻⁶ of the value.
        let floor = if height > 0.0 { 2f64.powi(-14) } else { 2f64.powi(-18) };
        assert!(median >= floor, "{name}: median {median}");
    }
}

/// glTF's hard cases: `range` 0 (the schema says > 0) is read as infinite and named in the
/// warning; inner ≥ outer is the spec's hard edge; an outer cone past π/2 and a negative range are
/// errors at their pointers.
#[test]
fn gltf_light_hard_cases() {
    let dir = temp_dir("point_spot_hard");
    let base = |lights: Vec<serde_json::Value>| {
        let mut w = Writer::default();
        let plane = hadou::scene::procedural::plane(4.0).unwrap();
        let prim = w.primitive(&plane, IndexWidth::U16, true, None);
        let mesh = w.mesh(vec![prim]);
        let ground = w.node(json!({ "mesh": mesh }));
        w.uses("KHR_lights_punctual");
        let mut roots = vec![ground];
        for (i, l) in lights.into_iter().enumerate() {
            w.lights.push(l);
            roots.push(w.node(json!({
                "translation": [0.0, 1.0, 0.0],
                "extensions": { "KHR_lights_punctual": { "light": i } }
            })));
        }
        w.scene_roots = roots;
        w
    };
    let w = base(vec![
        json!({ "type": "point", "intensity": 5.0, "range": 0.0 }),
        json!({ "type": "spot", "intensity": 5.0, "spot": { "innerConeAngle": 0.5, "outerConeAngle": 0.5 } }),
    ]);
    let path = w.write_glb(&dir, "hard");
    let imp = hadou::scene::gltf::import(&path, &Default::default()).unwrap();
    let summary = imp.ignored.summary();
    assert!(
        summary.contains(
            "light ranges of 0 (invalid: drawn as infinite) (/extensions/KHR_lights_punctual/lights/0/range)"
        ),
        "{summary}"
    );
    assert_eq!(imp.lights.len(), 2);
    assert_eq!((imp.lights[0].range, imp.lights[0].position), (None, DVec3::Y));
    // inner = outer on a regular node: the spec's guard, a hard edge.
    let mut w =
        base(vec![json!({ "type": "spot", "spot": { "innerConeAngle": 0.5, "outerConeAngle": 0.5 } })]);
    w.nodes[1]["scale"] = json!([1.0, 1.0, 1.0]);
    let s = hadou::scene::load_scene(&w.write_glb(&dir, "edge")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.lights[0].kind, LightKind::Spot { inner_cone: 0.5f32 as f64, outer_cone: 0.5f32 as f64 });
    assert_eq!(s.lights[0].cone_scale_offset().0, 1000.0);
    w.lights[0] = json!({ "type": "spot", "spot": { "outerConeAngle": 2.0 } });
    let e = hadou::scene::load_scene(&w.write_glb(&dir, "wide")).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("/extensions/KHR_lights_punctual/lights/0/spot/outerConeAngle: 2 (expected a number in (0, pi/2])"), "{e}");
    w.lights[0] = json!({ "type": "point", "range": -1.0 });
    let e = hadou::scene::load_scene(&w.write_glb(&dir, "negative")).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("/extensions/KHR_lights_punctual/lights/0/range"), "{e}");
}

/// A translucent material under a point light alone: its surface is lit as an opaque one's (the
/// raster's Lambert: the top face of a translucent cube per pixel against the twin), the
/// translucency pass runs without a light to look through (no directional light), zero
/// validation messages; with a directional light added after the point light, that one is the
/// light through (`Scene::first_directional_light`).
#[test]
fn translucent_material_under_a_point_light() {
    let text = format!(
        "{TOML}[[mesh]]\nname = \"box\"\nkind = \"cube\"\nsize = 1\n[[material]]\nname = \"jade\"\nkind = \
         \"translucent\"\nalbedo = [0.55, 0.85, 0.65]\nsigma = [3.0, 1.2, 2.2]\nvoxel_res = 8\n[[instance]]\nmesh = \
         \"box\"\nmaterial = \"jade\"\ntransform = [{{ translate = [-1.0, 0.0, 1.3] }}]\n"
    );
    let mut scene = parse(&text);
    assert!(scene.first_directional_light().is_none());
    let shot = shoot(&scene);
    compare_with_twin("translucent scene, ground", &scene, &shot);
    let top = Face { y: 0.5, cx: -1.0, cz: 1.3, half: 0.5, instance: 1 };
    compare_face("translucent cube's top", &scene, &shot, &top, 20);
    scene.lights.push(Light::directional(DVec3::new(0.3, -1.0, 0.2), DVec3::ONE, 0.5));
    assert_eq!(scene.first_directional_light(), Some(&scene.lights[2]));
    let shot = shoot(&scene);
    assert!(shot.hdr.iter().flatten().all(|v| v.is_finite()));
}

/// Metaballs under a point and a spot light (shaders/metaballs.comp calls the same
/// `light_arriving` at its hit point camera + t·u): per pixel against `Lighting::metaball_at`.
///
/// The GPU shades its own f32 hit, read back exactly (the distance AOV is R32F: t) and its normal
/// (the normal AOV, RGBA16F: within 1.01·2⁻¹⁰ rad of the f32 normal by its encoding). So the GPU's
/// point is within δ = |t_gpu − t| + t·2⁻²² of the f64 cast's (the f32 ray direction adds ~2⁻²³
/// rad) and its normal within θ = ∠(n_aov, n) + 1.01·2⁻¹⁰ of the f64 normal; the twin's variation
/// over that neighbourhood — V_p = max |twin(q ± δ·e_k) − twin(q)| over the three axes and V_n =
/// max |twin(n tilted by ±θ about two axes) − twin(n)| — bounds the shading's change to first
/// order, doubled for the second order. On top the f32 arithmetic (the pow of the highlight:
/// 3 + 2·48·|log₂ x| ulps, ≤ 2⁻¹⁶ relative with the rest) and the f16 store (2⁻¹⁰, 2⁻²⁴ below
/// 2⁻¹⁴). Pixels in a group's tangency band or on the outline (a 4-neighbour's hit differs) are
/// left out: f32 may hit or miss there. This checks the shading given the geometry; the geometry
/// itself is tests/gpu_shading.rs's.
#[test]
fn metaballs_under_point_and_spot_lights_match_the_twin() {
    use hadou::effects::metaballs::cast;
    use hadou::effects::metaballs_f32::tangency;
    let scene = parse(
        r#"
        [render]
        ambient = [0.03, 0.03, 0.04]
        [camera]
        position = [2.5, 3, 6]
        look_at = [0, 1, 0]
        fov_y_deg = 40
        [[light]]
        kind = "point"
        position = [1.2, 2.6, 1.6]
        color = [1.0, 0.85, 0.7]
        intensity = 6
        range = 8
        [[light]]
        kind = "spot"
        position = [-2.5, 3.5, 1.0]
        direction = [0.8, -1, -0.3]
        color = [0.5, 0.7, 1.0]
        intensity = 25
        inner_cone_deg = 8
        outer_cone_deg = 16
        [[material]]
        name = "green"
        albedo = [0.3, 0.75, 0.35]
        [[metaballs]]
        name = "blob"
        material = "green"
        transform = [{ scale = [1.3, 0.8, 1.0] }, { translate = [0, 1.2, 0] }]
        balls = [
          { centre = [-0.6, 0, 0], radius = 1.6 },
          { centre = [0.6, 0.1, 0], radius = 1.5 },
        ]
        "#,
    );
    let (w, h) = (128u32, 96u32);
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let mut request = FrameRequest::new(w, h);
    request.aovs = vec![Aov::Hdr, Aov::Depth, Aov::Normal];
    let frame = rt.render(&request).unwrap();
    rt.finish();
    let hdr = &frame.aov(Aov::Hdr).unwrap().data;
    let depth = &frame.aov(Aov::Depth).unwrap().data;
    let normal = &frame.aov(Aov::Normal).unwrap().data;
    let lighting = Lighting::new(&scene);
    let p = pre_exposure(&scene);
    let group = scene.metaballs()[0].at(0.0);
    let albedo = scene.materials[scene.metaballs()[0].material].albedo;
    let forward = scene.camera.basis().forward;
    let hits: Vec<Option<(DVec3, DVec3, f64)>> = (0..w * h)
        .map(|i| {
            let (o, u) = scene.camera.pixel_ray(i % w, i / w, w, h);
            let along = u.dot(forward);
            let (t0, t1) = (scene.camera.near / along, scene.camera.far / along);
            if tangency(&group, o, u, t0, t1).in_band() {
                return None;
            }
            cast(&group, o, u, t0, t1).map(|hit| {
                let n = if hit.normal.dot(u) > 0.0 { -hit.normal } else { hit.normal };
                (o + u * hit.t, n, hit.t)
            })
        })
        .collect();
    let (mut compared, mut lit_by_spot, mut worst) = (0usize, 0usize, 0.0f64);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = (y * w + x) as usize;
            let Some((q, n, t)) = hits[i] else { continue };
            let neighbours = [i - 1, i + 1, i - w as usize, i + w as usize];
            if neighbours.iter().any(|&j| hits[j].is_none()) {
                continue; // the outline (or a band pixel beside it)
            }
            let (_, u) = scene.camera.pixel_ray(x, y, w, h);
            let v = -u;
            let twin = |q: DVec3, n: DVec3| lighting.metaball_at(albedo, q, n, v) * p;
            let n_gpu = DVec3::new(normal[i * 4] as f64, normal[i * 4 + 1] as f64, normal[i * 4 + 2] as f64);
            let theta = n_gpu.normalize().dot(n).clamp(-1.0, 1.0).acos() + 1.01 / 1024.0;
            let delta = (depth[i] as f64 - t).abs() + t * 2f64.powi(-22);
            let base = twin(q, n);
            let mut vp = DVec3::ZERO;
            for e in [DVec3::X, DVec3::Y, DVec3::Z] {
                for s in [-1.0, 1.0] {
                    vp = vp.max((twin(q + e * (s * delta), n) - base).abs());
                }
            }
            let (a, b) = n.any_orthonormal_pair();
            let mut vn = DVec3::ZERO;
            for axis in [a, b] {
                for s in [-1.0, 1.0] {
                    let turned = glam::DQuat::from_axis_angle(axis, s * theta) * n;
                    vn = vn.max((twin(q, turned) - base).abs());
                }
            }
            let bound =
                (vp + vn) * 2.0 + base * (2f64.powi(-10) + 2f64.powi(-16)) + DVec3::splat(2f64.powi(-24));
            for k in 0..3 {
                let e = (hdr[i * 4 + k] as f64 - base[k]).abs();
                worst = worst.max(e / bound[k]);
                assert!(
                    e <= bound[k],
                    "({x}, {y}) channel {k}: gpu {}, twin {}, bound {}",
                    hdr[i * 4 + k],
                    base[k],
                    bound[k]
                );
            }
            compared += 1;
            let spot = &lighting.local[1];
            lit_by_spot +=
                usize::from(spot.arriving(q).1.max_element() > 0.0 && n.dot(spot.arriving(q).0) > 0.0);
        }
    }
    println!("metaballs: {compared} pixels, {lit_by_spot} lit by the spot; max error / bound {worst:.3}");
    assert!(compared > 1000 && lit_by_spot > 50, "{compared} pixels, {lit_by_spot} lit by the spot");
}
