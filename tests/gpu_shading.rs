//! The base shading on the GPU vs its f64 twin (`effects::shading`), per pixel, on lavapipe with
//! validation on: raster surfaces (shaders/raster.frag), metaball surfaces (shaders/metaballs.comp)
//! and the background, each in the HDR AOV and, through the tonemap, in the 8-bit colour.
//!
//! # The reference, independent of the GPU
//! Per pixel centre the f64 camera ray (`Camera::pixel_ray`) is cast against the scene's raster
//! instances in closed form — cubes (a slab test in object space) and planes — and against its
//! metaball groups (`metaballs::cast`, Bézier clipping in f64, from the near plane to the raster
//! hit, and `metaballs_f32::tangency`, the band); the nearest hit gives the surface, its world normal M⁻ᵀn (n the face's object normal)
//! turned toward the camera, or the metaball's f64 normal. The twin shades it in f64
//! (`Lighting::raster`, `Lighting::metaball`) and tonemaps it (`effects::tonemap`).
//!
//! # The bounds (per pixel and channel)
//! - **f32 shading.** The GPU's inputs are the f64 scene rounded to f32 (2⁻²⁴ relative). A raster
//!   face's normal is one column of the f32 normal matrix (its vertex normals are ±eₖ), the same at
//!   the three vertices, interpolated (Σ of the barycentric weights within a few ulps of 1) and
//!   normalized: within ε_n = 2⁻²⁰ of the f64 unit normal (16 ulps). Each n·l is then within
//!   2⁻¹⁹ (ε_n, l's rounding, the 3-term dot), and max(·, 0) keeps that; the products and the ≤ 9
//!   sums add ≤ 16 ulps of the largest value. So |HDR_f32 − twin| ≤ E₃₂ = 2⁻¹⁸·a·(ambient + ΣL).
//! - **RGBA16F.** The HDR target stores 11 significant bits: within one f16 step, ≤ 2⁻¹⁰ of the
//!   value (Vulkan lets a store round to nearest or toward zero; lavapipe truncates), or 2⁻²⁴
//!   absolutely below 2⁻¹⁴ (subnormal f16). So E = E₃₂ + 2⁻¹⁰·(|twin| + E₃₂) + 2⁻²⁴.
//! - **The normal AOV** is RGBA16F too: each component within 2⁻¹⁰·(|n_c| + ε_n) + 2⁻²⁴ + ε_n
//!   of the f64 normal on raster faces.
//! - **Metaballs** are shaded by the twin from the f64 cast's normal. The GPU's f32 cast puts its
//!   normal within an angle θ of it, derived per pixel (`metaball_normal_bound`: the f32 root's
//!   and gradient's errors outside the tangency band, turned by at most cond(M); ~3e-4 rad here),
//!   so |Δn| ≤ θ. The diffuse term moves by ≤ a·L·(θ + 2⁻¹⁹) per light; each highlight
//!   0.25·L·(n·h)⁴⁸ by ≤ 0.25·L·48·(n·h + Δh)⁴⁷·Δh (mean value theorem, Δh = θ + 2⁻¹⁸ with h's
//!   f32 rounding), and where |n·l| ≤ θ + 2⁻¹⁹ the GPU may include or drop the light, so its
//!   whole highlight joins the bound; a light with n·l below −(θ + 2⁻¹⁹) is off for both. E₃₂ and
//!   the f16 store are added as on raster surfaces. The normal AOV is checked against the same θ plus its f16 encoding (each component within 2⁻¹⁰
//!   of itself: ≤ 1.01·2⁻¹⁰ rad).
//! - **8-bit colour.** The tonemap runs in f32 on the stored HDR value h ∈ [twin − E, twin + E];
//!   the curve r(x) = 255·srgb(aces(x·exposure)) is monotone, so the f32 code r_gpu is within
//!   b = max(r(twin + E) − r(twin), r(twin) − r(twin − E)) + 255·2⁻¹⁶ of r(twin) (the last term: f32
//!   evaluation of the curve, 256 ulps of it, far above pow's 3 + 2|y·log₂x| ulps). The UNORM store
//!   rounds to nearest (what Vulkan says implementations should do), so |code − r(twin)| ≤ ½ + b:
//!   the code is round(r(twin)) unless r(twin) lies within b of a rounding boundary k + ½, and
//!   then one step off. On raster surfaces and the background E is f16 and f32 rounding only,
//!   b ≤ ~0.1 code, so every code there is within ±1 step (b < ½ asserted); on metaballs the
//!   normal's θ can make b exceed ½ in dark or highlight pixels (counted and printed), where the
//!   bound ½ + b still holds but is no ±1-step claim.
//!
//! Each comparison records error / bound per value (`Comparison`, tolerance 1) with a floor of
//! compared pixels (about half of what the f64 reference finds at each framing, so a scene that
//! stopped showing a surface, or exclusions that grew, fail); NaN anywhere fails.
//!
//! # What is left out, and the caps
//! - **Raster edges**: pixel centres within δ = 1/16 pixel of a projected edge of a cube or plane
//!   (visible or not). The GPU's edges are the f32 vertices snapped to the sub-pixel grid: Vulkan
//!   requires ≥ 4 sub-pixel bits, so an edge moves by ≤ 1/32 pixel (the f32 transforms add
//!   ~1e-4 pixel); elsewhere the GPU's sample and the f64 ray see the same face. The cap: the
//!   centres within δ < 1/(2√2) of a segment of length L (pixels) are at most one per column
//!   along its major axis (a cross-section of the δ-neighbourhood is ≤ 2δ√2 < 1 tall), over at most
//!   L + 2δ columns: ≤ L + 2 pixels per segment, Σ (L + 2) over all edges.
//! - **The tangency band** of a metaball group (`metaballs_f32::tangency`): rays that graze the
//!   surface within δ = 16·ε_f32·(S + X·G), where f32 may legitimately differ in hit/miss. Its
//!   width is ~10⁻⁵ world units, a small fraction of a pixel, and it runs along the outline (the
//!   groups here have no pinch, where a ray inside could graze from within), so every band pixel
//!   is an outline pixel: one whose f64 hit/miss differs from a 4-neighbour's. Cap: band ≤
//!   outline pixels.

mod common;

use glam::{DMat3, DVec3, DVec4};
use hadou::effects::metaballs::{cast, gradient, MetaHit, MetaballGroupParams};
use hadou::effects::metaballs_f32::{tangency, BAND_C};
use hadou::effects::shading::{Lighting, METABALL_SHININESS, METABALL_SPECULAR};
use hadou::effects::tonemap::tonemap_channel;
use hadou::scene::transform::{condition_number, Transform};
use hadou::scene::Scene;
use hadou::testing::Comparison;
use hadou::{Aov, FrameRequest};

/// The f16 step: a stored value is within 2⁻¹⁰ of itself (relative), 2⁻²⁴ below 2⁻¹⁴.
const F16_REL: f64 = 1.0 / 1024.0;
const F16_ABS: f64 = 1.0 / 16_777_216.0;
/// The f32 unit normal of a raster face vs the f64 one (module docs).
const EPS_NORMAL: f64 = 1.0 / 1_048_576.0;
/// The f32 n·l (ε_n, l's rounding, the dot).
const EPS_DOT: f64 = 2.0 * EPS_NORMAL;
/// Relative f32 error of a shaded colour against the scale a·(ambient + ΣL).
const EPS_SHADE: f64 = 4.0 * EPS_NORMAL;
/// Edge exclusion: pixel centres this close (pixels) to a projected raster edge.
const EDGE_DELTA: f64 = 1.0 / 16.0;
/// f32 evaluation of the tonemap curve, in 8-bit codes (256 ulps of full scale).
const CURVE_F32: f64 = 255.0 / 65536.0;

// ---------------------------------------------------------------------------------------------
// Rendering

struct Rendered {
    hdr: Vec<f32>,
    normal: Vec<f32>,
    color: Vec<u8>,
}

fn render(scene: &Scene, width: u32, height: u32) -> Rendered {
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let mut request = FrameRequest::new(width, height);
    request.color = true;
    request.aovs = vec![Aov::Hdr, Aov::Normal];
    let frame = rt.render(&request).unwrap();
    common::assert_clean(&rt);
    if !scene.metaballs().is_empty() {
        assert_eq!(frame.stats.counter(hadou::passes::metaballs::DROPPED), 0);
    }
    rt.finish();
    Rendered {
        hdr: frame.aov(Aov::Hdr).unwrap().data.clone(),
        normal: frame.aov(Aov::Normal).unwrap().data.clone(),
        color: frame.color.unwrap(),
    }
}

// ---------------------------------------------------------------------------------------------
// The f64 reference: closed-form raster shapes, the metaball cast

#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    /// An axis-aligned box of these half extents, centred.
    Cube(DVec3),
    /// The square |x|, |z| ≤ half in y = 0 (normal +y).
    Plane(f64),
}

struct Solid {
    instance: usize,
    shape: Shape,
    transform: Transform,
}

/// The scene's instances as closed-form shapes (cubes and planes only: from their meshes' boxes).
fn solids(scene: &Scene) -> Vec<Solid> {
    scene
        .instances
        .iter()
        .enumerate()
        .map(|(instance, inst)| {
            let mesh = &scene.meshes[inst.mesh];
            let (lo, hi) = mesh.mesh.bounds();
            assert_eq!(lo, -hi, "{}: centred shapes only", mesh.name);
            let shape = match mesh.mesh.triangle_count() {
                12 => Shape::Cube(hi),
                2 if hi.y == 0.0 && hi.x == hi.z => Shape::Plane(hi.x),
                n => panic!("{}: a cube or a plane ({n} triangles)", mesh.name),
            };
            Solid { instance, shape, transform: inst.transform }
        })
        .collect()
}

/// A raster hit: world distance, the instance, its world normal turned toward the camera, and
/// which face (for diagnostics).
#[derive(Clone, Copy, Debug)]
struct RasterHit {
    t: f64,
    instance: usize,
    normal: DVec3,
}

fn cast_solid(s: &Solid, o: DVec3, u: DVec3) -> Option<RasterHit> {
    let ray = s.transform.ray_to_object(o, u);
    let (ro, rd) = (ray.origin, ray.dir);
    let (t_obj, n_obj) = match s.shape {
        Shape::Cube(h) => {
            let (mut near, mut far, mut axis) = (f64::NEG_INFINITY, f64::INFINITY, 0);
            for k in 0..3 {
                if rd[k] == 0.0 {
                    if ro[k].abs() > h[k] {
                        return None;
                    }
                    continue;
                }
                let (a, b) = ((-h[k] - ro[k]) / rd[k], (h[k] - ro[k]) / rd[k]);
                let (a, b) = (a.min(b), a.max(b));
                if a > near {
                    near = a;
                    axis = k;
                }
                far = far.min(b);
            }
            if near > far || near <= 0.0 {
                return None;
            }
            let mut n = DVec3::ZERO;
            n[axis] = -rd[axis].signum();
            (near, n)
        }
        Shape::Plane(h) => {
            let t = -ro.y / rd.y;
            let p = ro + rd * t;
            if !(t > 0.0 && p.x.abs() <= h && p.z.abs() <= h) {
                return None;
            }
            (t, DVec3::Y)
        }
    };
    let t = t_obj / ray.t_scale;
    let mut normal = (s.transform.normal_matrix() * n_obj).normalize();
    // Turned toward the camera, as raster.frag turns it.
    if normal.dot(-u) < 0.0 {
        normal = -normal;
    }
    Some(RasterHit { t, instance: s.instance, normal })
}

fn cast_raster(solids: &[Solid], o: DVec3, u: DVec3) -> Option<RasterHit> {
    solids.iter().filter_map(|s| cast_solid(s, o, u)).min_by(|a, b| a.t.total_cmp(&b.t))
}

/// The projected edges of every solid, in pixels.
fn projected_edges(scene: &Scene, solids: &[Solid], w: u32, h: u32) -> Vec<[glam::DVec2; 2]> {
    let vp = scene.camera.view_projection(w, h);
    let project = |p: DVec3| {
        let c = vp * DVec4::new(p.x, p.y, p.z, 1.0);
        assert!(c.w > scene.camera.near, "{p} is behind the near plane");
        glam::DVec2::new((c.x / c.w + 1.0) * 0.5 * w as f64, (c.y / c.w + 1.0) * 0.5 * h as f64)
    };
    // The projection agrees with the pixel rays: a point on pixel (x, y)'s ray lands on its centre.
    for (x, y) in [(0, 0), (w - 1, 0), (w / 3, h / 2), (w - 1, h - 1)] {
        let (o, u) = scene.camera.pixel_ray(x, y, w, h);
        let p = project(o + u * 5.0);
        assert!((p - glam::DVec2::new(x as f64 + 0.5, y as f64 + 0.5)).length() < 1e-9, "{p}");
    }
    let mut edges = Vec::new();
    for s in solids {
        let m = |p: DVec3| project(s.transform.transform_point(p));
        match s.shape {
            Shape::Cube(hh) => {
                for k in 0..3 {
                    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
                    for (si, sj) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
                        let mut a = DVec3::ZERO;
                        a[i] = si * hh[i];
                        a[j] = sj * hh[j];
                        let (mut p, mut q) = (a, a);
                        p[k] = -hh[k];
                        q[k] = hh[k];
                        edges.push([m(p), m(q)]);
                    }
                }
            }
            Shape::Plane(hh) => {
                let c = [(-hh, -hh), (hh, -hh), (hh, hh), (-hh, hh)].map(|(x, z)| DVec3::new(x, 0.0, z));
                for e in 0..4 {
                    edges.push([m(c[e]), m(c[(e + 1) % 4])]);
                }
            }
        }
    }
    edges
}

fn distance_to_segment(p: glam::DVec2, [a, b]: [glam::DVec2; 2]) -> f64 {
    let ab = b - a;
    let s =
        if ab.length_squared() > 0.0 { ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * s)).length()
}

/// The angle (radians) within which the GPU's f32 cast puts its world normal of the f64 `hit`'s,
/// outside the tangency band (module docs of `metaballs_f32`: g = F − T is evaluated in f32 within
/// δ = BAND_C·ε·(S + X·G)). In object space, at the f64 root p with gradient ∇F and Hessian H
/// (central differences; the Frobenius norm bounds the spectral one):
/// - the f32 root is within Δt = δ/|∇F·d| (g moved by δ, crossed with slope ∇F·d) + 2⁻²²·2R_max
///   (the clipping stops at 2⁻²² of an interval, which lies within one chord) along the ray;
/// - its gradient is within ‖H‖·Δt of ∇F(p), plus the f32 evaluation: positions rounded by ε·X
///   (‖H‖·ε·X) and 16 ulps of the terms' magnitudes (Σ|qᵢ|γ/Rᵢ = G);
/// - the normal −∇F/‖∇F‖ turns by at most that over ‖∇F‖, and M⁻ᵀ turns an angle by at most
///   cond(M) (Frobenius); 16 ulps more for the f32 mapping and normalization.
///
/// H is taken at p for the whole ~1e-6-long segment to the f32 root (F is C¹ only across a
/// support sphere, where the differences average H's jump). Near-grazing hits (small |∇F·d|) get
/// a large bound, which is what their normals allow.
fn metaball_normal_bound(g: &MetaballGroupParams, o: DVec3, u: DVec3, hit: &MetaHit) -> f64 {
    let eps = f64::from(f32::EPSILON);
    let ray = g.transform.ray_to_object(o, u);
    let t = hit.t * ray.t_scale;
    let p = ray.origin + ray.dir * t;
    let grad = gradient(g, p);
    let r_min = g.balls.iter().map(|b| b.radius).fold(f64::INFINITY, f64::min);
    let r_max = g.balls.iter().map(|b| b.radius).fold(0.0, f64::max);
    let step = 1e-4 * r_min;
    let hessian = (0..3)
        .map(|k| {
            let e = DVec3::from_array(std::array::from_fn(|j| if j == k { step } else { 0.0 }));
            ((gradient(g, p + e) - gradient(g, p - e)) / (2.0 * step)).length_squared()
        })
        .sum::<f64>()
        .sqrt();
    let inside: Vec<_> = g.balls.iter().filter(|b| (p - b.centre).length() < b.radius).collect();
    let big_g: f64 = inside.iter().map(|b| b.q.abs() * g.kernel.max_slope() / b.radius).sum();
    // S ≤ Σ|qᵢ|·max_k d_k(a = 1) + T: restricted coefficients are convex combinations of the
    // chord's, which grow with a ≤ 1.
    let d_max = g.kernel.chord_bernstein(1.0).into_iter().fold(0.0, f64::max);
    let s = inside.iter().map(|b| b.q.abs()).sum::<f64>() * d_max + g.threshold;
    let x = ray.origin.length() + t;
    let delta = BAND_C * eps * (s + x * big_g);
    let dt = delta / grad.dot(ray.dir).abs() + 2f64.powi(-22) * 2.0 * r_max;
    let grad_error = hessian * dt + hessian * eps * x + 16.0 * eps * big_g;
    let kappa = condition_number(DMat3::from_mat4(g.transform.matrix));
    kappa * grad_error / grad.length() + 16.0 * eps
}

/// What the f64 reference sees at a pixel centre.
#[derive(Clone, Copy, Debug)]
enum Seen {
    /// Within δ of a projected raster edge: left out.
    Edge,
    /// In a metaball group's tangency band: left out.
    Band,
    Background,
    Raster(RasterHit),
    /// A metaball surface: the f64 normal (toward the camera), the group, and the angle within
    /// which the f32 cast's normal lies of it (`metaball_normal_bound`).
    Metaball {
        normal: DVec3,
        group: usize,
        normal_bound: f64,
    },
}

struct Reference {
    seen: Vec<Seen>,
    /// Σ (L + 2) over the projected edges: the cap on `Seen::Edge` pixels.
    edge_cap: f64,
    /// Pixels whose f64 metaball hit/miss differs from a 4-neighbour's: the cap on band pixels.
    outline: usize,
}

fn reference(scene: &Scene, w: u32, h: u32) -> Reference {
    let solids = solids(scene);
    let edges = projected_edges(scene, &solids, w, h);
    let edge_cap: f64 = edges.iter().map(|[a, b]| (*b - *a).length() + 2.0).sum();
    let groups: Vec<MetaballGroupParams> = scene.metaballs().iter().map(|g| g.at(0.0)).collect();
    let forward = scene.camera.basis().forward;
    let mut seen = Vec::with_capacity((w * h) as usize);
    let mut mb_hit = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let (o, u) = scene.camera.pixel_ray(x, y, w, h);
            let centre = glam::DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            let raster = cast_raster(&solids, o, u);
            // The pass casts from the near plane to the raster's distance (or the far plane).
            let along = u.dot(forward);
            let (t_min, t_max) =
                (scene.camera.near / along, raster.map_or(scene.camera.far / along, |r| r.t));
            let mut metaball: Option<(usize, MetaHit)> = None;
            let mut band = false;
            for (k, g) in groups.iter().enumerate() {
                if let Some(hit) = cast(g, o, u, t_min, t_max) {
                    if metaball.is_none_or(|(_, m)| hit.t < m.t) {
                        metaball = Some((k, hit));
                    }
                }
                band |= tangency(g, o, u, t_min, t_max).in_band();
            }
            mb_hit.push(metaball.is_some());
            seen.push(if band {
                Seen::Band
            } else if edges.iter().any(|&e| distance_to_segment(centre, e) < EDGE_DELTA) {
                Seen::Edge
            } else if let Some((group, hit)) = metaball {
                // −∇F points out of the blob; the pass turns it toward the camera.
                let normal = if hit.normal.dot(u) > 0.0 { -hit.normal } else { hit.normal };
                let normal_bound = metaball_normal_bound(&groups[group], o, u, &hit);
                Seen::Metaball { normal, group, normal_bound }
            } else if let Some(r) = raster {
                Seen::Raster(r)
            } else {
                Seen::Background
            });
        }
    }
    let at = |x: i64, y: i64| {
        (x >= 0 && y >= 0 && x < w as i64 && y < h as i64).then(|| mb_hit[(y * w as i64 + x) as usize])
    };
    let mut outline = 0;
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let me = at(x, y).unwrap();
            let neighbours = [(1, 0), (-1, 0), (0, 1), (0, -1)];
            outline +=
                usize::from(neighbours.iter().any(|(dx, dy)| at(x + dx, y + dy).is_some_and(|n| n != me)));
        }
    }
    Reference { seen, edge_cap, outline }
}

// ---------------------------------------------------------------------------------------------
// The comparison

/// The 8-bit codes of one surface kind vs the tonemapped twin (module docs: ½ + b per channel).
struct Ldr {
    c: Comparison,
    /// Codes one step off round(r(twin)): allowed within b of a rounding boundary.
    off_by_one: usize,
    /// Codes whose b reaches ½ (the HDR bound spans more than a step: no ±1 claim there).
    wide: usize,
    /// The largest b, in codes.
    worst_b: f64,
}

impl Ldr {
    fn new(what: &str) -> Self {
        Ldr { c: Comparison::new(what), off_by_one: 0, wide: 0, worst_b: 0.0 }
    }

    fn compare(&mut self, at: (u32, u32), code: &[u8], twin: DVec3, e: DVec3, exposure: f64) {
        for k in 0..3 {
            let r = tonemap_channel(twin[k], exposure);
            let lo = tonemap_channel((twin[k] - e[k]).max(0.0), exposure);
            let hi = tonemap_channel(twin[k] + e[k], exposure);
            let b = (hi - r).max(r - lo) + CURVE_F32;
            let code = f64::from(code[k]);
            self.c.error(
                format_args!("{at:?} channel {k}: code {code}, twin {r:.4}, b {b:.4}"),
                (code - r).abs() / (0.5 + b),
            );
            self.off_by_one += usize::from(code != r.round());
            self.wide += usize::from(b >= 0.5);
            // NaN-propagating (a NaN b must not hide behind the running maximum).
            if b.is_nan() || b > self.worst_b {
                self.worst_b = b;
            }
        }
    }

    fn summary(&self) -> String {
        format!(
            "{}\n    {} codes one step off round(twin), {} with b ≥ ½, largest b {:.4} codes",
            self.c.summary(),
            self.off_by_one,
            self.wide,
            self.worst_b
        )
    }
}

/// The comparisons of one frame, by surface kind.
struct Checks {
    raster_hdr: Comparison,
    raster_normal: Comparison,
    raster_ldr: Ldr,
    metaball_hdr: Comparison,
    metaball_normal: Comparison,
    metaball_ldr: Ldr,
    background: Comparison,
    background_ldr: Ldr,
    edge_cap: f64,
    outline: usize,
    /// The f64 normal of each compared raster pixel, with its instance.
    raster_normals: Vec<(usize, DVec3)>,
    /// Compared metaball pixels whose twin has a highlight above 0.02 in some channel.
    highlights: usize,
}

fn compare(scene: &Scene, w: u32, h: u32) -> Checks {
    let frame = render(scene, w, h);
    let reference = reference(scene, w, h);
    let lighting = Lighting::new(scene);
    let exposure = scene.render.exposure;
    let mut checks = Checks {
        raster_hdr: Comparison::new("raster HDR vs f64 twin (error / bound)"),
        raster_normal: Comparison::new("raster normal AOV vs closed-form M⁻ᵀn (error / bound)"),
        raster_ldr: Ldr::new("raster 8-bit colour vs tonemapped twin (error / (½ + b))"),
        metaball_hdr: Comparison::new("metaball HDR vs f64 twin (error / bound)"),
        metaball_normal: Comparison::new("metaball normal AOV vs f64 cast (angle / bound)"),
        metaball_ldr: Ldr::new("metaball 8-bit colour vs tonemapped twin (error / (½ + b))"),
        background: Comparison::new("background HDR vs the scene's (error / bound)"),
        background_ldr: Ldr::new("background 8-bit colour vs tonemapped (error / (½ + b))"),
        edge_cap: reference.edge_cap,
        outline: reference.outline,
        raster_normals: Vec::new(),
        highlights: 0,
    };
    for (i, seen) in reference.seen.iter().enumerate() {
        let at = (i as u32 % w, i as u32 / w);
        let hdr = DVec3::from_array([0, 1, 2].map(|k| f64::from(frame.hdr[i * 4 + k])));
        let aov_n = DVec3::from_array([0, 1, 2].map(|k| f64::from(frame.normal[i * 4 + k])));
        let code = &frame.color[i * 4..i * 4 + 3];
        let stored = |twin: DVec3, e32: DVec3| e32 + (twin.abs() + e32) * F16_REL + DVec3::splat(F16_ABS);
        match *seen {
            // Left out of the kind they border (per channel, as the kind counts its values).
            Seen::Edge => (0..3).for_each(|_| checks.raster_hdr.exclude()),
            Seen::Band => (0..3).for_each(|_| checks.metaball_hdr.exclude()),
            Seen::Background => {
                let twin = scene.render.background;
                let e = twin * F16_REL + DVec3::splat(F16_ABS);
                for k in 0..3 {
                    checks
                        .background
                        .error(format_args!("{at:?} HDR channel {k}"), (hdr[k] - twin[k]).abs() / e[k]);
                }
                checks.background_ldr.compare(at, code, twin, e, exposure);
            }
            Seen::Raster(r) => {
                let albedo = scene.materials[scene.instances[r.instance].material].albedo;
                let twin = lighting.raster(albedo, r.normal);
                checks.raster_normals.push((r.instance, r.normal));
                let e32 = albedo * lighting.diffuse_scale() * EPS_SHADE;
                let e = stored(twin, e32);
                for k in 0..3 {
                    checks.raster_hdr.error(
                        format_args!(
                            "{at:?} channel {k}: gpu {}, twin {}, bound {}, n {}",
                            hdr[k], twin[k], e[k], r.normal
                        ),
                        (hdr[k] - twin[k]).abs() / e[k],
                    );
                    let en = (r.normal[k].abs() + EPS_NORMAL) * F16_REL + F16_ABS + EPS_NORMAL;
                    checks.raster_normal.error(
                        format_args!("{at:?} component {k}: gpu {}, f64 {}", aov_n[k], r.normal[k]),
                        (aov_n[k] - r.normal[k]).abs() / en,
                    );
                }
                checks.raster_ldr.compare(at, code, twin, e, exposure);
            }
            Seen::Metaball { normal, group, normal_bound } => {
                let albedo = scene.materials[scene.metaballs()[group].material].albedo;
                let (_, u) = scene.camera.pixel_ray(at.0, at.1, w, h);
                let v = -u;
                // Shaded from the f64 normal: the GPU's f32 one is within `normal_bound` of it
                // (module docs), a chord no longer than the arc.
                let n = normal;
                let twin = lighting.metaball(albedo, n, v);
                checks.highlights += usize::from(lighting.metaball_light(n, v).specular.max_element() > 0.02);
                let dn = normal_bound;
                let dh = dn + 4.0 * EPS_NORMAL;
                let mut e32 = albedo * lighting.diffuse_scale() * EPS_SHADE;
                for l in &lighting.lights {
                    let nl = n.dot(l.to_light);
                    if nl < -(dn + EPS_DOT) {
                        continue; // off for the GPU's normal too
                    }
                    let hv = (l.to_light + v).normalize_or_zero();
                    let nh = (n.dot(hv).max(0.0) + dh).min(1.0);
                    e32 += albedo * l.radiance * (dn + EPS_DOT);
                    e32 += l.radiance
                        * METABALL_SPECULAR
                        * METABALL_SHININESS
                        * nh.powf(METABALL_SHININESS - 1.0)
                        * dh;
                    if nl.abs() <= dn + EPS_DOT {
                        e32 += l.radiance * METABALL_SPECULAR * nh.powf(METABALL_SHININESS);
                    }
                }
                let e = stored(twin, e32);
                for k in 0..3 {
                    checks.metaball_hdr.error(
                        format_args!(
                            "{at:?} channel {k}: gpu {}, twin {}, bound {}, n {n}",
                            hdr[k], twin[k], e[k]
                        ),
                        (hdr[k] - twin[k]).abs() / e[k],
                    );
                }
                // The f32 cast's normal within `normal_bound` of the f64 one, the AOV's f16 within
                // |Δn| ≤ 2⁻¹⁰ of that (an angle ≤ 1.01·2⁻¹⁰).
                let angle = aov_n.angle_between(normal);
                let bound = normal_bound + 1.01 * F16_REL;
                checks.metaball_normal.error(
                    format_args!("{at:?}: gpu {aov_n}, f64 {normal}, angle {angle:.3e}, bound {bound:.3e}"),
                    angle / bound,
                );
                checks.metaball_ldr.compare(at, code, twin, e, exposure);
            }
        }
    }
    checks
}

impl Checks {
    /// Asserts every comparison (floors: the least raster, metaball and background pixels the
    /// scene must show), the ±1-step claim where the argument gives it, and the exclusion caps.
    fn assert(&self, label: &str, min_raster: usize, min_metaball: usize, min_background: usize) {
        println!("{label}:");
        // 3 values per pixel (channels or components), the metaball normal 1.
        let all = [
            (&self.raster_hdr, 3 * min_raster),
            (&self.raster_normal, 3 * min_raster),
            (&self.raster_ldr.c, 3 * min_raster),
            (&self.metaball_hdr, 3 * min_metaball),
            (&self.metaball_normal, min_metaball),
            (&self.metaball_ldr.c, 3 * min_metaball),
            (&self.background, 3 * min_background),
            (&self.background_ldr.c, 3 * min_background),
        ];
        let failures: Vec<String> = all.iter().filter_map(|(c, min)| c.check(1.0, *min).err()).collect();
        for c in [
            &self.raster_hdr,
            &self.raster_normal,
            &self.metaball_hdr,
            &self.background,
            &self.metaball_normal,
        ] {
            println!("  {}", c.summary());
        }
        for l in [&self.raster_ldr, &self.metaball_ldr, &self.background_ldr] {
            println!("  {}", l.summary());
        }
        println!(
            "  {} edge pixels (cap Σ(L + 2) = {:.0}), {} band pixels (cap: {} outline pixels)",
            self.raster_hdr.excluded() / 3,
            self.edge_cap,
            self.metaball_hdr.excluded() / 3,
            self.outline
        );
        assert!(failures.is_empty(), "{label}: {failures:#?}");
        // Raster and background: only f16 and f32 rounding, b ≤ ~0.12 codes (module docs), so every
        // code is round(r(twin)) or one step off.
        for l in [&self.raster_ldr, &self.background_ldr] {
            assert!(
                l.worst_b < 0.5,
                "{label}: {}: b = {} codes: the ±1-step claim needs b < ½",
                l.c.summary(),
                l.worst_b
            );
        }
        // The caps as shares of each kind's values (3 per pixel, compared or left out).
        let share =
            |c: &Comparison, cap: f64| (3.0 * cap / (c.compared() + c.excluded()).max(1) as f64).min(1.0);
        self.raster_hdr.assert_excluded_at_most(share(&self.raster_hdr, self.edge_cap));
        self.metaball_hdr.assert_excluded_at_most(share(&self.metaball_hdr, self.outline as f64));
    }
}

// ---------------------------------------------------------------------------------------------
// Tests

/// A rotated, non-uniformly scaled cube on a floor under one light, exposure 1.5: every raster
/// pixel's HDR, normal and 8-bit colour against the twin; the background too.
#[test]
fn raster_surfaces_match_the_f64_shading() {
    let scene = common::parse(
        r#"
        [render]
        exposure = 1.5
        background = [0.05, 0.07, 0.1]
        ambient = [0.1, 0.12, 0.15]
        [camera]
        position = [3, 3, 6]
        look_at = [0, 0.4, 0]
        fov_y_deg = 40
        [[light]]
        direction = [-1, -2, -0.5]
        color = [1, 0.9, 0.8]
        intensity = 2.5
        [[mesh]]
        name = "box"
        kind = "cube"
        size = 1.5
        [[mesh]]
        name = "floor"
        kind = "plane"
        size = 6
        [[material]]
        name = "red"
        albedo = [0.8, 0.2, 0.15]
        [[material]]
        name = "grey"
        albedo = [0.6, 0.6, 0.6]
        [[instance]]
        mesh = "box"
        material = "red"
        transform = [{ scale = [1.2, 0.8, 1] }, { rotate = { angle_deg = 30, axis = [0, 1, 0] } }, { translate = [0, 0.7, 0] }]
        [[instance]]
        mesh = "floor"
        material = "grey"
        "#,
    );
    let checks = compare(&scene, 192, 144);
    checks.assert("cube and floor", 7000, 0, 7000);
}

/// A metaball group under a non-uniform scale above a floor, two lights: the metaball pixels'
/// HDR (diffuse + highlight) and 8-bit colour against the twin, the floor and background too.
#[test]
fn metaball_surfaces_match_the_f64_shading() {
    let scene = common::parse(
        r#"
        [render]
        exposure = 1.2
        background = [0.02, 0.03, 0.05]
        ambient = [0.08, 0.08, 0.1]
        [camera]
        position = [2.5, 3, 6]
        look_at = [0, 1, 0]
        fov_y_deg = 40
        [[light]]
        direction = [-1, -2, -1]
        intensity = 2
        [[light]]
        direction = [1, -0.5, 0.5]
        color = [0.5, 0.6, 1]
        intensity = 0.8
        [[mesh]]
        name = "floor"
        kind = "plane"
        size = 8
        [[material]]
        name = "green"
        albedo = [0.3, 0.75, 0.35]
        [[instance]]
        mesh = "floor"
        [[metaballs]]
        name = "blob"
        material = "green"
        transform = [{ scale = [1.3, 0.8, 1.0] }, { rotate = { angle_deg = 25, axis = [0, 1, 0.3] } }, { translate = [0, 1.2, 0] }]
        balls = [
          { centre = [-0.6, 0, 0], radius = 1.6 },
          { centre = [0.6, 0.1, 0], radius = 1.5 },
          { centre = [0, 0.5, 0.3], radius = 1.2, q = 0.8 },
        ]
        "#,
    );
    let checks = compare(&scene, 192, 144);
    checks.assert("metaball blob and floor", 6000, 2000, 5000);
    // The highlight is compared where it is large, not only where it vanishes.
    println!("  {} metaball pixels with a highlight", checks.highlights);
    assert!(checks.highlights >= 100, "{} pixels with a highlight", checks.highlights);
}

/// Several lights on both surface kinds, the hard cases: a cube under rotate–scale–rotate (its
/// normals need M⁻ᵀ: M would tilt them), one light exactly perpendicular to the cube's top face
/// (M⁻ᵀn; it must add nothing there — it would with M's normal), one grazing its front face at
/// 1°, one travelling parallel to the floor (n·l = 0 exactly), one from below (lighting no visible
/// face); the floor is a plane turned upside down (its normal points away from the camera, which
/// the raster turns back).
#[test]
fn grazing_and_perpendicular_lights_under_a_non_uniform_scale() {
    let mut scene = common::parse(
        r#"
        [render]
        exposure = 0.9
        background = [0.1, 0.1, 0.12]
        ambient = [0.05, 0.06, 0.07]
        [camera]
        position = [4, 3.5, 5]
        look_at = [0, 0.6, 0]
        fov_y_deg = 45
        [[light]]
        direction = [0, -1, 0]
        intensity = 3
        [[light]]
        direction = [0, -1, 0]
        color = [1, 0.7, 0.4]
        intensity = 4
        [[light]]
        direction = [1, 0, -0.4]
        color = [0.6, 0.8, 1]
        intensity = 2
        [[light]]
        direction = [0.3, 1, 0.2]
        intensity = 5
        [[mesh]]
        name = "box"
        kind = "cube"
        size = 1.4
        [[mesh]]
        name = "floor"
        kind = "plane"
        size = 7
        [[material]]
        name = "clay"
        albedo = [0.75, 0.55, 0.4]
        [[material]]
        name = "blue"
        albedo = [0.25, 0.35, 0.8]
        [[instance]]
        mesh = "box"
        material = "clay"
        transform = [
          { rotate = { angle_deg = 35, axis = [0, 0, 1] } },
          { scale = [1.8, 0.6, 1.2] },
          { rotate = { angle_deg = 20, axis = [0, 1, 0] } },
          { translate = [-0.6, 0.9, 0.4] },
        ]
        [[instance]]
        mesh = "floor"
        transform = [{ rotate = { angle_deg = 180, axis = [1, 0, 0] } }]
        [[metaballs]]
        material = "blue"
        transform = [{ scale = [0.9, 0.6, 0.7] }, { translate = [1.6, 0.9, -0.8] }]
        balls = [{ centre = [0, 0, 0], radius = 1.6 }, { centre = [0.9, 0.3, 0], radius = 1.3 }]
        "#,
    );
    // Light 0 perpendicular to the cube's top face (object +y) under M⁻ᵀ; light 1 at 1° to its
    // front face (object +z).
    let m = scene.instances[0].transform;
    let top = m.transform_normal(DVec3::Y);
    let front = m.transform_normal(DVec3::Z);
    assert!(
        top.angle_between(m.transform_point(DVec3::Y) - m.transform_point(DVec3::ZERO)) > 0.1,
        "M would do"
    );
    scene.lights[0].direction = top.cross(DVec3::X).normalize();
    let tangent = front.cross(DVec3::Y).normalize();
    let to_light = front * 1f64.to_radians().sin() + tangent * 1f64.to_radians().cos();
    scene.lights[1].direction = -to_light;
    assert!(top.dot(scene.lights[0].direction).abs() < 1e-15);
    let checks = compare(&scene, 192, 144);
    checks.assert("several lights", 6000, 700, 5000);
    // The hard cases are on screen: the cube's top (light 0 at 90° under M⁻ᵀ) and front (light 1
    // at 1°), and the floor (light 2 at 90°), each over hundreds of compared pixels.
    let on = |instance: usize, n: DVec3| {
        checks.raster_normals.iter().filter(|(i, m)| *i == instance && (*m - n).length() < 1e-9).count()
    };
    let (top_px, front_px, floor_px) = (on(0, top), on(0, front), on(1, DVec3::Y));
    println!("  compared pixels: cube top {top_px}, cube front {front_px}, floor {floor_px}");
    assert!(top_px >= 300 && front_px >= 300 && floor_px >= 3000, "{top_px}, {front_px}, {floor_px}");
    println!("  {} metaball pixels with a highlight", checks.highlights);
}
