//! The layered-maps pass and the back-depth builders (issue 13):
//! `refl_layered_pass_options_default`, `refl_layered_pass_scratch_len`,
//! `refl_layered_pass_prepare`, `refl_layered_trace_rows`,
//! `refl_layered_trace_host_rays`, `refl_trace_back_depth_rows`,
//! `refl_trace_back_depth_layered_rows`.
//!
//! A fuzzed G-buffer (`fuzz/src/gbuffer.rs`, shared with `ssr`), zero to
//! three layered maps (cleared and filled with spheres or fuzzed crossings
//! for a local box, then placed in the world; sometimes of another stamp or
//! layout, short, NULL, misaligned or never cleared), optional object ids,
//! fuzzed options, scratch, outputs, host lists, listed rays, row bands and
//! back-face images. Checked:
//!  * the NULL and error rules (nothing written on error, inputs never
//!    written), valid input accepted and accepted input valid;
//!  * defaults are the documented values, accepted options in range;
//!  * prepare: one bounding sphere per map holding the map's world box, the
//!    scratch past the maps untouched;
//!  * trace rows: only the band's rows written; per status the fields the
//!    header promises (zeros without a hit, unit `dir` with a ray, a hit's
//!    map/face/texel/layer/payload from that map, `t` in `[t_min, t_max]`,
//!    the position in the map's box and on the pixel's ray, confidence in
//!    [0, 1]), skipped exactly where the mask or roughness says, colors from
//!    the payloads, stats equal to the texels, the host list in row-major
//!    order with its texels' statuses and the options' range; two bands give
//!    the bytes of one call; a scratch prepared for maps of another
//!    placement or order is refused; with `start_pixels == 0` a host pixel
//!    listed again through `refl_layered_trace_host_rays` gives the same
//!    texel;
//!  * trace host rays: every ray validated, outputs past `rays_len`
//!    untouched, each texel equal to the nearest hit of
//!    `refl_layered_trace_ray` over the maps in order (ids skipping the
//!    ray's own object), the host list in order with the rays' own fields,
//!    outputs overlapping the rays or each other refused;
//!  * back depth: per pixel the header's rule (back kept bit for bit at or
//!    behind the front, else the front; no front surface: the back as
//!    stored), the counts, only the band written, bands equal one call; the
//!    layered variant changes only front-surface pixels, to an exit at or
//!    behind the front and nearer than a valid back depth there, and equals
//!    the rule applied to the exits it writes over a NaN image.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refl_fuzz::*;

const SKIPPED: u32 = 0;
const NO_SURFACE: u32 = 1;
const HIT: u32 = 2;
const SKY: u32 = 3;
const LEFT_MAPS: u32 = 4;
const OUT_OF_STEPS: u32 = 5;
const STARTED_INSIDE: u32 = 6;
const NO_PROJECTION: u32 = 7;
const LAST_STATUS: u32 = 7;

// ---------------------------------------------------------------------------
// Layered maps (`fuzz/src/layered.rs`, shared with `layered.rs`).

/// A map as the pass gets it: the buffers passed, their bytes, and what
/// the target knows of it.
struct PassMap {
    m: Map,
    snap: [Vec<u8>; 4],
    /// Cleared for its grid (its stamp), every buffer valid and long
    /// enough: refl must not refuse it for its layout.
    sound: bool,
    /// Sound, with a moderate box and placement: refl must accept it.
    intact: bool,
}

/// A box of moderate numbers (extent at least 1e-2, within 1e3).
fn box_moderate(g: &refl_layered_grid) -> bool {
    let (a, c) = ([g.min.x, g.min.y, g.min.z], [g.max.x, g.max.y, g.max.z]);
    (0..3).all(|k| a[k].is_finite() && c[k].is_finite() && c[k] - a[k] >= 1e-2 && a[k].abs() < 1e3 && c[k].abs() < 1e3)
}

/// A local grid (identity placement).
fn local_grid(b: &mut Bytes) -> refl_layered_grid {
    let min = if b.chance(16) { b.vec3_in(-3.0, 3.0) } else { v3(-1.0, -1.0, -1.0) };
    let max = if b.chance(16) { b.vec3_in(-3.0, 3.0) } else { v3(1.0, b.f32_fine(0.2, 2.0), 1.0) };
    refl_layered_grid {
        min,
        max,
        face_res: match b.u8() % 16 {
            0 => 0,
            1 => b.u32(),
            _ => 1 + b.below(12),
        },
        layers: match b.u8() % 16 {
            0 => 0,
            1 => b.u32(),
            _ => 1 + b.below(4),
        },
        world_from_local: identity(),
    }
}

/// A placement and whether it is moderate (an invertible transform of
/// moderate numbers).
fn placement(b: &mut Bytes) -> (refl_mat4, bool) {
    let mut m = identity();
    let mut raw = false;
    let translate = |b: &mut Bytes, m: &mut refl_mat4| {
        m.m[12] = b.f32_in(-3.0, 3.0);
        m.m[13] = b.f32_in(-0.5, 2.5);
        m.m[14] = b.f32_in(-4.0, 1.0);
    };
    match b.u8() % 8 {
        0 => {}
        1 => {
            m.m[b.below(16) as usize] = b.f32_any();
            raw = true;
        }
        2 => {
            let a = b.f32_fine(0.0, 6.28);
            m.m[0] = a.cos();
            m.m[2] = -a.sin();
            m.m[8] = a.sin();
            m.m[10] = a.cos();
            translate(b, &mut m);
        }
        3 => {
            let s = b.f32_fine(0.3, 2.0);
            m.m[0] = s;
            m.m[5] = s;
            m.m[10] = s;
            translate(b, &mut m);
        }
        _ => translate(b, &mut m),
    }
    let moderate = !raw && m.m.iter().all(|v| v.is_finite() && v.abs() < 1e3);
    (m, moderate)
}

fn face_ray(g: &refl_layered_grid, f: u32, i: u32, j: u32) -> Option<refl_layered_column_ray> {
    let mut r = refl_layered_column_ray::default();
    // SAFETY: pointers valid.
    (unsafe { refl_layered_face_ray(&mut r, g, f, i, j) } == refl_status::Ok).then_some(r)
}

fn hits(b: &mut Bytes, t_max: f32) -> Vec<refl_layered_layer_hit> {
    let n = b.below(7) as usize;
    (0..n)
        .map(|_| refl_layered_layer_hit {
            t: if b.chance(16) { b.f32_special() } else { b.f32_fine(-0.2, t_max * 1.2) },
            id: b.u32(),
            front: b.u8() & 1 == 1,
        })
        .collect()
}

/// The crossings of a column ray with spheres `(center, radius, id)`
/// (entries and exits, clamped to the column).
fn sphere_hits(r: &refl_layered_column_ray, objs: &[([f64; 3], f64, u32)]) -> Vec<refl_layered_layer_hit> {
    let (o, d) = (d3(r.origin), d3(r.dir));
    let tm = f64::from(r.t_max);
    let mut out = Vec::new();
    for &(c, rad, id) in objs {
        let oc = [o[0] - c[0], o[1] - c[1], o[2] - c[2]];
        let bq = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
        let cq = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - rad * rad;
        let disc = bq * bq - cq;
        if !(disc > 0.0) {
            continue;
        }
        let s = disc.sqrt();
        let (t0, t1) = (-bq - s, -bq + s);
        if t1 <= 0.0 || t0 >= tm {
            continue;
        }
        out.push(refl_layered_layer_hit { t: t0.clamp(0.0, tm) as f32, id, front: true });
        out.push(refl_layered_layer_hit { t: t1.clamp(0.0, tm) as f32, id, front: false });
    }
    out
}

/// Clears and fills a map built for a local grid: every face from the
/// crossings of its columns with one or two spheres in the box, or fuzzed
/// crossings. Returns whether the clear succeeded.
fn build(b: &mut Bytes, m: &mut Map) -> bool {
    let d = m.desc_mut();
    // SAFETY: pointers valid for their lengths.
    let s = unsafe { refl_layered_clear(&d) };
    no_panic(s, "refl_layered_clear");
    if s != refl_status::Ok {
        return false;
    }
    let g = m.grid;
    let res = g.face_res;
    let (lo, hi) = (d3(g.min), d3(g.max));
    let ext = (0..3).map(|k| hi[k] - lo[k]).fold(f64::INFINITY, f64::min);
    let objs: Vec<([f64; 3], f64, u32)> = (0..1 + b.below(2))
        .map(|_| {
            let c = [0, 1, 2].map(|k| lo[k] + (hi[k] - lo[k]) * f64::from(b.f32_fine(0.2, 0.8)));
            (c, ext * f64::from(b.f32_fine(0.1, 0.6)), b.u32())
        })
        .collect();
    let fuzzed = b.chance(40);
    for face in 0..6u32 {
        if b.chance(12) {
            continue;
        }
        let mut all = Vec::new();
        let mut offsets = vec![0usize];
        for c in 0..res * res {
            if let Some(r) = face_ray(&g, face, c % res, c / res) {
                if fuzzed {
                    all.extend(hits(b, r.t_max));
                } else {
                    all.extend(sphere_hits(&r, &objs));
                }
            }
            offsets.push(all.len());
        }
        let mut hb = Buf::from_slice(&all, PtrKind::Valid);
        let ob = Buf::from_slice(&offsets, PtrKind::Valid);
        let d = m.desc_mut();
        // SAFETY: pointers valid for their lengths.
        let s = unsafe { refl_layered_fill_face(core::ptr::null_mut(), &d, face, hb.ptr(), all.len(), ob.cptr(), offsets.len()) };
        no_panic(s, "refl_layered_fill_face");
    }
    if b.chance(24) {
        let d = m.desc_mut();
        // SAFETY: pointers valid.
        no_panic(unsafe { refl_layered_build_bounds(&d) }, "refl_layered_build_bounds");
    }
    true
}

/// A fuzzed map for the pass: built for a local grid, placed, and passed
/// as is or spoiled (another stamp or layout, short, NULL, misaligned,
/// never cleared).
fn pass_map(b: &mut Bytes) -> PassMap {
    let g = local_grid(b);
    let z = sizes(g.face_res, g.layers).unwrap_or_default();
    let cap = 1usize << 15;
    let mut built = Map {
        grid: g,
        depth: Buf::sentinel(z.depth_len.min(cap), PtrKind::Valid),
        payload: Buf::sentinel(z.payload_len.min(cap), PtrKind::Valid),
        counts: Buf::sentinel(z.counts_len.min(cap), PtrKind::Valid),
        bounds: Buf::sentinel(z.bounds_len.min(cap), PtrKind::Valid),
    };
    let cleared = build(b, &mut built);
    let (place, moderate) = placement(b);
    let mut grid = g;
    grid.world_from_local = place;
    let mut kinds = [PtrKind::Valid; 4];
    let mut lens = [built.depth.len(), built.payload.len(), built.counts.len(), built.bounds.len()];
    let mut sound = cleared;
    let mut source_cleared = true;
    if b.chance(40) {
        match b.u8() % 6 {
            0 => {
                // Another box: the stamp's fingerprint differs, if the
                // box did change: at |min.x| >= 2^23 subtracting 0.25
                // rounds back to min.x (finding F36: min.x = f32::MIN).
                let old = grid.min.x;
                grid.min.x -= 0.25;
                if grid.min.x.to_bits() != old.to_bits() {
                    sound = false;
                }
            }
            1 => {
                if b.bool() {
                    grid.layers = grid.layers.wrapping_add(1);
                } else {
                    grid.face_res = grid.face_res.wrapping_sub(1);
                }
                sound = false;
            }
            2 => {
                let k = b.below(4) as usize;
                kinds[k] = b.ptr_kind();
            }
            3 => {
                let k = b.below(4) as usize;
                lens[k] = b.len_for(lens[k]);
            }
            4 => {
                source_cleared = false;
                sound = false;
            }
            _ => {
                // Another valid placement only.
            }
        }
    }
    let need = sizes(grid.face_res, grid.layers).map(|z| [z.depth_len, z.payload_len, z.counts_len, z.bounds_len]);
    sound = sound && kinds.iter().all(|k| *k == PtrKind::Valid) && need.is_some_and(|n| (0..4).all(|k| lens[k] >= n[k]));
    let copy_f = |src: &Buf<f32>, len: usize, kind: PtrKind| {
        if source_cleared {
            Buf::from_fn(len, kind, |i| if i < src.len() { src.get(i) } else { 0.0 })
        } else {
            Buf::sentinel(len, kind)
        }
    };
    let copy_u = |src: &Buf<u32>, len: usize, kind: PtrKind| {
        if source_cleared {
            Buf::from_fn(len, kind, |i| if i < src.len() { src.get(i) } else { 0 })
        } else {
            Buf::sentinel(len, kind)
        }
    };
    let m = Map {
        grid,
        depth: copy_f(&built.depth, lens[0], kinds[0]),
        payload: copy_u(&built.payload, lens[1], kinds[1]),
        counts: copy_u(&built.counts, lens[2], kinds[2]),
        bounds: copy_f(&built.bounds, lens[3], kinds[3]),
    };
    let snap = m.snap();
    let intact = sound && moderate && box_moderate(&grid) && grid_ok(&grid);
    PassMap { m, snap, sound, intact }
}

/// The world box of a map's grid (f32, as `layered.rs`).
fn world_box(g: &refl_layered_grid) -> ([f32; 3], [f32; 3]) {
    let m = &g.world_from_local.m;
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for c in 0..8 {
        let p = [
            if c & 1 == 0 { g.min.x } else { g.max.x },
            if c & 2 == 0 { g.min.y } else { g.max.y },
            if c & 4 == 0 { g.min.z } else { g.max.z },
        ];
        for a in 0..3 {
            let v = m[a] * p[0] + m[4 + a] * p[1] + m[8 + a] * p[2] + m[12 + a];
            lo[a] = lo[a].min(v);
            hi[a] = hi[a].max(v);
        }
    }
    (lo, hi)
}

fn texel_index(res: u32, face: u32, i: u32, j: u32) -> usize {
    ((face as usize * res as usize + j as usize) * res as usize) + i as usize
}

// ---------------------------------------------------------------------------
// Options.

fn options(b: &mut Bytes) -> refl_layered_pass_options {
    let mut o = refl_layered_pass_options_default();
    if b.chance(40) {
        let p = &mut o.trace;
        match b.u8() % 6 {
            0 => p.step_texels = b.pick(&[0.25, 1.0, 2.0, 8.0, 0.0, -1.0, f32::NAN, f32::INFINITY, 1e-3]),
            1 => p.max_steps = b.pick(&[0, 1, 3, 64, u32::MAX]),
            2 => p.binary_steps = b.pick(&[0, 1, 64, 65, u32::MAX]),
            3 => p.texel_fraction = b.f32_any(),
            4 => p.early_stop_texels = b.f32_any(),
            _ => p.smooth_texels = b.f32_any(),
        }
    }
    if b.chance(40) {
        o.start_pixels = b.f32_in(0.0, 3.0);
    }
    if b.chance(48) {
        o.t_min = b.f32_in(0.0, 1.0);
    }
    if b.chance(64) {
        o.t_max = t_max(b);
    }
    if b.chance(48) {
        o.max_roughness = b.f32_in(-0.1, 1.1);
    }
    o.payload_color = b.bool();
    o
}

fn trace_options_in_range(p: &refl_layered_options) -> bool {
    p.step_texels > 0.0
        && p.step_texels.is_finite()
        && p.max_steps >= 1
        && p.binary_steps <= 64
        && p.texel_fraction >= 0.0
        && p.early_stop_texels >= 0.0
        && p.smooth_texels >= 0.0
        && p.smooth_texels.is_finite()
}

fn pass_options_in_range(o: &refl_layered_pass_options) -> bool {
    trace_options_in_range(&o.trace)
        && o.start_pixels.is_finite()
        && o.start_pixels >= 0.0
        && o.t_min.is_finite()
        && o.t_min >= 0.0
        && o.t_max > o.t_min
        && !o.max_roughness.is_nan()
}

// ---------------------------------------------------------------------------
// Texels.

fn texel_bits(t: &refl_layered_pass_texel) -> [u32; 18] {
    [
        t.status,
        t.map,
        t.face,
        t.texel_x,
        t.texel_y,
        t.uv.x.to_bits(),
        t.uv.y.to_bits(),
        t.layer,
        t.payload,
        t.t.to_bits(),
        t.position.x.to_bits(),
        t.position.y.to_bits(),
        t.position.z.to_bits(),
        t.confidence.to_bits(),
        t.dir.x.to_bits(),
        t.dir.y.to_bits(),
        t.dir.z.to_bits(),
        t.fetches,
    ]
}

/// Every hit field is zero (bits).
fn no_hit_fields(t: &refl_layered_pass_texel) -> bool {
    let b = texel_bits(t);
    b[1..14].iter().all(|&v| v == 0)
}

fn unit(v: refl_vec3) -> bool {
    finite3(v) && (len3(v) - 1.0).abs() < 1e-3
}

/// The header's promises of a hit texel of map `t.map` with `t` in
/// `[t_min, t_max]`.
#[track_caller]
fn check_hit(t: &refl_layered_pass_texel, maps: &[PassMap], t_min: f32, t_max: f32, what: &str) {
    let k = t.map as usize;
    assert!(k < maps.len(), "{what}: hit of map {k} of {}", maps.len());
    let m = &maps[k].m;
    let g = m.grid;
    assert!(t.face < 6 && t.texel_x < g.face_res && t.texel_y < g.face_res && t.layer < g.layers, "{what}: hit {t:?} of a grid {g:?}");
    let idx = texel_index(g.face_res, t.face, t.texel_x, t.texel_y);
    let c = m.counts.get(idx);
    assert!(t.layer < c, "{what}: hit layer {} of a texel with {c} layers", t.layer);
    let p = m.payload.get(idx * g.layers as usize + t.layer as usize);
    assert_eq!(t.payload, p, "{what}: payload {} but the map holds {p}", t.payload);
    let res = g.face_res as f32;
    let tol = 1e-2 * res + 1e-3;
    assert!(
        t.uv.x.is_finite() && t.uv.y.is_finite() && t.uv.x >= -tol && t.uv.y >= -tol && t.uv.x <= res + tol && t.uv.y <= res + tol,
        "{what}: uv {:?} outside the face of {res} texels",
        t.uv
    );
    assert!(t.t.is_finite() && t.t >= t_min && t.t <= t_max, "{what}: hit t {} outside [{t_min}, {t_max}]: {t:?}", t.t);
    assert!(finite3(t.position), "{what}: position {:?}", t.position);
    let (lo, hi) = world_box(&g);
    let pad = 1e-3 * (1.0 + lo.iter().chain(hi.iter()).fold(0f32, |a, v| a.max(v.abs())));
    let q = [t.position.x, t.position.y, t.position.z];
    assert!((0..3).all(|a| q[a] >= lo[a] - pad && q[a] <= hi[a] + pad), "{what}: hit {q:?} outside the map's box {lo:?}..{hi:?}");
    assert!((0.0..=1.0).contains(&t.confidence), "{what}: confidence {}", t.confidence);
    assert!(unit(t.dir), "{what}: hit dir {:?}", t.dir);
    assert!(t.fetches > 0, "{what}: a hit without buffer reads");
}

/// The color a texel's payload gives (black without a hit).
fn payload_color(t: &refl_layered_pass_texel) -> refl_vec3 {
    if t.status != HIT {
        return v3(0.0, 0.0, 0.0);
    }
    let [r, g, b, _] = t.payload.to_le_bytes();
    v3(f32::from(r) / 255.0, f32::from(g) / 255.0, f32::from(b) / 255.0)
}

// ---------------------------------------------------------------------------
// The G-buffer's validity.

fn img_ok<T: Copy>(i: &(Buf<T>, u32, u32, u32), w: u32, h: u32) -> bool {
    i.0.usable() && i.1 == w && i.2 == h && required_len(i.1, i.2, i.3).is_some_and(|n| i.0.len() >= n)
}

/// Whether refl must accept the G-buffer (every image valid, of the
/// camera's size, a known normal space).
fn gbuffer_valid(fg: &FuzzGBuffer) -> bool {
    let (w, h) = (fg.img.width, fg.img.height);
    fg.img.valid()
        && img_ok(&fg.normals, w, h)
        && fg.normal_space <= 1
        && (fg.mask.0.is_null() || img_ok(&fg.mask, w, h))
        && (fg.roughness.0.is_null() || img_ok(&fg.roughness, w, h))
        && (fg.color.0.is_null() || img_ok(&fg.color, w, h))
        && (fg.back.0.is_null() || img_ok(&fg.back, w, h))
}

// ---------------------------------------------------------------------------
// The pass.

/// Object ids: the image and the ids of the maps.
struct Ids {
    img: (Buf<u32>, u32, u32, u32),
    map_ids: Buf<u32>,
}

impl Ids {
    fn present(&self) -> bool {
        !self.img.0.is_null()
    }
    fn desc(&self) -> refl_image_u32 {
        refl_image_u32 { data: self.img.0.cptr(), len: self.img.0.len(), width: self.img.1, height: self.img.2, stride: self.img.3 }
    }
    /// The id at (x, y) if present and inside the image.
    fn at(&self, x: u32, y: u32) -> Option<u32> {
        (self.present() && x < self.img.1 && y < self.img.2).then(|| self.img.0.get(y as usize * self.img.3 as usize + x as usize))
    }
}

fn ids(b: &mut Bytes, w: u32, h: u32, n: usize) -> Ids {
    if !b.chance(80) {
        return Ids { img: (Buf::sentinel(0, PtrKind::Null), 0, 0, 0), map_ids: Buf::sentinel(0, PtrKind::Null) };
    }
    let (iw, ih) = if b.chance(12) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    let stride = if b.chance(24) { b.stride(iw) } else { iw };
    let seed = b.u8();
    let mut buf = image_buf(b, iw, ih, stride, |x, y| (x / 3 + y / 2 + u32::from(seed)) % 4, 9);
    if buf.is_null() {
        buf = Buf::from_fn(buf.len(), PtrKind::Valid, |i| i as u32 % 4);
    }
    let mids: Vec<u32> = (0..n).map(|_| b.below(5)).collect();
    let len = if b.chance(16) { b.len_for(n) } else { n };
    let kind = if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid };
    let map_ids = Buf::from_fn(len, kind, |i| mids.get(i).copied().unwrap_or(0));
    Ids { img: (buf, iw, ih, stride), map_ids }
}

struct Run {
    s: refl_status,
    st: refl_layered_pass_stats,
    out: Vec<refl_layered_pass_texel>,
    col: Vec<refl_vec3>,
    host: Vec<refl_host_ray>,
}

/// One `refl_layered_trace_rows` over `rows` into fresh valid buffers.
fn run(
    inp: &refl_layered_pass_input,
    o: &refl_layered_pass_options,
    scratch: &Buf<refl_layered_bound>,
    with_color: bool,
    host_len: usize,
    rows: refl_row_range,
) -> Run {
    let (w, h) = (inp.gbuffer.depth.camera.width, inp.gbuffer.depth.camera.height);
    let n = w as usize * h as usize;
    let mut out = Buf::<refl_layered_pass_texel>::sentinel(n, PtrKind::Valid);
    let mut col = Buf::<refl_vec3>::sentinel(if with_color { n } else { 0 }, if with_color { PtrKind::Valid } else { PtrKind::Null });
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, if host_len > 0 { PtrKind::Valid } else { PtrKind::Null });
    let cm = refl_image_vec3_mut { data: col.ptr(), len: col.len(), width: w, height: h, stride: w };
    let mut st = refl_layered_pass_stats::default();
    // SAFETY: buffers valid for their lengths; the input as fuzzed (accepted once).
    let s = unsafe { refl_layered_trace_rows(&mut st, out.ptr(), n, cm, host.ptr(), host_len, inp, o, scratch.cptr(), scratch.len(), rows) };
    Run { s, st, out: out.to_vec(), col: if with_color { col.to_vec() } else { Vec::new() }, host: host.to_vec() }
}

/// `refl_layered_trace_host_rays` of `rays` into fresh valid buffers.
fn run_rays(
    inp: &refl_layered_pass_input,
    o: &refl_layered_pass_options,
    scratch: &Buf<refl_layered_bound>,
    rays: &[refl_host_ray],
) -> (refl_status, refl_layered_pass_stats, Vec<refl_layered_pass_texel>) {
    let n = rays.len();
    let mut out = Buf::<refl_layered_pass_texel>::sentinel(n, PtrKind::Valid);
    let rb = Buf::from_slice(rays, PtrKind::Valid);
    let mut st = refl_layered_pass_stats::default();
    // SAFETY: buffers valid for their lengths.
    let s = unsafe {
        refl_layered_trace_host_rays(&mut st, out.ptr(), n, core::ptr::null_mut(), 0, core::ptr::null_mut(), 0, inp, o, scratch.cptr(), scratch.len(), rb.cptr(), n)
    };
    (s, st, out.to_vec())
}

/// The texel `refl_layered_trace_host_rays` must give for `r`: the nearest
/// hit of `refl_layered_trace_ray` over the maps in order (each later map
/// up to the nearest hit so far, ids skipping the ray's own object), or
/// the host status of the misses. `None` where the kernel refuses a map's
/// trace (the pass then passes over that map).
fn expected_ray_texel(r: &refl_host_ray, maps: &[PassMap], ids: &Ids, o: &refl_layered_pass_options) -> Option<refl_layered_pass_texel> {
    let origin = v3(r.origin.x + r.dir.x * r.t_min, r.origin.y + r.dir.y * r.t_min, r.origin.z + r.dir.z * r.t_min);
    let seg = refl_ray { origin, dir: r.dir };
    let t_seg = r.t_max - r.t_min;
    let own = ids.at(r.x, r.y);
    let mut best: Option<(usize, refl_layered_result)> = None;
    let (mut inside, mut steps) = (false, false);
    for (k, pm) in maps.iter().enumerate() {
        if let Some(id) = own {
            if ids.map_ids.len() > k && ids.map_ids.get(k) == id {
                continue;
            }
        }
        let tm = best.map_or(t_seg, |(_, h)| h.t);
        if !(tm > 0.0) {
            break;
        }
        let mut res = refl_layered_result::default();
        let d = pm.m.desc();
        // SAFETY: pointers valid.
        let s = unsafe { refl_layered_trace_ray(&mut res, &d, seg, tm, &o.trace) };
        if s != refl_status::Ok {
            return None;
        }
        if res.hit {
            if best.is_none_or(|(_, h)| res.t < h.t) {
                best = Some((k, res));
            }
        } else if res.miss == 5 {
            inside = true;
        } else if res.miss == 4 {
            steps = true;
        }
    }
    let mut t = refl_layered_pass_texel { dir: r.dir, ..Default::default() };
    match best {
        None => {
            t.status = if inside {
                STARTED_INSIDE
            } else if steps {
                OUT_OF_STEPS
            } else {
                LEFT_MAPS
            };
        }
        Some((k, h)) => {
            let e = o.trace.early_stop_texels;
            t.status = HIT;
            t.map = k as u32;
            t.face = h.face;
            t.texel_x = h.texel_x;
            t.texel_y = h.texel_y;
            t.layer = h.layer;
            t.payload = h.payload;
            t.t = r.t_min + h.t;
            t.position = h.position;
            t.confidence = if h.mismatch <= e {
                1.0
            } else if h.mismatch > e {
                (e / h.mismatch).clamp(0.0, 1.0)
            } else {
                0.0
            };
        }
    }
    Some(t)
}

/// Compares a texel with [`expected_ray_texel`]'s (not `uv` and
/// `fetches`: the pass's sphere test skips kernel work).
#[track_caller]
fn assert_same_as_expected(got: &refl_layered_pass_texel, want: &refl_layered_pass_texel, what: &str) {
    let (g, w) = (texel_bits(got), texel_bits(want));
    let keep = |v: [u32; 18]| [v[0], v[1], v[2], v[3], v[4], v[7], v[8], v[13], v[14], v[15], v[16]];
    assert!(
        keep(g) == keep(w) && got.t == want.t && bits3(got.position) == bits3(want.position),
        "{what}: texel {got:?}, but refl_layered_trace_ray over the maps gives {want:?}"
    );
}

#[allow(clippy::too_many_arguments)]
fn pass_section(b: &mut Bytes, fg: &FuzzGBuffer, maps: &[PassMap], o: &refl_layered_pass_options) {
    let img = &fg.img;
    let (w, h) = (img.width, img.height);
    let cam = img.cam;
    let g = fg.desc();
    let n = maps.len();
    let descs: Vec<refl_layered_map> = maps.iter().map(|pm| pm.m.desc()).collect();
    let mkind = if n == 0 {
        if b.bool() { PtrKind::Null } else { PtrKind::Valid }
    } else if b.chance(12) {
        b.ptr_kind()
    } else {
        PtrKind::Valid
    };
    let mbuf = Buf::from_slice(&descs, mkind);
    let ids = ids(b, w, h, n);
    let inp = refl_layered_pass_input {
        gbuffer: g,
        maps: mbuf.cptr(),
        maps_len: n,
        ids: ids.desc(),
        map_ids: ids.map_ids.cptr(),
        map_ids_len: ids.map_ids.len(),
        // Potential reflection regions are not fuzzed here (none given).
        regions: refl_image_u32 { data: core::ptr::null(), len: 0, width: 0, height: 0, stride: 0 },
        region_masks: core::ptr::null(),
        region_masks_len: 0,
    };
    let ib = Buf::from_slice(&[inp], b.ptr_kind());
    let ob = Buf::from_slice(&[*o], b.ptr_kind());
    let id_snaps = (ids.img.0.snapshot(), ids.map_ids.snapshot(), mbuf.snapshot());
    let inputs_unchanged = |what: &str| {
        fg.assert_unchanged(what);
        for (k, pm) in maps.iter().enumerate() {
            assert!(pm.m.same(&pm.snap), "{what}: map {k} written");
        }
        ids.img.0.assert_unchanged(&id_snaps.0, what);
        ids.map_ids.assert_unchanged(&id_snaps.1, what);
        mbuf.assert_unchanged(&id_snaps.2, what);
    };
    let args_mis = ib.kind() == PtrKind::Misaligned || ob.kind() == PtrKind::Misaligned;
    let nested_null = img.buf.is_null()
        || fg.normals.0.is_null()
        || (mbuf.is_null() && n > 0)
        || maps.iter().any(|pm| pm.m.any_null())
        || (ids.present() && ids.map_ids.is_null());
    let ids_ok = !ids.present()
        || (img_ok(&ids.img, w, h) && ids.map_ids.len() >= n && (ids.map_ids.is_empty() || ids.map_ids.usable()));
    let maps_array_ok = mbuf.usable() || (n == 0 && mbuf.is_null());
    let all_maps_intact = maps.iter().all(|pm| pm.intact);
    let inputs_valid = ib.usable() && ob.usable() && pass_options_in_range(o) && gbuffer_valid(fg) && maps_array_ok && all_maps_intact && ids_ok;

    // 1. The size query: one record per map.
    let mut lo = out1::<usize>(b.ptr_kind());
    // SAFETY: pointers NULL, misaligned or valid.
    let s = unsafe { refl_layered_pass_scratch_len(lo.ptr(), ib.cptr(), ob.cptr()) };
    let null = lo.is_null() || ib.is_null() || ob.is_null();
    null_rules_m(s, null, null, args_mis || lo.kind() == PtrKind::Misaligned, "refl_layered_pass_scratch_len");
    on_error_untouched(s, &[("out_len", lo.is_sentinel(0))], "refl_layered_pass_scratch_len");
    if lo.usable() && ib.usable() && ob.usable() {
        assert_eq!(s, refl_status::Ok, "scratch_len refused valid pointers");
    }
    if s == refl_status::Ok {
        assert_eq!(lo.get(0), n, "scratch_len is not the number of maps");
    }
    inputs_unchanged("refl_layered_pass_scratch_len");

    // 2. Prepare.
    let slen = if b.chance(24) { b.len_for(n) } else { n };
    let skind = if n == 0 && b.chance(64) { PtrKind::Null } else if b.chance(24) { b.ptr_kind() } else { PtrKind::Valid };
    let mut scratch = Buf::<refl_layered_bound>::sentinel(slen, skind);
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_layered_pass_prepare(scratch.ptr(), slen, ib.cptr(), ob.cptr()) };
    let scratch_null = scratch.is_null() && n > 0;
    // (Finding F25, fixed: a NULL `scratch` was reported after the inputs.)
    let req_null = ib.is_null() || ob.is_null() || scratch_null;
    let nested_mis = [img.buf.kind(), fg.normals.0.kind(), fg.roughness.0.kind(), fg.color.0.kind(), fg.back.0.kind(), mbuf.kind(), ids.img.0.kind(), ids.map_ids.kind(), scratch.kind()].contains(&PtrKind::Misaligned)
        || maps.iter().any(|pm| pm.m.any_misaligned());
    null_rules_m(s, req_null, req_null || scratch_null || nested_null, args_mis || nested_mis, "refl_layered_pass_prepare");
    on_error_untouched(s, &[("scratch", (0..slen).all(|i| scratch.is_sentinel(i)))], "refl_layered_pass_prepare");
    inputs_unchanged("refl_layered_pass_prepare");
    let scratch_ok = n == 0 || (scratch.usable() && slen >= n);
    if inputs_valid && scratch_ok {
        assert_eq!(s, refl_status::Ok, "refl_layered_pass_prepare refused valid input: {}", last_error());
    }
    if s != refl_status::Ok {
        return;
    }
    assert!(pass_options_in_range(o), "prepare accepted options {o:?}");
    fg.assert_accepted("refl_layered_pass_prepare");
    assert!(maps_array_ok || mbuf.usable(), "prepare accepted a bad maps array");
    for (k, pm) in maps.iter().enumerate() {
        assert!(pm.sound, "prepare accepted map {k} (grid {:?}, lengths {} {} {} {})", pm.m.grid, pm.m.depth.len(), pm.m.payload.len(), pm.m.counts.len(), pm.m.bounds.len());
    }
    if ids.present() {
        assert!(ids.img.1 == w && ids.img.2 == h && ids.map_ids.len() >= n, "prepare accepted ids of {}x{} with {} map ids", ids.img.1, ids.img.2, ids.map_ids.len());
    }
    assert!(scratch_ok, "prepare accepted a scratch of {slen} for {n} maps ({:?})", scratch.kind());
    for i in n..slen {
        assert!(scratch.is_sentinel(i), "prepare wrote scratch record {i} past {n} maps");
    }
    for (k, pm) in maps.iter().enumerate() {
        let r = scratch.get(k);
        assert!(finite3(r.center) && r.radius.is_finite() && r.radius >= 0.0, "bound {k}: {r:?}");
        let gr = &pm.m.grid;
        let m = gr.world_from_local.m.map(f64::from);
        let c = d3(r.center);
        for q in 0..8 {
            let p = [
                f64::from(if q & 1 == 0 { gr.min.x } else { gr.max.x }),
                f64::from(if q & 2 == 0 { gr.min.y } else { gr.max.y }),
                f64::from(if q & 4 == 0 { gr.min.z } else { gr.max.z }),
            ];
            let wp: Vec<f64> = (0..3).map(|a| m[a] * p[0] + m[4 + a] * p[1] + m[8 + a] * p[2] + m[12 + a]).collect();
            let dist = ((wp[0] - c[0]).powi(2) + (wp[1] - c[1]).powi(2) + (wp[2] - c[2]).powi(2)).sqrt();
            let cl = c.iter().fold(0f64, |a, v| a.max(v.abs()));
            assert!(dist <= f64::from(r.radius) * (1.0 + 1e-6) + 1e-6 * (1.0 + cl), "bound {k}: corner {wp:?} at {dist} from {c:?} beyond radius {}", r.radius);
        }
    }

    // Bounded work: a tiny step with a huge cap is the caller's choice.
    let npix = w as usize * h as usize;
    let res_max = maps.iter().map(|pm| pm.m.grid.face_res).max().unwrap_or(1) as f64;
    let per = f64::from(o.trace.max_steps).min(3.0 * (6.0 * res_max / f64::from(o.trace.step_texels) + 6.0 * res_max));
    if npix as f64 * (n.max(1) as f64) * per > 4e6 {
        return;
    }

    // 3. Trace a band with fuzzed buffers.
    let rows = b.rows(h);
    let out_len = b.len_for(npix);
    let mut out = Buf::<refl_layered_pass_texel>::sentinel(out_len, b.ptr_kind());
    let want_color = b.chance(120);
    let (ocw, och) = if b.chance(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    let col_len = if want_color { b.len_for((ocw as usize * och as usize).min(1 << 16)) } else { 0 };
    let mut col = Buf::<refl_vec3>::sentinel(col_len, if want_color { b.ptr_kind() } else { PtrKind::Null });
    let cm = refl_image_vec3_mut { data: col.ptr(), len: col_len, width: ocw, height: och, stride: ocw };
    let want_color = want_color && !col.is_null();
    let host_len = match b.u8() % 4 {
        0 => 0,
        1 => b.below(4) as usize,
        _ => npix,
    };
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, if host_len == 0 && b.bool() { PtrKind::Null } else { b.ptr_kind() });
    let mut st = out1::<refl_layered_pass_stats>(b.ptr_kind());
    let scratch_snap = scratch.snapshot();
    // Sometimes a NULL scratch (with a count of 0 or of the maps).
    let (sp, sl) = if n > 0 && b.chance(10) { (core::ptr::null(), if b.bool() { 0 } else { n }) } else { (scratch.cptr(), slen) };
    let sc_null = sp.is_null() && n > 0;
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_layered_trace_rows(st.ptr(), out.ptr(), out_len, cm, host.ptr(), host_len, ib.cptr(), ob.cptr(), sp, sl, rows) };
    // (Finding F25, fixed: a NULL `scratch` was reported after the inputs
    // and, with `scratch_len` 0, as a short one.)
    let req_null = st.is_null() || out.is_null() || ib.is_null() || ob.is_null() || (host.is_null() && host_len > 0) || sc_null;
    let mis = [out.kind(), col.kind(), host.kind(), st.kind(), scratch.kind()].contains(&PtrKind::Misaligned) || args_mis;
    null_rules_m(s, req_null, req_null || sp.is_null() || nested_null || host.is_null() || col.is_null(), mis, "refl_layered_trace_rows");
    on_error_untouched(
        s,
        &[
            ("out_stats", st.is_sentinel(0)),
            ("out", (0..out_len).all(|i| out.is_sentinel(i))),
            ("color", (0..col_len).all(|i| col.is_sentinel(i))),
            ("host", (0..host_len).all(|i| host.is_sentinel(i))),
        ],
        "refl_layered_trace_rows",
    );
    inputs_unchanged("refl_layered_trace_rows");
    scratch.assert_unchanged(&scratch_snap, "refl_layered_trace_rows scratch");
    let rows_ok = rows.begin < rows.end && rows.end <= h;
    let color_ok = !want_color || (o.payload_color && ocw == w && och == h && col.usable() && col_len >= npix);
    let outs_ok = st.usable() && out.usable() && out_len >= npix && (host.usable() || (host.is_null() && host_len == 0)) && (col.is_null() || color_ok);
    if inputs_valid && !sc_null && (n == 0 || (scratch.usable() && slen >= n)) && rows_ok && outs_ok {
        assert_eq!(s, refl_status::Ok, "refl_layered_trace_rows refused valid input: {}", last_error());
    }
    if s != refl_status::Ok {
        return;
    }
    assert!(rows_ok, "trace_rows accepted rows {rows:?} of {h}");
    assert!(!sc_null, "trace_rows accepted a NULL scratch ({sl}) for {n} maps");
    assert!(out_len >= npix, "trace_rows accepted out_len {out_len} < {npix}");
    if want_color {
        assert!(color_ok, "trace_rows accepted a color output of {ocw}x{och} ({col_len}) with payload_color {}", o.payload_color);
    }
    let stats = st.get(0);
    let (mut traced, mut hitc, mut sky, mut hostc, mut fetches) = (0u32, 0u32, 0u32, 0u32, 0u64);
    let moderate = camera_moderate(&cam);
    let eye = eye_of(&cam);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            if y < rows.begin || y >= rows.end {
                assert!(out.is_sentinel(i), "texel ({x}, {y}) outside rows {rows:?} written");
                if want_color {
                    assert!(col.is_sentinel(i), "color ({x}, {y}) outside rows written");
                }
                continue;
            }
            let t = out.get(i);
            let what = format!("refl_layered_trace_rows ({x}, {y})");
            assert!(t.status <= LAST_STATUS, "{what}: status {}", t.status);
            match t.status {
                SKIPPED | NO_SURFACE => {
                    assert!(no_hit_fields(&t) && bits3(t.dir) == [0; 3] && t.fetches == 0, "{what}: status {} with fields {t:?}", t.status);
                }
                HIT => {
                    check_hit(&t, maps, o.t_min, o.t_max, &what);
                    // The hit lies on the pixel's ray: position - t dir is
                    // the surface point seen at the pixel's center.
                    if moderate && t.t < 100.0 && max_abs3(t.position) < 100.0 {
                        let p = v3(t.position.x - t.t * t.dir.x, t.position.y - t.t * t.dir.y, t.position.z - t.t * t.dir.z);
                        if let Some(q) = project(&cam, p) {
                            let tol = 0.05 + pixel_tol(&cam, q.depth) * (1.0 + t.t);
                            assert!(
                                (q.x - (x as f32 + 0.5)).abs() <= tol && (q.y - (y as f32 + 0.5)).abs() <= tol,
                                "{what}: the hit's ray starts at ({}, {}), not at the pixel: {t:?}",
                                q.x,
                                q.y
                            );
                        }
                    }
                }
                _ => {
                    assert!(no_hit_fields(&t), "{what}: status {} with hit fields {t:?}", t.status);
                    assert!(unit(t.dir), "{what}: status {} with dir {:?}", t.status, t.dir);
                    if t.status == SKY || t.status == NO_PROJECTION {
                        assert_eq!(t.fetches, 0, "{what}: an untraced ray read the maps");
                    }
                }
            }
            if t.status != SKIPPED && t.status != NO_SURFACE {
                traced += 1;
            }
            hitc += u32::from(t.status == HIT);
            sky += u32::from(t.status == SKY);
            hostc += u32::from(t.status >= LEFT_MAPS);
            fetches += u64::from(t.fetches);
            // Skipped exactly where the mask or the roughness says.
            let masked = fg.masked(x, y);
            let rough = fg.roughness_at(x, y).is_some_and(|r| !(r <= o.max_roughness));
            assert_eq!(t.status == SKIPPED, masked || rough, "{what}: status {} but masked {masked} rough {rough}", t.status);
            if !(masked || rough) {
                let nn = fg.normal_at(x, y);
                if !finite3(nn) || (nn.x == 0.0 && nn.y == 0.0 && nn.z == 0.0) || img.texel(x, y).is_nan() {
                    assert_eq!(t.status, NO_SURFACE, "{what}: normal {nn:?} depth {}", img.texel(x, y));
                }
            }
            if want_color {
                let c = col.get(i);
                let want = payload_color(&t);
                assert!(bits3(c) == bits3(want), "{what}: color {c:?}, want {want:?} (status {})", t.status);
            }
        }
    }
    assert_eq!((stats.traced, stats.hits, stats.sky, stats.host_rays), (traced, hitc, sky, hostc), "stats {stats:?}");
    assert_eq!(stats.host_rays_written as usize, (hostc as usize).min(host_len), "host rays written");
    assert_eq!(stats.fetches, fetches, "stats fetches are not the texels' sum");
    assert!(stats.kernel_traces >= u64::from(hitc), "{} kernel traces for {hitc} hits", stats.kernel_traces);
    assert!(stats.kernel_traces <= u64::from(traced) * n as u64, "{} kernel traces for {traced} rays and {n} maps", stats.kernel_traces);
    let mut last: Option<(u32, u32)> = None;
    let mut listed = Vec::new();
    for k in 0..host_len {
        if k >= stats.host_rays_written as usize {
            assert!(host.is_sentinel(k), "host entry {k} past the written ones");
            continue;
        }
        let r = host.get(k);
        assert!(r.y >= rows.begin && r.y < rows.end && r.x < w, "host ray at ({}, {})", r.x, r.y);
        assert!(last.is_none_or(|l| (r.y, r.x) > l), "host rays not in row-major order");
        last = Some((r.y, r.x));
        let t = out.get((r.y * w + r.x) as usize);
        assert!(t.status >= LEFT_MAPS && t.status == r.status, "host ray status {} vs texel {}", r.status, t.status);
        assert!(finite3(r.origin), "host ray origin {:?}", r.origin);
        assert!(unit(r.dir) && bits3(r.dir) == bits3(t.dir), "host ray dir {:?}, texel dir {:?}", r.dir, t.dir);
        assert!(r.t_min.to_bits() == o.t_min.to_bits() && r.t_max.to_bits() == o.t_max.to_bits(), "host ray range {} {}", r.t_min, r.t_max);
        // The reflected direction leaves on the viewer's side of the
        // surface (world-space normals).
        if let (0, Some(e)) = (fg.normal_space, eye) {
            let nn = fg.normal_at(r.x, r.y);
            let v = [r.origin.x - e.x, r.origin.y - e.y, r.origin.z - e.z].map(f64::from);
            let (nd, dd) = (d3(nn), d3(r.dir));
            let vn = v[0] * nd[0] + v[1] * nd[1] + v[2] * nd[2];
            let dn = dd[0] * nd[0] + dd[1] * nd[1] + dd[2] * nd[2];
            let vl = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let nl = len3(nn);
            if vl > 1e-3 * (1.0 + len3(r.origin)) && nl.is_finite() && nl > 0.0 {
                assert!(vn * dn <= 1e-3 * vl * nl * nl, "host ray on the far side of its surface: v.n {vn}, d.n {dn}");
            }
        }
        listed.push((r, t));
    }

    // 4. With no start offset a pixel's ray is its host ray from t_min:
    // the same ray listed again gives the same texel.
    let cheap = npix <= 24 * 24;
    if o.start_pixels == 0.0 && !listed.is_empty() && b.chance(128) {
        let rays: Vec<refl_host_ray> = listed.iter().filter(|(r, _)| r.status != NO_PROJECTION).take(16).map(|(r, _)| *r).collect();
        if !rays.is_empty() {
            let (s2, st2, t2) = run_rays(&inp, o, &scratch, &rays);
            assert_eq!(s2, refl_status::Ok, "refl_layered_trace_host_rays refused the host rays of refl_layered_trace_rows: {}", last_error());
            let texels: Vec<_> = listed.iter().filter(|(r, _)| r.status != NO_PROJECTION).take(16).map(|(_, t)| *t).collect();
            for (k, (a, c)) in t2.iter().zip(&texels).enumerate() {
                assert!(texel_bits(a) == texel_bits(c), "listed host ray {k} {a:?}, the pixel's texel {c:?}");
            }
            assert_eq!(st2.host_rays as usize, rays.len(), "listed host rays");
        }
    }

    // 6. Potential reflection regions (seed 001 Sec. 3.2): fuzzed region
    // ids with masks of every map give the same texels as without regions
    // (and skip no sphere test); masks of no map leave a pixel with a region
    // nothing to trace (no hit, no fetch) and the others as they were; a
    // region id past the masks is refused, nothing written.
    if cheap && b.chance(64) {
        let whole = refl_row_range { begin: 0, end: h };
        let pc = o.payload_color;
        let base = run(&inp, o, &scratch, pc, 0, whole);
        assert_eq!(base.s, refl_status::Ok, "the whole image refused after a band was accepted: {}", last_error());
        let nr = 1 + b.below(4) as usize;
        let words = n.div_ceil(64).max(1);
        let regions: Vec<u32> = (0..npix).map(|_| if b.chance(64) { REFL_LAYERED_NO_REGION } else { b.below(nr as u32) }).collect();
        let with = |masks: &[u64], regions: &[u32]| {
            let inp2 = refl_layered_pass_input {
                regions: refl_image_u32 { data: regions.as_ptr(), len: npix, width: w, height: h, stride: w },
                region_masks: masks.as_ptr(),
                region_masks_len: masks.len(),
                ..inp
            };
            run(&inp2, o, &scratch, pc, 0, whole)
        };
        let all = vec![u64::MAX; nr * words];
        let r = with(&all, &regions);
        assert_eq!(r.s, refl_status::Ok, "regions of every map refused: {}", last_error());
        for i in 0..npix {
            assert!(texel_bits(&r.out[i]) == texel_bits(&base.out[i]), "texel {i}: regions of every map changed it");
        }
        assert_eq!((r.st.traced, r.st.hits, r.st.fetches, r.st.kernel_traces), (base.st.traced, base.st.hits, base.st.fetches, base.st.kernel_traces));
        assert_eq!(r.st.prr_skipped, 0, "masks of every map skipped a lookup");
        let none = vec![0u64; nr * words];
        let r = with(&none, &regions);
        assert_eq!(r.s, refl_status::Ok, "regions of no map refused: {}", last_error());
        for i in 0..npix {
            let (t, t0) = (&r.out[i], &base.out[i]);
            if regions[i] == REFL_LAYERED_NO_REGION || t0.status == SKIPPED || t0.status == NO_SURFACE {
                assert!(texel_bits(t) == texel_bits(t0), "texel {i} without a region changed");
            } else {
                assert!(t.status != HIT && t.status != OUT_OF_STEPS && t.status != STARTED_INSIDE && t.fetches == 0, "texel {i}: a region of no map traced one: {t:?}");
                assert!(bits3(t.dir) == bits3(t0.dir), "texel {i}: the ray changed");
            }
        }
        // A region id past the masks: refused, nothing written.
        let mut bad = regions.clone();
        let k = b.below(npix as u32) as usize;
        bad[k] = nr as u32 + b.below(3);
        let inp3 = refl_layered_pass_input {
            regions: refl_image_u32 { data: bad.as_ptr(), len: npix, width: w, height: h, stride: w },
            region_masks: all.as_ptr(),
            region_masks_len: all.len(),
            ..inp
        };
        let mut out3 = Buf::<refl_layered_pass_texel>::sentinel(npix, PtrKind::Valid);
        let cm3 = refl_image_vec3_mut { data: core::ptr::null_mut(), len: 0, width: w, height: h, stride: w };
        let mut st3 = refl_layered_pass_stats::default();
        // SAFETY: buffers valid for their lengths.
        let s3 = unsafe { refl_layered_trace_rows(&mut st3, out3.ptr(), npix, cm3, core::ptr::null_mut(), 0, &inp3, o, scratch.cptr(), scratch.len(), whole) };
        assert_eq!(s3, refl_status::InvalidArgument, "a region id past the masks accepted");
        assert!((0..npix).all(|i| out3.is_sentinel(i)), "written on a refused region id");
    }

    // 5. Bands: the same bytes as one call over the whole image.
    if cheap && h >= 2 && b.chance(64) {
        let whole = refl_row_range { begin: 0, end: h };
        let k = 1 + b.below(h - 1);
        let pc = o.payload_color;
        let r1 = run(&inp, o, &scratch, pc, npix, whole);
        let r2 = run(&inp, o, &scratch, pc, npix, refl_row_range { begin: 0, end: k });
        let r3 = run(&inp, o, &scratch, pc, npix, refl_row_range { begin: k, end: h });
        assert!(r1.s == refl_status::Ok && r2.s == refl_status::Ok && r3.s == refl_status::Ok, "bands refused: {:?} {:?} {:?}: {}", r1.s, r2.s, r3.s, last_error());
        let split = (k * w) as usize;
        for i in 0..npix {
            let (part, pcol) = if i < split { (&r2.out[i], r2.col.get(i)) } else { (&r3.out[i], r3.col.get(i)) };
            assert!(texel_bits(&r1.out[i]) == texel_bits(part), "texel {i} differs between one call and two bands");
            if pc {
                assert!(bits3(r1.col[i]) == bits3(*pcol.unwrap()), "color {i} differs between one call and two bands");
            }
        }
        let sum = |f: fn(&refl_layered_pass_stats) -> u64| f(&r2.st) + f(&r3.st);
        assert_eq!(u64::from(r1.st.traced), sum(|s| u64::from(s.traced)));
        assert_eq!(u64::from(r1.st.hits), sum(|s| u64::from(s.hits)));
        assert_eq!(u64::from(r1.st.sky), sum(|s| u64::from(s.sky)));
        assert_eq!(u64::from(r1.st.host_rays), sum(|s| u64::from(s.host_rays)));
        assert_eq!(r1.st.kernel_traces, sum(|s| s.kernel_traces));
        assert_eq!(r1.st.fetches, sum(|s| s.fetches));
        let joined: Vec<_> = r2.host[..r2.st.host_rays_written as usize].iter().chain(&r3.host[..r3.st.host_rays_written as usize]).collect();
        assert_eq!(joined.len(), r1.st.host_rays_written as usize);
        for (a, c) in r1.host.iter().zip(joined) {
            assert!(host_bits(a) == host_bits(c), "host list differs between one call and two bands");
        }
    }

    // 6. A scratch prepared for these maps, used with a map moved or the
    // maps reordered: refused.
    if cheap && n >= 1 && b.chance(64) {
        let whole = refl_row_range { begin: 0, end: h };
        let mut moved = descs.clone();
        let k = b.below(n as u32) as usize;
        let before = moved[k].grid.world_from_local.m[12];
        moved[k].grid.world_from_local.m[12] = before + 0.5;
        if moved[k].grid.world_from_local.m[12] != before {
            let mut inp2 = inp;
            inp2.maps = moved.as_ptr();
            let r = run(&inp2, o, &scratch, false, 0, whole);
            assert_eq!(r.s, refl_status::InvalidArgument, "a scratch prepared before map {k} moved was accepted");
            assert!(r.out.iter().all(|t| texel_bits(t).iter().all(|&v| v == u32::from_ne_bytes([SENTINEL; 4]))), "refused trace wrote");
        }
        if n >= 2 {
            let mut swapped = descs.clone();
            swapped.swap(0, 1);
            let (g0, g1) = (&descs[0].grid, &descs[1].grid);
            let same = bits3(g0.min) == bits3(g1.min)
                && bits3(g0.max) == bits3(g1.max)
                && g0.face_res == g1.face_res
                && g0.layers == g1.layers
                && g0.world_from_local.m.map(f32::to_bits) == g1.world_from_local.m.map(f32::to_bits);
            let mut inp2 = inp;
            inp2.maps = swapped.as_ptr();
            let r = run(&inp2, o, &scratch, false, 0, whole);
            if !same {
                assert_eq!(r.s, refl_status::InvalidArgument, "a scratch prepared for other map order was accepted");
            }
        }
    }

    // 7. The host's own rays.
    host_rays_section(b, fg, maps, &ids, o, &inp, &ib, &ob, &scratch, &listed, &inputs_unchanged);
}

#[allow(clippy::too_many_arguments)]
fn host_rays_section(
    b: &mut Bytes,
    fg: &FuzzGBuffer,
    maps: &[PassMap],
    ids: &Ids,
    o: &refl_layered_pass_options,
    inp: &refl_layered_pass_input,
    ib: &Buf<refl_layered_pass_input>,
    ob: &Buf<refl_layered_pass_options>,
    scratch: &Buf<refl_layered_bound>,
    listed: &[(refl_host_ray, refl_layered_pass_texel)],
    inputs_unchanged: &dyn Fn(&str),
) {
    let img = &fg.img;
    let (w, h) = (img.width, img.height);
    let n = maps.len();
    let nr = b.below(7) as usize;
    let rays: Vec<refl_host_ray> = (0..nr)
        .map(|k| {
            if !listed.is_empty() && b.chance(64) {
                let mut r = listed[k % listed.len()].0;
                if b.chance(64) {
                    r.t_min = b.f32_in(0.0, 1.0);
                }
                return r;
            }
            let ray = if b.chance(128) && !maps.is_empty() {
                // Toward a map's box.
                let (lo, hi) = world_box(&maps[b.below(n as u32) as usize].m.grid);
                let origin = v3(b.f32_fine(-4.0, 4.0), b.f32_fine(-1.0, 4.0), b.f32_fine(-4.0, 4.0));
                let target = [0, 1, 2].map(|a| lo[a] + (hi[a] - lo[a]) * b.f32_fine(0.0, 1.0));
                let d = [target[0] - origin.x, target[1] - origin.y, target[2] - origin.z].map(f64::from);
                let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let dir = if l.is_finite() && l > 1e-3 { v3((d[0] / l) as f32, (d[1] / l) as f32, (d[2] / l) as f32) } else { b.dir3() };
                refl_ray { origin, dir }
            } else {
                ray_for(b, img)
            };
            refl_host_ray {
                x: if b.chance(16) { b.u32() } else { b.below(w.max(1)) },
                y: if b.chance(16) { b.u32() } else { b.below(h.max(1)) },
                origin: ray.origin,
                dir: ray.dir,
                t_min: match b.u8() % 4 {
                    0 => b.f32_in(0.0, 1.0),
                    1 => b.f32_special(),
                    _ => 0.0,
                },
                t_max: t_max(b),
                status: b.u32(),
            }
        })
        .collect();
    let rays_kind = if nr == 0 && b.bool() { PtrKind::Null } else if b.chance(12) { b.ptr_kind() } else { PtrKind::Valid };
    let rb = Buf::from_slice(&rays, rays_kind);
    let out_len = b.len_for(nr);
    let mut out = Buf::<refl_layered_pass_texel>::sentinel(out_len, if out_len == 0 && b.bool() { PtrKind::Null } else if b.chance(12) { b.ptr_kind() } else { PtrKind::Valid });
    let want_color = b.chance(96);
    let col_len = if want_color { b.len_for(nr) } else { 0 };
    let mut col = Buf::<refl_vec3>::sentinel(col_len, if want_color && !(col_len == 0 && b.bool()) { if b.chance(12) { b.ptr_kind() } else { PtrKind::Valid } } else { PtrKind::Null });
    let host_len = match b.u8() % 3 {
        0 => 0,
        1 => b.below(3) as usize,
        _ => nr,
    };
    let mut host = Buf::<refl_host_ray>::sentinel(host_len, if host_len == 0 && b.bool() { PtrKind::Null } else if b.chance(12) { b.ptr_kind() } else { PtrKind::Valid });
    let mut st = out1::<refl_layered_pass_stats>(if b.chance(12) { b.ptr_kind() } else { PtrKind::Valid });
    let rays_snap = rb.snapshot();
    let scratch_snap = scratch.snapshot();
    let (sp, sl) = if n > 0 && b.chance(10) { (core::ptr::null(), if b.bool() { 0 } else { n }) } else { (scratch.cptr(), scratch.len()) };
    let sc_null = sp.is_null() && n > 0;
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_layered_trace_host_rays(st.ptr(), out.ptr(), out_len, col.ptr(), col_len, host.ptr(), host_len, ib.cptr(), ob.cptr(), sp, sl, rb.cptr(), nr) };
    let what = "refl_layered_trace_host_rays";
    let req_null = st.is_null()
        || ib.is_null()
        || ob.is_null()
        || sc_null
        || (out.is_null() && out_len > 0)
        || (rb.is_null() && nr > 0)
        || (col.is_null() && col_len > 0)
        || (host.is_null() && host_len > 0);
    let mis = [out.kind(), col.kind(), host.kind(), st.kind(), scratch.kind(), rb.kind(), ib.kind(), ob.kind()].contains(&PtrKind::Misaligned);
    let any_null = req_null || sp.is_null() || fg.img.buf.is_null() || fg.normals.0.is_null() || maps.iter().any(|pm| pm.m.any_null()) || inp.maps.is_null() || (ids.present() && ids.map_ids.is_null());
    null_rules_m(s, req_null, any_null, mis, what);
    on_error_untouched(
        s,
        &[
            ("out_stats", st.is_sentinel(0)),
            ("out", (0..out_len).all(|i| out.is_sentinel(i))),
            ("color", (0..col_len).all(|i| col.is_sentinel(i))),
            ("host", (0..host_len).all(|i| host.is_sentinel(i))),
        ],
        what,
    );
    inputs_unchanged(what);
    rb.assert_unchanged(&rays_snap, "refl_layered_trace_host_rays rays");
    scratch.assert_unchanged(&scratch_snap, "refl_layered_trace_host_rays scratch");
    let ray_ok = |r: &refl_host_ray| {
        let start = v3(r.origin.x + r.dir.x * r.t_min, r.origin.y + r.dir.y * r.t_min, r.origin.z + r.dir.z * r.t_min);
        finite3(r.origin) && finite3(r.dir) && r.t_min >= 0.0 && r.t_min.is_finite() && r.t_max > r.t_min && finite3(start)
    };
    // Unit within "about 1e-3": refused well off it, accepted well on it.
    let unit_state = |r: &refl_host_ray| {
        let e = (len3(r.dir) - 1.0).abs();
        if e < 0.5e-3 {
            Some(true)
        } else if e > 2e-3 {
            Some(false)
        } else {
            None
        }
    };
    if s == refl_status::Ok {
        assert!(rays.iter().all(|r| ray_ok(r) && unit_state(r) != Some(false)), "{what} accepted a bad ray: {rays:?}");
        assert!(out_len >= nr && (col.is_null() || (col_len >= nr && o.payload_color)), "{what} accepted out {out_len} color {col_len} ({}) for {nr} rays", o.payload_color);
    }
    if s != refl_status::Ok {
        return;
    }
    assert!(!sc_null, "{what} accepted a NULL scratch ({sl}) for {n} maps");
    let stats = st.get(0);
    let (mut hitc, mut hostc, mut fetches) = (0u32, 0u32, 0u64);
    let mut hk = 0usize;
    for (k, r) in rays.iter().enumerate() {
        let t = out.get(k);
        let wk = format!("{what} ray {k}");
        assert!(t.status == HIT || (LEFT_MAPS..=STARTED_INSIDE).contains(&t.status), "{wk}: status {}", t.status);
        assert!(bits3(t.dir) == bits3(r.dir), "{wk}: dir {:?} is not the ray's {:?}", t.dir, r.dir);
        if t.status == HIT {
            hitc += 1;
            check_hit(&t, maps, r.t_min, r.t_max, &wk);
        } else {
            hostc += 1;
            assert!(no_hit_fields(&t), "{wk}: status {} with hit fields {t:?}", t.status);
            if hk < host_len {
                let e = host.get(hk);
                let mut want = *r;
                want.status = t.status;
                assert!(host_bits(&e) == host_bits(&want), "{wk}: host entry {e:?}, want {want:?}");
                hk += 1;
            }
        }
        fetches += u64::from(t.fetches);
        if !col.is_null() {
            let c = col.get(k);
            assert!(bits3(c) == bits3(payload_color(&t)), "{wk}: color {c:?} for {t:?}");
        }
        if unit_state(r) == Some(true) {
            if let Some(want) = expected_ray_texel(r, maps, ids, o) {
                assert_same_as_expected(&t, &want, &wk);
            }
        }
    }
    for k in nr..out_len {
        assert!(out.is_sentinel(k), "{what}: out[{k}] past {nr} rays written");
    }
    for k in nr..col_len {
        assert!(col.is_sentinel(k), "{what}: color[{k}] past {nr} rays written");
    }
    for k in hk..host_len {
        assert!(host.is_sentinel(k), "{what}: host[{k}] past the written ones");
    }
    assert_eq!(
        (stats.traced, stats.hits, stats.sky, stats.host_rays, stats.host_rays_written as usize),
        (nr as u32, hitc, 0, hostc, hk),
        "{what}: stats {stats:?}"
    );
    assert_eq!(stats.fetches, fetches, "{what}: stats fetches");

    // Outputs overlapping the rays or each other: refused, nothing written.
    if nr > 0 && b.chance(64) {
        let tsz = core::mem::size_of::<refl_layered_pass_texel>();
        let rsz = core::mem::size_of::<refl_host_ray>();
        let mut mem = vec![0u64; (nr * tsz.max(rsz)).div_ceil(8) + 8];
        // SAFETY: mem holds nr rays.
        unsafe { core::ptr::copy_nonoverlapping(rays.as_ptr(), mem.as_mut_ptr().cast::<refl_host_ray>(), nr) };
        let before = mem.clone();
        let pm = mem.as_mut_ptr();
        let mut st2 = refl_layered_pass_stats::default();
        let mut other = Buf::<refl_layered_pass_texel>::sentinel(nr, PtrKind::Valid);
        let s2 = match b.u8() % 3 {
            // SAFETY: valid (overlapping) pointers.
            0 => unsafe { refl_layered_trace_host_rays(&mut st2, pm.cast(), nr, core::ptr::null_mut(), 0, core::ptr::null_mut(), 0, inp, o, scratch.cptr(), scratch.len(), pm.cast::<refl_host_ray>().cast_const(), nr) },
            // SAFETY: as above: the host list over the rays.
            1 => unsafe { refl_layered_trace_host_rays(&mut st2, other.ptr(), nr, core::ptr::null_mut(), 0, pm.cast(), nr, inp, o, scratch.cptr(), scratch.len(), pm.cast::<refl_host_ray>().cast_const(), nr) },
            // SAFETY: as above: the stats inside `out`.
            _ => {
                let rb2 = Buf::from_slice(&rays, PtrKind::Valid);
                let p = other.ptr();
                unsafe { refl_layered_trace_host_rays(p.cast(), p, nr, core::ptr::null_mut(), 0, core::ptr::null_mut(), 0, inp, o, scratch.cptr(), scratch.len(), rb2.cptr(), nr) }
            }
        };
        check_last_error(s2, what);
        assert_eq!(s2, refl_status::InvalidArgument, "{what} with overlapping outputs");
        assert!(mem == before, "{what}: refused overlapping call wrote");
        assert!((0..nr).all(|i| other.is_sentinel(i)), "{what}: refused overlapping call wrote");
    }
}

// ---------------------------------------------------------------------------
// Back depth.

/// `b` at or behind `f` (reversed-Z: closer is greater).
fn behind(b: f32, f: f32, conv: u32) -> bool {
    if conv == 2 {
        b <= f
    } else {
        b >= f
    }
}

/// The front texel if it holds a surface: decodes to a linear depth in
/// `[near, far)`.
fn front_surface(cam: &refl_camera, f: f32, conv: u32) -> bool {
    decode(cam, f, conv).is_some_and(|z| z >= cam.z_near && z < cam.z_far)
}

fn back_value(f: f32, mode: u32, conv: u32, k: f32) -> f32 {
    match mode {
        0 => f,
        1 => f32::NAN,
        2 => match conv {
            0 => f32::INFINITY,
            1 => 1.0,
            _ => 0.0,
        },
        3 | 6 => match conv {
            2 => f * (1.0 - k),
            1 => f + k * (1.0 - f),
            _ => f * (1.0 + k) + k,
        },
        4 => match conv {
            2 => f + k * (1.0 - f),
            _ => f * (1.0 - k),
        },
        _ => f32::from_bits(f.to_bits().wrapping_add(1)),
    }
}

/// A fuzzed dst image: descriptor fields and buffer.
struct Dst {
    buf: Buf<f32>,
    w: u32,
    h: u32,
    stride: u32,
}

impl Dst {
    fn desc(&mut self) -> refl_image_f32_mut {
        refl_image_f32_mut { data: self.buf.ptr(), len: self.buf.len(), width: self.w, height: self.h, stride: self.stride }
    }
    fn ok(&self, w: u32, h: u32) -> bool {
        self.buf.usable() && self.w == w && self.h == h && required_len(self.w, self.h, self.stride).is_some_and(|n| self.buf.len() >= n)
    }
}

fn whole_dst(w: u32, h: u32, f: impl FnMut(usize) -> f32) -> Dst {
    Dst { buf: Buf::from_fn(w as usize * h as usize, PtrKind::Valid, f), w, h, stride: w }
}

fn back_section(b: &mut Bytes, fg: &FuzzGBuffer, maps: &[PassMap]) {
    let img = &fg.img;
    let (w, h) = (img.width, img.height);
    let cam = img.cam;
    let conv = img.conv;
    let front = img.desc();
    let fb = Buf::from_slice(&[front], b.ptr_kind());
    let readable = |x: u32, y: u32| {
        img.buf.usable() && x < w && (y as u64) * u64::from(img.stride) + u64::from(x) < img.buf.len() as u64
    };
    let front_at = |x: u32, y: u32| if readable(x, y) { img.texel(x, y) } else { f32::NAN };
    let (bw, bh) = if b.chance(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    let bstride = if b.chance(24) { b.stride(bw) } else { bw };
    let seed = b.u8();
    let kpush = b.f32_fine(0.0, 0.5);
    let mut back = image_buf(b, bw, bh, bstride, |x, y| back_value(front_at(x, y), (x * 5 + y * 3 + u32::from(seed)) % 7, conv.min(2), kpush), f32::NAN);
    if back.is_null() && b.chance(192) {
        back = Buf::from_fn(back.len(), PtrKind::Valid, |_| 1.0);
    }
    let back_desc = img_f32(&back, bw, bh, bstride);
    let back_snap = back.snapshot();
    let front_valid = img.valid();
    let back_valid = back.usable() && bw == w && bh == h && required_len(bw, bh, bstride).is_some_and(|n| back.len() >= n);
    let npix = w as usize * h as usize;

    // 1. refl_trace_back_depth_rows with a fuzzed dst.
    let (dw, dh) = if b.chance(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    let dstride = if b.chance(24) { b.stride(dw) } else { dw };
    let dlen = b.len_for(required_len(dw, dh, dstride).unwrap_or(16).min(1 << 16));
    let mut dst = Dst { buf: Buf::sentinel(dlen, b.ptr_kind()), w: dw, h: dh, stride: dstride };
    let alias = b.chance(10);
    let mut dd = dst.desc();
    if alias {
        // dst over the back image (an input).
        dd = refl_image_f32_mut { data: back_desc.data.cast_mut(), len: back_desc.len, width: bw, height: bh, stride: bstride };
    }
    let mut st = out1::<refl_trace_back_depth_stats>(b.ptr_kind());
    let rows = b.rows(h);
    let dsnap = dst.buf.snapshot();
    // SAFETY: pointers NULL, misaligned or valid for their lengths.
    let s = unsafe { refl_trace_back_depth_rows(st.ptr(), dd, fb.cptr(), back_desc, rows) };
    let what = "refl_trace_back_depth_rows";
    let req_null = st.is_null() || fb.is_null();
    let any_null = req_null || img.buf.is_null() || back.is_null() || (!alias && dst.buf.is_null());
    let mis = [st.kind(), fb.kind(), img.buf.kind(), back.kind(), dst.buf.kind()].contains(&PtrKind::Misaligned);
    null_rules_m(s, req_null, any_null, mis, what);
    on_error_untouched(s, &[("out_stats", st.is_sentinel(0)), ("dst", dst.buf.bytes() == &dsnap[..])], what);
    fg.assert_unchanged(what);
    if !(alias && s == refl_status::Ok) {
        back.assert_unchanged(&back_snap, "refl_trace_back_depth_rows back");
    }
    let rows_ok = rows.begin < rows.end && rows.end <= h;
    if front_valid && back_valid && dst.ok(w, h) && rows_ok && st.usable() && fb.usable() && !alias {
        assert_eq!(s, refl_status::Ok, "{what} refused valid input: {}", last_error());
    }
    let mut bd_whole: Option<Vec<f32>> = None;
    if s == refl_status::Ok {
        assert!(!alias, "{what} accepted dst over the back image");
        assert!(front_valid && back_valid && dst.ok(w, h) && rows_ok, "{what} accepted bad input (front {front_valid}, back {back_valid}, dst {}, rows {rows:?})", dst.ok(w, h));
        let stats = st.get(0);
        let (mut surf, mut clamped, mut cleared) = (0u32, 0u32, 0u32);
        let mut inband = vec![false; dst.buf.len()];
        for y in rows.begin..rows.end {
            for x in 0..w {
                let i = y as usize * dstride as usize + x as usize;
                inband[i] = true;
                let f = img.texel(x, y);
                let bv = back.get(y as usize * bstride as usize + x as usize);
                let got = dst.buf.get(i);
                let want = if front_surface(&cam, f, conv) {
                    surf += 1;
                    if behind(bv, f, conv) {
                        if !decode(&cam, bv, conv).is_some_and(|z| z < cam.z_far) {
                            cleared += 1;
                        }
                        bv
                    } else {
                        clamped += 1;
                        f
                    }
                } else {
                    bv
                };
                assert!(got.to_bits() == want.to_bits(), "{what} ({x}, {y}): {got} (front {f}, back {bv}), want {want}; convention {conv}, camera {cam:?}");
            }
        }
        for (i, inb) in inband.iter().enumerate() {
            if !inb {
                dst.buf.assert_texel_unchanged(&dsnap, i, "refl_trace_back_depth_rows texel outside the band");
            }
        }
        assert_eq!((stats.surfaces, stats.clamped, stats.cleared, stats.exits), (surf, clamped, cleared, 0), "{what}: stats {stats:?}");
        // Bands: the same bytes as one call.
        if npix <= 48 * 48 {
            let mut one = whole_dst(w, h, |_| -7.0);
            let mut s1 = refl_trace_back_depth_stats::default();
            let all = refl_row_range { begin: 0, end: h };
            // SAFETY: valid pointers.
            let r = unsafe { refl_trace_back_depth_rows(&mut s1, one.desc(), &front, back_desc, all) };
            assert_eq!(r, refl_status::Ok, "{what} over the whole image: {}", last_error());
            if h >= 2 && b.chance(96) {
                let k = 1 + b.below(h - 1);
                let mut two = whole_dst(w, h, |_| -7.0);
                let (mut sa, mut sb) = (refl_trace_back_depth_stats::default(), refl_trace_back_depth_stats::default());
                // SAFETY: valid pointers.
                let ra = unsafe { refl_trace_back_depth_rows(&mut sa, two.desc(), &front, back_desc, refl_row_range { begin: 0, end: k }) };
                // SAFETY: valid pointers.
                let rb = unsafe { refl_trace_back_depth_rows(&mut sb, two.desc(), &front, back_desc, refl_row_range { begin: k, end: h }) };
                assert!(ra == refl_status::Ok && rb == refl_status::Ok, "{what} bands refused");
                assert!(one.buf.bytes() == two.buf.bytes(), "{what}: two bands differ from one call");
                assert_eq!(
                    (s1.surfaces, s1.clamped, s1.cleared),
                    (sa.surfaces + sb.surfaces, sa.clamped + sb.clamped, sa.cleared + sb.cleared),
                    "{what}: band stats"
                );
            }
            bd_whole = Some(one.buf.to_vec());
        }
    }

    // 2. refl_trace_back_depth_layered_rows, per map.
    if maps.is_empty() && !b.chance(32) {
        return;
    }
    for _ in 0..1 + b.below(2) {
        let k = if maps.is_empty() { 0 } else { b.below(maps.len() as u32) as usize };
        let pm = maps.get(k);
        let md = pm.map(|p| p.m.desc());
        let mb = match md {
            Some(d) => Buf::from_slice(&[d], if b.chance(16) { b.ptr_kind() } else { PtrKind::Valid }),
            None => Buf::sentinel(0, PtrKind::Null),
        };
        let map_null = mb.is_null() || md.is_none();
        let (dw, dh) = if b.chance(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
        let dstride = if b.chance(24) { b.stride(dw) } else { dw };
        let dlen = b.len_for(required_len(dw, dh, dstride).unwrap_or(16).min(1 << 16));
        let mode = b.u8() % 4;
        let seedv = b.u8();
        let init = |i: usize| -> f32 {
            match mode {
                0 => bd_whole.as_ref().and_then(|v| {
                    let st = dstride.max(1) as usize;
                    let (x, y) = (i % st, i / st);
                    (x < w as usize).then(|| v.get(y * w as usize + x).copied()).flatten()
                })
                .unwrap_or(f32::NAN),
                1 => f32::NAN,
                2 => {
                    let st = dstride.max(1) as usize;
                    let (x, y) = ((i % st) as u32, (i / st) as u32);
                    back_value(front_at(x, y), (x * 3 + y + u32::from(seedv)) % 7, conv.min(2), kpush)
                }
                _ => f32::from_bits(u32::from_ne_bytes([SENTINEL; 4])),
            }
        };
        let dkind = b.ptr_kind();
        let mut dst = Dst { buf: Buf::from_fn(dlen, dkind, |i| init(i)), w: dw, h: dh, stride: dstride };
        let alias = b.chance(8) && img.buf.usable();
        let dd = if alias {
            // dst over the front depth (an input).
            refl_image_f32_mut { data: front.depth.data.cast_mut(), len: front.depth.len, width: w, height: h, stride: img.stride }
        } else {
            dst.desc()
        };
        let mut st = out1::<refl_trace_back_depth_stats>(b.ptr_kind());
        let rows = b.rows(h);
        let dsnap = dst.buf.snapshot();
        // SAFETY: pointers NULL, misaligned or valid for their lengths.
        let s = unsafe { refl_trace_back_depth_layered_rows(st.ptr(), dd, fb.cptr(), mb.cptr(), rows) };
        let what = "refl_trace_back_depth_layered_rows";
        let req_null = st.is_null() || fb.is_null() || map_null;
        let any_null = req_null || img.buf.is_null() || dst.buf.is_null() || pm.is_some_and(|p| p.m.any_null());
        let mis = [st.kind(), fb.kind(), img.buf.kind(), dst.buf.kind(), mb.kind()].contains(&PtrKind::Misaligned) || pm.is_some_and(|p| p.m.any_misaligned());
        null_rules_m(s, req_null, any_null, mis, what);
        on_error_untouched(s, &[("out_stats", st.is_sentinel(0)), ("dst", dst.buf.bytes() == &dsnap[..])], what);
        fg.assert_unchanged(what);
        for (j, p) in maps.iter().enumerate() {
            assert!(p.m.same(&p.snap), "{what}: map {j} written");
        }
        let rows_ok = rows.begin < rows.end && rows.end <= h;
        if s != refl_status::Ok {
            continue;
        }
        let pm = pm.expect("accepted without a map");
        assert!(!alias, "{what} accepted dst over the front depth");
        assert!(front_valid && dst.ok(w, h) && rows_ok && pm.sound && grid_ok(&pm.m.grid), "{what} accepted bad input (front {front_valid}, dst {}, rows {rows:?}, map sound {})", dst.ok(w, h), pm.sound);
        let stats = st.get(0);
        let mut surf = 0u32;
        let mut changed = 0u32;
        let mut inband = vec![false; dst.buf.len()];
        for y in rows.begin..rows.end {
            for x in 0..w {
                let i = y as usize * dstride as usize + x as usize;
                inband[i] = true;
                let f = img.texel(x, y);
                let old = f32::from_bits(u32::from_ne_bytes(dsnap[i * 4..i * 4 + 4].try_into().unwrap()));
                let got = dst.buf.get(i);
                if !front_surface(&cam, f, conv) {
                    assert!(got.to_bits() == old.to_bits(), "{what} ({x}, {y}): changed a pixel without a front surface ({f})");
                    continue;
                }
                surf += 1;
                if got.to_bits() == old.to_bits() {
                    continue;
                }
                changed += 1;
                assert!(!got.is_nan() && behind(got, f, conv), "{what} ({x}, {y}): exit {got} in front of the front {f} (convention {conv})");
                if let Some(z) = decode(&cam, got, conv) {
                    assert!(!(z > cam.z_far * (1.0 + 1e-4)), "{what} ({x}, {y}): exit at depth {z} beyond the far plane {}", cam.z_far);
                }
                let old_valid = !old.is_nan() && behind(old, f, conv);
                if old_valid {
                    assert!(behind(old, got, conv) && old != got, "{what} ({x}, {y}): replaced a nearer valid back depth {old} by {got} (front {f})");
                }
            }
        }
        for (i, inb) in inband.iter().enumerate() {
            if !inb {
                dst.buf.assert_texel_unchanged(&dsnap, i, "refl_trace_back_depth_layered_rows texel outside the band");
            }
        }
        assert_eq!((stats.surfaces, stats.clamped, stats.cleared), (surf, 0, 0), "{what}: stats {stats:?}");
        assert!(stats.exits >= changed && stats.exits <= surf, "{what}: {} exits, {changed} pixels changed of {surf} surfaces", stats.exits);
        // The exits over a NaN image (every old value invalid): the rule
        // applied to them gives this call's image.
        let mut nan = Dst { buf: Buf::from_fn(dst.buf.len(), PtrKind::Valid, |_| f32::NAN), w, h, stride: dstride };
        let mut sn = refl_trace_back_depth_stats::default();
        let md = pm.m.desc();
        // SAFETY: valid pointers.
        let r = unsafe { refl_trace_back_depth_layered_rows(&mut sn, nan.desc(), &front, &md, rows) };
        assert_eq!(r, refl_status::Ok, "{what} over a NaN image: {}", last_error());
        let mut written = 0u32;
        for y in rows.begin..rows.end {
            for x in 0..w {
                let i = y as usize * dstride as usize + x as usize;
                let e = nan.buf.get(i);
                let old = f32::from_bits(u32::from_ne_bytes(dsnap[i * 4..i * 4 + 4].try_into().unwrap()));
                let f = img.texel(x, y);
                let want = if e.is_nan() {
                    old
                } else {
                    written += 1;
                    let old_valid = !old.is_nan() && behind(old, f, conv);
                    if old_valid && !(behind(old, e, conv) && old != e) {
                        old
                    } else {
                        e
                    }
                };
                let got = dst.buf.get(i);
                assert!(got.to_bits() == want.to_bits(), "{what} ({x}, {y}): {got}, but the exit {e} over {old} (front {f}) gives {want}");
            }
        }
        assert_eq!((sn.exits, sn.surfaces), (stats.exits, stats.surfaces), "{what}: stats over a NaN image");
        assert_eq!(written, sn.exits, "{what}: exits over a NaN image vs pixels written");
        // Bands: the same bytes as one call.
        if h >= 2 && npix <= 24 * 24 && b.chance(96) {
            let k = 1 + b.below(h - 1);
            let mut one = whole_dst(w, h, |i| init(i));
            let mut two = whole_dst(w, h, |i| init(i));
            let mut s1 = refl_trace_back_depth_stats::default();
            let (mut sa, mut sb) = (s1, s1);
            // SAFETY: valid pointers.
            let r1 = unsafe { refl_trace_back_depth_layered_rows(&mut s1, one.desc(), &front, &md, refl_row_range { begin: 0, end: h }) };
            // SAFETY: valid pointers.
            let ra = unsafe { refl_trace_back_depth_layered_rows(&mut sa, two.desc(), &front, &md, refl_row_range { begin: 0, end: k }) };
            // SAFETY: valid pointers.
            let rb = unsafe { refl_trace_back_depth_layered_rows(&mut sb, two.desc(), &front, &md, refl_row_range { begin: k, end: h }) };
            assert!(r1 == refl_status::Ok && ra == refl_status::Ok && rb == refl_status::Ok, "{what} bands refused");
            assert!(one.buf.bytes() == two.buf.bytes(), "{what}: two bands differ from one call");
            assert_eq!((s1.surfaces, s1.exits), (sa.surfaces + sb.surfaces, sa.exits + sb.exits), "{what}: band stats");
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);

    // Defaults: the documented values.
    let d = refl_layered_pass_options_default();
    let k = refl_layered_options_default();
    assert!(pass_options_in_range(&d), "defaults out of range: {d:?}");
    assert!(
        d.trace.step_texels == k.step_texels
            && d.trace.max_steps == k.max_steps
            && d.trace.binary_steps == k.binary_steps
            && d.trace.texel_fraction == k.texel_fraction
            && d.trace.early_stop_texels == k.early_stop_texels
            && d.trace.smooth_texels == k.smooth_texels,
        "pass defaults' kernel settings {:?} are not refl_layered_options_default {k:?}",
        d.trace
    );
    assert!(
        d.start_pixels == 0.0 && d.t_min == 0.0 && d.t_max == f32::INFINITY && d.max_roughness == 0.1 && !d.payload_color,
        "pass defaults {d:?}"
    );

    let fg = FuzzGBuffer::new(&mut b, [96; 4]);
    let nmaps = match b.u8() % 8 {
        0 => 0,
        1..=4 => 1,
        5 | 6 => 2,
        _ => 3,
    };
    let maps: Vec<PassMap> = (0..nmaps).map(|_| pass_map(&mut b)).collect();
    let o = options(&mut b);
    pass_section(&mut b, &fg, &maps, &o);
    back_section(&mut b, &fg, &maps);
});
