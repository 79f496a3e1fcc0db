//! The custom effect of examples/custom_effect (a height fog written against hadou's public
//! effect API, outside the library): its scene-file table, its run-time handle, its f64 twin on
//! ordinary and hard rays, and the frame checks every effect's passes get.

mod common;

#[path = "../examples/custom_effect/fog.rs"]
mod fog;
#[path = "../examples/custom_effect/glow.rs"]
mod glow;

use std::path::Path;

use fog::{Fog, FogParams, HeightFog, FOG_TRANSMITTANCE};
use glam::DVec3;
use glow::{Glow, GlowParams, SkyGlow};
use hadou::effect::{
    Binding, Effect, EffectError, EffectPass, Effects, FrameContext, GpuResult, ImageAccess, ImageDesc,
    ImageUse, Pass, PassRecording, Pipeline, Target,
};
use hadou::gpu::vk;
use hadou::scene::Scene;
use hadou::{Aov, AovImage, Error, FrameRequest};

fn fog_effects() -> Effects {
    Effects::builtin().with(HeightFog::default()).unwrap()
}

fn parse(text: &str) -> Result<Scene, hadou::scene::SceneError> {
    hadou::scene::parse_scene_with(text, Path::new("fog.toml"), &fog_effects())
}

const SCENE: &str = r#"
[render]
background = [0.3, 0.4, 0.5]
ambient = [0.1, 0.1, 0.1]

[camera]
position = [0, 2, 8]
look_at = [0, 0.5, 0]
far = 50

[[light]]
kind = "directional"
direction = [-1, -2, -1]
color = [1, 1, 1]
intensity = 1.2

[[mesh]]
name = "floor"
kind = "plane"
size = 1

[[mesh]]
name = "box"
kind = "cube"
size = 1

[[instance]]
mesh = "floor"
transform = [{ scale = [40, 1, 40] }]

[[instance]]
mesh = "box"
transform = [{ translate = [-1, 0.5, 0] }]
"#;

fn scene_with(camera: &str, fog: &str) -> String {
    let base = SCENE.replace("position = [0, 2, 8]\nlook_at = [0, 0.5, 0]", camera);
    format!("{base}\n[fog]\n{fog}\n")
}

const SIZE: (u32, u32) = (96, 64);

/// The fog's transmittance, the HDR colour with it, the HDR colour without it (the fog taken out
/// through the handle), the distance AOV.
struct Frames {
    scene: Scene,
    t: AovImage,
    hdr: AovImage,
    hdr_clear: AovImage,
    distance: AovImage,
}

fn render(text: &str) -> Frames {
    let scene = parse(text).unwrap_or_else(|e| panic!("{e}"));
    let mut rt = common::runtime_with_effects(fog_effects());
    rt.load_scene(scene.clone()).unwrap();
    let mut request = FrameRequest::new(SIZE.0, SIZE.1);
    request.aovs = vec![Aov::Effect(&FOG_TRANSMITTANCE), Aov::Hdr, Aov::Depth];
    let fogged = rt.render(&request).unwrap();
    assert!(rt.pass_names().contains(&"fog"), "{:?}", rt.pass_names());
    assert!(rt.renderer().remove_effect("height_fog").unwrap());
    assert!(!rt.pass_names().contains(&"fog"), "a fog taken out is not run: {:?}", rt.pass_names());
    request.aovs = vec![Aov::Hdr];
    let clear = rt.render(&request).unwrap();
    let get = |f: &hadou::FrameOutput, a: Aov| f.aov(a).unwrap().clone();
    Frames {
        t: get(&fogged, Aov::Effect(&FOG_TRANSMITTANCE)),
        hdr: get(&fogged, Aov::Hdr),
        distance: get(&fogged, Aov::Depth),
        hdr_clear: get(&clear, Aov::Hdr),
        scene,
    }
}

const ULP: f64 = 1.0 / (1u64 << 24) as f64; // 2⁻²⁴: f32 round-to-nearest, relative

/// The twin's inputs: what fog.comp is given, f32 values taken exactly into f64.
struct Inputs {
    fog: Fog,
    camera: DVec3,
    frame: [[f32; 4]; 3],
    far: f64,
}

impl Inputs {
    fn new(scene: &Scene) -> Self {
        let fog = scene.effects.get::<Fog>().unwrap();
        let p = FogParams::new(fog, hadou::effect::pre_exposure(scene));
        let c = p.color_log_density;
        let fog = Fog {
            density: f64::from(c[3]).exp(),
            falloff: f64::from(p.shape[0]),
            base_height: f64::from(p.shape[1]),
            color: DVec3::new(c[0].into(), c[1].into(), c[2].into()),
        };
        let cam = &scene.camera;
        let camera = cam.position.as_vec3().as_dvec3();
        Inputs { fog, camera, frame: cam.ray_frame(SIZE.0, SIZE.1).to_f32(), far: f64::from(cam.far as f32) }
    }

    /// camera_pixel_ray (shaders/common/camera.glsl) in f64 on the f32 frame.
    fn ray(&self, x: u32, y: u32) -> DVec3 {
        let v = |a: [f32; 4]| DVec3::new(a[0].into(), a[1].into(), a[2].into());
        let [right, up, forward] = self.frame;
        let ndc_x = 2.0 * (x as f64 + 0.5) / SIZE.0 as f64 - 1.0 + f64::from(right[3]);
        let ndc_y = 1.0 - 2.0 * (y as f64 + 0.5) / SIZE.1 as f64 + f64::from(up[3]);
        (v(forward) + ndc_x * v(right) + ndc_y * v(up)).normalize()
    }
}

/// How far fog.comp's f32 T may lie from the twin's at one pixel. Arguments: every f32 operation
/// rounds by ≤ 2⁻²⁴ relative; the Vulkan spec bounds GLSL's exp by 3 + 2|x| ulp and log by 3 ulp
/// (2⁻²¹ absolute inside [0.5, 2]); the f32 unit ray's components are within 2⁻²⁰ of the f64 ray
/// of the same f32 frame (about 8 roundings and inversesqrt's 2 ulp). Every term is doubled.
fn t_tolerance(inputs: &Inputs, u: DVec3, len: f64) -> f64 {
    let f = &inputs.fog;
    let (k, x) = (f.falloff, f.falloff * u.y * len);
    let kh = k * (inputs.camera.y - f.base_height);
    let tau = f.optical_depth(inputs.camera, u, len);
    let t = (-tau).exp();
    if tau > 200.0 {
        return 2f64.powi(-126); // T underflows: 0 or an f32 denormal
    }
    if len == 0.0 || tau == 0.0 {
        return 4.0 * ULP;
    }
    let ln_tau = tau.ln();
    let log_err = |v: f64| 2f64.powi(-21) + 6.0 * ULP * v.abs();
    // ln D: its terms' evaluation, and x's error (d ln D / dx is within (−1, 0)).
    let span_terms = if x.abs() < 0.01 {
        log_err(len.ln()) + log_err(1.0) + 4.0 * ULP
    } else {
        let one_minus = -(-x.abs()).exp_m1();
        let exp_err = (3.0 + 2.0 * x.abs()) * 2.0 * ULP * (1.0 - one_minus) + ULP;
        exp_err / one_minus + log_err(one_minus.ln()) + log_err((k * u.y.abs()).ln()) + x.abs() * ULP
    };
    let x_err = k * len * 2f64.powi(-20) + x.abs() * 2.0 * ULP;
    let ln_tau_err = ULP * (2.0 * kh.abs() + f.density.ln().abs() + 2.0 * ln_tau.abs() + 4.0)
        + span_terms
        + x_err
        + (3.0 + 2.0 * ln_tau.abs()) * 2.0 * ULP; // exp(ln τ)
    let tau_rel = ln_tau_err.exp_m1();
    // Vulkan lets a device flush f32 denormals to zero: T below 2⁻¹²⁶ may read 0.
    2.0 * (t * tau * tau_rel + t * (3.0 + 2.0 * tau) * 2.0 * ULP) + 2f64.powi(-126)
}

struct Check {
    worst: f64,
    pixels: usize,
}

/// Every pixel's T and HDR against the twin; returns the largest error over its tolerance.
fn check_twin(frames: &Frames) -> Check {
    let inputs = Inputs::new(&frames.scene);
    let mut worst: f64 = 0.0;
    let (w, h) = SIZE;
    for y in 0..h {
        for x in 0..w {
            let u = inputs.ray(x, y);
            let len = f64::from(frames.distance.at(x, y, 0)).min(inputs.far);
            let t_ref = inputs.fog.transmittance(inputs.camera, u, len);
            let t_gpu = f64::from(frames.t.at(x, y, 0));
            assert!(t_gpu.is_finite() && (0.0..=1.0).contains(&t_gpu), "T {t_gpu} at ({x}, {y})");
            let t_tol = t_tolerance(&inputs, u, len);
            worst = worst.max((t_gpu - t_ref).abs() / t_tol);
            assert!(
                (t_gpu - t_ref).abs() <= t_tol,
                "T at ({x}, {y}): gpu {t_gpu:e}, twin {t_ref:e}, tolerance {t_tol:e} (len {len}, u {u})"
            );
            for c in 0..3 {
                let clear = f64::from(frames.hdr_clear.at(x, y, c));
                let fog = inputs.fog.color[c as usize];
                let want = clear * t_ref + fog * (1.0 - t_ref);
                let got = f64::from(frames.hdr.at(x, y, c));
                assert!(got.is_finite(), "HDR {got} at ({x}, {y})");
                // T's error carried by the blend, the blend's 3 f32 roundings, and the store
                // into RGBA16F: Vulkan leaves the rounding of a conversion to a 16-bit float to
                // the implementation (to nearest or toward zero), so one ulp: 2⁻¹⁰ relative,
                // 2⁻²⁴ absolute among its subnormals.
                let tol = (clear - fog).abs() * t_tol
                    + 4.0 * ULP * (clear + fog)
                    + want * 2f64.powi(-10)
                    + 2f64.powi(-24);
                assert!(
                    (got - want).abs() <= tol,
                    "HDR[{c}] at ({x}, {y}): gpu {got}, twin {want}, tolerance {tol:e}"
                );
            }
        }
    }
    Check { worst, pixels: (w * h) as usize }
}

#[test]
fn fog_matches_its_f64_twin() {
    let frames = render(&scene_with(
        "position = [0, 2, 8]\nlook_at = [0, 0.5, 0]",
        "density = 0.15\nfalloff = 0.7\nbase_height = 0.2\ncolor = [0.6, 0.65, 0.7]",
    ));
    let check = check_twin(&frames);
    // The fog did something: the far floor is mostly fog, the sky less so (it looks up).
    let t_min = frames.t.data.iter().cloned().fold(1.0f32, f32::min);
    assert!(t_min < 0.5, "the fog is visible: min T {t_min}");
    eprintln!("fog twin: {} pixels, worst error {:.3} of its tolerance", check.pixels, check.worst);
}

#[test]
fn fog_on_hard_rays() {
    let cases = [
        // The camera deep below the base with a steep falloff: τ overflows f32 (T = 0, not NaN).
        ("position = [0, 0.5, 8]\nlook_at = [0, 0.5, 0]", "density = 1e30\nfalloff = 1e6\nbase_height = 1e3"),
        // Level rays (u_y = 0 across the middle row) through a uniform fog: the series branch.
        ("position = [0, 1, 8]\nlook_at = [0, 1, 0]", "density = 0.05\nfalloff = 0"),
        // High above a thin fog with a tiny density: exp underflows, rays down cross it.
        ("position = [0, 40, 8]\nlook_at = [0, 0, 0]", "density = 1e-30\nfalloff = 3\nbase_height = 0"),
        // Far from the origin: large heights in f32.
        (
            "position = [1e6, 3, 1e6]\nlook_at = [1e6, 0, 999990]",
            "density = 0.2\nfalloff = 0.5\nbase_height = 2",
        ),
        // The densest fog the table takes: everything is fog colour.
        ("position = [0, 2, 8]\nlook_at = [0, 0.5, 0]", "density = 3e38\nfalloff = 0.01"),
    ];
    for (camera, fog) in cases {
        let text = scene_with(camera, fog);
        let frames = render(&text);
        let check = check_twin(&frames);
        eprintln!("{fog:?}: worst {:.3} of tolerance", check.worst);
    }
}

#[test]
fn the_game_changes_the_fog_per_frame_by_its_handle() {
    let scene = parse(&scene_with("position = [0, 2, 8]\nlook_at = [0, 0.5, 0]", "density = 0.1")).unwrap();
    let mut rt = common::runtime_with_effects(fog_effects());
    rt.load_scene(scene).unwrap();
    let mut request = FrameRequest::new(SIZE.0, SIZE.1);
    request.aovs = vec![Aov::Effect(&FOG_TRANSMITTANCE), Aov::Depth];
    let mut last_mean = 1.0;
    for density in [0.05, 0.1, 0.2] {
        rt.renderer().update_effect(|f: &mut Fog| f.density = density).unwrap();
        let frame = rt.render(&request).unwrap();
        let t = frame.aov(Aov::Effect(&FOG_TRANSMITTANCE)).unwrap();
        let mean = t.data.iter().map(|&v| f64::from(v)).sum::<f64>() / t.data.len() as f64;
        assert!(mean < last_mean, "denser fog lets less through: {mean} after {last_mean}");
        last_mean = mean;
        assert_eq!(rt.renderer().effect::<Fog>().unwrap().density, density);
    }
    // Values the shader is not written for are refused, and the fog stays as it was.
    let e = rt.renderer().update_effect(|f: &mut Fog| f.density = f64::NAN).unwrap_err();
    assert!(
        matches!(e, Error::InvalidUpdate { .. }) && e.to_string().contains("density in 0..=3.4e38"),
        "{e}"
    );
    assert_eq!(rt.renderer().effect::<Fog>().unwrap().density, 0.2);
    let e = rt.renderer().update_effect(|f: &mut Fog| f.falloff = -1.0).unwrap_err();
    assert!(matches!(e, Error::InvalidUpdate { .. }), "{e}");
    // Density 0: the pass is parked, the image is not produced.
    rt.renderer().update_effect(|f: &mut Fog| f.density = 0.0).unwrap();
    assert!(!rt.pass_names().contains(&"fog"));
    let e = rt.render(&request).unwrap_err();
    assert!(matches!(e, Error::NotProduced { target: "fog_transmittance", .. }), "{e}");
    // A fog brought back by the game after the file had none.
    assert!(rt.renderer().remove_effect("height_fog").unwrap());
    assert!(matches!(
        rt.renderer().update_effect(|f: &mut Fog| f.density = 1.0),
        Err(Error::Effect(EffectError::NoData(_)))
    ));
    let fog = Fog { density: 0.3, falloff: 0.0, base_height: 0.0, color: DVec3::ONE };
    rt.renderer().insert_effect("height_fog", fog).unwrap();
    assert!(rt.pass_names().contains(&"fog"));
    rt.render(&request).unwrap();
    let e = rt.renderer().insert_effect("mist", 1.0f64).unwrap_err();
    assert!(matches!(e, Error::Effect(EffectError::NotRegistered(ref n)) if n == "mist"), "{e}");
}

#[test]
fn the_fog_table_is_checked_where_it_is_written() {
    let text = scene_with("position = [0, 2, 8]\nlook_at = [0, 0.5, 0]", "density = -1");
    let e = parse(&text).unwrap_err();
    let line = text.lines().position(|l| l.starts_with("density = -1")).unwrap() + 1;
    assert_eq!((e.line, e.column), (line, 11), "{e}");
    assert!(e.message.contains("[fog] `density`: expected a number in 0..=3.4e38, found -1"), "{e}");

    let e = parse(&scene_with("position = [0, 2, 8]\nlook_at = [0, 0.5, 0]", "density = 1\nhue = 2"))
        .unwrap_err();
    assert!(e.message.contains("unknown field `hue`"), "{e}");
    let e =
        parse(&scene_with("position = [0, 2, 8]\nlook_at = [0, 0.5, 0]", "density = 1\ncolor = [1, -2, 0]"))
            .unwrap_err();
    assert!(e.message.contains("[fog] `color`: expected 3 numbers in 0..=65504"), "{e}");

    // Without the effect registered the table is hadou's unknown field, at its line.
    let text = scene_with("position = [0, 2, 8]\nlook_at = [0, 0.5, 0]", "density = 1");
    let e = hadou::scene::parse_scene(&text, Path::new("fog.toml")).unwrap_err();
    let line = text.lines().position(|l| l == "[fog]").unwrap() + 1;
    assert_eq!(e.line, line, "{e}");
    assert!(e.message.starts_with("unknown field `fog`, expected one of `render`, `camera`"), "{e}");
    let expected = e.message.split_once("expected one of").unwrap().1;
    assert!(!expected.contains("`fog`"), "{e}");
    // With it registered, the list of tables names it.
    let e = parse(&text.replace("[fog]", "[mist]")).unwrap_err();
    assert!(e.message.ends_with("`gltf`, `metaballs`, `wave`, `fog`"), "{e}");
}

#[test]
fn a_scene_needs_its_effects_registered() {
    let scene = parse(&scene_with("position = [0, 2, 8]\nlook_at = [0, 0.5, 0]", "density = 1")).unwrap();
    let mut rt = common::runtime();
    let e = rt.load_scene(scene).unwrap_err();
    assert!(matches!(e, Error::Effect(EffectError::NotRegistered(ref n)) if n == "height_fog"), "{e}");
}

/// An effect registering what is taken already.
struct Claims {
    name: &'static str,
    tables: &'static [&'static str],
    pass: &'static str,
}

impl Effect for Claims {
    fn name(&self) -> &'static str {
        self.name
    }

    fn tables(&self) -> &'static [&'static str] {
        self.tables
    }

    fn passes(&self) -> Vec<EffectPass> {
        vec![EffectPass::new(self.pass, |_| false, |_| unreachable!("never needed"))]
    }
}

#[test]
fn registrations_that_collide_are_refused() {
    let claims = |name, tables, pass| fog_effects().with(Claims { name, tables, pass }).unwrap_err();
    assert!(
        matches!(claims("height_fog", &[], "other"), EffectError::DuplicateEffect(n) if n == "height_fog")
    );
    let e = claims("x", &["camera"], "other");
    assert!(matches!(&e, EffectError::TableClaimed { owner, .. } if owner == "hadou's scene format"), "{e}");
    let e = claims("x", &["fog"], "other");
    assert!(matches!(&e, EffectError::TableClaimed { owner, .. } if owner == "effect `height_fog`"), "{e}");
    assert!(matches!(claims("x", &[], "fog"), EffectError::DuplicatePass(n) if n == "fog"));
    assert!(matches!(claims("x", &[], "raster"), EffectError::DuplicatePass(n) if n == "raster"));
    assert!(matches!(claims("x", &[], "energy_wave"), EffectError::DuplicatePass(n) if n == "energy_wave"));
}

/// An effect's own configuration reaches its passes (`EffectPass` holds closures): with the
/// game's `min_density` above the file's fog, the fog pass is not needed, so not planned; at or
/// below it, it is. A pass's build captures its configuration the same way (a build counter here).
#[test]
fn the_effects_configuration_reaches_its_passes() {
    let scene = parse(&scene_with("position = [0, 2, 8]\nlook_at = [0, 0.5, 0]", "density = 0.2")).unwrap();
    let plan = |min_density| Effects::builtin().with(HeightFog { min_density }).unwrap().plan(&scene);
    assert!(plan(0.0).contains(&"fog"));
    assert!(plan(0.2).contains(&"fog"));
    assert!(!plan(0.25).contains(&"fog"), "{:?}", plan(0.25));

    let builds = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let counter = builds.clone();
    let pass = EffectPass::new(
        "counted",
        |_| true,
        move |_| {
            counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            Err(hadou::gpu::GpuError::Shader { name: "counted".into(), message: "never built whole".into() })
        },
    );
    assert!(pass.needed(&scene) && pass.variant(&scene).is_empty());
    let effects = fog_effects().with(Counted(pass)).unwrap();
    let mut rt = common::runtime_with_effects(effects);
    let err = rt.load_scene(scene).expect_err("the failing build fails the load").to_string();
    assert!(err.contains("never built whole"), "{err}");
    assert_eq!(
        builds.load(std::sync::atomic::Ordering::Relaxed),
        1,
        "the captured counter counted the build"
    );
}

/// An effect whose one pass is given whole.
struct Counted(EffectPass);

impl Effect for Counted {
    fn name(&self) -> &'static str {
        "counted"
    }

    fn passes(&self) -> Vec<EffectPass> {
        vec![self.0.clone()]
    }
}

/// An effect's graphics pass: the sky glow (examples/custom_effect/glow.rs), a full-screen
/// fragment shader blended additively into `hdr`, inserted at run time. Against its f64 twin on
/// the shader's f32 inputs: hdr with the glow − hdr without it is the twin's radiance where the
/// pixel sees sky, and exactly 0 on surfaces (adding 0 to a value the image holds gives it back).
/// Tolerance: the blend rounds the f32 sum into RGBA16F once, which Vulkan lets a float attachment
/// do either way — ≤ 2⁻¹⁰ of the sum; the shader's ray (a normalize of f32 sums), dot and square
/// add ≤ 32·2⁻²⁴ of the glow.
#[test]
fn a_graphics_pass_adds_the_sky_glow() {
    let scene = parse(SCENE).unwrap();
    let mut rt = common::runtime_with_effects(fog_effects().with(SkyGlow).unwrap());
    rt.load_scene(scene.clone()).unwrap();
    let mut request = FrameRequest::new(SIZE.0, SIZE.1);
    request.aovs = vec![Aov::Hdr, Aov::Depth];
    let plain = rt.render(&request).unwrap();
    assert!(!rt.pass_names().contains(&"sky_glow"));
    let glow = Glow { direction: DVec3::new(0.2, 0.5, -1.0), color: DVec3::new(2.0, 1.0, 0.5) };
    rt.renderer().insert_effect("sky_glow", glow.clone()).unwrap();
    let glowing = rt.render(&request).unwrap();
    assert!(rt.pass_names().contains(&"sky_glow"), "{:?}", rt.pass_names());
    common::assert_clean(&rt);

    let p = GlowParams::new(&glow, hadou::effect::pre_exposure(&scene));
    let v = |a: [f32; 4]| DVec3::new(a[0].into(), a[1].into(), a[2].into());
    let twin = Glow { direction: v(p.direction), color: v(p.color) };
    let [right, up, forward] = scene.camera.ray_frame(SIZE.0, SIZE.1).to_f32();
    let (before, after) = (plain.aov(Aov::Hdr).unwrap(), glowing.aov(Aov::Hdr).unwrap());
    let distance = plain.aov(Aov::Depth).unwrap();
    let (mut sky, mut surface) = (0, 0);
    for y in 0..SIZE.1 {
        for x in 0..SIZE.0 {
            let ndc_x = 2.0 * (x as f64 + 0.5) / SIZE.0 as f64 - 1.0 + f64::from(right[3]);
            let ndc_y = 1.0 - 2.0 * (y as f64 + 0.5) / SIZE.1 as f64 + f64::from(up[3]);
            let u = (v(forward) + ndc_x * v(right) + ndc_y * v(up)).normalize();
            let is_sky = distance.at(x, y, 0).is_infinite();
            let want = if is_sky { twin.radiance(u) } else { DVec3::ZERO }.to_array();
            for c in 0..3 {
                let (b, a) = (f64::from(before.at(x, y, c)), f64::from(after.at(x, y, c)));
                if !is_sky {
                    assert_eq!(a, b, "({x}, {y}) channel {c}: a surface pixel changed");
                    continue;
                }
                let bound = a.abs() / 1024.0 + 32.0 * ULP * want[c as usize];
                let err = (a - b - want[c as usize]).abs();
                assert!(
                    err <= bound,
                    "({x}, {y}) channel {c}: {a} − {b} vs glow {} (bound {bound})",
                    want[c as usize]
                );
            }
            assert_eq!(before.at(x, y, 3), after.at(x, y, 3), "({x}, {y}): alpha changed");
            if is_sky {
                sky += 1;
            } else {
                surface += 1;
            }
        }
    }
    assert!(sky > 100 && surface > 100, "{sky} sky and {surface} surface pixels");
    // A glow with no direction is refused, the scene left as it was.
    let bad = rt.renderer().update_effect(|g: &mut Glow| g.direction = DVec3::ZERO).unwrap_err();
    assert!(bad.to_string().contains("non-zero direction"), "{bad}");
}

static NOBODY_WRITES: ImageDesc = ImageDesc {
    name: "nobody_writes",
    format: vk::Format::R32_SFLOAT,
    texel_bytes: 4,
    usage: vk::ImageUsageFlags::empty(),
    needs: "a pass that writes it",
};

/// A pass that gets its declaration wrong: reads an image no pass writes, or declares one image
/// with two uses (bound as a storage image, and sampled in `images()`).
struct Wrong {
    reads_unwritten: bool,
}

impl Pass for Wrong {
    fn name(&self) -> &'static str {
        "wrong"
    }

    fn images(&self) -> Vec<ImageUse> {
        match self.reads_unwritten {
            true => Vec::new(),
            false => vec![ImageUse::new(Target::Hdr, ImageAccess::COMPUTE_SAMPLED)],
        }
    }

    fn prepare(&mut self, _frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        match self.reads_unwritten {
            true => Ok(vec![Binding::read(Target::Custom(&NOBODY_WRITES))]),
            false => Ok(vec![Binding::read_write(Target::Hdr), Binding::read(Target::Distance)]),
        }
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        Vec::new()
    }

    fn record(&self, _pass: &PassRecording) {
        unreachable!("a frame with this pass is refused before recording")
    }
}

struct WrongEffect;

impl Effect for WrongEffect {
    fn name(&self) -> &'static str {
        "wrong"
    }

    fn passes(&self) -> Vec<EffectPass> {
        vec![EffectPass::new(
            "wrong",
            |s| s.effects.get::<bool>().is_some(),
            |b| Ok(Box::new(Wrong { reads_unwritten: *b.scene.effects.get::<bool>().unwrap() })),
        )
        .with_variant(|s| format!("{:?}", s.effects.get::<bool>()))]
    }
}

#[test]
fn frames_with_wrong_declarations_are_errors_not_panics() {
    let mut rt = common::runtime_with_effects(Effects::builtin().with(WrongEffect).unwrap());
    rt.load_scene(common::parse(SCENE)).unwrap();
    let request = FrameRequest::new(8, 8);
    rt.render(&request).unwrap();
    rt.renderer().insert_effect("wrong", true).unwrap();
    let e = rt.render(&request).unwrap_err();
    assert!(
        matches!(e, Error::Effect(EffectError::NotWritten { pass: "wrong", image: "nobody_writes", .. })),
        "{e}"
    );
    rt.renderer().update_effect(|reads: &mut bool| *reads = false).unwrap();
    let e = rt.render(&request).unwrap_err();
    assert!(matches!(e, Error::Effect(EffectError::Declaration { pass: "wrong", image: "hdr", .. })), "{e}");
    assert!(e.to_string().contains("one use per image"), "{e}");
    // Taken out again, the frame renders (nothing was half-recorded).
    assert!(rt.renderer().remove_effect("wrong").unwrap());
    rt.render(&request).unwrap();
}
