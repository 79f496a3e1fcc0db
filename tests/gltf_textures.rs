//! glTF material textures (issue 26 item 1): `baseColorTexture` and `emissiveTexture`, with the
//! file's sampler, texture coordinate set and `KHR_texture_transform`, from a GLB's buffer view,
//! an external file and a data: URI (PNG and JPEG), drawn by the raster on lavapipe (validation
//! and synchronization validation on, zero messages) and compared per pixel with an f64 twin on
//! a glTF the test writes; and the refusals of bad images.
//!
//! # The scene
//! Four 2×2 quads in z = 0 (normal +z) seen straight on from a glTF camera at z = 7, under the
//! default light. TEXCOORD_0 is (s, t) = ((x + 1)/2, (1 − y)/2) of the quad's local (x, y) (v
//! down, as glTF images are stored), TEXCOORD_1 is (t, s).
//! - **A** base-colour texture, an 8×8 two-colour checker PNG in the GLB's buffer, NEAREST.
//! - **B** the same image as an external PNG file, NEAREST, wrapS MIRRORED_REPEAT, wrapT REPEAT,
//!   through `KHR_texture_transform` (offset, rotation, scale) whose `texCoord` 1 overrides the
//!   textureInfo's 0.
//! - **C** emissive texture, a 4×4 checker JPEG in a data: URI (the twin reads the texels the
//!   `image` crate decodes: JPEG is lossy), NEAREST, emissiveFactor 1, a dark base colour.
//! - **D** LINEAR_MIPMAP_LINEAR over a 1-texel black/white 8×8 checker repeated 40 times across
//!   the quad: about 4 texels a pixel (lod ≈ 2), where every mip level past 0 is the linear-light
//!   mean, sRGB 188 (`scene::texture::mip_chain`), so the quad must be that grey everywhere;
//!   level 0 alone would alias into black and white.
//!
//! # The bound (per pixel and channel of HDR)
//! - **Which texel (NEAREST).** The twin computes the texel-space coordinate a = u'·w of the
//!   pixel centre's hit in f64. The GPU's differs by the rasterizer's vertex snapping (≤ 1/32
//!   pixel, tests/gltf_materials.rs: ≤ g/32, g the change of a between neighbour pixels), the f32
//!   interpolation and transform (≤ g/32 more, with headroom) and the sampler's fixed-point texel
//!   coordinates (lavapipe: 8 sub-texel bits, ≤ 1/256 texel; 1/128 taken). Pixels whose a (or b)
//!   lies within g/16 + 1/128 texel of a texel edge are left out and counted; elsewhere the texel
//!   is the twin's.
//! - **The colour of that texel**: factor × sRGB-decoded texel (f64) × (ambient + ΣL) +
//!   emission: f32 shading ≤ 2⁻¹⁸·S (S the value's scale) as tests/gpu_shading.rs argues, with
//!   2⁻¹⁶·S headroom; the sRGB decode within half the 8-bit step at the texel's code (its
//!   weight × (lin(c+1) − lin(c))/2): Vulkan leaves the decode's precision to the implementation,
//!   lavapipe approximates the curve (measured: 2.5·10⁻⁴ off the f64 curve at sRGB 32, a third of
//!   the step there), and a decode within half a step still tells every pair of neighbouring codes
//!   apart, as exact as 8-bit data can be; the RGBA16F store 2⁻¹⁰·(|twin| + E) + 2⁻²⁴.
//! - **D (filtered)**: the same with code 188 (the filter blends equal texels: their value).
//!
//! Pixels within one pixel of a quad's outline are left out as in tests/gltf_materials.rs.

mod common;

use std::io::Cursor;

use common::gltf_writer::{temp_dir, IndexWidth, Writer};
use glam::{DVec2, DVec3};
use hadou::effects::shading::Lighting;
use hadou::scene::texture::{srgb_to_linear, uv_transform};
use hadou::scene::Scene;
use hadou::testing::Comparison;
use hadou::{Aov, FrameRequest};
use serde_json::{json, Value};

const W: u32 = 640;
const H: u32 = 160;
const CENTRES: [f64; 4] = [-3.6, -1.2, 1.2, 3.6];
const CORNERS: [[f32; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
const CHECKER: [[u8; 4]; 2] = [[255, 64, 32, 255], [16, 128, 255, 255]];
const EMISSIVE: [[u8; 4]; 2] = [[250, 250, 40, 255], [40, 90, 250, 255]];
const BASE_FACTOR: [f64; 3] = [0.9, 0.8, 1.0];
const DARK: [f64; 3] = [0.1, 0.1, 0.1];
/// D's texture coordinates span this many checker repeats.
const D_REPEATS: f64 = 40.0;
/// B's KHR_texture_transform.
const OFFSET: [f64; 2] = [0.25, -0.1];
const ROTATION: f64 = 0.3;
const SCALE: [f64; 2] = [1.5, 2.0];

/// A checker of `n`×`n` texels alternating between two colours, RGBA8.
fn checker(n: u32, colours: [[u8; 4]; 2]) -> image::RgbaImage {
    image::RgbaImage::from_fn(n, n, |x, y| image::Rgba(colours[((x + y) % 2) as usize]))
}

fn png(img: &image::RgbaImage) -> Vec<u8> {
    let mut out = Vec::new();
    img.write_to(&mut Cursor::new(&mut out), image::ImageFormat::Png).unwrap();
    out
}

fn jpeg(img: &image::RgbaImage) -> Vec<u8> {
    let rgb = image::DynamicImage::ImageRgba8(img.clone()).into_rgb8();
    let mut out = Vec::new();
    rgb.write_to(&mut Cursor::new(&mut out), image::ImageFormat::Jpeg).unwrap();
    out
}

/// TEXCOORD_0 (and TEXCOORD_1: swapped) at a quad's local (x, y), times `span`.
fn texcoords(x: f64, y: f64, span: f64) -> [DVec2; 2] {
    let (s, t) = ((x + 1.0) / 2.0 * span, (1.0 - y) / 2.0 * span);
    [DVec2::new(s, t), DVec2::new(t, s)]
}

fn vec2_accessor(w: &mut Writer, v: &[[f32; 2]]) -> usize {
    let bytes: Vec<u8> = v.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    let view = w.view(&bytes, 34962);
    w.accessors.push(json!({ "bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC2" }));
    w.accessors.len() - 1
}

fn quad(w: &mut Writer, material: usize, span: f64) -> Value {
    let pos: Vec<[f32; 3]> = CORNERS.iter().map(|c| [c[0], c[1], 0.0]).collect();
    let p = w.vec3(&pos, true);
    let n = w.vec3(&[[0.0, 0.0, 1.0]; 4], false);
    let uv = |k: usize| -> Vec<[f32; 2]> {
        CORNERS
            .iter()
            .map(|c| {
                let t = texcoords(c[0] as f64, c[1] as f64, span)[k];
                [t.x as f32, t.y as f32]
            })
            .collect()
    };
    let (uv0, uv1) = (uv(0), uv(1));
    let t0 = vec2_accessor(w, &uv0);
    let t1 = vec2_accessor(w, &uv1);
    let ind = w.indices(&[0, 1, 2, 0, 2, 3], IndexWidth::U16);
    json!({
        "attributes": { "POSITION": p, "NORMAL": n, "TEXCOORD_0": t0, "TEXCOORD_1": t1 },
        "indices": ind, "mode": 4, "material": material
    })
}

/// An image in the GLB's buffer.
fn view_image(w: &mut Writer, bytes: &[u8], mime: &str) -> Value {
    while w.bin.len() % 4 != 0 {
        w.bin.push(0);
    }
    let offset = w.bin.len();
    w.bin.extend_from_slice(bytes);
    w.views.push(json!({ "buffer": 0, "byteOffset": offset, "byteLength": bytes.len() }));
    json!({ "bufferView": w.views.len() - 1, "mimeType": mime })
}

const NEAREST: u32 = 9728;
const LINEAR_MIPMAP_LINEAR: u32 = 9987;
const LINEAR: u32 = 9729;
const REPEAT: u32 = 10497;
const MIRRORED_REPEAT: u32 = 33648;

/// The test scene in `dir` (the external image beside it).
fn scene_file(dir: &std::path::Path) -> std::path::PathBuf {
    let mut w = Writer::default();
    w.uses("KHR_texture_transform");
    std::fs::write(dir.join("checker b.png"), png(&checker(8, CHECKER))).unwrap();
    let images = vec![
        view_image(&mut w, &png(&checker(8, CHECKER)), "image/png"),
        json!({ "uri": "checker%20b.png" }),
        json!({ "uri": format!("data:image/jpeg;base64,{}", base64_encode(&jpeg(&checker(4, EMISSIVE)))) }),
        view_image(&mut w, &png(&checker(8, [[0, 0, 0, 255], [255, 255, 255, 255]])), "image/png"),
    ];
    let samplers = json!([
        { "magFilter": NEAREST, "minFilter": NEAREST },
        { "magFilter": NEAREST, "minFilter": NEAREST, "wrapS": MIRRORED_REPEAT, "wrapT": REPEAT },
        { "magFilter": LINEAR, "minFilter": LINEAR_MIPMAP_LINEAR }
    ]);
    let textures = json!([
        { "source": 0, "sampler": 0 },
        { "source": 1, "sampler": 1 },
        { "source": 2, "sampler": 0 },
        { "source": 3, "sampler": 2 }
    ]);
    w.extra.insert("images".into(), json!(images));
    w.extra.insert("samplers".into(), samplers);
    w.extra.insert("textures".into(), textures);
    let base = json!([BASE_FACTOR[0], BASE_FACTOR[1], BASE_FACTOR[2], 1.0]);
    let ma = w.material(json!({ "pbrMetallicRoughness": {
        "baseColorFactor": base, "metallicFactor": 0.0, "baseColorTexture": { "index": 0 } } }));
    let mb = w.material(json!({ "pbrMetallicRoughness": {
        "baseColorFactor": base, "metallicFactor": 0.0,
        "baseColorTexture": { "index": 1, "texCoord": 0, "extensions": { "KHR_texture_transform": {
            "offset": OFFSET, "rotation": ROTATION, "scale": SCALE, "texCoord": 1 } } } } }));
    let mc = w.material(json!({
        "pbrMetallicRoughness": { "baseColorFactor": [DARK[0], DARK[1], DARK[2], 1.0], "metallicFactor": 0.0 },
        "emissiveFactor": [1.0, 1.0, 1.0], "emissiveTexture": { "index": 2 } }));
    let md = w.material(json!({ "pbrMetallicRoughness": {
        "baseColorFactor": base, "metallicFactor": 0.0, "baseColorTexture": { "index": 3 } } }));
    for (k, (m, span)) in [(ma, 1.0), (mb, 1.0), (mc, 1.0), (md, D_REPEATS)].into_iter().enumerate() {
        let p = quad(&mut w, m, span);
        let mesh = w.mesh(vec![p]);
        let n = w.node(json!({ "mesh": mesh, "translation": [CENTRES[k], 0.0, 0.0] }));
        w.scene_roots.push(n);
    }
    w.cameras.push(json!({ "type": "perspective", "perspective": { "yfov": 0.6, "znear": 0.1, "zfar": 100.0, "aspectRatio": 4.0 } }));
    let cam = w.node(json!({ "camera": 0, "translation": [0.0, 0.0, 7.0] }));
    w.scene_roots.push(cam);
    w.write_glb(dir, "textures")
}

fn base64_encode(bytes: &[u8]) -> String {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// Half the step between sRGB code `c` and its upper neighbour (its lower one at 255), in
/// linear light.
fn half_step(c: u8) -> f64 {
    let c = c.min(254);
    (srgb_to_linear(c + 1) - srgb_to_linear(c)) / 2.0
}

/// The texel index along one axis of texel-space coordinate `a` in an image `n` texels wide.
fn wrap(a: f64, n: u32, mirrored: bool) -> u32 {
    let i = a.floor() as i64;
    let n = n as i64;
    if mirrored {
        let m = i.rem_euclid(2 * n);
        (if m >= n { 2 * n - 1 - m } else { m }) as u32
    } else {
        i.rem_euclid(n) as u32
    }
}

/// What the twin expects of one pixel's hit on quad k at local (x, y): the texel-space
/// coordinates the texture is read at (NEAREST quads), and the HDR colour.
struct Expect {
    quad: usize,
    local: [f64; 2],
    texel_coords: Option<DVec2>,
    hdr: DVec3,
    /// The texel's sRGB codes and what multiplies their decoded value in `hdr`.
    codes: [u8; 3],
    weight: DVec3,
}

fn twin(scene: &Scene, lighting: &Lighting, jpeg: &image::RgbaImage, x: u32, y: u32) -> Option<Expect> {
    let (o, u) = scene.camera.pixel_ray(x, y, W, H);
    let p = o + u * (-o.z / u.z);
    let k = (0..4).find(|&k| (p.x - CENTRES[k]).abs() <= 1.0 && p.y.abs() <= 1.0)?;
    let (lx, ly) = (p.x - CENTRES[k], p.y);
    let diffuse = lighting.diffuse(DVec3::Z);
    let lin = |t: [u8; 4]| DVec3::new(srgb_to_linear(t[0]), srgb_to_linear(t[1]), srgb_to_linear(t[2]));
    let factor = DVec3::from_array(BASE_FACTOR);
    let rgb = |t: [u8; 4]| [t[0], t[1], t[2]];
    let (texel_coords, hdr, codes, weight) = match k {
        0 | 1 => {
            let uv = if k == 0 {
                texcoords(lx, ly, 1.0)[0]
            } else {
                let f = |v: f64| v as f32 as f64;
                let m = uv_transform(OFFSET.map(f), f(ROTATION), SCALE.map(f));
                let t = texcoords(lx, ly, 1.0)[1];
                DVec2::new(m[0][0] * t.x + m[0][1] * t.y + m[0][2], m[1][0] * t.x + m[1][1] * t.y + m[1][2])
            };
            let a = uv * 8.0;
            let (i, j) = (wrap(a.x, 8, k == 1), wrap(a.y, 8, false));
            let texel = CHECKER[((i + j) % 2) as usize];
            (Some(a), factor * lin(texel) * diffuse, rgb(texel), factor * diffuse)
        }
        2 => {
            let a = texcoords(lx, ly, 1.0)[0] * 4.0;
            let texel = jpeg.get_pixel(wrap(a.x, 4, false), wrap(a.y, 4, false)).0;
            (Some(a), DVec3::from_array(DARK) * diffuse + lin(texel), rgb(texel), DVec3::ONE)
        }
        _ => (None, factor * DVec3::splat(srgb_to_linear(188)) * diffuse, [188; 3], factor * diffuse),
    };
    Some(Expect { quad: k, local: [lx, ly], texel_coords, hdr, codes, weight })
}

#[test]
fn the_importer_reads_textures_samplers_and_transforms() {
    let dir = temp_dir("textures-import");
    let path = scene_file(&dir);
    let scene = hadou::scene::load_scene(&path).unwrap();
    let mat = |k: usize| &scene.materials[scene.instances[k].material].surface.textures;
    let a = mat(0).base.as_ref().expect("A has a base-colour texture");
    assert_eq!((a.image.width, a.image.height, a.image.levels.len()), (8, 8, 4));
    assert_eq!(a.image.texel(0, 1, 0), CHECKER[1]);
    assert_eq!(a.sampler.mag, hadou::scene::texture::Filter::Nearest);
    assert_eq!(a.sampler.mipmap, None);
    let b = mat(1).base.as_ref().unwrap();
    assert_eq!(b.texcoord, 1, "the extension's texCoord overrides the textureInfo's");
    assert_eq!(b.sampler.wrap_s, hadou::scene::texture::Wrap::MirroredRepeat);
    assert_eq!(b.image.levels, a.image.levels, "the same checker from a file");
    assert!(mat(2).base.is_none());
    assert_eq!(mat(2).emissive.as_ref().unwrap().image.width, 4);
    let d = mat(3).base.as_ref().unwrap();
    assert_eq!(d.sampler.mipmap, Some(hadou::scene::texture::Filter::Linear));
    assert!(d.image.levels[1..].iter().flat_map(|l| l.chunks(4)).all(|t| t == [188, 188, 188, 255]));
    let imp = hadou::scene::gltf::import(&path, &Default::default()).unwrap();
    assert!(imp.ignored.is_empty(), "{}", imp.ignored.summary());
    assert!(imp.files.iter().any(|f| f.ends_with("textures.glb")));
    assert!(imp.files.iter().any(|f| f.ends_with("checker b.png")), "{:?}", imp.files);
    let referenced = hadou::scene::gltf::referenced_files(&path);
    assert!(referenced.iter().any(|f| f.ends_with("checker b.png")), "{referenced:?}");
}

#[test]
fn textures_match_the_f64_twin() {
    let dir = temp_dir("textures-gpu");
    let scene = hadou::scene::load_scene(&scene_file(&dir)).unwrap();
    let jpeg_texels = {
        let c = &scene.materials[scene.instances[2].material].surface.textures;
        let img = &c.emissive.as_ref().unwrap().image;
        image::RgbaImage::from_raw(4, 4, img.levels[0].clone()).unwrap()
    };
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let mut request = FrameRequest::new(W, H);
    request.aovs = vec![Aov::Hdr];
    // Two frames: the first uploads the textures, the second draws with them already there.
    let first = rt.render(&request).unwrap();
    let frame = rt.render(&request).unwrap();
    common::assert_clean(&rt);
    rt.finish();
    assert!(common::same_bits(first.aov(Aov::Hdr).unwrap(), frame.aov(Aov::Hdr).unwrap()));
    let hdr = &frame.aov(Aov::Hdr).unwrap().data;
    let lighting = Lighting::new(&scene);
    let scale = lighting.diffuse_scale();
    let pixel = 2.0 * 7.0 * (0.3f64).tan() / H as f64;
    let mut quads = [
        Comparison::new("A: base colour, NEAREST"),
        Comparison::new("B: KHR_texture_transform, TEXCOORD_1, mirrored"),
        Comparison::new("C: emissive JPEG"),
        Comparison::new("D: LINEAR_MIPMAP_LINEAR minified"),
    ];
    let mut edge_band = [0usize; 4];
    for y in 0..H {
        for x in 0..W {
            let Some(e) = twin(&scene, &lighting, &jpeg_texels, x, y) else { continue };
            let k = e.quad;
            let i = (y * W + x) as usize;
            if 1.0 - e.local[0].abs() < pixel || 1.0 - e.local[1].abs() < pixel {
                (0..3).for_each(|_| quads[k].exclude());
                continue;
            }
            if let Some(a) = e.texel_coords {
                // g: the largest change of the texel-space coordinates between neighbour pixels.
                let mut g: f64 = 0.0;
                for (dx, dy) in [(-1i32, 0i32), (1, 0), (0, -1), (0, 1)] {
                    let n =
                        twin(&scene, &lighting, &jpeg_texels, (x as i32 + dx) as u32, (y as i32 + dy) as u32);
                    if let Some(n) = n.filter(|n| n.quad == k) {
                        let b = n.texel_coords.unwrap();
                        g = g.max((b.x - a.x).abs()).max((b.y - a.y).abs());
                    }
                }
                let band = g / 16.0 + 1.0 / 128.0;
                let near_edge = |v: f64| (v - v.round()).abs() < band;
                if near_edge(a.x) || near_edge(a.y) {
                    edge_band[k] += 1;
                    (0..3).for_each(|_| quads[k].exclude());
                    continue;
                }
            }
            let s = match k {
                2 => DVec3::from_array(DARK) * scale + DVec3::ONE,
                _ => DVec3::from_array(BASE_FACTOR) * scale,
            };
            for c in 0..3 {
                let decode = e.weight[c] * half_step(e.codes[c]);
                let e32 = s[c] * (2f64.powi(-18) + 2f64.powi(-16)) + decode;
                let bound = e32 + (e.hdr[c].abs() + e32) / 1024.0 + 2f64.powi(-24);
                let err = (hdr[4 * i + c] as f64 - e.hdr[c]).abs();
                quads[k].error(
                    format!("pixel ({x}, {y}) channel {c}: gpu {} twin {}", hdr[4 * i + c], e.hdr[c]),
                    err / bound,
                );
            }
        }
    }
    for (k, q) in quads.iter().enumerate() {
        println!("{} ({} pixels in the texel-edge band)", q.summary(), edge_band[k]);
        q.assert_within(1.0, 2000);
    }
    // The bands: 8 texel edges each way over ~74 pixels, each band ≲ 1 pixel wide.
    for q in &quads[..3] {
        q.assert_excluded_at_most(0.45);
    }
    quads[3].assert_excluded_at_most(0.1);
}

/// A file with textures renders the textured quads, and its untextured materials exactly as a
/// file without any texture does (the untextured pipelines are untouched).
#[test]
fn untextured_materials_beside_textured_ones_keep_their_bits() {
    let dir = temp_dir("textures-untouched");
    let path = scene_file(&dir);
    let with = hadou::scene::load_scene(&path).unwrap();
    let mut without = with.clone();
    for m in &mut without.materials {
        m.surface.textures = Default::default();
    }
    let mut mixed = with.clone();
    mixed.materials[mixed.instances[0].material].surface.textures = Default::default();
    let mut request = FrameRequest::new(W, H);
    request.aovs = vec![Aov::Hdr];
    let render = |s: &Scene| {
        let mut rt = common::runtime();
        rt.load_scene(s.clone()).unwrap();
        let f = rt.render(&request).unwrap();
        rt.finish();
        f.aov(Aov::Hdr).unwrap().clone()
    };
    let (plain, mixed) = (render(&without), render(&mixed));
    // Quad A's pixels (its material untextured in both) are the same bits.
    let (x0, x1) = (W / 8 - 25, W / 8 + 25);
    for y in H / 2 - 25..H / 2 + 25 {
        for x in x0..x1 {
            let i = 4 * (y * W + x) as usize;
            assert_eq!(
                plain.data[i..i + 4].iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                mixed.data[i..i + 4].iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "pixel ({x}, {y})"
            );
        }
    }
}

/// A one-quad file whose material's base-colour texture is `image` (JSON).
fn one_texture(
    dir: &std::path::Path,
    name: &str,
    image: Value,
    extra_view: Option<&[u8]>,
) -> std::path::PathBuf {
    let mut w = Writer::default();
    let m = w.material(
        json!({ "pbrMetallicRoughness": { "metallicFactor": 0.0, "baseColorTexture": { "index": 0 } },
        "normalTexture": { "index": 0 } }),
    );
    let p = quad(&mut w, m, 1.0);
    let image = match extra_view {
        Some(bytes) => view_image(&mut w, bytes, "image/png"),
        None => image,
    };
    let mesh = w.mesh(vec![p]);
    let n = w.node(json!({ "mesh": mesh }));
    w.scene_roots.push(n);
    w.extra.insert("images".into(), json!([image]));
    w.extra.insert("textures".into(), json!([{ "source": 0 }]));
    w.write_glb(dir, name)
}

#[test]
fn bad_images_are_refused_naming_the_file_and_pointer() {
    let dir = temp_dir("textures-bad");
    let err = |path: &std::path::Path| {
        hadou::scene::gltf::import(path, &Default::default()).unwrap_err().to_string()
    };
    let missing = one_texture(&dir, "missing", json!({ "uri": "nowhere.png" }), None);
    let e = err(&missing);
    assert!(
        e.contains("missing.glb")
            && e.contains("/images/0/uri")
            && e.contains("missing image")
            && e.contains("nowhere.png"),
        "{e}"
    );
    let garbage =
        one_texture(&dir, "garbage", json!(null), Some(b"\x89PNG\r\n\x1a\nnot really a png at all"));
    let e = err(&garbage);
    assert!(
        e.contains("garbage.glb") && e.contains("/images/0/bufferView") && e.contains("undecodable image"),
        "{e}"
    );
    let text = one_texture(&dir, "text", json!(null), Some(b"hello, I am no image"));
    let e = err(&text);
    assert!(e.contains("/images/0/bufferView") && e.contains("not a PNG or JPEG"), "{e}");
    let wide = png(&image::RgbaImage::new(hadou::scene::gltf::MAX_TEXTURE_SIDE + 1, 1));
    let too_wide = one_texture(&dir, "wide", json!(null), Some(&wide));
    let e = err(&too_wide);
    assert!(e.contains("/images/0/bufferView") && e.contains("16385x1"), "{e}");
    let outside = one_texture(&dir, "outside", json!({ "uri": "../secret.png" }), None);
    let e = err(&outside);
    assert!(e.contains("/images/0/uri") && e.contains("leads out of the glTF file's folder"), "{e}");
    // Textures hadou does not draw stay named in the one warning.
    let ok = one_texture(&dir, "ok", json!(null), Some(&png(&checker(2, CHECKER))));
    let imp = hadou::scene::gltf::import(&ok, &Default::default()).unwrap();
    let summary = imp.ignored.summary();
    assert!(
        summary.contains("textures hadou does not draw (normal, occlusion, metallic-roughness, transmission, thickness) (/materials/0/normalTexture)"),
        "{summary}"
    );
}

/// Past the `texels` budget the file is refused before the image is decoded (the budget comes
/// from the environment, so a child process sets it).
#[test]
fn images_past_the_texel_budget_are_refused() {
    let dir = temp_dir("textures-budget");
    let path = one_texture(&dir, "big", json!(null), Some(&png(&checker(8, CHECKER))));
    let out = common::cli::output_within(
        std::process::Command::new(env!("CARGO_BIN_EXE_hadou"))
            .args(["render", path.to_str().unwrap(), "-o", dir.join("out.png").to_str().unwrap()])
            .env("HADOU_GLTF_BUDGET", "texels=63"),
        common::cli::RUN_LIMIT,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("big.glb")
            && stderr.contains("/images/0/bufferView")
            && stderr.contains("64 texels")
            && stderr.contains("texels=N"),
        "{stderr}"
    );
}

/// `alphaMode: MASK` reads the base-colour texture's alpha: a 4×4 checker of alpha 0 and 255
/// (NEAREST) on one quad seen straight on leaves exactly the opaque texels' pixels drawn (normal
/// AOV w > 0), outside the texel-edge band argued at the top of this file.
#[test]
fn mask_reads_the_texture_alpha() {
    const S: u32 = 160;
    let dir = temp_dir("textures-mask");
    let mut w = Writer::default();
    let clear = [[255, 255, 255, 0], [255, 255, 255, 255]];
    let image = view_image(&mut w, &png(&checker(4, clear)), "image/png");
    w.extra.insert("images".into(), json!([image]));
    w.extra.insert("samplers".into(), json!([{ "magFilter": NEAREST, "minFilter": NEAREST }]));
    w.extra.insert("textures".into(), json!([{ "source": 0, "sampler": 0 }]));
    let m = w.material(json!({ "alphaMode": "MASK", "alphaCutoff": 0.5,
        "pbrMetallicRoughness": { "metallicFactor": 0.0, "baseColorTexture": { "index": 0 } } }));
    let p = quad(&mut w, m, 1.0);
    let mesh = w.mesh(vec![p]);
    let n = w.node(json!({ "mesh": mesh }));
    w.scene_roots.push(n);
    w.cameras.push(json!({ "type": "perspective", "perspective": { "yfov": 0.4, "znear": 0.1, "zfar": 100.0, "aspectRatio": 1.0 } }));
    let cam = w.node(json!({ "camera": 0, "translation": [0.0, 0.0, 7.0] }));
    w.scene_roots.push(cam);
    let scene = hadou::scene::load_scene(&w.write_glb(&dir, "mask")).unwrap();
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let mut request = FrameRequest::new(S, S);
    request.aovs = vec![Aov::Normal];
    let frame = rt.render(&request).unwrap();
    common::assert_clean(&rt);
    rt.finish();
    let normal = &frame.aov(Aov::Normal).unwrap().data;
    // The texel-space coordinates of a pixel's hit, None off the quad.
    let at = |x: i32, y: i32| {
        let (o, u) = scene.camera.pixel_ray(x as u32, y as u32, S, S);
        let p = o + u * (-o.z / u.z);
        (p.x.abs() <= 1.0 && p.y.abs() <= 1.0).then(|| texcoords(p.x, p.y, 1.0)[0] * 4.0)
    };
    let (mut drawn, mut holes, mut band, mut wrong) = (0, 0, 0, Vec::new());
    for y in 0..S as i32 {
        for x in 0..S as i32 {
            let Some(a) = at(x, y) else { continue };
            let g = [(-1, 0), (1, 0), (0, -1), (0, 1)]
                .iter()
                .filter_map(|(dx, dy)| at(x + dx, y + dy))
                .map(|b| (b.x - a.x).abs().max((b.y - a.y).abs()))
                .fold(0.0f64, f64::max);
            let edge = |v: f64| (v - v.round()).abs() < g / 16.0 + 1.0 / 128.0;
            // The quad's outline (texel edges 0 and 4) is in the band too.
            if edge(a.x) || edge(a.y) {
                band += 1;
                continue;
            }
            let opaque = (wrap(a.x, 4, false) + wrap(a.y, 4, false)) % 2 == 1;
            let surface = normal[4 * (y as u32 * S + x as u32) as usize + 3] > 0.0;
            match (opaque, surface) {
                (true, true) => drawn += 1,
                (false, false) => holes += 1,
                _ => wrong.push((x, y)),
            }
        }
    }
    println!("mask: {drawn} drawn, {holes} holes, {band} in the texel-edge band");
    assert!(wrong.is_empty(), "{} pixels disagree, first {:?}", wrong.len(), &wrong[..wrong.len().min(5)]);
    assert!(drawn > 1500 && holes > 1500, "{drawn} {holes}");
}
