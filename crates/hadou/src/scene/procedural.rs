//! Procedural meshes. Every generator validates its parameters (`MeshError::Invalid` with
//! "`<kind> <field> must be …, got …`"), builds in f64 and stores f32. All shapes except the plane
//! are closed: every edge is shared by exactly two triangles walking it in opposite directions
//! (`Mesh::check_closed_oriented`), faces are counter-clockwise seen from outside, normals are
//! unit length and point out of the solid.
//!
//! Solids of revolution (sphere, torus, cavity, bottle) are built from a profile in the (r, y)
//! half-plane, revolved about +y with vertex j of each ring at angle θⱼ = 2πj/segments,
//! position (r·cos θ, y, r·sin θ). Profile points with r = 0 become single shared pole vertices.

use std::f64::consts::{PI, TAU};
use std::fmt::Display;

use glam::{DVec2, DVec3};

use super::mesh::{Mesh, MeshError};

/// Smallest and largest accepted length (any size, radius, height, wall): f32 keeps ~7 digits
/// either way and the GPU's products of such lengths stay far from f32 under- and overflow.
pub const MIN_LENGTH: f64 = 1e-6;
/// Largest accepted length (see `MIN_LENGTH`).
pub const MAX_LENGTH: f64 = 1e6;
/// Upper bound for segment, ring and side counts (2048² quads is already 8M triangles).
pub const MAX_SEGMENTS: u32 = 2048;
/// A feature (cavity, minor radius, wall) must be at least this fraction of the shape's size so
/// that its f32 vertices stay distinct and its triangles non-degenerate.
pub const MIN_FEATURE_FRACTION: f64 = 1e-3;

/// Bottle proportions (see `bottle`): body, shoulder and neck heights as fractions of `height`.
pub const BOTTLE_BODY_FRACTION: f64 = 0.6;
/// Shoulder (the cone from body to neck) height as a fraction of `height`; the neck takes the rest.
pub const BOTTLE_SHOULDER_FRACTION: f64 = 0.2;
/// Outer neck radius as a fraction of `radius`.
pub const BOTTLE_NECK_RADIUS_FRACTION: f64 = 0.6;
/// Gap between the liquid and the inner glass wall, as a fraction of `wall` (≥ 1 % so the two
/// surfaces never coincide in f32).
pub const BOTTLE_LIQUID_GAP_FRACTION: f64 = 0.02;

/// Square of edge `size` in the xz-plane centred at the origin, normal +y; two triangles, open.
pub fn plane(size: f64) -> Result<Mesh, MeshError> {
    let h = check_length("plane", "size", size)? / 2.0;
    let mut b = Builder::default();
    let corners = [(-h, -h), (-h, h), (h, h), (h, -h)];
    let v = corners.map(|(x, z)| b.vertex(DVec3::new(x, 0.0, z), DVec3::Y));
    b.quad(v);
    Ok(b.mesh)
}

/// Axis-aligned cube of edge `size` centred at the origin: 24 vertices (4 per face, flat
/// normals), 12 triangles. Volume size³.
pub fn cube(size: f64) -> Result<Mesh, MeshError> {
    let h = check_length("cube", "size", size)? / 2.0;
    let mut b = Builder::default();
    add_cube(&mut b, h);
    Ok(b.mesh)
}

/// UV sphere of `radius` centred at the origin, smooth normals. `segments` (≥ 3) vertices per
/// latitude ring, `rings` (≥ 2) latitude bands between the poles; each pole is one shared vertex
/// whose fan has no degenerate triangles. All vertices lie on the sphere, so the mesh is inside it
/// and contains the ball of radius `radius·cos(π/segments)·cos(π/(2·rings))`.
pub fn uv_sphere(radius: f64, segments: u32, rings: u32) -> Result<Mesh, MeshError> {
    let r = check_length("sphere", "radius", radius)?;
    let segments = check_count("sphere", "segments", segments, 3)?;
    let rings = check_count("sphere", "rings", rings, 2)?;
    let mut b = Builder::default();
    b.revolve(&sphere_profile(r, rings), false, segments);
    Ok(b.mesh)
}

/// Torus around the y axis centred at the origin: tube centre circle of `major_radius` in the
/// xz-plane, tube radius `minor_radius` (< major, ≥ major/1000); `segments` (≥ 3) around y,
/// `sides` (≥ 3) around the tube, smooth normals. Volume of the tessellation exactly
/// segments·sin(2π/segments) · (sides/2)·minor²·sin(2π/sides) · major (→ 2π²·major·minor²).
pub fn torus(major_radius: f64, minor_radius: f64, segments: u32, sides: u32) -> Result<Mesh, MeshError> {
    let major = check_length("torus", "major_radius", major_radius)?;
    let minor = check_length("torus", "minor_radius", minor_radius)?;
    if minor >= major {
        return Err(invalid("torus", "minor_radius", &format!("< major_radius (= {major})"), minor));
    }
    if minor < major * MIN_FEATURE_FRACTION {
        let limit = major * MIN_FEATURE_FRACTION;
        return Err(invalid("torus", "minor_radius", &format!("≥ major_radius/1000 (= {limit})"), minor));
    }
    let segments = check_count("torus", "segments", segments, 3)?;
    let sides = check_count("torus", "sides", sides, 3)?;
    // The tube's cross-section walked counter-clockwise in (r, y): the solid is on the left.
    let profile: Vec<ProfilePoint> = (0..sides)
        .map(|k| {
            let (s, c) = (TAU * k as f64 / sides as f64).sin_cos();
            ProfilePoint { r: major + minor * c, y: minor * s, normal: DVec2::new(c, s) }
        })
        .collect();
    let mut b = Builder::default();
    b.revolve(&profile, true, segments);
    Ok(b.mesh)
}

/// Regular tetrahedron centred at the origin with circumradius `size` (vertices at
/// size·(±1, ±1, ±1)/√3 with an even number of minus signs; edge size·√(8/3)); flat normals,
/// 12 vertices. Volume 8·size³/(9√3).
pub fn tetrahedron(size: f64) -> Result<Mesh, MeshError> {
    let s = check_length("tetrahedron", "size", size)? / 3f64.sqrt();
    let corners = [DVec3::new(s, s, s), DVec3::new(s, -s, -s), DVec3::new(-s, s, -s), DVec3::new(-s, -s, s)];
    let mut b = Builder::default();
    for opposite in 0..4 {
        let mut face: Vec<DVec3> = (0..4).filter(|&k| k != opposite).map(|k| corners[k]).collect();
        // Order the face counter-clockwise seen from outside (away from the opposite corner).
        let outward = -corners[opposite];
        if (face[1] - face[0]).cross(face[2] - face[0]).dot(outward) < 0.0 {
            face.swap(1, 2);
        }
        let n = outward.normalize();
        let v = [0, 1, 2].map(|k| b.vertex(face[k], n));
        b.triangle(v[0], v[1], v[2]);
    }
    Ok(b.mesh)
}

/// Cube of edge `size` centred at the origin (as `cube`) with a spherical cavity of
/// `cavity_radius` (< size/2, ≥ size/1000) at the centre: the cavity is a UV sphere (as
/// `uv_sphere`) whose faces and normals point inward, toward the centre, so the solid is the
/// space between the two shells. Volume size³ minus the tessellated sphere's volume.
pub fn cavity_cube(size: f64, cavity_radius: f64, segments: u32, rings: u32) -> Result<Mesh, MeshError> {
    let size = check_length("cavity_cube", "size", size)?;
    let r = check_length("cavity_cube", "cavity_radius", cavity_radius)?;
    if r >= size / 2.0 {
        return Err(invalid("cavity_cube", "cavity_radius", &format!("< size/2 (= {})", size / 2.0), r));
    }
    if r < size * MIN_FEATURE_FRACTION {
        let limit = size * MIN_FEATURE_FRACTION;
        return Err(invalid("cavity_cube", "cavity_radius", &format!("≥ size/1000 (= {limit})"), r));
    }
    let segments = check_count("cavity_cube", "segments", segments, 3)?;
    let rings = check_count("cavity_cube", "rings", rings, 2)?;
    let mut b = Builder::default();
    add_cube(&mut b, size / 2.0);
    // Walking the sphere profile from the north pole down puts the solid on the left (outside
    // the sphere), which flips the faces inward; the normals follow.
    let inward: Vec<ProfilePoint> =
        sphere_profile(r, rings).iter().rev().map(|p| ProfilePoint { normal: -p.normal, ..*p }).collect();
    b.revolve(&inward, false, segments);
    Ok(b.mesh)
}

/// Ball of `radius` (a UV sphere as `uv_sphere`) with two spherical cavities of `cavity_radius`
/// (< radius/4, ≥ radius/1000) centred at (0, ±radius/2, 0): inward-facing UV spheres as in
/// `cavity_cube`, so a light path along y crosses both cavities (six crossings). The cavities stay
/// a quarter radius from the outer shell and from each other. Volume: the outer tessellated sphere
/// minus the two inner ones.
pub fn hollow_ball(radius: f64, cavity_radius: f64, segments: u32, rings: u32) -> Result<Mesh, MeshError> {
    let big = check_length("hollow_ball", "radius", radius)?;
    let r = check_length("hollow_ball", "cavity_radius", cavity_radius)?;
    if r >= big / 4.0 {
        return Err(invalid("hollow_ball", "cavity_radius", &format!("< radius/4 (= {})", big / 4.0), r));
    }
    if r < big * MIN_FEATURE_FRACTION {
        let limit = big * MIN_FEATURE_FRACTION;
        return Err(invalid("hollow_ball", "cavity_radius", &format!("≥ radius/1000 (= {limit})"), r));
    }
    let segments = check_count("hollow_ball", "segments", segments, 3)?;
    let rings = check_count("hollow_ball", "rings", rings, 2)?;
    let cavity = |y: f64| (DVec3::new(0.0, y, 0.0), r);
    ball_with_cavities(big, &[cavity(-0.5 * big), cavity(0.5 * big)], segments, rings)
}

/// A ball of `radius` at the origin with spherical cavities (centre, radius) inside it, faces of
/// the cavities pointing inward (as `cavity_cube`): the tests' hollow shape with several cavities.
/// Each cavity must lie inside the ball, apart from the others, by at least radius/1000.
pub fn ball_with_cavities(
    radius: f64,
    cavities: &[(DVec3, f64)],
    segments: u32,
    rings: u32,
) -> Result<Mesh, MeshError> {
    let r = check_length("ball_with_cavities", "radius", radius)?;
    let segments = check_count("ball_with_cavities", "segments", segments, 3)?;
    let rings = check_count("ball_with_cavities", "rings", rings, 2)?;
    let gap = r * MIN_FEATURE_FRACTION;
    for (k, &(c, cr)) in cavities.iter().enumerate() {
        check_length("ball_with_cavities", "cavity radius", cr)?;
        if !c.is_finite() || c.length() + cr > r - gap {
            return Err(invalid(
                "ball_with_cavities",
                "cavity",
                "inside the ball",
                format!("{k}: {c} r {cr}"),
            ));
        }
        for &(d, dr) in &cavities[..k] {
            if c.distance(d) < cr + dr + gap {
                return Err(invalid(
                    "ball_with_cavities",
                    "cavity",
                    "apart from the others",
                    format!("{k}: {c} r {cr}"),
                ));
            }
        }
    }
    let mut b = Builder::default();
    b.revolve(&sphere_profile(r, rings), false, segments);
    for &(c, cr) in cavities {
        // Reversed and shifted along the axis in the profile (exact in f64), then beside it: faces
        // and normals point into the cavity.
        let first = b.mesh.positions.len();
        let inward: Vec<ProfilePoint> = sphere_profile(cr, rings)
            .iter()
            .rev()
            .map(|p| ProfilePoint { y: p.y + c.y, normal: -p.normal, ..*p })
            .collect();
        b.revolve(&inward, false, segments);
        let beside = DVec3::new(c.x, 0.0, c.z);
        if beside != DVec3::ZERO {
            for p in &mut b.mesh.positions[first..] {
                *p = (DVec3::from_array(p.map(f64::from)) + beside).as_vec3().to_array();
            }
        }
    }
    Ok(b.mesh)
}

/// A box of half extents `half` at the origin with a box cavity of half extents `cavity_half`
/// centred at `offset` (faces pointing inward), at least size/1000 from the outer faces.
pub fn box_with_box_cavity(half: DVec3, cavity_half: DVec3, offset: DVec3) -> Result<Mesh, MeshError> {
    for (field, v) in [("half", half), ("cavity_half", cavity_half)] {
        for c in v.to_array() {
            check_length("box_with_box_cavity", field, c)?;
        }
    }
    let gap = half.max_element() * MIN_FEATURE_FRACTION;
    let inside = (offset.abs() + cavity_half).cmplt(half - gap).all();
    if !offset.is_finite() || !inside {
        return Err(invalid(
            "box_with_box_cavity",
            "cavity_half",
            "inside the box",
            format!("{cavity_half} at {offset}"),
        ));
    }
    let mut b = Builder::default();
    add_box(&mut b, DVec3::ZERO, half, false);
    add_box(&mut b, offset, cavity_half, true);
    Ok(b.mesh)
}

/// A U of `width` × `height` with arms and base `thickness` thick, extruded `depth` along z,
/// centred at the origin (opening toward +y): two inner concave corners. Flat normals.
pub fn u_shape(width: f64, height: f64, depth: f64, thickness: f64) -> Result<Mesh, MeshError> {
    let (w, h) = (check_length("u_shape", "width", width)?, check_length("u_shape", "height", height)?);
    let (d, t) = (check_length("u_shape", "depth", depth)?, check_length("u_shape", "thickness", thickness)?);
    if 2.0 * t >= w || t >= h {
        return Err(invalid("u_shape", "thickness", "< width/2 and < height", t));
    }
    let o = DVec2::new(w, h) / 2.0;
    // Counter-clockwise outline in the xy-plane.
    let outline = [[0.0, 0.0], [w, 0.0], [w, h], [w - t, h], [w - t, t], [t, t], [t, h], [0.0, h]]
        .map(|[x, y]| DVec2::new(x, y) - o);
    let mut b = Builder::default();
    // Caps: the base and two arms, each a quad of outline corners (no T-junctions).
    let quads = [[0, 1, 4, 5], [0, 5, 6, 7], [1, 2, 3, 4]];
    for (z, n) in [(d / 2.0, DVec3::Z), (-d / 2.0, DVec3::NEG_Z)] {
        for q in quads {
            let mut idx = q.map(|k| b.vertex(outline[k].extend(z), n));
            if n.z < 0.0 {
                idx.reverse();
            }
            b.quad(idx);
        }
    }
    for k in 0..outline.len() {
        let (p, q) = (outline[k], outline[(k + 1) % outline.len()]);
        let n = DVec3::new(q.y - p.y, p.x - q.x, 0.0).normalize();
        let corners = [p.extend(-d / 2.0), q.extend(-d / 2.0), q.extend(d / 2.0), p.extend(d / 2.0)];
        let idx = corners.map(|c| b.vertex(c, n));
        b.quad(idx);
    }
    Ok(b.mesh)
}

/// The bottle's profile in the (r, y) half-plane, polylines from the axis upward.
#[derive(Clone, Debug, PartialEq)]
pub struct BottleProfile {
    /// Outer glass surface: bottom centre, bottom corner, shoulder start, neck base, rim.
    pub outer: Vec<[f64; 2]>,
    /// Inner glass surface: `outer` offset inward by `wall` (mitred corners).
    pub inner: Vec<[f64; 2]>,
    /// Liquid surface, closed back to the axis at the liquid level; `None` when fill = 0.
    pub liquid: Option<Vec<[f64; 2]>>,
}

/// The exact dimensions `bottle` revolves. With R = radius, H = height, w = wall, y₀ = −H/2:
/// - outer: (0, y₀) → (R, y₀) → (R, y₀+0.6H) → shoulder cone → (0.6R, y₀+0.8H) → neck → (0.6R, H/2);
/// - inner: the outer offset inward by w, perpendicular to each segment (bottom at y₀+w, body
///   radius R−w, neck radius 0.6R−w; the inner shoulder is the outer one shifted down by
///   w·(L−b)/a with a = 0.4R, b = 0.2H, L = √(a²+b²)), open at the top where the flat rim
///   annulus (r from 0.6R−w to 0.6R at y = H/2) joins the two walls;
/// - liquid: the inner surface offset inward by the gap g = 0.02·w, filled from its bottom
///   y₀+w+g up to the level y₀+w+g + max(g, fill·((H/2−g) − (y₀+w+g))), i.e. `fill` is the
///   fraction of the cavity's height (fill = 1 stops g below the rim; any fill > 0 is at least g
///   deep). A wall corner closer than g/4 below the level is dropped from the liquid outline so
///   no band is thinner than f32 can hold (the liquid then stays ≥ 0.75·g from the glass).
pub fn bottle_profile(radius: f64, height: f64, wall: f64, fill: f64) -> Result<BottleProfile, MeshError> {
    let (r, h, w, fill) = check_bottle(radius, height, wall, fill)?;
    let y0 = -h / 2.0;
    let neck = BOTTLE_NECK_RADIUS_FRACTION * r;
    let outer = vec![
        [0.0, y0],
        [r, y0],
        [r, y0 + BOTTLE_BODY_FRACTION * h],
        [neck, y0 + (BOTTLE_BODY_FRACTION + BOTTLE_SHOULDER_FRACTION) * h],
        [neck, h / 2.0],
    ];
    let inner = offset_left(&outer, w);
    let gap = BOTTLE_LIQUID_GAP_FRACTION * w;
    let liquid = (fill > 0.0).then(|| {
        let side = offset_left(&inner, gap);
        let bottom = side[0][1];
        // At least one gap deep, so a tiny fill still has distinct f32 top and bottom.
        let depth = (fill * (h / 2.0 - gap - bottom)).max(gap);
        cut_at_level(&side, bottom + depth, gap / 4.0)
    });
    Ok(BottleProfile { outer, inner, liquid })
}

/// Bottle standing on the xz-plane's y = −height/2, axis +y, as two closed solids: the glass
/// (outer wall, inner wall, bottom, open neck with a flat rim) and, when `fill` > 0, the liquid
/// inside it. Dimensions in `bottle_profile`. Limits: wall < radius/2, wall < height/4, wall ≥
/// max(radius, height)/1000, fill in [0, 1], segments ≥ 3. Each profile segment is its own band
/// of vertices (creased edges), normals revolve smoothly around the axis.
pub fn bottle_parts(
    radius: f64,
    height: f64,
    wall: f64,
    fill: f64,
    segments: u32,
) -> Result<(Mesh, Option<Mesh>), MeshError> {
    let p = bottle_profile(radius, height, wall, fill)?;
    let segments = check_count("bottle", "segments", segments, 3)?;
    // Up the outside, across the rim, down the inside: the glass stays on the left.
    let glass_outline: Vec<[f64; 2]> = p.outer.iter().chain(p.inner.iter().rev()).copied().collect();
    let mut glass = Builder::default();
    glass.revolve_creased(&glass_outline, segments);
    let liquid = p.liquid.map(|outline| {
        let mut b = Builder::default();
        b.revolve_creased(&outline, segments);
        b.mesh
    });
    Ok((glass.mesh, liquid))
}

/// `bottle_parts` merged into one mesh: the glass's triangles first, then the liquid's.
pub fn bottle(radius: f64, height: f64, wall: f64, fill: f64, segments: u32) -> Result<Mesh, MeshError> {
    let (mut glass, liquid) = bottle_parts(radius, height, wall, fill, segments)?;
    if let Some(l) = liquid {
        let base = glass.positions.len() as u32;
        glass.positions.extend(l.positions);
        glass.normals.extend(l.normals);
        glass.indices.extend(l.indices.iter().map(|i| i + base));
    }
    Ok(glass)
}

fn check_bottle(radius: f64, height: f64, wall: f64, fill: f64) -> Result<(f64, f64, f64, f64), MeshError> {
    let r = check_length("bottle", "radius", radius)?;
    let h = check_length("bottle", "height", height)?;
    let w = check_length("bottle", "wall", wall)?;
    if w >= r / 2.0 {
        return Err(invalid("bottle", "wall", &format!("< radius/2 (= {})", r / 2.0), w));
    }
    if w >= h / 4.0 {
        return Err(invalid("bottle", "wall", &format!("< height/4 (= {})", h / 4.0), w));
    }
    let min_wall = r.max(h) * MIN_FEATURE_FRACTION;
    if w < min_wall {
        return Err(invalid("bottle", "wall", &format!("≥ max(radius, height)/1000 (= {min_wall})"), w));
    }
    if !(0.0..=1.0).contains(&fill) {
        return Err(invalid("bottle", "fill", "in [0, 1]", fill));
    }
    Ok((r, h, w, fill))
}

/// The polyline offset by `d` to its left (walking direction), corners mitred. The first and last
/// points move along their segment's normal, so an end on the axis of a horizontal segment stays
/// on the axis and a vertical last segment keeps its end height.
fn offset_left(poly: &[[f64; 2]], d: f64) -> Vec<[f64; 2]> {
    let pts: Vec<DVec2> = poly.iter().map(|&p| DVec2::from(p)).collect();
    let normals: Vec<DVec2> = pts.windows(2).map(|s| (s[1] - s[0]).normalize().perp()).collect();
    let mut out = Vec::with_capacity(pts.len());
    for (i, &p) in pts.iter().enumerate() {
        let n = match (i.checked_sub(1).and_then(|k| normals.get(k)), normals.get(i)) {
            // Miter: the point at distance d from both offset lines.
            (Some(&a), Some(&b)) => (a + b) / (1.0 + a.dot(b)),
            (Some(&a), None) | (None, Some(&a)) => a,
            (None, None) => DVec2::ZERO,
        };
        let q = p + n * d;
        // Keep axis points exactly on the axis (0 + d·(−0) must not become −0 or noise).
        out.push([if p.x == 0.0 && n.x.abs() < 1e-15 { 0.0 } else { q.x }, q.y]);
    }
    out
}

/// The part of an upward polyline below `level`, closed back to the axis along the level. A
/// corner closer than `min_spacing` to the cut point is dropped (the band between them would
/// collapse in f32).
fn cut_at_level(poly: &[[f64; 2]], level: f64, min_spacing: f64) -> Vec<[f64; 2]> {
    let mut out = vec![poly[0]];
    for s in poly.windows(2) {
        let (p, q) = (s[0], s[1]);
        if q[1] < level {
            out.push(q);
            continue;
        }
        let t = (level - p[1]) / (q[1] - p[1]);
        let cut = [p[0] + t * (q[0] - p[0]), level];
        if out.len() > 1 && (DVec2::from(cut) - DVec2::from(p)).length() < min_spacing {
            out.pop();
        }
        out.push(cut);
        break;
    }
    out.push([0.0, level]);
    out
}

fn sphere_profile(r: f64, rings: u32) -> Vec<ProfilePoint> {
    (0..=rings)
        .map(|i| {
            let phi = PI * i as f64 / rings as f64;
            let (s, c) = phi.sin_cos();
            // Poles exactly on the axis: sin(π) is not 0 in floating point.
            let s = if i == 0 || i == rings { 0.0 } else { s };
            let c = if i == 0 {
                1.0
            } else if i == rings {
                -1.0
            } else {
                c
            };
            ProfilePoint { r: r * s, y: -r * c, normal: DVec2::new(s, -c) }
        })
        .collect()
}

fn add_cube(b: &mut Builder, h: f64) {
    add_box(b, DVec3::ZERO, DVec3::splat(h), false);
}

/// A box at `centre` with half extents `half`; `inward`: faces and normals toward its centre.
fn add_box(b: &mut Builder, centre: DVec3, half: DVec3, inward: bool) {
    // (normal, u, v) with u × v = normal, so corners n + (±u ±v) in this order are CCW.
    let faces = [
        (DVec3::X, DVec3::Y, DVec3::Z),
        (DVec3::NEG_X, DVec3::Z, DVec3::Y),
        (DVec3::Y, DVec3::Z, DVec3::X),
        (DVec3::NEG_Y, DVec3::X, DVec3::Z),
        (DVec3::Z, DVec3::X, DVec3::Y),
        (DVec3::NEG_Z, DVec3::Y, DVec3::X),
    ];
    for (n, u, v) in faces {
        let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
        let normal = if inward { -n } else { n };
        let mut idx = corners.map(|(a, c)| b.vertex(centre + (n + u * a + v * c) * half, normal));
        if inward {
            idx.reverse();
        }
        b.quad(idx);
    }
}

/// A profile point in the (r, y) half-plane with its outward normal (n_r, n_y).
#[derive(Clone, Copy, Debug)]
struct ProfilePoint {
    r: f64,
    y: f64,
    normal: DVec2,
}

#[derive(Default)]
struct Builder {
    mesh: Mesh,
}

impl Builder {
    fn vertex(&mut self, p: DVec3, n: DVec3) -> u32 {
        let i = self.mesh.positions.len() as u32;
        self.mesh.positions.push(p.as_vec3().to_array());
        self.mesh.normals.push(n.normalize().as_vec3().to_array());
        i
    }

    fn triangle(&mut self, a: u32, b: u32, c: u32) {
        self.mesh.indices.extend([a, b, c]);
    }

    /// Corners in counter-clockwise order.
    fn quad(&mut self, [a, b, c, d]: [u32; 4]) {
        self.triangle(a, b, c);
        self.triangle(a, c, d);
    }

    /// Revolves a profile with the solid on the left of its walking direction; `closed` joins the
    /// last point back to the first. Faces come out counter-clockwise seen from outside because
    /// (profile tangent) × (∂/∂θ) is the outward normal for this θ direction.
    fn revolve(&mut self, profile: &[ProfilePoint], closed: bool, segments: u32) {
        let rings: Vec<Ring> = profile.iter().map(|p| self.ring(p, segments)).collect();
        let bands = if closed { rings.len() } else { rings.len().saturating_sub(1) };
        for i in 0..bands {
            self.band(&rings[i], &rings[(i + 1) % rings.len()], segments);
        }
    }

    /// Revolves a polyline with a crease at every corner: each segment is its own band with the
    /// segment's normal, so the bottle's corners stay sharp.
    fn revolve_creased(&mut self, outline: &[[f64; 2]], segments: u32) {
        for s in outline.windows(2) {
            let (p, q) = (DVec2::from(s[0]), DVec2::from(s[1]));
            // The right-hand normal of the walking direction points out of the solid.
            let normal = -(q - p).normalize().perp();
            let ends = [p, q].map(|e| ProfilePoint { r: e.x, y: e.y, normal });
            self.revolve(&ends, false, segments);
        }
    }

    fn ring(&mut self, p: &ProfilePoint, segments: u32) -> Ring {
        if p.r == 0.0 {
            let n = DVec3::new(0.0, p.normal.y.signum(), 0.0);
            return Ring::Pole(self.vertex(DVec3::new(0.0, p.y, 0.0), n));
        }
        let first = self.mesh.positions.len() as u32;
        for j in 0..segments {
            let (s, c) = (TAU * j as f64 / segments as f64).sin_cos();
            let pos = DVec3::new(p.r * c, p.y, p.r * s);
            let n = DVec3::new(p.normal.x * c, p.normal.y, p.normal.x * s);
            self.vertex(pos, n);
        }
        Ring::Circle(first)
    }

    fn band(&mut self, a: &Ring, b: &Ring, segments: u32) {
        for j in 0..segments {
            let k = (j + 1) % segments;
            match (*a, *b) {
                (Ring::Circle(a), Ring::Circle(b)) => self.quad([a + j, b + j, b + k, a + k]),
                (Ring::Pole(p), Ring::Circle(b)) => self.triangle(p, b + j, b + k),
                (Ring::Circle(a), Ring::Pole(p)) => self.triangle(a + j, p, a + k),
                // Two poles in a row would be a zero-width band: nothing to draw.
                (Ring::Pole(_), Ring::Pole(_)) => {}
            }
        }
    }
}

/// A revolved profile point: one pole vertex or `segments` consecutive vertices from this index.
#[derive(Clone, Copy, Debug)]
enum Ring {
    Pole(u32),
    Circle(u32),
}

fn invalid(kind: &str, field: &str, expected: &str, got: impl Display) -> MeshError {
    MeshError::Invalid(format!("{kind} {field} must be {expected}, got {got}"))
}

fn check_length(kind: &str, field: &str, v: f64) -> Result<f64, MeshError> {
    if (MIN_LENGTH..=MAX_LENGTH).contains(&v) {
        Ok(v)
    } else {
        Err(invalid(kind, field, &format!("a finite length in [{MIN_LENGTH:e}, {MAX_LENGTH:e}]"), v))
    }
}

fn check_count(kind: &str, field: &str, v: u32, min: u32) -> Result<u32, MeshError> {
    if (min..=MAX_SEGMENTS).contains(&v) {
        Ok(v)
    } else {
        Err(invalid(kind, field, &format!("between {min} and {MAX_SEGMENTS}"), v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed, oriented, no degenerate triangles, unit normals, and every vertex normal on the
    /// same side as the triangle's CCW normal.
    fn check_solid(m: &Mesh) {
        m.validate_basic().unwrap();
        m.check_closed_oriented().unwrap();
        assert!(m.degenerate_triangles().is_empty(), "{:?}", m.degenerate_triangles());
        check_normals_agree(m);
    }

    fn check_normals_agree(m: &Mesh) {
        for t in 0..m.triangle_count() {
            let [a, b, c] = m.triangle(t);
            let n = (m.position(b) - m.position(a)).cross(m.position(c) - m.position(a)).normalize();
            for v in [a, b, c] {
                let vn = DVec3::from(m.normals[v].map(f64::from));
                assert!(vn.dot(n) > 0.0, "triangle {t} vertex {v}: {vn} vs {n}");
            }
        }
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// The tests' hollow shapes: closed, oriented, with the volumes of their parts.
    #[test]
    fn hollow_shapes_are_solids_with_their_volumes() {
        let cavities = [(DVec3::new(0.4, 0.0, 0.0), 0.3), (DVec3::new(-0.35, 0.3, 0.1), 0.25)];
        let ball = ball_with_cavities(1.0, &cavities, 64, 32).unwrap();
        check_solid(&ball);
        let sphere = |r: f64| 4.0 / 3.0 * PI * r * r * r;
        let want = sphere(1.0) - sphere(0.3) - sphere(0.25);
        assert!(rel(ball.signed_volume(), want) < 0.01, "{} vs {want}", ball.signed_volume());
        let offset = DVec3::new(0.1, 0.05, 0.0);
        let boxed =
            box_with_box_cavity(DVec3::new(1.0, 0.8, 0.6), DVec3::new(0.5, 0.4, 0.3), offset).unwrap();
        check_solid(&boxed);
        assert!(rel(boxed.signed_volume(), 8.0 * (0.48 - 0.06)) < 1e-6);
        let u = u_shape(2.0, 1.6, 1.0, 0.5).unwrap();
        check_solid(&u);
        assert!(rel(u.signed_volume(), 2.0 * 0.5 + 2.0 * 1.1 * 0.5) < 1e-6);
        assert!(ball_with_cavities(1.0, &[(DVec3::new(0.9, 0.0, 0.0), 0.2)], 16, 8).is_err());
        assert!(ball_with_cavities(1.0, &[(DVec3::ZERO, 0.3), (DVec3::X * 0.5, 0.3)], 16, 8).is_err());
        assert!(box_with_box_cavity(DVec3::ONE, DVec3::splat(0.5), DVec3::X * 0.6).is_err());
        assert!(u_shape(1.0, 1.0, 1.0, 0.5).is_err());
    }

    /// Volume of the revolution of a tessellated profile: segments·sin(2π/segments)·∫∫ r dA
    /// (each wedge maps the profile linearly onto a chord), vs 2π·∫∫ r dA for the smooth solid.
    fn polygon_factor(segments: u32) -> f64 {
        let n = segments as f64;
        n * (TAU / n).sin() / TAU
    }

    #[test]
    fn plane_is_two_upward_triangles() {
        let m = plane(2.0).unwrap();
        m.validate_basic().unwrap();
        assert_eq!(m.triangle_count(), 2);
        check_normals_agree(&m);
        assert_eq!(m.bounds(), (DVec3::new(-1.0, 0.0, -1.0), DVec3::new(1.0, 0.0, 1.0)));
        assert!(m.check_closed_oriented().is_err());
    }

    #[test]
    fn cube_volume_is_exact() {
        let m = cube(2.0).unwrap();
        check_solid(&m);
        assert_eq!((m.positions.len(), m.triangle_count()), (24, 12));
        assert_eq!(m.signed_volume(), 8.0);
        // A size that f32 rounds: only the rounding of h remains.
        let m = cube(0.3).unwrap();
        assert!(rel(m.signed_volume(), 0.027) < 4e-7);
    }

    #[test]
    fn sphere_volume_within_inscribed_bounds() {
        for (seg, rings) in [(3, 2), (8, 4), (32, 16), (64, 31)] {
            let r = 1.5;
            let m = uv_sphere(r, seg, rings).unwrap();
            check_solid(&m);
            assert_eq!(m.positions.len() as u32, seg * (rings - 1) + 2);
            let ball = 4.0 / 3.0 * PI * r.powi(3);
            let inner = (PI / seg as f64).cos() * (PI / (2.0 * rings as f64)).cos();
            let v = m.signed_volume();
            assert!(
                v <= ball * (1.0 + 1e-6) && v >= ball * inner.powi(3) * (1.0 - 1e-6),
                "{seg}x{rings}: {v}"
            );
            for (p, n) in m.positions.iter().zip(&m.normals) {
                let p = DVec3::from(p.map(f64::from));
                assert!((p.length() - r).abs() < 1e-6);
                assert!(p.normalize().dot(DVec3::from(n.map(f64::from))) > 1.0 - 1e-6);
            }
        }
    }

    #[test]
    fn torus_volume_matches_polygonal_pappus() {
        let (major, minor, seg, sides) = (2.0, 0.5, 48, 24);
        let m = torus(major, minor, seg, sides).unwrap();
        check_solid(&m);
        let section = sides as f64 / 2.0 * minor * minor * (TAU / sides as f64).sin();
        let expect = TAU * polygon_factor(seg) * section * major;
        assert!(rel(m.signed_volume(), expect) < 1e-6, "{} vs {expect}", m.signed_volume());
        // And close to the smooth torus.
        assert!(rel(m.signed_volume(), 2.0 * PI * PI * major * minor * minor) < 0.02);
    }

    #[test]
    fn tetrahedron_is_regular() {
        let size = 1.25;
        let m = tetrahedron(size).unwrap();
        check_solid(&m);
        let expect = 8.0 * size.powi(3) / (9.0 * 3f64.sqrt());
        assert!(rel(m.signed_volume(), expect) < 1e-6);
        for p in &m.positions {
            assert!((DVec3::from(p.map(f64::from)).length() - size).abs() < 1e-6);
        }
    }

    #[test]
    fn cavity_cube_is_cube_minus_sphere() {
        let (size, r, seg, rings) = (2.0, 0.6, 24, 12);
        let m = cavity_cube(size, r, seg, rings).unwrap();
        check_solid(&m);
        let sphere = uv_sphere(r, seg, rings).unwrap();
        assert!(rel(m.signed_volume(), size.powi(3) - sphere.signed_volume()) < 1e-9);
        // The shell's normals point toward the centre.
        for (p, n) in m.positions.iter().zip(&m.normals).skip(24) {
            let p = DVec3::from(p.map(f64::from));
            assert!(p.normalize().dot(DVec3::from(n.map(f64::from))) < -1.0 + 1e-6);
        }
    }

    /// Frustum volume π·h·(r₀² + r₀r₁ + r₁²)/3 (a cylinder when r₀ = r₁).
    fn frustum(r0: f64, r1: f64, h: f64) -> f64 {
        PI * h * (r0 * r0 + r0 * r1 + r1 * r1) / 3.0
    }

    #[test]
    fn bottle_glass_volume_matches_documented_dimensions() {
        let (r, h, w, seg) = (0.5, 1.6, 0.04, 40);
        let (glass, liquid) = bottle_parts(r, h, w, 0.5, seg).unwrap();
        check_solid(&glass);
        let liquid = liquid.unwrap();
        check_solid(&liquid);
        // Recompute the documented dimensions independently of the generator.
        let (body, shoulder, neck_h) = (0.6 * h, 0.2 * h, 0.2 * h);
        let neck = 0.6 * r;
        let (a, b) = (r - neck, shoulder);
        let drop = w * ((a * a + b * b).sqrt() - b) / a;
        let outer = frustum(r, r, body) + frustum(r, neck, shoulder) + frustum(neck, neck, neck_h);
        let cavity = frustum(r - w, r - w, body - w - drop)
            + frustum(r - w, neck - w, shoulder)
            + frustum(neck - w, neck - w, neck_h + drop);
        let expect = polygon_factor(seg) * (outer - cavity);
        assert!(rel(glass.signed_volume(), expect) < 1e-5, "{} vs {expect}", glass.signed_volume());
        // Half-filled: the level is in the body, so the liquid is a cylinder of radius R−w−g.
        let g = 0.02 * w;
        let bottom = -h / 2.0 + w + g;
        let level = bottom + 0.5 * (h / 2.0 - g - bottom);
        assert!(level < -h / 2.0 + body - drop);
        let expect = polygon_factor(seg) * frustum(r - w - g, r - w - g, level - bottom);
        assert!(rel(liquid.signed_volume(), expect) < 1e-5);
        let merged = bottle(r, h, w, 0.5, seg).unwrap();
        check_solid(&merged);
        assert_eq!(merged.triangle_count(), glass.triangle_count() + liquid.triangle_count());
    }

    /// Distance from p to triangle abc (Ericson, Real-Time Collision Detection 5.1.5).
    fn point_triangle_distance(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
        let (ab, ac, ap) = (b - a, c - a, p - a);
        let (d1, d2) = (ab.dot(ap), ac.dot(ap));
        if d1 <= 0.0 && d2 <= 0.0 {
            return ap.length();
        }
        let bp = p - b;
        let (d3, d4) = (ab.dot(bp), ac.dot(bp));
        if d3 >= 0.0 && d4 <= d3 {
            return bp.length();
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            return (p - (a + ab * (d1 / (d1 - d3)))).length();
        }
        let cp = p - c;
        let (d5, d6) = (ab.dot(cp), ac.dot(cp));
        if d6 >= 0.0 && d5 <= d6 {
            return cp.length();
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            return (p - (a + ac * (d2 / (d2 - d6)))).length();
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
            return (p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))))).length();
        }
        let denom = 1.0 / (va + vb + vc);
        (p - (a + ab * (vb * denom) + ac * (vc * denom))).length()
    }

    #[test]
    fn bottle_liquid_never_touches_the_glass() {
        let (r, h, w, seg) = (0.5, 1.6, 0.05, 16);
        for fill in [0.3, 0.7, 0.85, 1.0] {
            let (glass, liquid) = bottle_parts(r, h, w, fill, seg).unwrap();
            let liquid = liquid.unwrap();
            check_solid(&liquid);
            let gap = 0.02 * w;
            for p in 0..liquid.positions.len() {
                let p = liquid.position(p);
                let d = (0..glass.triangle_count())
                    .map(|t| {
                        let [a, b, c] = glass.triangle(t).map(|v| glass.position(v));
                        point_triangle_distance(p, a, b, c)
                    })
                    .fold(f64::INFINITY, f64::min);
                // Chords of the same angles keep g·cos(π/segments) apart.
                assert!(d >= 0.9 * gap * (PI / seg as f64).cos(), "fill {fill}: {p} at {d}");
            }
        }
        assert!(bottle_parts(r, h, w, 0.0, seg).unwrap().1.is_none());
    }

    /// Fills that put the level on, just above and just below each wall corner, and tiny ones.
    #[test]
    fn bottle_liquid_is_closed_for_awkward_levels() {
        let (r, h, w) = (0.5, 1.6, 0.05);
        let p = bottle_profile(r, h, w, 1.0).unwrap();
        let side = offset_left(&p.inner, 0.02 * w);
        let (bottom, top) = (side[0][1], h / 2.0 - 0.02 * w);
        let mut fills = vec![1e-12, 1e-6, 1e-3, 1.0];
        for corner in &side[1..] {
            let f = (corner[1] - bottom) / (top - bottom);
            fills.extend([f, f * (1.0 + 1e-12), f * (1.0 - 1e-12), f + 1e-7, f - 1e-7]);
        }
        for fill in fills.into_iter().filter(|&f| f > 0.0 && f <= 1.0) {
            let (glass, liquid) = bottle_parts(r, h, w, fill, 12).unwrap();
            check_solid(&glass);
            check_solid(&liquid.unwrap());
        }
    }

    #[test]
    fn bottle_profile_is_documented() {
        let p = bottle_profile(1.0, 2.0, 0.1, 1.0).unwrap();
        let expect = [[0.0, -1.0], [1.0, -1.0], [1.0, 0.2], [0.6, 0.6], [0.6, 1.0]];
        for (a, b) in p.outer.iter().zip(expect) {
            assert!((DVec2::from(*a) - DVec2::from(b)).length() < 1e-15, "{a:?} vs {b:?}");
        }
        assert_eq!(p.inner[0], [0.0, -0.9]);
        assert!((p.inner[4][0] - 0.5).abs() < 1e-15 && p.inner[4][1] == 1.0);
        let liquid = p.liquid.unwrap();
        let top = liquid.last().unwrap();
        assert!(top[0] == 0.0 && (top[1] - (1.0 - 0.002)).abs() < 1e-15, "{top:?}");
    }

    #[test]
    fn invalid_parameters_name_kind_and_field() {
        let cases: Vec<(Result<Mesh, MeshError>, &str)> = vec![
            (plane(0.0), "plane size must be a finite length in [1e-6, 1e6], got 0"),
            (cube(f64::NAN), "cube size must be a finite length in [1e-6, 1e6], got NaN"),
            (cube(f64::INFINITY), "cube size must be"),
            (uv_sphere(1.0, 2, 4), "sphere segments must be between 3 and 2048, got 2"),
            (uv_sphere(1.0, 8, 1), "sphere rings must be between 2 and 2048, got 1"),
            (uv_sphere(-1.0, 8, 4), "sphere radius must be"),
            (torus(1.0, 1.0, 8, 8), "torus minor_radius must be < major_radius (= 1), got 1"),
            (torus(1.0, 1e-5, 8, 8), "torus minor_radius must be ≥ major_radius/1000"),
            (torus(1.0, 0.5, 8, 2), "torus sides must be between 3"),
            (tetrahedron(-2.0), "tetrahedron size must be"),
            (cavity_cube(1.0, 0.5, 8, 4), "cavity_cube cavity_radius must be < size/2 (= 0.5), got 0.5"),
            (cavity_cube(1.0, 0.3, 8, 99999), "cavity_cube rings must be between 2 and 2048, got 99999"),
            (bottle(0.5, 1.0, 0.25, 0.5, 16), "bottle wall must be < radius/2 (= 0.25), got 0.25"),
            (bottle(0.5, 0.2, 0.05, 0.5, 16), "bottle wall must be < height/4 (= 0.05), got 0.05"),
            (bottle(0.5, 1.0, 1e-4, 0.5, 16), "bottle wall must be ≥ max(radius, height)/1000"),
            (bottle(0.5, 1.0, 0.05, 1.5, 16), "bottle fill must be in [0, 1], got 1.5"),
            (bottle(0.5, 1.0, 0.05, f64::NAN, 16), "bottle fill must be in [0, 1], got NaN"),
            (bottle(0.5, 1.0, 0.05, 0.5, 2), "bottle segments must be between 3"),
        ];
        for (result, expect) in cases {
            match result {
                Err(MeshError::Invalid(msg)) => assert!(msg.starts_with(expect), "{msg:?} vs {expect:?}"),
                other => panic!("expected {expect:?}, got {other:?}"),
            }
        }
    }

    #[test]
    fn extreme_valid_parameters_stay_closed() {
        check_solid(&uv_sphere(MIN_LENGTH, 3, 2).unwrap());
        check_solid(&uv_sphere(MAX_LENGTH, 512, 256).unwrap());
        check_solid(&torus(1.0, 1.0e-3, 64, 3).unwrap());
        check_solid(&cavity_cube(1.0, 1e-3, 16, 8).unwrap());
        check_solid(&bottle(3.0, 1000.0, 1.0, 1.0, 3).unwrap());
        check_solid(&bottle(1.0, 4.0, 0.499, 1.0, 5).unwrap());
    }
}
