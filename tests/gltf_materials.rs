//! glTF materials from the file (issue 26 item 1): vertex colours (`COLOR_0`, normalized u8 and
//! u16 and float), emission (`emissiveFactor` × `KHR_materials_emissive_strength`) and alpha mask
//! (`alphaMode: MASK`, `alphaCutoff`), read by the importer and drawn by the raster on lavapipe
//! (validation on), each pixel against the f64 twin (`Lighting::raster_surface`,
//! `Lighting::drawn`) on a glTF the test writes.
//!
//! # The scene
//! Three 2×2 quads in z = 0 (normal +z), seen straight on from a glTF camera at z = 7, under the
//! default light: **A** u8 vertex colours × the base colour plus emission (0.25, 0.5, 0.125) ×
//! strength 2 (the pipeline with vertex attributes); **B** base alpha 0.8 × a u16 vertex alpha
//! running 0 → 1 across x, MASK with cutoff 0.5, so its left 5/8 are not drawn; **C** no vertex
//! attributes, emission (1, 0.5, 0) alone (the plain pipeline). The vertex colours are affine in
//! the quad's x and y (corners 51, 102, 153, 204 / 255: 51 + 204 = 102 + 153), so any
//! triangulation interpolates them to the same function and the twin evaluates it in closed form
//! at the f64 ray's hit point.
//!
//! # The bound (per pixel and channel of HDR)
//! - **f32 shading** as tests/gpu_shading.rs argues: ≤ 2⁻¹⁸·S, S = a·c·(ambient + ΣL) + e the
//!   value's scale.
//! - **Attribute interpolation.** The rasterizer snaps vertices to its sub-pixel grid (Vulkan:
//!   ≥ 4 bits, an edge moves ≤ 1/32 pixel), which shifts where the affine colour is sampled by at
//!   most that much: ≤ g/32, g the largest change of the twin's value between 4-neighbour pixel
//!   centres. The f32 barycentric evaluation adds ≤ 2⁻¹⁶·S (tens of ulps of the plane equation's
//!   terms, with headroom).
//! - **RGBA16F store**: 2⁻¹⁰·(|twin| + E) + 2⁻²⁴.
//!
//! Pixels whose hit lies within one pixel of a quad's outline are left out (the edge itself may
//! fall on either side of a pixel centre: tests/gpu_shading.rs), as are masked pixels whose alpha
//! lies within the same interpolation bound of the cutoff (one column along the mask's edge).
//! Elsewhere a masked-out pixel must show no surface (normal AOV w = 0) and a drawn one the twin.

mod common;

use common::gltf_writer::{temp_dir, IndexWidth, Writer};
use glam::DVec3;
use hadou::effects::shading::Lighting;
use hadou::scene::Scene;
use hadou::testing::Comparison;
use hadou::{Aov, FrameRequest};
use serde_json::{json, Value};

const W: u32 = 480;
const H: u32 = 160;
/// Quad centres along x.
const CENTRES: [f64; 3] = [-2.4, 0.0, 2.4];
const BASE_A: [f64; 3] = [0.9, 0.8, 0.7];
const EMISSION_A: [f64; 3] = [0.5, 1.0, 0.25];
const BASE_B: [f64; 4] = [0.3, 0.6, 0.9, 0.8];
const CUTOFF_B: f64 = 0.5;
const BASE_C: [f64; 3] = [0.5, 0.5, 0.5];
const EMISSION_C: [f64; 3] = [1.0, 0.5, 0.0];

/// The quad's corners (counter-clockwise from (−1, −1)) and indices.
const CORNERS: [[f32; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Quad A's u8 colour at corner k, per channel: affine in (x, y) (R: 51 + 25.5(x+1) + 51(y+1)).
const COLOR_A: [[u8; 4]; 4] =
    [[51, 204, 255, 255], [102, 153, 255, 255], [204, 51, 255, 255], [153, 102, 255, 255]];

/// Quad A's vertex colour at local (x, y), in f64: the affine function through the corners.
fn color_a(x: f64, y: f64) -> DVec3 {
    let c = |k: usize| COLOR_A[k].map(|v| v as f64 / 255.0);
    let (c0, c1, c3) = (c(0), c(1), c(3));
    let (s, t) = ((x + 1.0) / 2.0, (y + 1.0) / 2.0);
    DVec3::from_array([0, 1, 2].map(|i| c0[i] + s * (c1[i] - c0[i]) + t * (c3[i] - c0[i])))
}

/// Quad B's vertex alpha at local x: 0 at x = −1, 1 at x = +1 (u16 0 and 65535).
fn alpha_b(x: f64) -> f64 {
    (x + 1.0) / 2.0
}

fn quad_primitive(w: &mut Writer, color: Option<Value>, material: usize) -> Value {
    let pos: Vec<[f32; 3]> = CORNERS.iter().map(|c| [c[0], c[1], 0.0]).collect();
    let p = w.vec3(&pos, true);
    let n = w.vec3(&[[0.0, 0.0, 1.0]; 4], false);
    let ind = w.indices(&[0, 1, 2, 0, 2, 3], IndexWidth::U16);
    let mut attributes = json!({ "POSITION": p, "NORMAL": n });
    if let Some(c) = color {
        attributes["COLOR_0"] = c;
    }
    json!({ "attributes": attributes, "indices": ind, "mode": 4, "material": material })
}

/// A VEC4 accessor of normalized unsigned components (`ty` 5121 or 5123).
fn normalized_vec4(w: &mut Writer, bytes: Vec<u8>, ty: u32) -> Value {
    let view = w.view(&bytes, 34962);
    w.accessors.push(
        json!({ "bufferView": view, "componentType": ty, "normalized": true, "count": 4, "type": "VEC4" }),
    );
    json!(w.accessors.len() - 1)
}

fn scene_file(dir: &std::path::Path) -> std::path::PathBuf {
    let mut w = Writer::default();
    w.uses("KHR_materials_emissive_strength");
    let ma = w.material(json!({
        "pbrMetallicRoughness": { "baseColorFactor": [BASE_A[0], BASE_A[1], BASE_A[2], 1.0], "metallicFactor": 0.0 },
        "emissiveFactor": [0.25, 0.5, 0.125],
        "extensions": { "KHR_materials_emissive_strength": { "emissiveStrength": 2.0 } }
    }));
    let mb = w.material(json!({
        "pbrMetallicRoughness": { "baseColorFactor": BASE_B, "metallicFactor": 0.0 },
        "alphaMode": "MASK", "alphaCutoff": CUTOFF_B
    }));
    let mc = w.material(json!({
        "pbrMetallicRoughness": { "baseColorFactor": [BASE_C[0], BASE_C[1], BASE_C[2], 1.0], "metallicFactor": 0.0 },
        "emissiveFactor": EMISSION_C
    }));
    let ca = normalized_vec4(&mut w, COLOR_A.iter().flatten().copied().collect(), 5121);
    let b_alpha = [0u16, 65535, 65535, 0];
    let cb_bytes: Vec<u8> =
        b_alpha.iter().flat_map(|&a| [65535u16, 65535, 65535, a]).flat_map(u16::to_le_bytes).collect();
    let cb = normalized_vec4(&mut w, cb_bytes, 5123);
    let pa = quad_primitive(&mut w, Some(ca), ma);
    let pb = quad_primitive(&mut w, Some(cb), mb);
    let pc = quad_primitive(&mut w, None, mc);
    for (k, p) in [pa, pb, pc].into_iter().enumerate() {
        let m = w.mesh(vec![p]);
        let n = w.node(json!({ "mesh": m, "translation": [CENTRES[k], 0.0, 0.0] }));
        w.scene_roots.push(n);
    }
    w.cameras.push(json!({ "type": "perspective", "perspective": { "yfov": 0.6, "znear": 0.1, "zfar": 100.0, "aspectRatio": 3.0 } }));
    let cam = w.node(json!({ "camera": 0, "translation": [0.0, 0.0, 7.0] }));
    w.scene_roots.push(cam);
    w.write_glb(dir, "materials")
}

/// What the twin says of pixel (x, y): None for the background, else the quad, its local hit,
/// and (drawn, HDR colour, alpha).
fn twin(scene: &Scene, lighting: &Lighting, x: u32, y: u32) -> Option<(usize, [f64; 2], bool, DVec3, f64)> {
    let (o, u) = scene.camera.pixel_ray(x, y, W, H);
    let t = -o.z / u.z;
    let p = o + u * t;
    let k = (0..3).find(|&k| (p.x - CENTRES[k]).abs() <= 1.0 && p.y.abs() <= 1.0)?;
    let (lx, ly) = (p.x - CENTRES[k], p.y);
    let n = DVec3::Z;
    let (drawn, hdr, alpha) = match k {
        0 => {
            let c = lighting.raster_surface(
                DVec3::from_array(BASE_A),
                color_a(lx, ly),
                DVec3::from_array(EMISSION_A),
                n,
            );
            (true, c, 1.0)
        }
        1 => {
            let alpha = BASE_B[3] * alpha_b(lx);
            let base = DVec3::new(BASE_B[0], BASE_B[1], BASE_B[2]);
            (
                Lighting::drawn(alpha, CUTOFF_B),
                lighting.raster_surface(base, DVec3::ONE, DVec3::ZERO, n),
                alpha,
            )
        }
        _ => {
            let c = lighting.raster_surface(
                DVec3::from_array(BASE_C),
                DVec3::ONE,
                DVec3::from_array(EMISSION_C),
                n,
            );
            (true, c, 1.0)
        }
    };
    Some((k, [lx, ly], drawn, hdr, alpha))
}

#[test]
fn the_importer_reads_colours_emission_and_mask() {
    let dir = temp_dir("materials-import");
    let path = scene_file(&dir);
    let scene = hadou::scene::load_scene(&path).unwrap();
    assert_eq!(scene.meshes.len(), 3);
    let a = scene.meshes[0].mesh.attributes.as_ref().expect("quad A has COLOR_0");
    for (k, c) in a.colors.iter().enumerate() {
        assert_eq!(*c, COLOR_A[k].map(|v| (v as f64 / 255.0) as f32), "corner {k}");
    }
    assert!(a.texcoords.iter().all(Vec::is_empty));
    let b = scene.meshes[1].mesh.attributes.as_ref().unwrap();
    assert_eq!(b.colors.iter().map(|c| c[3]).collect::<Vec<_>>(), vec![0.0, 1.0, 1.0, 0.0]);
    assert!(scene.meshes[2].mesh.attributes.is_none());
    let mat = |k: usize| &scene.materials[scene.instances[k].material];
    assert_eq!(mat(0).surface.emission, DVec3::from_array(EMISSION_A));
    assert_eq!(mat(0).surface.alpha_cutoff, 0.0);
    assert_eq!(mat(1).surface.alpha_cutoff, CUTOFF_B);
    assert_eq!(mat(1).surface.alpha, BASE_B[3] as f32 as f64);
    assert_eq!(mat(2).surface.emission, DVec3::from_array(EMISSION_C));
    // Nothing of these materials is left out of the one warning's list.
    let imp = hadou::scene::gltf::import(&path, &Default::default()).unwrap();
    assert!(imp.ignored.is_empty(), "{}", imp.ignored.summary());
}

#[test]
fn blend_is_named_and_bad_values_are_refused() {
    let dir = temp_dir("materials-blend");
    let cube = hadou::scene::procedural::cube(1.0).unwrap();
    let write = |material: Value, name: &str| {
        let mut w = Writer::default();
        let m = w.material(material);
        let p = w.primitive(&cube, IndexWidth::U16, true, Some(m));
        let mesh = w.mesh(vec![p]);
        let n = w.node(json!({ "mesh": mesh }));
        w.scene_roots.push(n);
        w.write_glb(&dir, name)
    };
    let blend =
        write(json!({ "alphaMode": "BLEND", "pbrMetallicRoughness": { "metallicFactor": 0.0 } }), "blend");
    let imp = hadou::scene::gltf::import(&blend, &Default::default()).unwrap();
    assert!(
        imp.ignored
            .summary()
            .contains("alpha blending (alphaMode BLEND, drawn opaque) (/materials/0/alphaMode)"),
        "{}",
        imp.ignored.summary()
    );
    let bad = write(json!({ "emissiveFactor": [2.0, 0.0, 0.0] }), "bad-emission");
    let e = hadou::scene::gltf::import(&bad, &Default::default()).unwrap_err().to_string();
    assert!(e.contains("/materials/0/emissiveFactor"), "{e}");
}

#[test]
fn vertex_colours_emission_and_mask_match_the_f64_twin() {
    let dir = temp_dir("materials-gpu");
    let scene = hadou::scene::load_scene(&scene_file(&dir)).unwrap();
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let mut request = FrameRequest::new(W, H);
    request.aovs = vec![Aov::Hdr, Aov::Normal];
    let frame = rt.render(&request).unwrap();
    common::assert_clean(&rt);
    rt.finish();
    let hdr = &frame.aov(Aov::Hdr).unwrap().data;
    let normal = &frame.aov(Aov::Normal).unwrap().data;
    let lighting = Lighting::new(&scene);
    let scale = lighting.diffuse_scale();
    // One pixel in world units at z = 0 (the quads' plane), for the outline exclusion.
    let pixel = 2.0 * 7.0 * (0.3f64).tan() / H as f64;
    let mut quads = [
        Comparison::new("quad A (vertex colours, emission)"),
        Comparison::new("quad B (mask)"),
        Comparison::new("quad C (emission)"),
    ];
    let (mut masked_out, mut masked_wrong) = (0, 0);
    for y in 0..H {
        for x in 0..W {
            let Some((k, [lx, ly], drawn, hdr_ref, alpha)) = twin(&scene, &lighting, x, y) else { continue };
            let i = (y * W + x) as usize;
            if 1.0 - lx.abs() < pixel || 1.0 - ly.abs() < pixel {
                (0..3).for_each(|_| quads[k].exclude());
                continue;
            }
            // The largest change of the twin between 4-neighbour pixel centres (same quad).
            let mut g = DVec3::ZERO;
            let mut g_alpha: f64 = 0.0;
            for (dx, dy) in [(-1i32, 0i32), (1, 0), (0, -1), (0, 1)] {
                let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                if let Some((nk, _, _, h2, a2)) = twin(&scene, &lighting, nx as u32, ny as u32) {
                    if nk == k {
                        g = g.max((h2 - hdr_ref).abs());
                        g_alpha = g_alpha.max((a2 - alpha).abs());
                    }
                }
            }
            if k == 1 && (alpha - CUTOFF_B).abs() <= g_alpha / 32.0 + 1e-4 {
                (0..3).for_each(|_| quads[k].exclude());
                continue;
            }
            let surface = normal[4 * i + 3] > 0.0;
            if !drawn {
                masked_out += 1;
                masked_wrong += surface as usize;
                continue;
            }
            assert!(surface, "pixel ({x}, {y}) of quad {k}: no surface where the twin draws one");
            let (base, emission) = match k {
                0 => (DVec3::from_array(BASE_A) * color_a(lx, ly), DVec3::from_array(EMISSION_A)),
                1 => (DVec3::new(BASE_B[0], BASE_B[1], BASE_B[2]), DVec3::ZERO),
                _ => (DVec3::from_array(BASE_C), DVec3::from_array(EMISSION_C)),
            };
            let s = base * scale + emission;
            for c in 0..3 {
                let e32 = s[c] * (2f64.powi(-18) + 2f64.powi(-16)) + g[c] / 32.0;
                let bound = e32 + (hdr_ref[c].abs() + e32) / 1024.0 + 2f64.powi(-24);
                let err = (hdr[4 * i + c] as f64 - hdr_ref[c]).abs();
                quads[k].error(
                    format!("pixel ({x}, {y}) channel {c}: gpu {} twin {}", hdr[4 * i + c], hdr_ref[c]),
                    err / bound,
                );
            }
        }
    }
    for q in &quads {
        println!("{}", q.summary());
        // Each quad covers ~2/4.33 of the height and a third of the width: ≥ 2000 values.
        q.assert_within(1.0, 2000);
        // The outline exclusion: 4 edges of ~74 pixels; quad B compares only its drawn 3/8.
        q.assert_excluded_at_most(0.25);
    }
    println!("{masked_out} masked-out pixels, {masked_wrong} drawn");
    assert!(masked_out > 1000, "{masked_out}");
    assert_eq!(masked_wrong, 0);
}

/// Emission is pre-exposed as the lights are: a light changed at run time so that the frame's
/// pre-exposure changes (here past RGBA16F: p = 1 → a power of two below 1) rescales the material
/// table's emission too, and the frame is the file's with that light, bit for bit.
#[test]
fn emission_follows_the_pre_exposure_when_a_light_changes() {
    let dir = temp_dir("materials-pre-exposure");
    let mut scene = hadou::scene::load_scene(&scene_file(&dir)).unwrap();
    scene.render.exposure_mode = hadou::scene::ExposureMode::Linear;
    scene.render.exposure = 1.0;
    assert!(!scene.lights.is_empty());
    assert_eq!(hadou::effect::pre_exposure(&scene), 1.0);
    let mut request = FrameRequest::new(W, H);
    request.aovs = vec![Aov::Hdr];
    let mut live = common::runtime();
    live.load_scene(scene.clone()).unwrap();
    live.render(&request).unwrap();
    let light = scene.lights[0];
    let id = live.renderer().light_ids()[0];
    live.renderer().set_light(id, light.direction, light.color, 1e6).unwrap();
    let got = live.render(&request).unwrap();
    live.finish();
    let mut bright = scene.clone();
    bright.lights[0].intensity = 1e6;
    assert!(hadou::effect::pre_exposure(&bright) < 1.0);
    let mut file = common::runtime();
    file.load_scene(bright).unwrap();
    let want = file.render(&request).unwrap();
    file.finish();
    assert!(common::same_bits(got.aov(Aov::Hdr).unwrap(), want.aov(Aov::Hdr).unwrap()), "HDR differs");
}
